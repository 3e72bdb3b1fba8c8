"""A study can sweep vehicles as a grid axis; a categorical axis gets no 'changes between
consecutive groups' table in the report."""

from __future__ import annotations

import numpy as np

from offroadbench.study import load, run_study, study_from_dict
from offroadbench.study.report.markdown import build_report
from offroadbench.study.spec.config import plan_cells

STUDY = {
    "study": {"name": "vehicles", "recipe": "paper-d2.3", "root_seed": 3, "terrains_per_cell": 1,
              "missions_per_terrain": 2},
    "grid": {"vehicle.name": ["husky", "jackal"]},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121, "layers.base.relief_m": 0.3},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5},
}


def test_vehicle_axis_runs_each_vehicle_and_reports_without_consecutive_changes(tmp_path):
    study = study_from_dict(STUDY)
    cells = plan_cells(study)
    assert [c.section("vehicle").name for c in cells] == ["husky", "jackal"]
    assert cells[0].section("vehicle").track_m != cells[1].section("vehicle").track_m
    run_study(study, cells, tmp_path, executor="inline")
    df = load(tmp_path)
    assert sorted(set(df["vehicle"])) == ["husky", "jackal"] and len(df) == 4
    # paired terrains: both vehicles drive the same missions on the same terrain
    a, b = (df[df["vehicle"] == v].sort_values("mission") for v in ("husky", "jackal"))
    assert np.allclose(a[["start_x_m", "goal_x_m"]].to_numpy(), b[["start_x_m", "goal_x_m"]].to_numpy())
    assert not np.allclose(a["path_length_m"].to_numpy(), b["path_length_m"].to_numpy())  # two vehicles
    report = build_report(tmp_path)
    assert "median_changes.csv" not in report.tables
    assert "between consecutive groups" not in report.markdown


def test_a_vehicle_axis_takes_every_steering_kind():
    """Every shipped vehicle resolves on a grid axis, with its own steering kind (issue 32)."""
    names = ["husky", "jackal", "talon", "hunter", "sojourner"]
    study = study_from_dict({**STUDY, "grid": {"vehicle.name": names}})
    kinds = {c.section("vehicle").name: c.section("vehicle").steering for c in plan_cells(study)}
    assert kinds == {"husky": "skid", "jackal": "skid", "talon": "skid", "hunter": "ackermann",
                     "sojourner": "rocker_bogie"}
