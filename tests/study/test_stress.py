"""Planner stress-test statistics (Wilson intervals, breaking points, exact McNemar) and the report
section of a study with a planner axis, on a cheap stand-in for the physics."""

import math

import numpy as np
import pandas as pd
import pytest

from offroadbench.study import load, run_study, study_from_dict
from offroadbench.study.report.markdown import build_report
from offroadbench.study.spec.config import plan_cells
from offroadbench.study.stats.clustered import fieller_set, isotonic_decreasing
from offroadbench.study.stats.stress import (
    arm_table,
    breaking_points,
    describe_breaking_point,
    isotonic_crossing,
    first_level_below,
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


def test_first_level_below_does_not_interpolate():
    assert first_level_below([2.3, 2.5, 2.7], [0.9, 0.6, 0.2]) == 2.7
    assert first_level_below([2.3, 2.5], [0.9, 0.8]) == math.inf
    assert first_level_below([2.3, 2.5], [0.4, 0.8]) == 2.3


def _synthetic_trials(n_terrains, levels, missions, d50, width, rng, planner="p"):
    rows = []
    for j in range(n_terrains):
        shift = rng.normal(0, 0.02)
        for x in levels:
            prob = 1 / (1 + np.exp((x - d50 - shift) / width))
            for m in range(missions):
                rows.append({"planner": planner, "D_high": x, "terrain": j, "mission": m,
                             "success": bool(rng.random() < prob)})
    return pd.DataFrame(rows)


def test_breaking_points_locate_a_known_crossing_inside_the_levels():
    rng = np.random.default_rng(2)
    t = pd.concat([_synthetic_trials(30, [2.3, 2.6, 2.8, 2.9, 2.95, 2.99], 8, 2.85, 0.04, rng, "a"),
                   _synthetic_trials(30, [2.3, 2.6, 2.8, 2.9, 2.95, 2.99], 8, 2.95, 0.03, rng, "b")])
    bp = breaking_points(t, "planner", "D_high", n_boot=400).set_index("planner")
    for name, truth in (("a", 2.85), ("b", 2.95)):
        r = bp.loc[name]
        # the isotonic crossing interpolates between studied levels: within a level step of the truth
        assert r["ci95_low"] - 0.05 < truth < r["ci95_high"] + 0.05 and r["ci95_high"] - r["ci95_low"] < 0.15
        assert r["terrains"] == 30 and 2.3 <= r["breaking_point"] <= 2.99
        assert r["logistic_point"] == pytest.approx(truth, abs=0.03)
        # Fieller's interval: given only as one bounded interval inside the levels, around the point
        assert 2.3 <= r["fieller_low"] < r["logistic_point"] < r["fieller_high"] <= 2.99
    assert bp.loc["a", "breaking_point"] < bp.loc["b", "breaking_point"]
    # a planner that never falls below 50 %: "not reached" (+inf), with the success at the last level
    never = breaking_points(_synthetic_trials(6, [2.3, 2.6], 8, 9.0, 0.01, rng), "planner", "D_high", n_boot=200)
    r = never.iloc[0]
    assert r["breaking_point"] == math.inf and r["ci95_high"] == math.inf and r["not_reached_share"] == 1.0
    assert r["success_at_last"] == 1.0
    # no logistic crossing inside the levels: no number (an extrapolation is not a measurement)
    assert math.isnan(r["logistic_point"]) and math.isnan(r["fieller_low"]) and math.isnan(r["fieller_high"])
    text = describe_breaking_point(r["breaking_point"], r["ci95_low"], r["ci95_high"], [2.3, 2.6],
                                   r["success_at_last"], "D_high")
    assert text.startswith("not reached up to D_high = 2.6 (success there 100 %)")


def test_isotonic_crossing_never_leaves_the_studied_levels():
    # success 0.9, 0.7, 0.3 at 2.9 / 2.95 / 2.99: crosses 0.5 halfway between 2.95 and 2.99
    assert isotonic_crossing([2.9, 2.95, 2.99], [9, 7, 3], [10, 10, 10]) == pytest.approx(2.97)
    # a rise is pooled away (pool-adjacent-violators): 0.6, 0.8 -> 0.7, 0.7, then 0.2
    assert isotonic_crossing([1, 2, 3], [6, 8, 2], [10, 10, 10]) == pytest.approx(2 + 0.2 / 0.5)
    assert isotonic_crossing([1, 2], [9, 8], [10, 10]) == math.inf
    assert isotonic_crossing([1, 2], [3, 1], [10, 10]) == -math.inf


def test_isotonic_decreasing_is_the_least_squares_monotone_fit():
    assert isotonic_decreasing([3, 1, 2, 0]).tolist() == [3, 1.5, 1.5, 0]
    assert isotonic_decreasing([1, 2], [3, 1]).tolist() == pytest.approx([1.25, 1.25])


def test_fieller_set_prints_two_rays_when_the_slope_is_unclear():
    from offroadbench.study.stats.clustered import LogisticFit

    sure = LogisticFit(intercept=30.0, slope=-10.0, cov=np.diag([0.01, 0.001]), n=100, clusters=10, converged=True)
    (piece,) = fieller_set(sure)
    assert piece[0] < 3.0 < piece[1]
    # slope -1 with variance 1: not significant, the set is the outside of two roots
    vague = LogisticFit(intercept=3.0, slope=-1.0, cov=np.array([[0.5, 0.0], [0.0, 1.0]]), n=100, clusters=10,
                        converged=True)
    pieces = fieller_set(vague)
    assert len(pieces) == 2 and pieces[0][0] == -math.inf and pieces[1][1] == math.inf


def test_breaking_points_print_no_extrapolation_and_no_unbounded_set():
    # success falls from 0.9 to 0.6 over the levels: the logistic crossing lies beyond the last level
    rng = np.random.default_rng(5)
    t = _synthetic_trials(12, [2.3, 2.6, 2.9], 8, 3.2, 0.25, rng)
    r = breaking_points(t, "planner", "D_high", n_boot=200).iloc[0]
    assert r["breaking_point"] == math.inf
    assert math.isnan(r["logistic_point"]) and math.isnan(r["fieller_low"]) and math.isnan(r["fieller_high"])
    assert not any(math.isinf(r[c]) for c in ("logistic_point", "fieller_low", "fieller_high", "logistic_slope"))


def test_bootstrap_of_a_cell_does_not_depend_on_the_other_cells():
    from offroadbench.study.stats.stress import success_by_level

    rng = np.random.default_rng(3)
    a = _synthetic_trials(10, [2.3, 2.6, 2.9], 4, 2.7, 0.1, rng, "a")
    b = _synthetic_trials(10, [2.3, 2.6, 2.9], 4, 2.8, 0.1, rng, "b")
    both = breaking_points(pd.concat([a, b]), "planner", "D_high", n_boot=300).set_index("planner")
    alone = breaking_points(b, "planner", "D_high", n_boot=300).set_index("planner")
    assert both.loc["b", ["ci95_low", "ci95_high"]].tolist() == alone.loc["b", ["ci95_low", "ci95_high"]].tolist()
    s_both = success_by_level(pd.concat([a, b]), "planner", "D_high", n_boot=300)
    s_alone = success_by_level(b, "planner", "D_high", n_boot=300)
    assert (s_both[s_both["planner"] == "b"][["ci95_low", "ci95_high"]].to_numpy()
            == s_alone[["ci95_low", "ci95_high"]].to_numpy()).all()
    # and a different seed draws differently (the generator is the seed's, not a constant)
    other = breaking_points(b, "planner", "D_high", n_boot=300, seed=1).set_index("planner")
    s_other = success_by_level(b, "planner", "D_high", n_boot=300, seed=1)
    assert (other.loc["b", ["ci95_low", "ci95_high"]].tolist() != alone.loc["b", ["ci95_low", "ci95_high"]].tolist()
            or not np.array_equal(s_other[["ci95_low", "ci95_high"]].to_numpy(),
                                  s_alone[["ci95_low", "ci95_high"]].to_numpy()))


def test_keyed_rng_is_the_key_and_the_seed():
    from offroadbench.study.stats.clustered import keyed_rng

    draw = lambda *k: keyed_rng(0, *k).integers(0, 2**31, 4).tolist()  # noqa: E731
    assert draw("a", 2.95) == draw("a", 2.95) == draw("a", np.float64(2.95))
    assert draw("a", 2) == draw("a", 2.0)
    assert draw("a", 2.95) != draw("a", 2.99) and draw("a", 2.95) != draw("b", 2.95)
    assert keyed_rng(1, "a").integers(0, 2**31) != keyed_rng(0, "a").integers(0, 2**31)


def test_paired_table_is_terrain_level():
    # the pilot of issue 22: at one level astar beats straight on 13 missions, 7 of them on one
    # terrain; per terrain [7, 1, 1, 1, 1, 2] of 8 missions
    rows = []
    wins = [7, 1, 1, 1, 1, 2]
    for j, w in enumerate(wins):
        for m in range(8):
            rows.append({"planner": "straight", "D_high": 2.9, "terrain": j, "mission": m, "success": m >= w})
            rows.append({"planner": "astar", "D_high": 2.9, "terrain": j, "mission": m, "success": True})
    t = pd.DataFrame(rows)
    tab = paired_table(t, "planner", "D_high", "straight")
    r = tab[tab["D_high"] == 2.9].iloc[0]
    assert r["only this"] == 13 and r["only baseline"] == 0 and r["terrains"] == 6
    assert r["mcnemar_p_missions"] == pytest.approx(2 * 0.5 ** 13)
    assert r["p_sign_flip"] == pytest.approx(2 / 64) and r["p_wilcoxon"] == pytest.approx(2 / 64)
    assert r["p_durkalski"] == pytest.approx(0.085, abs=5e-4)
    assert r["terrain_diff_pct"] == pytest.approx(100 * 13 / 48)
    assert r["terrain_ci95_low"] >= 100 / 8 and r["terrain_ci95_high"] <= 100 * 7 / 8
    # two rows (level and pooled, the same p): Holm gives 2 x 2/64 = 0.0625 to both. With 6
    # terrains a difference that was "p < 1e-3" over missions is not a terrain-level claim here
    assert r["p_holm"] == pytest.approx(2 * 2 / 64) and not r["significant"]


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
    assert pooled["mcnemar_p_missions"] == pytest.approx(mcnemar_exact(int(pooled["only this"]), 0))
    assert pooled["terrains"] == 4 and 0 <= pooled["p_sign_flip"] <= 1 and "p_holm" in paired
    assert paired_table(df, "planner", None, "straight").shape[0] == 1
    bp = rep.tables["breaking_points.csv"].set_index("planner")
    assert set(bp.columns) >= {"breaking_point", "ci95_low", "ci95_high", "terrains", "first_level_below"}
    assert bp.loc["straight", "first_level_below"] <= bp.loc["astar", "first_level_below"]
    assert "offroadbench study replay" in rep.tables["replay_examples.csv"]["replay"].iloc[0]
    assert "planner_paths.png" in rep.figures and "planner_success.png" in rep.figures


def fake_noisy_map_trials(prepared, settings):
    """As fake_planner_trials, but astar's tolerance shrinks with the planner map's error."""
    perception = settings.planner.perception
    noise = perception.map_noise_m if perception is not None else 0.0
    tolerance = {"straight": 1.2, "astar": 2.0 - 16 * noise}[settings.planner.name]
    for row in fake_planner_trials(prepared, settings):
        ok = row["rms_vertical_accel_m_s2"] < tolerance
        yield {**row, "success": ok, "failure_reason": "" if ok else "stuck"}


def test_report_with_a_map_error_axis_and_a_band_limited_axis(tmp_path):
    data = {**STUDY, "grid": {"planner.name": ["straight", "astar"], "recipe.layers.base.D_high": [2.3, 2.9],
                              "recipe.layers.base.wm.band_limited": [False, True],
                              "planner.map_noise_m": [0.0, 0.05]}}
    study = study_from_dict(data)
    run_study(study, plan_cells(study), tmp_path, executor="inline", trial_fn=fake_noisy_map_trials)
    rep = build_report(tmp_path)
    paired = rep.tables["paired_tests.csv"]
    assert {"band_limited", "map_noise_m", "D_high"} <= set(paired.columns)
    # one row per (stratum, level) and one pooled row per stratum: 4 strata x (2 levels + 1)
    assert len(paired) == 4 * 3
    pooled = paired[paired["D_high"] == "all"].set_index(["band_limited", "map_noise_m"])
    for band in (False, True):
        # the planner's advantage shrinks with the map error
        assert pooled.loc[(band, 0.05), "terrain_diff_pct"] <= pooled.loc[(band, 0.0), "terrain_diff_pct"]
    assert pooled.loc[(False, 0.0), "terrain_diff_pct"] > pooled.loc[(False, 0.05), "terrain_diff_pct"] == 0
    assert "### Advantage over the baseline per `band_limited` and `map_noise_m`" in rep.markdown
    by = rep.tables["planner_success.csv"]
    assert len(by) == 2 * 2 * 2 * 2 and {"band_limited", "map_noise_m"} <= set(by.columns)
    assert len(rep.tables["breaking_points.csv"]) == 2 * 4
    assert {f"planner_success_{i}.png" for i in range(4)} <= set(rep.figures)


def fake_sensed_trials(prepared, settings):
    """As fake_planner_trials, but planning through the mast sensor tolerates less than the oracle."""
    perception = settings.planner.perception
    cut = 0.5 if perception is not None and perception.sensor == "mast" else 0.0
    tolerance = {"straight": 1.2, "astar": 2.0}[settings.planner.name] - cut
    for row in fake_planner_trials(prepared, settings):
        ok = row["rms_vertical_accel_m_s2"] < tolerance
        yield {**row, "success": ok, "failure_reason": "" if ok else "stuck"}


def test_report_tests_the_sensor_arm_on_the_same_missions(tmp_path):
    data = {**STUDY, "grid": {"planner.name": ["straight", "astar"], "recipe.layers.base.D_high": [2.9],
                              "planner.sensor": ["oracle", "mast"]}}
    study = study_from_dict(data)
    run_study(study, plan_cells(study), tmp_path, executor="inline", trial_fn=fake_sensed_trials)
    rep = build_report(tmp_path)
    arms = rep.tables["sensor_tests.csv"]
    # mast against the oracle, as the READMEs name it: the difference is mast - oracle
    assert set(arms["planner"]) == {"straight", "astar"} and (arms["sensor"] == "mast vs oracle").all()
    assert np.allclose(arms["diff_pct"], arms["success_treatment_pct"] - arms["success_control_pct"])
    # the sensor (treatment) succeeds at most as often as the oracle (control) on every stratum
    assert (arms["diff_pct"] <= 0).all() and (arms["diff_pct"] < 0).any()
    assert "### Sensing: the mast sensor against the oracle" in rep.markdown


def test_band_limited_arm_drives_the_aliased_arms_missions_and_the_plan_is_computed(tmp_path):
    data = {**STUDY, "study": {**STUDY["study"], "terrains_per_cell": 3, "missions_per_terrain": 3,
                               "missions_from": {"recipe.layers.base.wm.band_limited": False}},
            "grid": {"planner.name": ["straight", "astar"], "recipe.layers.base.D_high": [2.9],
                     "recipe.layers.base.wm.band_limited": [False, True]},
            "analysis": {"comparisons": [{"name": "aliasing", "treatment": {"recipe.layers.base.wm.band_limited": True},
                                          "control": {"recipe.layers.base.wm.band_limited": False},
                                          "where": {"planner.name": "straight"}}]}}
    study = study_from_dict(data)
    run_study(study, plan_cells(study), tmp_path, executor="inline", trial_fn=fake_planner_trials)
    df = load(tmp_path)
    # one start and goal per (terrain, mission) over both surfaces and both planners
    ends = df.groupby(["terrain", "mission"])[["start_x_m", "start_y_m", "goal_x_m", "goal_y_m"]].nunique()
    assert (ends == 1).all().all()
    rep = build_report(tmp_path)
    arms = rep.tables["band_limited_tests.csv"]
    assert (arms["same_missions"] == 1.0).all() and "paired mission by mission" in rep.markdown
    # the band-limited surface lacks the terms above Nyquist: a positive share of the variance, below 1
    assert ((arms["mean_twin_unexplained_var"] > 0) & (arms["mean_twin_unexplained_var"] < 1)).all()
    conf = rep.tables["confirmatory.csv"]
    assert len(conf) == 1 and conf["terrains"].iloc[0] == 3
    straight = df[df["planner"] == "straight"]
    rate = straight.groupby(["band_limited", "terrain"])["success"].mean().unstack("band_limited") * 100
    assert conf["effect"].iloc[0] == pytest.approx((rate[True] - rate[False]).mean())
    row = arms[arms["planner"] == "straight"].iloc[0]
    assert row["diff_pct"] == pytest.approx(conf["effect"].iloc[0])
    assert "## Confirmatory analysis" in rep.markdown and "## Success rate (Fig. 6) (exploratory)" in rep.markdown
    # a plan changed after trials were stored is refused, in one line
    from offroadbench.errors import InputError

    data["analysis"]["alpha"] = 0.01
    changed = study_from_dict(data)
    with pytest.raises(InputError, match=r"the \[analysis\] plan differs from the one stored with its 36 trials"):
        run_study(changed, plan_cells(changed), tmp_path, executor="inline", trial_fn=fake_planner_trials)


def test_arm_table_pairs_missions_and_reports_the_resolution_statistic():
    rows = []
    for j in range(6):
        for m in range(4):
            for band in (False, True):
                # the band-limited arm succeeds on one more mission per terrain; same ends in both arms
                ok = m < (2 + (1 if band else 0))
                rows.append({"planner": "straight", "band_limited": band, "terrain": j, "mission": m, "cell": int(band),
                             "success": ok, "start_x_m": float(m), "start_y_m": 0.0, "goal_x_m": 1.0, "goal_y_m": float(j)})
    t = pd.DataFrame(rows)
    ter = pd.DataFrame([{"cell": c, "terrain": j, "area_high": 0.1 * (1 - c) + 0.01,
                         "twin_unexplained_var": (0.2 + 0.01 * j) if c == 1 else np.nan} for c in (0, 1) for j in range(6)])
    tab = arm_table(t, "band_limited", False, True, ["planner"], terrains=ter)
    r = tab.iloc[0]
    assert r["same_missions"] == 1.0 and r["terrains"] == 6 and r["missions"] == 24
    assert r["diff_pct"] == pytest.approx(25.0) and r["p_sign_flip"] == pytest.approx(2 / 64)
    assert r["mean_twin_unexplained_var"] == pytest.approx(0.225)
    assert r["area_high_control_pct"] == pytest.approx(11.0) and r["area_high_treatment_pct"] == pytest.approx(1.0)
    # missions drawn separately per arm: said as such
    moved = t.assign(goal_x_m=np.where(t["band_limited"], 2.0, 1.0))
    assert arm_table(moved, "band_limited", False, True, ["planner"])["same_missions"].iloc[0] == 0.0
