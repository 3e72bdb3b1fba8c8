"""A report says what ran: what was held fixed (with non-default values marked), a title naming a
non-default planner and gravity, box plots with their n and points, change tables with their n."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from offroadbench.study import run_study, study_from_dict
from offroadbench.study.report.header import held_fixed, report_title
from offroadbench.study.report.markdown import build_report
from offroadbench.study.store.results import load_meta
from offroadbench.study.spec.config import plan_cells

STUDY = {
    "study": {"name": "lunar-astar", "recipe": "paper-d2.45", "root_seed": 5, "terrains_per_cell": 2,
              "missions_per_terrain": 3},
    "grid": {"recipe.layers.base.D_high": [2.3, 2.6]},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5},
    "planner": {"name": "astar", "grid_m": 0.5},
    "sim": {"gravity_m_s2": 1.62},
}


def fake_trials(prepared, settings):
    """A stand-in for the physics: a pure function of the terrain along the mission line."""
    hm = prepared.hm
    for m in prepared.missions:
        (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
        t = np.linspace(0.0, 1.0, 31)
        z = hm.height_at(sx + t * (gx - sx), sy + t * (gy - sy))
        ok = m.index != 1
        yield {"mission_index": m.index, "success": ok, "failure_reason": "" if ok else "stuck",
               "traversal_time_s": m.length_m + float(np.ptp(z)) if ok else float("nan"),
               "rms_vertical_accel_m_s2": float(np.ptp(z)), "rms_pitch_rate_deg_s": 1.0 + m.index,
               "rms_roll_rate_deg_s": 2.0, "start_x_m": sx, "start_y_m": sy, "goal_x_m": gx, "goal_y_m": gy}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    study = study_from_dict(copy.deepcopy(STUDY))
    run_study(study, plan_cells(study), out, executor="inline", trial_fn=fake_trials)
    return out


def test_first_screen_names_the_planner_and_lunar_gravity(run):
    rep = build_report(run)
    head = rep.markdown.split("## ")[0]  # everything before the first section
    assert head.startswith("# Study report: lunar-astar (planner `astar`, gravity 1.62 m/s^2)")
    fixed = rep.tables["held_fixed.csv"].set_index("setting")
    assert fixed.loc["planner", "value"] == "astar" and "not the default (straight)" in fixed.loc["planner", "note"]
    assert "grid_m = 0.5" in fixed.loc["astar settings", "value"] and "grid_m" in fixed.loc["astar settings", "note"]
    assert fixed.loc["gravity (m/s^2)", "value"] == "1.62" and "9.81" in fixed.loc["gravity (m/s^2)", "note"]
    assert fixed.loc["physics rate (Hz)", "value"] == "60" and fixed.loc["physics rate (Hz)", "note"] == ""
    assert fixed.loc["tyre model", "value"] == "coulomb" and fixed.loc["vehicle", "value"] == "husky"
    assert "tipped > 75 deg" in fixed.loc["failure rules", "value"]
    assert "grid.rows = 121" in fixed.loc["terrain recipe", "value"]
    assert "recipe.layers.base.D_high" in fixed.loc["terrain recipe", "note"]
    assert fixed.loc["code version", "value"] and fixed.loc["platform", "value"]
    for name in ("astar", "1.62", "husky", "coulomb", "paper-d2.45"):
        assert name in head


def test_a_grid_axis_is_shown_as_varying_and_the_default_planner_is_not_in_the_title(tmp_path):
    data = copy.deepcopy(STUDY)
    del data["planner"], data["sim"]
    data["grid"] = {"planner.name": ["straight", "astar"]}
    study = study_from_dict(data)
    run_study(study, plan_cells(study), tmp_path, executor="inline", trial_fn=fake_trials)
    meta = load_meta(tmp_path)
    assert report_title(meta) == "Study report: lunar-astar"
    fixed = held_fixed(meta).set_index("setting")
    assert fixed.loc["planner", "value"] == "grid axis" and "planner.name" in fixed.loc["planner", "note"]
    assert fixed.loc["gravity (m/s^2)", "note"] == ""


def test_box_plots_show_n_and_their_points(run):
    rep = build_report(run)
    ax = rep.figures["fig6_success_rate.png"].axes[0]
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert labels == ["D_high=2.3\nn=2", "D_high=2.6\nn=2"]
    points = [line for line in ax.get_lines() if line.get_marker() == "o"]
    assert sum(len(line.get_ydata()) for line in points) == 4  # 2 terrains x 2 groups, each shown
    metrics = rep.figures["fig7_traversal_metrics.png"].axes[0]
    assert all("n=4" in t.get_text() for t in metrics.get_xticklabels())  # 2 successes on each of 2 terrains


def test_change_table_carries_its_n_and_a_caveat(run):
    rep = build_report(run)
    changes = rep.tables["median_changes.csv"]
    rate = changes[changes["quantity"] == "success_rate_pct"].iloc[0]
    assert (rate["n_from"], rate["n_to"]) == (2, 2)
    assert "not evidence of an effect on their own" in rep.markdown
