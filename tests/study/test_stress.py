"""Planner stress-test statistics (Wilson intervals, breaking points, exact McNemar) and the report
section of a study with a planner axis, on a cheap stand-in for the physics."""

import math

import numpy as np
import pytest

from offroadbench.study import load, run_study, study_from_dict
from offroadbench.study.report import build_report
from offroadbench.study.spec import plan_cells
from offroadbench.study.stress import (
    bootstrap_breaking_point,
    breaking_point,
    mcnemar_exact,
    paired_table,
    wilson_interval,
)


def test_wilson_interval_known_values():
    # Wilson 1927; values as given by e.g. statsmodels' proportion_confint(method="wilson")
    assert wilson_interval(5, 10) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson_interval(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)
    lo, hi = wilson_interval(0, 0)
    assert math.isnan(lo) and math.isnan(hi)


def test_wilson_interval_contains_the_rate_exactly():
    # 10 / 10 gave an upper end of 1 - 1.1e-16: a negative error bar, and the report's success
    # figure (matplotlib's errorbar) refused it
    for n in range(1, 60):
        for k in range(n + 1):
            lo, hi = wilson_interval(k, n)
            assert 0.0 <= lo <= k / n <= hi <= 1.0
    assert wilson_interval(10, 10)[1] == 1.0 and wilson_interval(0, 7)[0] == 0.0


def test_breaking_point_interpolates_the_first_crossing():
    assert breaking_point([2.3, 2.5, 2.7], [0.9, 0.6, 0.2]) == pytest.approx(2.55)
    assert breaking_point([2.3, 2.5], [0.9, 0.8]) == math.inf
    assert breaking_point([2.3, 2.5], [0.4, 0.8]) == -math.inf
    # a sharp drop between the same two levels on every terrain: the interval is that step's crossing
    s = np.zeros((10, 3, 4))
    s[:, 0], s[:, 1] = 1.0, 0.75
    lo, hi = bootstrap_breaking_point(s, [2.3, 2.5, 2.7], np.random.default_rng(0), n_boot=200)
    assert lo == hi == pytest.approx(2.5 + 0.25 / 0.75 * 0.2)


def test_exact_mcnemar_is_the_binomial_sign_test_on_discordant_pairs():
    assert mcnemar_exact(8, 0) == pytest.approx(2 * 0.5 ** 8)
    assert mcnemar_exact(3, 3) == pytest.approx(1.0)
    assert mcnemar_exact(0, 0) == 1.0
    assert mcnemar_exact(9, 1) == pytest.approx(2 * (1 + 10) / 2 ** 10)


STUDY = {
    "study": {"name": "stress", "recipe": "paper-d2.45", "root_seed": 5, "terrains_per_cell": 4,
              "missions_per_terrain": 5},
    "grid": {"planner.name": ["straight", "astar"], "recipe.layers.base.D_high": [2.3, 2.6, 2.9]},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5},
}


def fake_planner_trials(prepared, settings):
    """Success falls with the terrain's steepness along the line; the 'astar' cells tolerate more."""
    tolerance = {"straight": 1.2, "astar": 2.0}[settings.planner.name]
    hm = prepared.hm
    for m in prepared.missions:
        (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
        t = np.linspace(0.0, 1.0, 61)
        z = hm.height_at(sx + t * (gx - sx), sy + t * (gy - sy))
        slope = float(np.abs(np.diff(z)).max() / (m.length_m / 60))
        ok = slope < tolerance
        yield {"mission_index": m.index, "success": ok, "failure_reason": "" if ok else "stuck",
               "traversal_time_s": m.length_m if ok else float("nan"), "rms_vertical_accel_m_s2": slope,
               "rms_pitch_rate_deg_s": slope, "rms_roll_rate_deg_s": slope,
               "start_x_m": sx, "start_y_m": sy, "goal_x_m": gx, "goal_y_m": gy}


def test_report_of_a_planner_study(tmp_path):
    study = study_from_dict(STUDY)
    cells = plan_cells(study)
    assert study.column_names()["planner.name"] == "planner"
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_planner_trials)
    df = load(tmp_path)
    # every planner on the same missions
    ends = df.groupby(["D_high", "terrain", "mission"])[["start_x_m", "goal_y_m"]].nunique()
    assert (ends == 1).all().all()
    rep = build_report(tmp_path)
    md = rep.markdown
    for heading in ("## Planner stress test", "### Breaking points", "### Paired comparisons on the same missions",
                    "### Outcomes per planner", "### Failures to replay", "### Planned and driven paths"):
        assert heading in md
    assert "Changes of the medians" not in md
    by = rep.tables["planner_success.csv"]
    assert set(by["planner"]) == {"straight", "astar"} and (by["ci95_low"] <= by["success_rate"]).all()
    paired = rep.tables["paired_tests.csv"]
    pooled = paired[paired["D_high"] == "all"].iloc[0]
    assert pooled["only baseline"] == 0 and pooled["only this"] > 0  # astar tolerates strictly more
    assert pooled["mcnemar_p"] == pytest.approx(mcnemar_exact(int(pooled["only this"]), 0))
    assert paired_table(df, "planner", None, "straight").shape[0] == 1
    bp = rep.tables["breaking_points.csv"].set_index("planner")
    assert bp.loc["straight", "breaking_point"] <= bp.loc["astar", "breaking_point"]
    assert "offroadbench study replay" in rep.tables["replay_examples.csv"]["replay"].iloc[0]
    assert "planner_paths.png" in rep.figures and "planner_success.png" in rep.figures
