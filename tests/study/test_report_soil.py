"""The report's soft-soil section: slip and sinkage over the moving samples, and each group's soil and
gravity with where each came from (the study, the terrain's recipe, or the default)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from offroadbench.study import run_study, study_from_dict
from offroadbench.study.report.header import soil_conditions
from offroadbench.study.report.markdown import build_report
from offroadbench.study.store.results import load_meta
from offroadbench.study.spec.config import plan_cells

STUDY = {
    "study": {"name": "soil-report", "recipe": "lunar-mare", "root_seed": 3, "terrains_per_cell": 1,
              "missions_per_terrain": 3},
    "grid": {"sim.soil": ["lete-sand", "lunar-regolith"]},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5, "start_classes": ["low", "semi", "high"],
                 "goal_classes": ["low", "semi", "high"]},
    "sim": {"tyre_model": "terramechanics"},
}


def fake_soil_trials(prepared, settings):
    """A stand-in for the physics with the soil columns of a terramechanics trial."""
    for m in prepared.missions:
        (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
        yield {"mission_index": m.index, "success": True, "failure_reason": "", "traversal_time_s": 3.0,
               "rms_vertical_accel_m_s2": 0.1, "rms_pitch_rate_deg_s": 1.0, "rms_roll_rate_deg_s": 2.0,
               "start_x_m": sx, "start_y_m": sy, "goal_x_m": gx, "goal_y_m": gy,
               "mean_slip": 0.1 * (m.index + 1), "sinkage_median_m": 0.01 * (m.index + 1),
               "sinkage_p95_m": 0.02 * (m.index + 1), "outside_model_fraction": 0.25 * (m.index % 2)}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    study = study_from_dict(copy.deepcopy(STUDY))
    run_study(study, plan_cells(study), out, executor="inline", trial_fn=fake_soil_trials)
    return out


def test_conditions_name_soil_gravity_and_their_sources(run):
    meta = load_meta(run)
    first, second = soil_conditions(meta, 0), soil_conditions(meta, 1)
    assert first == {"soil": "lete-sand", "soil_source": "study", "gravity_m_s2": pytest.approx(1.62, abs=0.01),
                     "gravity_source": "terrain", "soil_map": False}
    assert second["soil"] == "lunar-regolith" and second["soil_source"] == "study"


def test_conditions_say_when_the_recipes_soil_map_applies(run):
    """A cell whose recipe has [[soil.regions]] ran on the map unless the study named a soil."""
    import copy

    from offroadbench.plots.soil import conditions_text

    meta = copy.deepcopy(load_meta(run))
    meta["cells"][0]["recipe"]["soil"] = {"name": "lunar-regolith", "regions": [{"soil": "snow", "in_crater": True}]}
    assert not soil_conditions(meta, 0)["soil_map"]  # this study's grid names the soil: it lies everywhere
    meta["cells"][0]["settings"]["sim"].pop("soil", None)
    c = soil_conditions(meta, 0)
    assert c["soil_map"] and "soil map" in conditions_text(c)


def test_soft_soil_section_reports_moving_sample_statistics_and_conditions(run):
    rep = build_report(run)
    section = rep.markdown.split("## Soft soil")[1].split("\n## ")[0]
    assert "median and 95th percentile" in section and "moving" in section
    assert "soil lete-sand (study), gravity 1.62" in section and "(terrain)" in section
    assert "soil lunar-regolith (study)" in section
    assert "Median wheel sinkage (moving) (m)" in section and "95th percentile wheel sinkage" in section
    assert "fig8_soil.png" in rep.figures
    # every other mission spent a quarter of its time bottomed out (fake rows): the line counts them
    line = next(ln for ln in section.splitlines() if ln.startswith("Outside the soil model"))
    assert " of " in line and "25.0 % of their time (median)" in line
    assert np.isfinite(rep.tables["summary.csv"].shape[0])
