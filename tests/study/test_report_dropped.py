"""The report's line on MuJoCo Warp's dropped false height-field contacts (TrialResult.dropped_contacts):
how many of a study's MuJoCo Warp trials had one dropped and their outcomes; "not recorded" for rows
from before the column; nothing for a study without a MuJoCo Warp cell."""

from __future__ import annotations

import copy
import math

import pytest

from offroadbench.study import run_study, study_from_dict
from offroadbench.study.report.html import report_html
from offroadbench.study.report.markdown import build_report
from offroadbench.study.spec.config import plan_cells

STUDY = {
    "study": {"name": "dropped-report", "recipe": "paper-d2.45", "root_seed": 3, "terrains_per_cell": 1,
              "missions_per_terrain": 3},
    "grid": {"sim.engine": ["mujoco", "mujoco_warp"]},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5, "start_classes": ["low", "semi", "high"],
                 "goal_classes": ["low", "semi", "high"]},
}
#: mission k's (outcome, dropped contacts) on MuJoCo Warp: one trial with none, two with some
WARP = {0: ("", 0), 1: ("", 2), 2: ("stuck", 5)}


def _trials(recorded: bool):
    def fake(prepared, settings):
        """A stand-in for the physics: MuJoCo Warp's rows carry the count (when ``recorded``)."""
        warp = settings.sim.engine == "mujoco_warp"
        for m in prepared.missions:
            (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
            reason, dropped = WARP[m.index] if warp else ("", math.nan)
            row = {"mission_index": m.index, "success": reason == "", "failure_reason": reason,
                   "traversal_time_s": 3.0 if reason == "" else math.nan, "rms_vertical_accel_m_s2": 0.1,
                   "rms_pitch_rate_deg_s": 1.0, "rms_roll_rate_deg_s": 2.0, "start_x_m": sx, "start_y_m": sy,
                   "goal_x_m": gx, "goal_y_m": gy}
            yield row | ({"dropped_contacts": float(dropped)} if recorded else {})
    return fake


def _run(out, recorded: bool = True, engines=("mujoco", "mujoco_warp")):
    raw = copy.deepcopy(STUDY)
    raw["grid"]["sim.engine"] = list(engines)
    study = study_from_dict(raw)
    run_study(study, plan_cells(study), out, executor="inline", trial_fn=_trials(recorded))
    return out


def _line(markdown: str) -> str:
    section = markdown.split("## Outcomes and failure reasons")[1].split("\n## ")[0]
    lines = [ln for ln in section.splitlines() if ln.startswith("MuJoCo Warp's false height-field contacts")]
    assert len(lines) <= 1
    return lines[0] if lines else ""


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("recorded"))


def test_the_report_counts_the_mujoco_warp_trials_with_a_dropped_contact_and_their_outcomes(recorded):
    line = _line(build_report(recorded).markdown)
    assert "2 of 3 MuJoCo Warp trials had a contact dropped (7 in all, counted per MuJoCo step; outcomes: stuck 1, success 1)." in line


def test_the_html_trial_table_shows_the_count_where_recorded(recorded):
    page = report_html(recorded, build_report(recorded))
    assert "<th>dropped_contacts</th>" in page or ">dropped_contacts<" in page
    assert "2 of 3 MuJoCo Warp trials had a contact dropped" in page


def test_rows_from_before_the_column_are_not_recorded(tmp_path):
    line = _line(build_report(_run(tmp_path / "old", recorded=False)).markdown)
    assert line.endswith("not recorded in this run (3 MuJoCo Warp trials).")


def test_a_study_without_mujoco_warp_has_no_line(tmp_path):
    rep = build_report(_run(tmp_path / "none", engines=("mujoco", "pybullet")))
    assert _line(rep.markdown) == "" and "dropped_contacts" not in report_html(tmp_path / "none", rep)


def test_a_run_resumed_across_the_column_says_how_many_rows_predate_it(recorded, monkeypatch):
    """A store with MuJoCo Warp rows from before the column and after (a run resumed across it):
    the line counts the recorded ones and says how many are not."""
    from offroadbench.study.report import markdown
    from offroadbench.study.store.results import load

    def mixed(run_dir):
        trials = load(run_dir)
        trials.loc[(trials["engine"] == "mujoco_warp") & (trials["mission"] == 2), "dropped_contacts"] = math.nan
        return trials

    monkeypatch.setattr(markdown, "load", mixed)
    line = _line(build_report(recorded).markdown)
    assert ("1 of 2 MuJoCo Warp trials (1 more from before the count was kept) had a contact dropped "
            "(2 in all, counted per MuJoCo step; outcomes: success 1).") in line
