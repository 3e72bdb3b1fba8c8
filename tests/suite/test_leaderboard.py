"""The committed score cards and docs/leaderboard.md: each card recomputes from its own task rows and
is of the suite's current tasks, and the page is what the cards give (regenerate it with
``offroadbench suite leaderboard --write docs/leaderboard.md``)."""

import json
import shutil
from pathlib import Path

import pytest

from offroadbench import resources
from offroadbench.suite import load_suite, shipped_cards, summarise
from offroadbench.suite.leaderboard import render

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "leaderboard.md"
CARDS = sorted(resources.suite_scores_dir().glob("*/*/*/score.json"))


def test_the_committed_leaderboard_is_current():
    assert PAGE.read_text() == render(PAGE), (
        "docs/leaderboard.md is stale: run `offroadbench suite leaderboard --write docs/leaderboard.md`")


def test_a_changed_card_makes_the_page_stale(tmp_path):
    scores = tmp_path / "scores"
    shutil.copytree(resources.suite_scores_dir(), scores)
    path = next(scores.glob("*/quick/astar/score.json"))
    card = json.loads(path.read_text())
    card["overall"]["score_iqm"] = 0.01
    path.write_text(json.dumps(card))
    assert render(PAGE, scores) != PAGE.read_text()


def test_the_quick_tier_has_the_line_and_astar():
    planners = {c["planner"] for c in shipped_cards("offroadbench-v1", "quick")}
    assert {"straight", "astar"} <= planners


@pytest.mark.parametrize("path", CARDS, ids=[str(p.parent.relative_to(p.parents[3])) for p in CARDS])
def test_a_committed_card_is_of_the_current_tasks_and_recomputes_from_its_rows(path):
    card = json.loads(path.read_text())
    suite, _ = load_suite(card["suite"]["name"])
    assert card["suite"]["tasks_sha256"] == suite.tasks_sha256, "a card of other tasks: re-run it or bump the suite"
    assert path.parent.parts[-3:] == (suite.name, card["suite"]["tier"], card["planner"])
    again = summarise(card["tasks"], [c.name for c in suite.categories])
    assert again["overall"] == card["overall"]
    assert again["categories"] == card["categories"]
    assert again["profile"] == card["profile"]
    planned = sum(1 for _ in card["tasks"])
    assert planned == card["overall"]["tasks"] > 0
    for name in ("score.md", "score.html", "profile.png"):
        assert (path.parent / name).is_file()
    assert f"--planner {card['planner']}" in card["command"] and f"--tier {card['suite']['tier']}" in card["command"]
