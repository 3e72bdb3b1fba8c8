"""Score cards on disk: read one, find the shipped baselines' cards, write a card's four files.

A card folder holds ``score.json`` (for machines), ``score.md`` with ``profile.png`` beside it, and
``score.html`` (one self-contained page), written all together (``offroadbench.io.atomic``). The
shipped baselines' cards live in ``suites/scores/<suite>/<tier>/<planner>/`` (package data:
``offroadbench.resources.suite_scores_dir()``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, Sequence

from offroadbench.errors import InputError
from offroadbench.suite.render import PROFILE_NAME, card_html, card_markdown
from offroadbench.suite.score import CARD_FORMAT, compare

__all__ = ["CARD_FILES", "card_dir", "read_card", "shipped_cards", "write_card", "profile_figure"]

#: the files of a card folder
CARD_FILES = ("score.json", "score.md", "score.html", PROFILE_NAME)


def read_card(path: str | Path) -> dict[str, Any]:
    """A score card from ``score.json`` (or the folder holding it); an unreadable or foreign file is
    an InputError naming it."""
    p = Path(path)
    if p.is_dir():
        p = p / "score.json"
    try:
        card = json.loads(p.read_text())
    except FileNotFoundError:
        raise InputError(f"{p}: no score card here (score.json is missing)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{p}: not a readable score card ({exc})") from None
    if not isinstance(card, dict) or card.get("format") != CARD_FORMAT:
        raise InputError(f"{p}: not an offroadbench score card (format {card.get('format') if isinstance(card, dict) else None!r}, "
                         f"expected {CARD_FORMAT!r})")
    return card


def card_dir(root: Path, suite: str, tier: str, planner: str) -> Path:
    """Where a baseline's card lives under a scores folder: ``root/<suite>/<tier>/<planner>``."""
    return root / suite / tier / planner


def shipped_cards(suite: str | None = None, tier: str | None = None, root: Path | None = None) -> list[dict[str, Any]]:
    """Every committed card under the scores folder (the shipped one by default), optionally of one
    suite and tier, sorted by suite, tier and planner."""
    from offroadbench import resources

    root = resources.suite_scores_dir() if root is None else Path(root)
    if not root.is_dir():
        return []
    cards = [read_card(p) for p in sorted(root.glob("*/*/*/score.json"))]
    return [c for c in cards if (suite is None or c["suite"]["name"] == suite) and (tier is None or c["suite"]["tier"] == tier)]


def profile_figure(card: Mapping[str, Any], baselines: Sequence[Mapping[str, Any]]):
    """The performance profile of ``card`` beside its baselines' (a matplotlib Figure)."""
    from offroadbench.plots.suite import performance_profile_figure

    profiles = {b["planner"]: (b["profile"]["taus"], b["profile"]["fraction"]) for b in baselines if b["planner"] != card["planner"]}
    profiles[card["planner"]] = (card["profile"]["taus"], card["profile"]["fraction"])
    s = card["suite"]
    return performance_profile_figure(profiles, f"{s['name']}, {s['tier']} tier: {len(card['tasks'])} tasks",
                                      highlight=card["planner"])


def write_card(out: str | Path, card: Mapping[str, Any], baselines: Sequence[Mapping[str, Any]]
               ) -> tuple[list[Path], dict[str, Any]]:
    """Write the card's files into ``out`` (created if missing), the baselines' paired comparisons
    and profiles beside it; every file replaced together. Returns the paths and the card as written
    (with its ``comparisons``)."""
    import io

    from offroadbench.io.atomic import atomic_paths
    from offroadbench.io.outputs import created_dirs

    comparisons = [compare(card, b) for b in baselines if b["planner"] != card["planner"]]
    full = {**card, "comparisons": comparisons}
    fig = profile_figure(card, baselines)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    png = buf.getvalue()
    out = Path(out)
    texts = {"score.json": json.dumps(full, indent=1, sort_keys=False) + "\n",
             "score.md": card_markdown(full, comparisons), "score.html": card_html(full, comparisons, png)}
    paths = [out / name for name in CARD_FILES]
    with created_dirs(out):
        with atomic_paths(paths) as temps:
            for path, tmp in zip(paths, temps, strict=True):
                if path.name == PROFILE_NAME:
                    tmp.write_bytes(png)
                else:
                    tmp.write_text(texts[path.name])
    return paths, full
