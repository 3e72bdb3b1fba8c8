"""``offroadbench suite`` end to end on a tiny suite: run, resume, card files, baselines, leaderboard."""

import json
import shutil
import subprocess
import sys

import pytest

from offroadbench.cli import main
from offroadbench.suite import read_card, summarise


def _run(tmp_path, capsys, *args):
    rc = main(["suite", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """The tiny suite run with the line (its card filed as a baseline) and with A* (beside it)."""
    from .conftest import suite_text

    tmp = tmp_path_factory.mktemp("suite")
    (tmp / "tiny-v1.toml").write_text(suite_text())
    base = tmp / "scores" / "tiny-v1" / "quick" / "straight"
    code = "import sys; from offroadbench.cli import main; sys.exit(main(sys.argv[1:]))"
    runs = {}
    for planner, extra in (("straight", ["--card-out", str(base)]), ("astar", ["--baselines", str(tmp / "scores")])):
        args = ["suite", "run", "--suite", str(tmp / "tiny-v1.toml"), "--tier", "quick", "--planner", planner,
                "--out", str(tmp / planner), "--executor", "inline", *extra]
        runs[planner] = subprocess.run([sys.executable, "-c", code, *args], cwd=tmp, capture_output=True, text=True)
    return tmp, runs


def test_a_run_writes_a_card_with_the_suite_version_and_every_task(scored):
    tmp, runs = scored
    assert runs["straight"].returncode == 0, runs["straight"].stderr
    assert "tiny-v1 quick tier, planner straight: 6 tasks" in runs["straight"].stdout
    card = read_card(tmp / "scores" / "tiny-v1" / "quick" / "straight")
    assert card["suite"]["name"] == "tiny-v1" and card["suite"]["tier"] == "quick" and len(card["suite"]["tasks_sha256"]) == 64
    assert card["planner"] == "straight" and len(card["tasks"]) == 6
    assert {t["category"] for t in card["tasks"]} == {"rough", "lunar"}
    # every summary number comes from the card's own rows
    again = summarise(card["tasks"], ["rough", "lunar"])
    assert again["overall"] == card["overall"] and again["categories"] == card["categories"]
    for t in card["tasks"]:
        assert 0.0 <= t["score"] <= 1.0 and (t["score"] > 0) == t["success"]
    md = (tmp / "scores" / "tiny-v1" / "quick" / "straight" / "score.md").read_text()
    assert "tiny-v1" in md and "IQM score" in md and "![performance profile](profile.png)" in md
    page = (tmp / "scores" / "tiny-v1" / "quick" / "straight" / "score.html").read_text()
    assert "data:image/png;base64," in page and 'src="profile.png"' not in page and "tiny-v1" in page


def test_the_baseline_stands_beside_with_a_paired_comparison(scored):
    tmp, runs = scored
    assert runs["astar"].returncode == 0, runs["astar"].stderr
    assert "against straight: score" in runs["astar"].stdout
    card = json.loads((tmp / "astar" / "score.json").read_text())
    (cmp,) = card["comparisons"]
    line = read_card(tmp / "scores" / "tiny-v1" / "quick" / "straight")
    assert cmp["comparable"] and cmp["baseline"] == "straight" and cmp["terrains"] == 6
    assert cmp["tasks_won"] + cmp["tasks_tied"] + cmp["tasks_lost"] == 6
    mine = {(t["category"], t["cell"], t["terrain"], t["mission"]): t for t in card["tasks"]}
    theirs = {(t["category"], t["cell"], t["terrain"], t["mission"]): t for t in line["tasks"]}
    assert all(mine[k]["mission_seed"] == theirs[k]["mission_seed"] for k in mine)  # the same tasks
    mean_diff = sum(mine[k]["score"] - theirs[k]["score"] for k in mine) / 6  # one mission per terrain
    assert cmp["score_diff"] == pytest.approx(mean_diff, abs=1e-6)
    assert "## Against the shipped baselines" in (tmp / "astar" / "score.md").read_text()


def test_running_again_resumes_and_runs_nothing(scored, capsys, monkeypatch):
    tmp, _ = scored
    monkeypatch.chdir(tmp)
    rc, out, err = _run(tmp, capsys, "run", "--suite", "tiny-v1.toml", "--planner", "astar", "--out", "astar",
                        "--executor", "inline", "--baselines", "scores")
    assert rc == 0, err
    assert "this run: 0 trials" in out


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, tiny_suite):
    rc, _, err = _run(tmp_path, capsys, "run", "--suite", str(tiny_suite), "--planner", "astr", "--out", str(tmp_path / "r"))
    assert rc == 2 and "did you mean 'astar'" in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()
    rc, _, err = _run(tmp_path, capsys, "run", "--suite", str(tiny_suite), "--planner", "astar", "--tier", "ful")
    assert rc == 2 and "unknown tier" in err
    rc, _, err = _run(tmp_path, capsys, "run", "--suite", "offroadbench-v0", "--planner", "astar")
    assert rc == 2 and "did you mean 'offroadbench-v1'" in err


def test_list_shows_tiers_tasks_and_cards(capsys, tmp_path):
    rc, out, _ = _run(tmp_path, capsys, "list")
    assert rc == 0
    assert "offroadbench-v1" in out and "tier quick" in out and "tier full" in out
    assert "multifractal" in out and "3 x 6 terrains x 2 missions =  36 tasks" in out


def test_the_leaderboard_ranks_the_cards_and_names_the_missing(scored, capsys):
    tmp, _ = scored
    page = tmp / "docs" / "leaderboard.md"
    rc, _, err = _run(tmp, capsys, "leaderboard", "--scores", str(tmp / "scores"), "--write", str(page))
    assert rc == 0, err
    text = page.read_text()
    assert "## tiny-v1, `quick` tier" in text and "## offroadbench-v1, `full` tier" in text
    assert "`straight`" in text and "../scores/tiny-v1/quick/straight/score.md" in text
    assert "No committed card yet for: `astar`" in text.split("## tiny-v1")[1]


def test_score_rewrites_a_card_against_later_baselines_running_nothing(scored, capsys):
    tmp, _ = scored
    later = tmp / "later" / "tiny-v1" / "quick"
    shutil.copytree(tmp / "astar", later / "astar")
    rc, out, err = _run(tmp, capsys, "score", "--suite", str(tmp / "tiny-v1.toml"), "--planner", "straight",
                        "--out", str(tmp / "straight"), "--card-out", str(tmp / "rescored"), "--baselines", str(tmp / "later"))
    assert rc == 0, err
    assert "against astar" in out and "this run" not in out
    card, astar = read_card(tmp / "rescored"), read_card(tmp / "astar")
    (cmp,) = card["comparisons"]
    assert cmp["baseline"] == "astar" and cmp["score_diff"] == pytest.approx(-astar["comparisons"][0]["score_diff"], abs=1e-6)
    assert card["tasks"] == read_card(tmp / "scores" / "tiny-v1" / "quick" / "straight")["tasks"]


def test_the_suite_runs_on_dask_with_the_same_rows(scored, capsys):
    pytest.importorskip("distributed")
    tmp, _ = scored
    rc, out, err = _run(tmp, capsys, "run", "--suite", str(tmp / "tiny-v1.toml"), "--planner", "straight",
                        "--out", str(tmp / "dask"), "--executor", "dask", "--workers", "1", "--baselines", str(tmp / "scores"))
    assert rc == 0, err
    local = read_card(tmp / "scores" / "tiny-v1" / "quick" / "straight")
    assert read_card(tmp / "dask")["tasks"] == local["tasks"]


def test_score_refuses_a_run_of_another_planner_or_an_empty_folder(scored, capsys, tmp_path):
    tmp, _ = scored
    rc, _, err = _run(tmp, capsys, "score", "--suite", str(tmp / "tiny-v1.toml"), "--planner", "astar",
                      "--out", str(tmp / "straight"))
    assert rc == 2 and "with planner straight, not tiny-v1-quick-rough with astar" in err
    rc, _, err = _run(tmp, capsys, "score", "--suite", str(tmp / "tiny-v1.toml"), "--planner", "astar",
                      "--out", str(tmp_path))
    assert rc == 2 and "has not run (no study.sqlite)" in err


def test_sigterm_ends_a_suite_run_with_one_line_and_resume_finishes_it(tmp_path, tiny_suite):
    """SIGTERM (and Ctrl-C) end ``suite run`` as they end ``study run``: exit 143, one line saying what
    is kept and how to resume, no lock left (it used to have no handler: an inherited SIG_IGN kept a
    background run deaf to SIGINT, and SIGTERM killed it without closing its session)."""
    import signal
    import time

    code = "import sys; from offroadbench.cli import main; sys.exit(main(sys.argv[1:]))"
    args = [sys.executable, "-c", code, "suite", "run", "--suite", str(tiny_suite), "--planner", "straight",
            "--out", str(tmp_path / "run"), "--workers", "1"]
    proc = subprocess.Popen(args, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while not list((tmp_path / "run").glob("*/study.lock")) and proc.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.01)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("offroadbench: ") and "run the same command again to" in lines[0], err
    assert not list((tmp_path / "run").glob("*/study.lock"))
    done = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
