"""README.md's figures from commands are the committed ones in docs/readme-figures.md.

docs/readme_figures.py runs each source command and writes its figures; README.md quotes them
(``QUOTES``). What is checked here, and what is not:

* every quote, filled with the committed figures, is in README.md (all sources: a README edited to
  another number, or a figures file regenerated without rewriting the README, fails);
* the committed file is exactly what the script renders from its own figures;
* the *cheap* sources (terrain statistics, deterministic on every CPU; the SB3 example's figures,
  read from examples/sb3_policy/results/) are re-run and must give the committed figures;
* the slow sources (``vehicle check`` of every vehicle on both engines, ``soil check``, the ``drive``
  counts: physics, 15-90 s each; ``roughness-study``: about a minute; about 20 minutes together on
  2 shared cores) are NOT re-run here: after a physics or terrain change run
  ``python docs/readme_figures.py``; it prints every figure that moved.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load():
    spec = importlib.util.spec_from_file_location("readme_figures", ROOT / "docs" / "readme_figures.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


rf = _load()
REGENERATE = "python docs/readme_figures.py"


def test_readme_quotes_the_committed_figures():
    readme = rf.README_PATH.read_text(encoding="utf-8")
    missing = rf.missing_quotes(readme, rf.committed())
    assert not missing, f"README.md does not quote the committed figures (run `{REGENERATE}`): {missing}"


def test_every_quoted_figure_is_committed_and_the_file_is_rendered():
    figures = rf.committed()
    quoted = {k for q in rf.QUOTES for k in re.findall(r"\{([\w.]+)\}", q)}
    assert quoted <= set(figures), sorted(quoted - set(figures))
    assert rf.FIGURES_PATH.read_text(encoding="utf-8") == rf.render(figures), f"hand-edited: run `{REGENERATE}`"
    assert {k.split(".")[0] for k in figures} <= set().union(*rf.PREFIXES.values())


@pytest.mark.parametrize("source", [s for s in rf.SOURCES if s.cheap], ids=lambda s: s.name)
def test_cheap_source_gives_the_committed_figures(source):
    committed = rf.committed()
    got = source.compute()
    assert got, source.name
    stale = {k: (committed.get(k), v) for k, v in got.items() if committed.get(k) != v}
    assert not stale, f"{source.name}: committed -> now {stale}; run `{REGENERATE} --only {source.name}`"


def test_a_stale_readme_number_is_caught_and_requote_fixes_it():
    figures = rf.committed()
    readme = rf.README_PATH.read_text(encoding="utf-8")
    quote = rf.fill(rf.QUOTES[0], figures)
    drift = f"| {figures['husky.drift_m']} m |"
    assert drift in quote and drift in readme
    stale = readme.replace(drift, "| 9.999 m |", 1)
    assert rf.missing_quotes(stale, figures) == [quote]
    moved = {**figures, "husky.drift_m": "9.999", "drive.husky.pybullet.seed0": "10"}  # regenerated figures
    new = rf.requote(readme, figures, moved)
    assert not rf.missing_quotes(new, moved) and rf.missing_quotes(new, figures)
    assert new.count("\n") == readme.count("\n")  # the README's line breaks are kept


def test_requote_refuses_a_readme_that_lost_the_quote():
    figures = rf.committed()
    with pytest.raises(SystemExit, match="does not quote"):
        rf.requote("no figures here", figures, {**figures, "husky.drift_m": "9.999"})
