"""The committed reports' plan and planner sections are what today's code computes from the committed tables
(experiments/rerender.py renders them again into a copy and nothing changes)."""

import shutil
from pathlib import Path

import pytest

RESULTS = Path(__file__).resolve().parents[2] / "experiments" / "results"


@pytest.mark.parametrize("name", ["engines", "lunar-soil", "planner-stress", "majhor2023-engines", "vehicle-planner", "engines-warp",
                                  "majhor2023", "majhor2023-mujoco", "soil-map", "vehicle-comparison",
                                  "vehicle-sensitivity", "crater-density"])
def test_a_rerender_of_a_committed_report_changes_nothing(tmp_path, name):
    from experiments.rerender import rerender

    copy = tmp_path / name
    shutil.copytree(RESULTS / name, copy)
    written = rerender(copy)
    for f in written:
        if f.endswith((".md", ".csv")):
            assert (copy / f).read_text() == (RESULTS / name / f).read_text(), f"{name}/{f} is stale"
    text = (copy / "report.md").read_text()
    assert "(extrapolated)" not in text and "inf)" not in text and "(-inf" not in text


def test_the_both_engines_readme_counts_come_from_its_trials():
    """majhor2023-engines/README.md's success counts and verdicts are its committed tables'."""
    import pandas as pd

    folder = RESULTS / "majhor2023-engines"
    text = (folder / "README.md").read_text()
    t = pd.read_parquet(folder / "trials.parquet")
    per_engine = t.groupby("engine")["success"].sum()
    assert "1148 of 1440" in text and f"PyBullet's {per_engine['pybullet']}" in text
    assert per_engine["mujoco"] == 1148
    for engine, name in (("pybullet", "PyBullet"), ("mujoco", "MuJoCo")):
        cells = t[t.engine == engine].groupby("D_high")["success"].sum()
        assert f"{name} {' / '.join(str(int(n)) for n in cells)}" in text
    eng = pd.read_csv(folder / "engine_verdicts.csv")
    verdicts = eng.groupby("comparison", sort=False)["verdict"].first()
    assert sorted(verdicts.value_counts().items()) == [("holds on both", 4), ("holds on neither", 3),
                                                       ("holds on pybullet only", 1)]
    assert text.count("**holds on both**") == 4 and text.count("**holds on neither**") == 3
    assert pd.read_csv(folder / "confirmatory.csv")["power"].min() >= 0.8


def test_no_committed_report_or_readme_prints_an_extrapolation_or_an_unbounded_interval():
    """Issue 42: what the data cannot support is not printed in any committed Markdown."""
    import re

    bad = re.compile(r"\(extrapolated\)|inf\)|\(-inf|-inf\]|, inf\]|-inf\b")
    found = [str(p.relative_to(RESULTS)) for p in sorted(RESULTS.rglob("*.md")) if bad.search(p.read_text())]
    assert found == []
