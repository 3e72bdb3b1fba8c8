"""The committed reports' plan and planner sections are what today's code computes from the committed tables
(experiments/rerender.py renders them again into a copy and nothing changes)."""

import shutil
from pathlib import Path

import pytest

RESULTS = Path(__file__).resolve().parents[2] / "experiments" / "results"


@pytest.mark.parametrize("name", ["engines", "lunar-soil", "planner-stress"])
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
