"""A sample of the numbers in experiments/results/*/README.md, recomputed from the committed tables.

Each sample is a regular expression that finds a number in a README and a function that computes it
from the study's trial table. The trial table is ``trials.parquet`` in the results folder when it is
committed (one row per trial, as ``offroadbench study export DIR --format parquet`` writes it);
until then, trials are rebuilt from the report's own ``terrains.csv`` (per-terrain trial and success
counts, enough for every success statistic), and metric medians are read from its ``summary.csv``.
A README that no longer states a sampled number fails with the sample's name: re-point the sample.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

RESULTS = Path(__file__).resolve().parents[2] / "experiments" / "results"


def trial_table(folder: Path) -> pd.DataFrame:
    """The trial table of a results folder: trials.parquet, or trials rebuilt from terrains.csv."""
    parquet = folder / "trials.parquet"
    if parquet.is_file():
        return pd.read_parquet(parquet)
    ter = pd.read_csv(folder / "terrains.csv")
    keys = [c for c in ter.columns if c not in {"terrain_seed", "trials", "successes", "success_rate_pct"}
            and not c.startswith("area_")]
    rows = []
    for r in ter.to_dict("records"):
        for m in range(int(r["trials"])):
            rows.append({**{k: r[k] for k in keys}, "mission": m, "success": m < r["successes"]})
    return pd.DataFrame(rows)


def per_terrain_rate(trials: pd.DataFrame, by: str) -> pd.DataFrame:
    """Per-terrain success rate (Eq. 5 of Majhor & Bos 2023), terrains as rows, ``by`` as columns."""
    return trials.groupby([by, "terrain"])["success"].mean().mul(100).unstack(by)


@dataclass(frozen=True)
class Sample:
    name: str
    folder: str
    pattern: str
    """A regex on the README whose groups are the stated numbers."""
    compute: Callable[[Path], list[float]]
    """The same numbers from the folder's tables."""
    tol: float = 0.0
    """Absolute tolerance after the README's rounding (half a unit of its last digit is added)."""


def _successes(folder: Path) -> list[float]:
    t = trial_table(folder)
    return list(t.groupby("D_high")["success"].sum().astype(float))


def _median_rates(folder: Path) -> list[float]:
    return list(per_terrain_rate(trial_table(folder), "D_high").median())


def _pooled_fall(folder: Path) -> list[float]:
    rate = trial_table(folder).groupby("D_high")["success"].mean() * 100
    return [float(rate.iloc[1] - rate.iloc[2])]


def _correlation_and_counts(folder: Path) -> list[float]:
    p = per_terrain_rate(trial_table(folder), "D_high")
    lo, hi = p.columns.min(), p.columns.max()
    d = p[hi] - p[lo]
    return [float(p[lo].corr(p[hi])), float((d < 0).sum()), float((d == 0).sum()), float((d > 0).sum())]


def _low_area_changes(folder: Path) -> list[float]:
    ter = pd.read_csv(folder / "terrains.csv")
    med = ter.groupby("D_high")["area_low"].median() * 100
    return list(np.diff(med.to_numpy()))


def _metric_medians(metric: str) -> Callable[[Path], list[float]]:
    def compute(folder: Path) -> list[float]:
        parquet = folder / "trials.parquet"
        if parquet.is_file():
            t = pd.read_parquet(parquet)
            return list(t[t["success"].astype(bool)].groupby("D_high")[metric].median())
        return list(pd.read_csv(folder / "summary.csv")[f"median_{metric}"])

    return compute


def _planner_successes(folder: Path) -> list[float]:
    """planner-stress: successes per engine, surface, level, sensor and planner, in the README table's order."""
    t = trial_table(folder)
    s = t.groupby(["engine", "band_limited", "D_high", "sensor", "planner"])["success"].sum()
    return [float(s[(e, b, d, arm, p)]) for e in PS_ENGINES for b in (False, True) for d in (2.9, 2.95, 2.99)
            for arm in ("mast", "oracle") for p in ("straight", "astar", "lattice")]


def _paired_effect(folder: Path, level: float, treatment: dict, control: dict, where: dict) -> float:
    """Mean per-terrain success difference (points) between two cells of one level, over the terrains
    with trials in both (a terrain whose missions are all faults drops out of the pair)."""
    t = trial_table(folder)
    t = t[t["D_high"] == level]
    for col, v in where.items():
        t = t[t[col] == v]

    def rate(sel: dict) -> pd.Series:
        part = t
        for col, v in sel.items():
            part = part[part[col] == v]
        return part.groupby("terrain")["success"].mean().mul(100)

    d = (rate(treatment) - rate(control)).dropna()
    return float(d.mean())


PS_ENGINES = ("pybullet", "mujoco")
PS_TESTS = [(name, lv) for name in ("astar against the line, through the sensor",
                                    "lattice against the line, through the sensor",
                                    "aliasing: the line on the band-limited against the aliased surface")
            for lv in (2.95, 2.99)]
"""planner-stress's plan (issue 42 re-run): each comparison at 2.95 and 2.99, each on both engines."""


def _ps_differences(trials: pd.DataFrame, name: str, level: float) -> pd.Series:
    """planner-stress: per-terrain success difference (points) of a planned comparison at ``level``: a planner
    against the line through the mast sensor on the aliased surface, or the line's oracle arm on the band-limited
    against the aliased surface."""
    rate = trials.groupby(["planner", "sensor", "band_limited", "D_high", "terrain"])["success"].mean().mul(100)
    if name.startswith("aliasing"):
        return (rate[("straight", "oracle", True, level)] - rate[("straight", "oracle", False, level)]).dropna()
    return (rate[(name.split()[0], "mast", False, level)] - rate[("straight", "mast", False, level)]).dropna()


def _planner_stress_plan(folder: Path) -> list[list[float]]:
    """The plan's 12 tests in the README's order (confirmatory.csv's): per comparison and level, PyBullet then
    MuJoCo. Per test: terrains, the arms' means, effect (points), interval (confirmatory.csv), exact sign-flip p,
    Holm p over the 12, power (confirmatory.csv, fixed before the run)."""
    from offroadbench.study.stats.clustered import holm, sign_flip_test

    t = trial_table(folder)
    conf = pd.read_csv(folder / "confirmatory.csv")
    rows, p = [], []
    for i, ((name, lv), engine) in enumerate((test, e) for test in PS_TESTS for e in PS_ENGINES):
        c = conf.iloc[i]
        assert c["comparison"] == name and f"D_high = {lv}" in c["stratum"] and f"engine = {engine}" in c["stratum"]
        part = t[t["engine"] == engine]
        d = _ps_differences(part, name, lv)
        p.append(sign_flip_test(d.to_numpy(float)))
        rows.append([float(len(d)), float(c["control_mean"]), float(c["treatment_mean"]), float(d.mean()),
                     float(c["ci_low"]), float(c["ci_high"]), p[-1]])
        # the arms' means are the per-terrain rates' means
        assert abs(float(d.mean()) - (c["treatment_mean"] - c["control_mean"])) < 1e-9
    return [[*r, float(q), float(c)] for r, q, c in zip(rows, holm(p), conf["power"], strict=True)]


def _planner_stress_old_plan(folder: Path) -> list[float]:
    """The previous run's plan (2026-11-26 evening, PyBullet, root seed 41; its trials are the committed pilot):
    per test, effect (points), exact sign-flip p and Holm p over its 6 tests."""
    from offroadbench.study.stats.clustered import holm, sign_flip_test

    o = pd.read_csv(RESULTS.parent / "pilots" / "planner-stress-2026-11-26-evening.csv")
    d = [_ps_differences(o, name, lv) for name, lv in PS_TESTS]
    p = [sign_flip_test(x.to_numpy(float)) for x in d]
    return [v for x, pv, q in zip(d, p, holm(p), strict=True) for v in (float(x.mean()), pv, float(q))]


def _planner_stress_sensor_cost(folder: Path) -> list[float]:
    """The sensor's cost (mast - oracle, points, as the README names it: mast against the oracle) to astar and
    lattice on the aliased surface at 2.95 / 2.99 on each engine: the mean per-terrain difference on the same
    missions and its terrain-bootstrap interval (as the report draws it: a generator of the row's own, keyed_rng)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, keyed_rng

    t = trial_table(folder)
    rate = t.groupby(["engine", "planner", "sensor", "band_limited", "D_high", "terrain"])["success"].mean().mul(100)
    out = []
    for p in ("astar", "lattice"):
        for lv in (2.95, 2.99):
            for e in PS_ENGINES:
                d = (rate[(e, p, "mast", False, lv)] - rate[(e, p, "oracle", False, lv)]).dropna().to_numpy(float)
                b = cluster_bootstrap(d, np.mean, keyed_rng(0, "arm_table", "sensor", "mast", "oracle", p, False, e, lv))
                out += [float(d.mean()), b.low, b.high]
    return out


def _vp_success_intervals(level: float) -> Callable[[Path], list[float]]:
    """vehicle-planner: the Husky's successes, rates and terrain-bootstrap intervals (%) per planner, oracle then
    mast, at ``level``, as the report computes them (stress.success_by_level over the report's strata: a
    generator per cell)."""
    def compute(folder: Path) -> list[float]:
        from experiments.rerender import folder_meta
        from offroadbench.study.report.planners import stress_axes
        from offroadbench.study.stats.stress import success_by_level

        group, lv, strata = stress_axes(folder_meta(folder))
        by = success_by_level(trial_table(folder), group, lv, by=strata).set_index([group, "vehicle", "sensor", lv])
        out = []
        for p in ("straight", "astar", "lattice", "reactive", "mppi", "ppo"):
            for sensor in ("oracle", "mast"):
                r = by.loc[(p, "husky", sensor, level)]
                out += [float(r["successes"]), 100 * r["success_rate"], 100 * r["ci95_low"], 100 * r["ci95_high"]]
        return out
    return compute


MAJHOR_TESTS = (("D 2.3 -> 2.45", "success_rate_pct", 2.3, 2.45), ("D 2.45 -> 2.6", "success_rate_pct", 2.45, 2.6),
                *((f"D {lo} -> {hi}: {label}", m, lo, hi)
                  for label, m in (("vertical acceleration", "rms_vertical_accel_m_s2"), ("pitch rate", "rms_pitch_rate_deg_s"),
                                   ("roll rate", "rms_roll_rate_deg_s"))
                  for lo, hi in ((2.3, 2.45), (2.45, 2.6))))
"""The majhor2023 plans' 8 tests in confirmatory.csv's order: (name, metric, control D_high, treatment D_high)."""


def _majhor_terrain_values(t: pd.DataFrame, metric: str, summary: str) -> pd.DataFrame:
    """Per terrain (rows) and D_high (columns): the success rate (%), or a ride metric's per-terrain ``summary``
    (median or mean) over the terrain's successful trials."""
    if metric == "success_rate_pct":
        return t.groupby(["D_high", "terrain"])["success"].mean().mul(100).unstack("D_high")
    ok = t[t["success"].astype(bool)]
    return ok.groupby(["D_high", "terrain"])[metric].agg(summary).unstack("D_high")


def _majhor_plan(folder: Path) -> list[list[float]]:
    """The plan's 8 tests, recomputed from the trial table: terrains, the control's and the treatment's mean
    per-terrain value, effect, the interval (confirmatory.csv), exact sign-flip p, Holm p over the 8, and the
    power the plan stated (confirmatory.csv, simulated before the run); the ride tests add the same test on the
    per-terrain mean (exploratory): effect and p."""
    from offroadbench.study.stats.clustered import holm, sign_flip_test

    t = trial_table(folder)
    conf = pd.read_csv(folder / "confirmatory.csv")
    rows, p = [], []
    for i, (name, metric, lo, hi) in enumerate(MAJHOR_TESTS):
        assert conf["comparison"].iloc[i] == name
        v = _majhor_terrain_values(t, metric, "median")[[lo, hi]].dropna()
        d = (v[hi] - v[lo]).to_numpy(float)
        p.append(sign_flip_test(d))
        rows.append([float(d.size), float(v[lo].mean()), float(v[hi].mean()), float(d.mean()),
                     float(conf["ci_low"].iloc[i]), float(conf["ci_high"].iloc[i]), p[-1]])
    out = []
    for i, (row, q) in enumerate(zip(rows, holm(p), strict=True)):
        row += [float(q), float(conf["power"].iloc[i])]
        name, metric, lo, hi = MAJHOR_TESTS[i]
        if metric != "success_rate_pct":
            v = _majhor_terrain_values(trial_table(folder), metric, "mean")[[lo, hi]].dropna()
            d = (v[hi] - v[lo]).to_numpy(float)
            row += [float(d.mean()), sign_flip_test(d)]
        out.append(row)
    return out


def _majhor_plan_pattern(names=tuple(n for n, *_ in MAJHOR_TESTS)) -> str:
    """The README rows of the plan's table (see _majhor_plan), in order."""
    return "".join(
        rf"\| {re.escape(n)} \| {_NUM} \| {_NUM} -> {_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\] \| {_SCI} \| {_SCI} \| (?:yes|no) "
        rf"\| {_NUM} at [+-][\d.]+ \| " + (r"– \|\n" if m == "success_rate_pct" else rf"\+?{_NUM}, p {_SCI} \|\n")
        for n, m, *_ in MAJHOR_TESTS if n in names)


def _majhor_both_plans(folder: Path) -> list[float]:
    """Per planned test: the effect and Holm p on PyBullet (majhor2023) and on MuJoCo (majhor2023-mujoco), from
    their confirmatory.csv (each recomputed from its trials by the plan samples)."""
    pb, mj = (pd.read_csv(RESULTS / s / "confirmatory.csv") for s in ("majhor2023", "majhor2023-mujoco"))
    return [float(v) for i in range(len(MAJHOR_TESTS))
            for v in (pb["effect"].iloc[i], pb["p_adjusted"].iloc[i], mj["effect"].iloc[i], mj["p_adjusted"].iloc[i])]


def _majhor_both_rows() -> str:
    """The README rows of the one-line-per-test table on both engines (see _majhor_both_plans), in order."""
    return "".join(rf"\| {re.escape(n)} \| \+?{_NUM}, Holm {_SCI}, (?:\*\*yes\*\*|no) \| \+?{_NUM}, Holm {_SCI}, "
                   r"(?:\*\*yes\*\*|no) \|[^\n]*\n" for n, *_ in MAJHOR_TESTS)


def _shared_missions(folder: Path) -> list[float]:
    """Band-limited trials whose start and goal equal those of the aliased trial of the same planner,
    level, sensor, terrain and mission."""
    t = trial_table(folder)
    keys = ["planner", "D_high", "sensor", "terrain", "mission"] + (["engine"] if "engine" in t else [])
    ends = ["start_x_m", "start_y_m", "goal_x_m", "goal_y_m"]
    a = t[~t["band_limited"].astype(bool)].set_index(keys)[ends]
    b = t[t["band_limited"].astype(bool)].set_index(keys)[ends]
    pair = pd.merge(a, b, how="inner", left_index=True, right_index=True, suffixes=("", "_b"))
    same = np.all([np.isclose(pair[c], pair[f"{c}_b"]) for c in ends], axis=0)
    return [float(same.sum())] if len(pair) == len(b) else [float("nan")]


def _above_nyquist_share(folder: Path) -> list[float]:
    """Mean per-terrain share (%) of the aliased surface's variance that its band-limited twin does not
    explain, per D_high (terrains.csv)."""
    ter = pd.read_csv(folder / "terrains.csv")
    per = ter[ter["band_limited"].astype(bool)].groupby(["D_high", "terrain"])["twin_unexplained_var"].first()
    return list(per.groupby("D_high").mean().mul(100))


def _straight_breaking_point(folder: Path) -> list[float]:
    """planner-stress: the line's breaking point on the paper's surface (oracle arm) and its interval, on each
    engine (as the report computes it: a generator per group)."""
    from offroadbench.study.stats.stress import breaking_points

    bp = breaking_points(trial_table(folder), "planner", "D_high", by=["band_limited", "sensor", "engine"])
    out = []
    for e in PS_ENGINES:
        row = bp[(bp["planner"] == "straight") & (~bp["band_limited"].astype(bool)) & (bp["sensor"] == "oracle")
                 & (bp["engine"] == e)].iloc[0]
        out += [float(row["breaking_point"]), float(row["ci95_low"]), float(row["ci95_high"])]
    return out


def _terrain_success_changes(folder: Path) -> list[float]:
    from offroadbench.study.stats.terrain import terrain_changes

    t = trial_table(folder)
    ter = pd.read_csv(folder / "terrains.csv")
    labels = {c: f"D_high = {d}" for c, d in ter.groupby("cell")["D_high"].first().items()}
    from offroadbench.study.stats.terrain import METRICS

    areas = [f"area_{c}_pct" for c in ("low", "semi", "high")]
    # the report's family of comparisons (Holm over all of them); metrics need the trial table
    metrics = list(METRICS) if (folder / "trials.parquet").is_file() else []
    tab = terrain_changes(t, ter, labels, ["success_rate_pct", *areas, *metrics]).iloc[0]
    return [-tab["mean_change"], tab["ci95_low"], tab["ci95_high"], tab["down"], tab["up"], tab["p_wilcoxon"],
            tab["p_holm"]]


def _pooled_success_effect(axis: str, treatment, control) -> Callable[[Path], list[float]]:
    """The mean per-terrain success difference (points) between two values of ``axis``, each terrain's
    rate over every other cell (the plans' ``pool``)."""
    def compute(folder: Path) -> list[float]:
        rate = trial_table(folder).groupby([axis, "terrain"])["success"].mean().mul(100).unstack(axis)
        return [float((rate[treatment] - rate[control]).mean())]
    return compute


_SETTINGS = [(28.0, 1.0), (22.0, 1.0), (16.5, 1.0), (28.0, 0.25), (22.0, 0.25), (16.5, 0.25)]
"""The vehicle-sensitivity README's rows: (wheel torque N m, spin inertia kg m^2)."""


def _vehicle_setting_successes(folder: Path) -> list[float]:
    s = trial_table(folder).groupby(["wheel_torque_limit_nm", "wheel_spin_inertia_kg_m2"])["success"].sum()
    return [float(s.loc[k]) for k in _SETTINGS]


def _torque_pitch_rate_drop(folder: Path) -> list[float]:
    """Mean per-terrain fall of the median RMS pitch rate of successful trials, 28 -> 16.5 N m at 1 kg m^2."""
    t = trial_table(folder)
    ok = t[t["success"].astype(bool) & (t["wheel_spin_inertia_kg_m2"] == 1.0)]
    med = ok.groupby(["wheel_torque_limit_nm", "terrain"])["rms_pitch_rate_deg_s"].median().unstack("wheel_torque_limit_nm")
    return [float((med[28.0] - med[16.5]).mean())]


VS_TESTS = [(22.0, 1.0, "success"), (16.5, 1.0, "success"), (28.0, 0.25, "success"), (22.0, 0.25, "success"),
            (16.5, 0.25, "success"), (16.5, 1.0, "pitch rate"), (28.0, 0.25, "pitch rate")]
"""The vehicle-sensitivity plan (confirmatory.csv's order): (torque N m, spin inertia kg m^2, metric), each against
the shipped 28 N m / 1.0 kg m^2."""


def _vehicle_sensitivity_plan(folder: Path) -> list[list[float]]:
    """The plan's 7 tests (5 on success, 2 on the per-terrain median pitch rate of successful trials), recomputed
    from the trial table as the report draws them (one generator seeded 0 through the tests in order: 2000
    bootstrap draws each; exact sign-flip over 20 terrains; Holm over the 7). Per test: the shipped vehicle's and
    the setting's mean per-terrain value, effect, interval, p, Holm p; then the power the plan stated
    (confirmatory.csv: simulated before the run from the pilot)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, holm, sign_flip_test

    t = trial_table(folder)
    key = ["wheel_torque_limit_nm", "wheel_spin_inertia_kg_m2"]
    vals = {"success": t.groupby([*key, "terrain"])["success"].mean().mul(100),
            "pitch rate": t[t["success"].astype(bool)].groupby([*key, "terrain"])["rms_pitch_rate_deg_s"].median()}
    conf = pd.read_csv(folder / "confirmatory.csv")
    rng = np.random.default_rng(0)
    rows, p = [], []
    for i, (torque, inertia, metric) in enumerate(VS_TESTS):
        assert conf["comparison"].iloc[i].startswith(f"{torque:g} N m, {inertia:g} kg m^2") and metric in conf["comparison"].iloc[i]
        v = vals[metric]
        d = (v[(torque, inertia)] - v[(28.0, 1.0)]).to_numpy(float)
        b = cluster_bootstrap(d, np.mean, rng, 2000, level=0.95)
        p.append(sign_flip_test(d, rng=rng))
        rows.append([float(v[(28.0, 1.0)].mean()), float(v[(torque, inertia)].mean()), float(d.mean()), b.low, b.high, p[-1]])
    return [row + [float(q), float(conf["power"].iloc[i])] for i, (row, q) in enumerate(zip(rows, holm(p), strict=True))]


VEHICLES = ("husky", "jackal", "talon", "hunter", "sojourner")
TERRAIN_KINDS = ("paper-d2.3", "paper-d2.45", "paper-d2.6", "lunar-mare")


def _vehicle_successes(folder: Path) -> list[float]:
    """Successes per vehicle and terrain kind, in the README table's order."""
    s = trial_table(folder).groupby(["vehicle", "recipe"])["success"].sum()
    return [float(s[(v, r)]) for v in VEHICLES for r in TERRAIN_KINDS]


CRATER_DENSITIES = (0.0, 0.03, 0.1, 0.3)
_CRATER_METRICS = ("traversal_time_s", "rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "max_abs_pitch_deg")


def _crater_density_rows(folder: Path) -> list[float]:
    """Per density: successes, then the medians of the successful trials' metrics (the README table's order)."""
    t = trial_table(folder)
    ok = t[t["success"].astype(bool)]
    out: list[float] = []
    for c in CRATER_DENSITIES:
        out.append(float(t.loc[t["c"] == c, "success"].sum()))
        out += [float(ok.loc[ok["c"] == c, m].median()) for m in _CRATER_METRICS]
    return out


def _plan_rows(folder: Path, diffs: list[pd.DataFrame]) -> list[list[float]]:
    """Planned tests in confirmatory.csv's order, each from its per-terrain table (columns ``t`` and ``c``, a terrain
    without a value on one side dropped), as the report draws them (offroadbench.study.stats.plan: one generator
    seeded 0 through the tests in order, 2000 bootstrap draws, the exact sign-flip test, Holm over the plan). Per
    test: terrains, the control's and the treatment's mean, effect, interval, p, Holm p; then the power the plan
    stated (confirmatory.csv: simulated before the run from the pilot)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, holm, sign_flip_test

    conf = pd.read_csv(folder / "confirmatory.csv")
    rng = np.random.default_rng(0)
    rows, p = [], []
    for both in diffs:
        both = both.dropna()
        d = (both["t"] - both["c"]).to_numpy(float)
        b = cluster_bootstrap(d, np.mean, rng, 2000, level=0.95)
        p.append(sign_flip_test(d, rng=rng))
        rows.append([float(d.size), float(both["c"].mean()), float(both["t"].mean()), float(d.mean()), b.low, b.high, p[-1]])
    return [row + [float(q), float(conf["power"].iloc[i])] for i, (row, q) in enumerate(zip(rows, holm(p), strict=True))]


CRATER_TESTS = [f"{n} against none: {m}" for m in ("success", "vertical acceleration")
                for n in ("craters", "more craters", "most craters")]
"""crater-density's planned tests in confirmatory.csv's order."""


def _crater_density_plan(folder: Path) -> list[list[float]]:
    """crater-density's 6 planned tests: each density against none, success (points) then the per-terrain median
    RMS vertical acceleration of successful trials (m/s^2)."""
    t = trial_table(folder)
    rate = t.groupby(["c", "terrain"])["success"].mean().mul(100).unstack("c")
    va = t[t["success"].astype(bool)].groupby(["c", "terrain"])["rms_vertical_accel_m_s2"].median().unstack("c")
    return _plan_rows(folder, [pd.DataFrame({"t": tab[c], "c": tab[0.0]}) for tab in (rate, va)
                               for c in CRATER_DENSITIES[1:]])


@pytest.mark.parametrize("name", ["crater-density", "engines", "engines-warp"])
def test_a_re_planned_studys_rejections_and_power_are_its_tables(name):
    """Issue 42's re-planned studies: the README's yes/no per planned test is confirmatory.csv's, every planned test
    had power >= 0.8 at its stated effect before the run, and a both-engine study's verdicts are engine_verdicts.csv's."""
    folder = RESULTS / name
    text = (folder / "README.md").read_text()
    conf = pd.read_csv(folder / "confirmatory.csv")
    assert conf["power"].min() >= 0.8 and not conf["exploratory"].any()
    rows = re.findall(r"^\| [^|\n]+ \| \d+ \| [^|\n]+ -> [^|\n]+ \|[^|\n]+\|[^|\n]+\|[^|\n]+\| (yes|no) \| [\d.]+ at ", text, re.M)
    assert rows == ["yes" if r else "no" for r in conf["reject"]]
    if (folder / "engine_verdicts.csv").is_file():  # one line per per-engine test: its cross-engine verdict
        eng = pd.read_csv(folder / "engine_verdicts.csv")
        for comparison, verdict in eng.groupby("comparison", sort=False)["verdict"].first().items():
            assert f"**{comparison}: {verdict}**" in text, comparison


def _failure_counts(folder: Path, where: str, reasons: tuple[str, ...]) -> list[float]:
    counts = trial_table(folder).query(where)["failure_reason"].value_counts()
    return [float(counts.get(r, 0)) for r in reasons]


SOIL_MAP_SNOW = "soil-map/mare-floors-snow.toml"
SOIL_MAP_SIMULANT = "soil-map/mare-floors-simulant.toml"
SOIL_MAP_ROWS = {r"lunar-mare \(one soil\)": "lunar-mare", "crater interiors on the simulant": SOIL_MAP_SIMULANT,
                 "crater interiors on the soft deposit": SOIL_MAP_SNOW}
"""The soil-map README table's rows: (row label regex, recipe)."""
SOIL_MAP_TESTS = {"soft crater interiors against one soil": SOIL_MAP_SNOW,
                  "simulant crater interiors against one soil": SOIL_MAP_SIMULANT}
"""The soil-map plan (confirmatory.csv's order): (README name, treatment recipe), each against lunar-mare."""
def _soil_map_outcomes(folder: Path, recipe: str) -> list[float]:
    """One soil layout's successes, then its entrapped, stuck, timeout and off_map failures."""
    t = trial_table(folder).query("recipe == @recipe")
    counts = t["failure_reason"].value_counts()
    return [float(t["success"].sum())] + [float(counts.get(r, 0)) for r in ("entrapped", "stuck", "timeout", "off_map")]


def _soil_map_flips(folder: Path, recipe: str) -> list[float]:
    """Missions (terrain, mission) that succeed on one soil and fail on ``recipe``, then the reverse."""
    w = trial_table(folder).pivot_table(index=["terrain", "mission"], columns="recipe", values="success",
                                        aggfunc="first").astype(bool)
    return [float((w["lunar-mare"] & ~w[recipe]).sum()), float((~w["lunar-mare"] & w[recipe]).sum())]


def _soil_map_plan(folder: Path) -> list[list[float]]:
    """The plan's 2 tests, recomputed from the trial table as the report draws them (one generator seeded 0
    through the tests in order: 2000 bootstrap draws, then the sign-flip test, Monte Carlo beyond 20 terrains;
    Holm over the 2). Per test: terrains, one soil's and the map's mean per-terrain success, effect, interval,
    p, Holm p; then the power the plan stated (confirmatory.csv: simulated before the run from the pilot)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, holm, sign_flip_test

    rate = trial_table(folder).groupby(["recipe", "terrain"])["success"].mean().mul(100).unstack("recipe")
    conf = pd.read_csv(folder / "confirmatory.csv").set_index("comparison")
    rng = np.random.default_rng(0)
    rows, p = [], []
    for recipe in SOIL_MAP_TESTS.values():
        d = (rate[recipe] - rate["lunar-mare"]).to_numpy(float)
        b = cluster_bootstrap(d, np.mean, rng, 2000, level=0.95)
        p.append(sign_flip_test(d, rng=rng))
        rows.append([float(d.size), float(rate["lunar-mare"].mean()), float(rate[recipe].mean()), float(d.mean()),
                     b.low, b.high, p[-1]])
    return [row + [float(q), float(conf.loc[f"{name}: success", "power"])]
            for row, q, name in zip(rows, holm(p), SOIL_MAP_TESTS, strict=True)]


LUNAR_SOIL_CELLS = [(e, m, g, a) for e in ("pybullet", "mujoco") for m in ("coulomb", "terramechanics")
                    for g in (1.62, 9.81) for a in (0.01, 0.1, 3.5)]
"""The lunar-soil README table's rows: (engine, tyre model, gravity m/s^2, surface age Ga)."""


def _lunar_soil_rows(folder: Path) -> list[float]:
    """Per row: successes and the successful trials' median traversal time; soil rows add the median mean
    slip and the medians of the per-trial median and 95th-percentile sinkage (mm)."""
    t = trial_table(folder)
    out: list[float] = []
    for e, m, g, a in LUNAR_SOIL_CELLS:
        cell = t[(t["engine"] == e) & (t["tyre_model"] == m) & (t["gravity_m_s2"] == g) & (t["age_ga"] == a)]
        out += [float(cell["success"].sum()), float(cell.loc[cell["success"].astype(bool), "traversal_time_s"].median())]
        if m == "terramechanics":
            out += [float(cell["mean_slip"].median()), 1000 * float(cell["sinkage_median_m"].median()),
                    1000 * float(cell["sinkage_p95_m"].median())]
    return out


def _soil_success_by_gravity(folder: Path) -> list[float]:
    """Mean per-terrain success (%) on regolith, lunar then Earth gravity, each terrain over the three ages:
    PyBullet, then MuJoCo."""
    t = trial_table(folder)
    out: list[float] = []
    for e in ("pybullet", "mujoco"):
        soil = t[(t["tyre_model"] == "terramechanics") & (t["engine"] == e)]
        rate = soil.groupby(["gravity_m_s2", "terrain"])["success"].mean().mul(100).groupby("gravity_m_s2").mean()
        out += [float(rate[1.62]), float(rate[9.81])]
    return out


def _soil_effect_per_engine(folder: Path) -> list[float]:
    """Regolith against rigid ground: the fall in mean per-terrain success (points), PyBullet then MuJoCo,
    each terrain's rate pooled over gravity and age (the plan's test, per engine)."""
    t = trial_table(folder)
    out: list[float] = []
    for e in ("pybullet", "mujoco"):
        rate = t[t["engine"] == e].groupby(["tyre_model", "terrain"])["success"].mean().mul(100).unstack("tyre_model")
        out.append(-float((rate["terramechanics"] - rate["coulomb"]).mean()))
    return out


def _one_engine_only(folder: Path) -> list[float]:
    """Paired missions (same D, terrain and mission) that succeed on MuJoCo only, then on PyBullet only."""
    w = trial_table(folder).pivot_table(index=["D_high", "terrain", "mission"], columns="engine", values="success",
                                        aggfunc="first").astype(bool)
    return [float((w["mujoco"] & ~w["pybullet"]).sum()), float((w["pybullet"] & ~w["mujoco"]).sum())]


ENGINES_TESTS = (("engine: success", "engine, success (MuJoCo - PyBullet, pooled), points"),
                 ("engine: roll rate", "engine, RMS roll rate (pooled), deg/s"),
                 ("D 2.3 -> 2.6: vertical acceleration, per engine", "D 2.3 -> 2.6, RMS vertical acceleration, PyBullet, m/s^2"),
                 ("D 2.3 -> 2.6: vertical acceleration, per engine", "D 2.3 -> 2.6, RMS vertical acceleration, MuJoCo, m/s^2"),
                 ("D 2.3 -> 2.6: success, per engine", "D 2.3 -> 2.6, success, PyBullet, points"),
                 ("D 2.3 -> 2.6: success, per engine", "D 2.3 -> 2.6, success, MuJoCo, points"))
"""The engines plan in confirmatory.csv's order: (comparison, the README's row label)."""


def _engines_plan(folder: Path) -> list[list[float]]:
    """engines' 6 planned tests: MuJoCo against PyBullet, success and the per-terrain median RMS roll rate, each
    terrain's value the mean over the three D_high (a terrain without a success at one D_high dropped); then
    D_high 2.3 -> 2.6 per engine, RMS vertical acceleration (per-terrain median) and success."""
    t = trial_table(folder)
    ok = t[t["success"].astype(bool)]
    rate = t.groupby(["engine", "D_high", "terrain"])["success"].mean().mul(100)
    roll = ok.groupby(["engine", "D_high", "terrain"])["rms_roll_rate_deg_s"].median()
    va = ok.groupby(["engine", "D_high", "terrain"])["rms_vertical_accel_m_s2"].median()

    def pooled(s: pd.Series, e: str) -> pd.Series:
        return s[e].unstack("D_high").mean(axis=1, skipna=False)

    def step(s: pd.Series, e: str) -> pd.DataFrame:
        return pd.DataFrame({"t": s[(e, 2.6)], "c": s[(e, 2.3)]})

    return _plan_rows(folder, [pd.DataFrame({"t": pooled(rate, "mujoco"), "c": pooled(rate, "pybullet")}),
                               pd.DataFrame({"t": pooled(roll, "mujoco"), "c": pooled(roll, "pybullet")}),
                               step(va, "pybullet"), step(va, "mujoco"), step(rate, "pybullet"), step(rate, "mujoco")])


def _engines_engine_differences(folder: Path) -> list[float]:
    """Per per-engine planned test (the D_high 2.3 -> 2.6 steps): the engine difference (per terrain, MuJoCo's step
    minus PyBullet's) with its terrain-bootstrap interval, a generator of the test's own
    (offroadbench.study.stats.engines.engine_table), and its terrains."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, keyed_rng

    t = trial_table(folder)
    ok = t[t["success"].astype(bool)]
    vals = {"D 2.3 -> 2.6: vertical acceleration, per engine":
            ok.groupby(["engine", "D_high", "terrain"])["rms_vertical_accel_m_s2"].median(),
            "D 2.3 -> 2.6: success, per engine": t.groupby(["engine", "D_high", "terrain"])["success"].mean().mul(100)}
    label = pd.read_csv(folder / "engine_verdicts.csv")["stratum"].iloc[0]
    out: list[float] = []
    for name, v in vals.items():
        step = {e: (v[(e, 2.6)] - v[(e, 2.3)]).dropna() for e in ("pybullet", "mujoco")}
        common = step["pybullet"].index.intersection(step["mujoco"].index)
        dd = (step["mujoco"].reindex(common) - step["pybullet"].reindex(common)).to_numpy(float)
        b = cluster_bootstrap(dd, np.mean, keyed_rng(0, "engine difference", name, label), 2000, level=0.95)
        out += [float(dd.mean()), b.low, b.high, float(dd.size)]
    return out


def _sign_flip_plan(trials: pd.DataFrame, axis: str, pairs: list[tuple], which: int) -> list[float]:
    """A plan of pooled per-terrain success comparisons (treatment, control) along ``axis``, every
    other column pooled (each terrain's rate over the rest), exact sign-flip tests, Holm over the
    pairs: comparison ``which``'s effect, p and Holm p, recomputed from the trial table."""
    from offroadbench.study.stats.clustered import holm, sign_flip_test

    rate = trials.groupby([axis, "terrain"])["success"].mean().mul(100).unstack(axis)
    diffs = [(rate[t] - rate[c]).to_numpy(float) for t, c in pairs]
    p = [sign_flip_test(d) for d in diffs]
    return [float(diffs[which].mean()), p[which], float(holm(p)[which])]


COMPARED_VEHICLES = (("jackal", "jackal"), ("talon", "talon (tracked)"), ("hunter", "hunter (Ackermann)"),
                     ("sojourner", "sojourner (rocker-bogie)"))
"""The vehicle-comparison plan's treatments against the Husky: (vehicle, its README and confirmatory.csv label)."""


def _vehicle_comparison_plan(which: int) -> Callable[[Path], list[float]]:
    """The vehicle-comparison plan's comparison ``which``: the Husky's and the vehicle's mean per-terrain success,
    effect, interval (confirmatory.csv), p and Holm p (exact sign-flip over 16 terrains), the power the plan stated."""
    def compute(folder: Path) -> list[float]:
        t = trial_table(folder)
        pairs = [(v, "husky") for v, _ in COMPARED_VEHICLES]
        effect, p, p_holm = _sign_flip_plan(t, "vehicle", pairs, which)
        rate = t.groupby(["vehicle", "terrain"])["success"].mean().mul(100)
        label = COMPARED_VEHICLES[which][1]
        ci = pd.read_csv(folder / "confirmatory.csv").set_index("comparison").loc[f"{label} against the husky"]
        return [float(rate["husky"].mean()), float(rate[COMPARED_VEHICLES[which][0]].mean()), effect,
                float(ci["ci_low"]), float(ci["ci_high"]), p, p_holm, float(ci["power"])]

    return compute


def _vehicle_kind_differences(vehicle: str) -> Callable[[Path], list[float]]:
    """Per terrain kind (the README's order): the vehicle's mean per-terrain success minus the Husky's, points."""
    def compute(folder: Path) -> list[float]:
        rate = trial_table(folder).groupby(["vehicle", "recipe", "terrain"])["success"].mean().mul(100)
        return [float((rate[vehicle][r] - rate["husky"][r]).mean()) for r in TERRAIN_KINDS]

    return compute


def _vehicle_ride_medians(vehicle: str) -> Callable[[Path], list[float]]:
    """One vehicle's README rows: per terrain kind, the medians of the successful trials' RMS vertical
    acceleration, pitch rate and roll rate."""
    metrics = ("rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s")

    def compute(folder: Path) -> list[float]:
        t = trial_table(folder)
        ok = t[(t["vehicle"] == vehicle) & t["success"].astype(bool)]
        return [float(ok.loc[ok["recipe"] == r, m].median()) for r in TERRAIN_KINDS for m in metrics]

    return compute


PLANNERS = ("straight", "astar", "lattice", "reactive", "mppi", "ppo")


VEHICLE_PLANNER_VEHICLES = ("husky", "jackal", "talon", "hunter", "sojourner")
VP_EARLIER = "vehicle-planner/earlier-2026-11-26"
"""The earlier vehicle-planner run (2026-11-26, 960 trials, PyBullet), kept beside the confirmatory re-run."""


def _vp_trials(folder: Path) -> pd.DataFrame:
    """The vehicle-planner trials at D_high 2.95, the level of its plan and of the README's main tables."""
    t = trial_table(folder)
    return t[t["D_high"] == 2.95]


def _vp_refused(folder: Path) -> list[float]:
    """Faults of the refused HUNTER x astar pair per cell at D_high 2.95 (oracle, then mast)."""
    cells = pd.read_csv(folder / "terrains.csv").groupby("cell")["D_high"].first()
    f = pd.read_csv(folder / "faults.csv").query("reason.str.startswith('the planner refuses this vehicle')")
    return [float(n) for n in f[f["cell"].map(cells) == 2.95].groupby("cell").size()]


def _vehicle_planner_successes(folder: Path) -> list[float]:
    """Successes per vehicle and planner, oracle then mast, in the README table's order (the refused
    HUNTER x astar pair left out: the README shows it as refused)."""
    s = _vp_trials(folder).groupby(["vehicle", "planner", "sensor"])["success"].sum()
    return [float(s[(v, p, arm)]) for v in VEHICLE_PLANNER_VEHICLES for p in PLANNERS
            if (v, p) != ("hunter", "astar") for arm in ("oracle", "mast")]


def _vp_old_plan(folder: Path) -> list[list[float]]:
    """The earlier vehicle-planner run's plan (each terrain's success, the mean over the vehicles, over the
    four that A* drives for A*'s two tests; exact sign-flip tests, Holm over the 4), in its order: per test the
    arms' means, effect, interval, p and Holm p. The interval as its report drew it (its confirmatory.csv is in
    git history only): the plan's one generator, seeded 0, through the tests in order (2000 draws each)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, holm, sign_flip_test

    arms = [(("mppi", "mast"), ("straight", "mast")), (("astar", "mast"), ("straight", "mast")),
            (("astar", "mast"), ("astar", "oracle")), (("ppo", "mast"), ("straight", "mast"))]
    t = _vp_trials(folder)
    rate_all = t.groupby(["planner", "sensor", "terrain"])["success"].mean().mul(100)
    rate_astar = t[t["vehicle"] != "hunter"].groupby(["planner", "sensor", "terrain"])["success"].mean().mul(100)
    rates = [rate_all, rate_astar, rate_astar, rate_all]
    rng = np.random.default_rng(0)
    rows, p = [], []
    for r, (a, c) in zip(rates, arms, strict=True):
        d = (r[a] - r[c]).to_numpy(float)
        b = cluster_bootstrap(d, np.mean, rng, 2000, level=0.95)
        p.append(sign_flip_test(d, rng=rng))
        rows.append([float(r[a].mean()), float(r[c].mean()), float(d.mean()), b.low, b.high, p[-1]])
    return [row + [float(q)] for row, q in zip(rows, holm(p), strict=True)]


def _vehicle_planner_plan(which: int) -> Callable[[Path], list[float]]:
    """The earlier vehicle-planner plan's comparison ``which`` (:func:`_vp_old_plan`): the arms' means, effect,
    interval, p and Holm p."""
    return lambda folder: _vp_old_plan(folder)[which]


def _vehicle_planner_pooled(folder: Path) -> list[float]:
    """The README's pooled table: per planner, successes and the per-terrain rate over the vehicles
    (the trials with an outcome) with its terrain-bootstrap interval (2000 draws, a generator seeded 0
    per entry), oracle then mast, then the mast - oracle difference with its interval."""
    from offroadbench.study.stats.clustered import cluster_bootstrap

    t = _vp_trials(folder)
    rate = t.groupby(["planner", "sensor", "terrain"])["success"].mean().mul(100)
    out: list[float] = []
    for p in PLANNERS:
        for arm in ("oracle", "mast"):
            b = cluster_bootstrap(rate[(p, arm)].to_numpy(float), np.mean, np.random.default_rng(0))
            out += [float(t.loc[(t["planner"] == p) & (t["sensor"] == arm), "success"].sum()),
                    b.estimate, b.low, b.high]
        d = (rate[(p, "mast")] - rate[(p, "oracle")]).to_numpy(float)
        b = cluster_bootstrap(d, np.mean, np.random.default_rng(0))
        out += [b.estimate, b.low, b.high]
    return out


VP_ENGINES = ("pybullet", "mujoco")
VP_VEHICLES = ("husky", "jackal", "talon")
VP_PLANNERS = ("straight", "astar", "mppi", "ppo")
VP_TESTS = (("mppi", "mppi against the line, through the sensor"), ("astar", "astar against the line, through the sensor"),
            ("ppo", "ppo against the line, through the sensor"))
"""The vehicle-planner plan (the confirmatory redesign): (treatment planner, comparison name), each against the line
through the sensor, on each engine."""


def _vp_terrain_differences(folder: Path) -> dict[tuple[str, str], pd.Series]:
    """Per (engine, treatment planner): per-terrain success difference (points) against the line, each terrain's
    rate the mean over the three vehicles' rates (the plan's pool)."""
    t = trial_table(folder)
    rate = t.groupby(["engine", "planner", "vehicle", "terrain"])["success"].mean().mul(100)
    pooled = {(e, p): rate[(e, p)].unstack("vehicle").mean(axis=1) for e in VP_ENGINES for p in VP_PLANNERS}
    return {(e, p): pooled[(e, p)] - pooled[(e, "straight")] for e in VP_ENGINES for p, _ in VP_TESTS}


def _vp_plan(folder: Path) -> list[list[float]]:
    """The plan's 6 tests in confirmatory.csv's order (per comparison, PyBullet then MuJoCo), recomputed from the
    trial table as the report draws them (one generator seeded 0 through the tests in order: 2000 bootstrap
    draws, then the sign-flip test, Monte Carlo beyond 20 terrains; Holm over the 6). Per test: terrains, the
    line's and the treatment's mean per-terrain success, effect, interval, p, Holm p; then the power the plan
    stated (confirmatory.csv: simulated before the run from the pilot)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, holm, sign_flip_test

    t = trial_table(folder)
    rate = t.groupby(["engine", "planner", "vehicle", "terrain"])["success"].mean().mul(100)
    pooled = {(e, p): rate[(e, p)].unstack("vehicle").mean(axis=1) for e in VP_ENGINES for p in VP_PLANNERS}
    conf = pd.read_csv(folder / "confirmatory.csv")
    rng = np.random.default_rng(0)
    rows, p = [], []
    for i, (tr, name) in enumerate((tr, name) for tr, name in VP_TESTS for _ in VP_ENGINES):
        e = VP_ENGINES[i % 2]
        assert conf["comparison"].iloc[i] == name and f"engine = {e}" in conf["stratum"].iloc[i]
        d = (pooled[(e, tr)] - pooled[(e, "straight")]).to_numpy(float)
        b = cluster_bootstrap(d, np.mean, rng, 2000, level=0.95)
        p.append(sign_flip_test(d, rng=rng))
        rows.append([float(d.size), float(pooled[(e, "straight")].mean()), float(pooled[(e, tr)].mean()),
                     float(d.mean()), b.low, b.high, p[-1]])
    return [row + [float(q), float(conf["power"].iloc[i])] for i, (row, q) in enumerate(zip(rows, holm(p), strict=True))]


def _vp_engine_differences(folder: Path) -> list[float]:
    """Per planned test: the engine difference (per terrain, MuJoCo's difference minus PyBullet's, points) with its
    terrain-bootstrap interval, a generator of the test's own (offroadbench.study.stats.engines.engine_table)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, keyed_rng

    d = _vp_terrain_differences(folder)
    label = pd.read_csv(folder / "engine_verdicts.csv")["stratum"].iloc[0]
    out: list[float] = []
    for tr, name in VP_TESTS:
        dd = (d[("mujoco", tr)] - d[("pybullet", tr)]).to_numpy(float)
        b = cluster_bootstrap(dd, np.mean, keyed_rng(0, "engine difference", name, label), 2000, level=0.95)
        out += [float(dd.mean()), b.low, b.high, float(dd.size)]
    return out


def _vp_new_beside_old(folder: Path) -> list[float]:
    """The README's new-beside-old table: per old planned test, its effect, interval and Holm p (the earlier
    folder's trials); for the three kept, the earlier run's three-vehicle mast arms' mean per-terrain difference
    and the new effect, interval and Holm p on each engine."""
    old = _vp_old_plan(RESULTS / VP_EARLIER)
    o = _vp_trials(RESULTS / VP_EARLIER)
    r3 = (o[o["vehicle"].isin(VP_VEHICLES) & (o["sensor"] == "mast")].groupby(["planner", "terrain"])["success"]
          .mean().mul(100))
    new = _vp_plan(folder)
    out: list[float] = []
    for i, tr in enumerate(("mppi", "astar", None, "ppo")):
        out += [old[i][2], old[i][3], old[i][4], old[i][6]]
        if tr is not None:
            out.append(float((r3[tr] - r3["straight"]).mean()))
            k = [j for j, (t_, _) in enumerate(VP_TESTS) if t_ == tr][0]
            for row in new[2 * k:2 * k + 2]:
                out += [row[3], row[4], row[5], row[7]]
    return out


def _vp_successes(folder: Path) -> list[float]:
    """Per vehicle and planner, PyBullet then MuJoCo: successes, rate and its terrain-bootstrap interval (%) as the
    report computes them (stress.success_by_level over the report's strata: a generator per cell)."""
    from experiments.rerender import folder_meta
    from offroadbench.study.report.planners import stress_axes
    from offroadbench.study.stats.stress import success_by_level

    group, lv, strata = stress_axes(folder_meta(folder))
    by = success_by_level(trial_table(folder), group, lv, by=strata).set_index([group, "vehicle", "engine"])
    out: list[float] = []
    for v in VP_VEHICLES:
        for p in VP_PLANNERS:
            for e in VP_ENGINES:
                r = by.loc[(p, v, e)]
                out += [float(r["successes"]), 100 * r["success_rate"], 100 * r["ci95_low"], 100 * r["ci95_high"]]
    return out


def _vp_pooled(folder: Path) -> list[float]:
    """Per planner, PyBullet then MuJoCo: successes and the per-terrain rate over the vehicles with its
    terrain-bootstrap interval (2000 draws, a generator seeded 0 per entry); then MuJoCo - PyBullet."""
    from offroadbench.study.stats.clustered import cluster_bootstrap

    t = trial_table(folder)
    rate = t.groupby(["engine", "planner", "terrain"])["success"].mean().mul(100)
    out: list[float] = []
    for p in VP_PLANNERS:
        for e in VP_ENGINES:
            b = cluster_bootstrap(rate[(e, p)].to_numpy(float), np.mean, np.random.default_rng(0))
            out += [float(t.loc[(t["planner"] == p) & (t["engine"] == e), "success"].sum()), b.estimate, b.low, b.high]
        b = cluster_bootstrap((rate[("mujoco", p)] - rate[("pybullet", p)]).to_numpy(float), np.mean,
                              np.random.default_rng(0))
        out += [b.estimate, b.low, b.high]
    return out


def _vp_totals(folder: Path) -> list[float]:
    """Successes in all and per engine, per vehicle and engine, then the failures per reason and engine."""
    t = trial_table(folder)
    se = t.groupby("engine")["success"].sum()
    sv = t.groupby(["engine", "vehicle"])["success"].sum()
    fr = t.groupby(["engine", "failure_reason"]).size()
    return ([float(t["success"].sum()), float(len(t)), float(se["pybullet"]), float(se["mujoco"])]
            + [float(sv[(e, v)]) for v in VP_VEHICLES for e in VP_ENGINES]
            + [float(fr.get((e, r), 0)) for r in ("stuck", "timeout", "off_map", "tipped") for e in VP_ENGINES])


def _vp_paired_missions(folder: Path) -> list[float]:
    """Paired missions (vehicle, planner, terrain, mission on both engines): in all, succeeding on both, on
    neither, only on MuJoCo, only on PyBullet; then per planner only on MuJoCo / only on PyBullet."""
    w = trial_table(folder).pivot_table(index=["vehicle", "planner", "terrain", "mission"], columns="engine",
                                        values="success", aggfunc="first").astype(bool)
    out = [float(len(w)), float((w["mujoco"] & w["pybullet"]).sum()), float((~w["mujoco"] & ~w["pybullet"]).sum()),
           float((w["mujoco"] & ~w["pybullet"]).sum()), float((w["pybullet"] & ~w["mujoco"]).sum())]
    for p in VP_PLANNERS:
        x = w.xs(p, level="planner")
        out += [float((x["mujoco"] & ~x["pybullet"]).sum()), float((x["pybullet"] & ~x["mujoco"]).sum())]
    return out


def _failure_search_estimates(planner: str, group: int):
    """The failure search's P(failure) row of one planner, from the committed search.toml and
    trials.csv (offroadbench.search.report): Monte Carlo p, failures, trials, interval, relative
    error; then importance sampling's p, failures, final draws, interval, relative error and the
    trial ratio."""
    def compute(folder: Path) -> list[float]:
        from offroadbench.search import load_search
        from offroadbench.search.report import estimates, mc_trials_ratio

        cfg = load_search(folder / "search.toml").search
        df = pd.read_csv(folder / "trials.csv")
        ests = estimates(df, cfg)
        mc, ce = ests[(group, "mc")], ests[(group, "ce-is")]
        return [mc.p, float(mc.failures), float(mc.n), mc.low, mc.high, mc.rel_error,
                ce.p, float(ce.failures), float(ce.n), ce.low, ce.high, ce.rel_error, mc_trials_ratio(mc, ce)]
    return compute


def _failure_search_first_k(folder: Path) -> list[float]:
    """The falsifier's trials to its 10th distinct failure and its failures' terrains, per planner."""
    from offroadbench.search import load_search
    from offroadbench.search.report import first_failures

    cfg = load_search(folder / "search.toml").search
    df = pd.read_csv(folder / "trials.csv")
    out = []
    for grp in (0, 1):
        s = df[(df["group"] == grp) & (df["method"] == "falsify")]
        out += [first_failures(cfg, s), float(s.loc[s["failed"], "terrain_seed"].nunique())]
    return out


WARP_TESTS = (("MuJoCo Warp - MuJoCo: success", "MuJoCo Warp - MuJoCo, success (pooled), points"),
              ("MuJoCo Warp - MuJoCo: vertical acceleration",
               "MuJoCo Warp - MuJoCo, RMS vertical acceleration (pooled), m/s^2"))
"""The engines-warp plan in confirmatory.csv's order: (comparison, the README's row label)."""


def _warp_plan(folder: Path) -> list[list[float]]:
    """engines-warp's 2 planned tests: MuJoCo Warp against MuJoCo, success and the per-terrain median RMS vertical
    acceleration of the successful trials, each terrain's value the mean over the three D_high (a terrain without a
    success at one D_high dropped)."""
    t = trial_table(folder)
    ok = t[t["success"].astype(bool)]
    rate = t.groupby(["engine", "D_high", "terrain"])["success"].mean().mul(100)
    va = ok.groupby(["engine", "D_high", "terrain"])["rms_vertical_accel_m_s2"].median()

    def pooled(s: pd.Series, e: str) -> pd.Series:
        return s[e].unstack("D_high").mean(axis=1, skipna=False)

    return _plan_rows(folder, [pd.DataFrame({"t": pooled(s, "mujoco_warp"), "c": pooled(s, "mujoco")}) for s in (rate, va)])


def _warp_one_engine_only(folder: Path) -> list[float]:
    """Paired missions (same D, terrain and mission): on both engines, on MuJoCo Warp only, on MuJoCo only, on
    neither."""
    w = trial_table(folder).pivot_table(index=["D_high", "terrain", "mission"], columns="engine", values="success",
                                        aggfunc="first").astype(bool)
    a, b = w["mujoco_warp"], w["mujoco"]
    return [float((a & b).sum()), float((a & ~b).sum()), float((b & ~a).sum()), float((~a & ~b).sum())]


def _warp_dropped(folder: Path) -> list[float]:
    """MuJoCo Warp's dropped false contacts (TrialResult.dropped_contacts): trials with one, all dropped, the
    median and most in such a trial, trials with one per D_high; then, by the MuJoCo twin's outcome: MuJoCo stuck
    missions with one and all MuJoCo stuck, MuJoCo-successful missions with one and all of those; of the
    MuJoCo-successful missions with / without one, those MuJoCo Warp gets stuck on; of the MuJoCo-stuck missions
    with / without one, those MuJoCo Warp completes."""
    t = trial_table(folder)
    key = ["D_high", "terrain", "mission"]
    w = t[t["engine"] == "mujoco_warp"].set_index(key)
    m = t[t["engine"] == "mujoco"].set_index(key).loc[w.index]
    had = w["dropped_contacts"] > 0
    mj_ok, mj_stuck = m["success"].astype(bool), m["failure_reason"].eq("stuck")
    n = [float(had.sum()), float(w["dropped_contacts"].sum()), float(w["dropped_contacts"][had].median()),
         float(w["dropped_contacts"].max())]
    n += [float(v) for v in had.groupby(level="D_high").sum()]
    n += [float((had & mj_stuck).sum()), float(mj_stuck.sum()), float((had & mj_ok).sum()), float(mj_ok.sum())]
    warp_stuck, warp_ok = w["failure_reason"].eq("stuck"), w["success"].astype(bool)
    n += [float((mj_ok & had & warp_stuck).sum()), float((mj_ok & had).sum()),
          float((mj_ok & ~had & warp_stuck).sum()), float((mj_ok & ~had).sum())]
    n += [float((mj_stuck & had & warp_ok).sum()), float((mj_stuck & had).sum()),
          float((mj_stuck & ~had & warp_ok).sum()), float((mj_stuck & ~had).sum())]
    return n


def _warp_ride_ratios(folder: Path) -> list[float]:
    """Missions that succeed on both engines: their count, then per ride metric (vertical acceleration, pitch rate,
    roll rate) the median of MuJoCo Warp's value over MuJoCo's, as a percentage change."""
    t = trial_table(folder)
    key = ["D_high", "terrain", "mission"]
    w = t.pivot_table(index=key, columns="engine", values="success", aggfunc="first").astype(bool)
    both = w.index[w["mujoco"] & w["mujoco_warp"]]
    out = [float(both.size)]
    for m in ("rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s"):
        v = t.pivot_table(index=key, columns="engine", values=m, aggfunc="first").loc[both]
        out.append(float(100 * ((v["mujoco_warp"] / v["mujoco"]).median() - 1)))
    return out


WARP_FIRST_RUN = "1fda3d7"
"""The commit whose experiments/results/engines-warp/ holds the first engines-warp run (before MuJoCo Warp's false
height-field contacts were dropped); its README's "New beside old" table quotes it."""


def _warp_failures(folder: Path, reason: str) -> list[float]:
    """MuJoCo Warp's trials ending ``reason`` at D_high 2.3, 2.45 and 2.6."""
    t = trial_table(folder)
    return [float((t["engine"].eq("mujoco_warp") & t["D_high"].eq(d) & t["failure_reason"].eq(reason)).sum())
            for d in (2.3, 2.45, 2.6)]


def _warp_beside(folder: Path) -> list[list[float]]:
    """One engines-warp run's values in the README's "New beside old" table, row by row: per planned test the
    effect, interval, p and Holm p; MuJoCo Warp's successes, `tipped` and `stuck` per D_high; the paired missions;
    the ride of the missions both engines complete."""
    t = trial_table(folder)
    ok = [float(v) for v in t[t["engine"] == "mujoco_warp"].groupby("D_high")["success"].sum()]
    return ([row[3:8] for row in _warp_plan(folder)]
            + [ok, _warp_failures(folder, "tipped"), _warp_failures(folder, "stuck"), _warp_one_engine_only(folder),
               _warp_ride_ratios(folder)])


def _warp_fix_changes(old: Path, new: Path) -> list[float]:
    """What dropping the false contacts changed, mission by mission (MuJoCo Warp's trials, first run against
    re-run): the missions that tipped, how they end now (successful, `stuck`), their MuJoCo twins (successful,
    `stuck`), those now successful whose twin is `stuck`; the trials that did not tip, those identical in every
    column both tables have, those that differ, in outcome, successes now failed, failures now successful."""
    key = ["D_high", "terrain", "mission"]
    a, b, mj = (trial_table(f) for f in (old, new, new))
    a, b = (x[x["engine"] == "mujoco_warp"].drop(columns="cell").set_index(key).sort_index() for x in (a, b))
    mj = mj[mj["engine"] == "mujoco"].set_index(key).sort_index()
    b = b[a.columns]  # the columns both runs have (the re-run's table has dropped_contacts too)
    tip = a["failure_reason"] == "tipped"
    ok_b, ok_a, ok_mj = (x["success"].astype(bool) for x in (b, a, mj))
    same = pd.Series([a.loc[i].equals(b.loc[i]) for i in a.index], index=a.index)
    flip = ok_a != ok_b
    return [float(v) for v in (tip.sum(), (tip & ok_b).sum(), (tip & ~ok_b).sum(), (tip & ok_mj).sum(),
                               (tip & ~ok_mj).sum(), (tip & ok_b & ~ok_mj).sum(), (~tip).sum(), (~tip & same).sum(),
                               (~tip & ~same).sum(), (~tip & flip).sum(), (~tip & flip & ok_a).sum(),
                               (~tip & flip & ~ok_a).sum())]


def _warp_drops_against_first_run(old: Path, new: Path) -> list[float]:
    """The re-run's dropped contacts against the first run, MuJoCo Warp's trials: missions that tipped in the first
    run and had a drop in the re-run; trials that changed (did not tip, not identical in the columns both tables
    have) with a drop; trials identical with the first run, without a drop, with one."""
    key = ["D_high", "terrain", "mission"]
    a, b = (trial_table(f) for f in (old, new))
    a, b = (x[x["engine"] == "mujoco_warp"].drop(columns="cell").set_index(key).sort_index() for x in (a, b))
    had = b["dropped_contacts"] > 0
    tip = a["failure_reason"] == "tipped"
    same = pd.Series([a.loc[i].equals(b.loc[i, a.columns]) for i in a.index], index=a.index)
    assert (tip & ~had).sum() == 0 and (~tip & ~same & ~had).sum() == 0  # every change had a drop
    return [float(v) for v in ((tip & had).sum(), (~tip & ~same & had).sum(), (~tip & same).sum(),
                               (~tip & same & ~had).sum(), (~tip & same & had).sum())]


def _warp_medians(folder: Path) -> list[float]:
    """The side-by-side table's medians over the successful trials, per metric, engine and D_high."""
    t = trial_table(folder)
    med = t[t["success"].astype(bool)].groupby(["engine", "D_high"])[
        ["rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s", "traversal_time_s"]].median()
    return [float(med.loc[(e, d), m]) for m in med.columns for e in ("mujoco", "mujoco_warp") for d in (2.3, 2.45, 2.6)]


def _warp_terrains_up_down(folder: Path) -> list[float]:
    """Terrains where MuJoCo Warp's success (pooled over D_high) is higher than MuJoCo's, lower, equal."""
    t = trial_table(folder)
    r = t.groupby(["engine", "terrain"])["success"].mean().unstack("engine")
    d = r["mujoco_warp"] - r["mujoco"]
    return [float((d > 0).sum()), float((d < 0).sum()), float((d == 0).sum())]


_VERDICT = r"(?:not )?rejected"
_EFFECT = r"\+?{n} \[{n}, {n}\], p {s}, Holm {s}, " + _VERDICT
_TRIPLE = r"{n} / {n} / {n}"


def _warp_beside_pattern() -> str:
    """The README's "New beside old" rows: old column then new column; the regex groups are in _warp_beside's
    order, old run first."""
    n, s = r"(-?\d+(?:\.\d+)?)", r"(\d+(?:\.\d+)?(?:e-\d+)?)"
    eff, tri = _EFFECT.format(n=n, s=s), _TRIPLE.format(n=n)
    rows = [(re.escape(label), eff) for _, label in WARP_TESTS] + [
        (r"MuJoCo Warp successes at D 2\.3 / 2\.45 / 2\.6 \(of 100\)", tri),
        (r"MuJoCo Warp `tipped` at D 2\.3 / 2\.45 / 2\.6", tri),
        (r"MuJoCo Warp `stuck` at D 2\.3 / 2\.45 / 2\.6", tri),
        (r"paired missions: both / MuJoCo Warp only / MuJoCo only / neither", rf"{n} / {n} / {n} / {n}"),
        (r"missions both complete: median % change of vertical acceleration / pitch rate / roll rate",
         rf"{n}: \+?{n} / \+?{n} / \+?{n}")]
    return "".join(rf"\| {label} \| {cell} \| {cell} \|\n" for label, cell in rows)


_NUM = r"(-?\d+(?:\.\d+)?)"
_FS_ROW = (rf"\*\*{_NUM}\*\* \({_NUM} / {_NUM}; 95 % CI {_NUM}-{_NUM}; rel\. error {_NUM}\) \| {_NUM} \({_NUM} "
           rf"failures in its {_NUM} final draws; 95 % interval {_NUM}-{_NUM}; rel\. error {_NUM}\) \| \*\*{_NUM}x\*\*")
_SCI = r"(\d+(?:\.\d+)?(?:e-\d+)?)"
SAMPLES = [
    Sample("failure-search P(failure), A*", "failure-search", rf"\| A\* \| {_FS_ROW}",
           _failure_search_estimates("astar", 0)),
    Sample("failure-search P(failure), straight", "failure-search", rf"\| straight \| {_FS_ROW}",
           _failure_search_estimates("straight", 1)),
    Sample("failure-search-site P(failure), A*", "failure-search-site", rf"\| A\* \| {_FS_ROW}",
           _failure_search_estimates("astar", 0)),
    Sample("failure-search-site P(failure), straight", "failure-search-site", rf"\| straight \| {_FS_ROW}",
           _failure_search_estimates("straight", 1)),
    # failure-search-site's reference, repeats, modes and baselines (issue 45): tests/search/test_results_site.py
    Sample("failure-search-site distance left by the failures", "failure-search-site",
           rf"a median {_NUM} m of the 6 m route left",
           lambda f: [float(trial_table(f).query("not success")["final_distance_to_goal_m"].median())]),
    Sample("failure-search falsifier's 10th distinct failure", "failure-search",
           rf"this run's falsifier: A\* {_NUM} trials \(failures on {_NUM} terrains\), the straight line {_NUM} "
           rf"\(on {_NUM}\)", _failure_search_first_k),
    Sample("engines plan: terrains, means, effect, interval, p, Holm p, power", "engines",
           "".join(rf"\| {re.escape(label)} \| {_NUM} \| {_NUM} -> {_NUM} \| \**\+?{_NUM} \[{_NUM}, {_NUM}\]\** "
                   rf"\| {_SCI} \| {_SCI} \| (?:yes|no) \| {_NUM} at [+-][\d.]+ \|\n" for _, label in ENGINES_TESTS),
           lambda f: [v for row in _engines_plan(f) for v in row]),
    Sample("engines engine difference of the per-engine tests", "engines",
           r"[\s\S]*?".join(rf"\*\*{re.escape(name)}: holds on [^*]+\*\* \([^)]*\)\. Engine difference \(per terrain, "
                            rf"MuJoCo - PyBullet; exploratory\) \+?{_NUM} \[{_NUM}, {_NUM}\] over {_NUM} terrains"
                            for name in dict.fromkeys(n for n, _ in ENGINES_TESTS[2:])), _engines_engine_differences),
    Sample("engines successes per engine and D_high", "engines",
           rf"successful trials \(of \d+; old of \d+\) \| {_NUM} / {_NUM} / {_NUM} \([^)]*\) \| {_NUM} / {_NUM} / {_NUM} \(",
           lambda f: [float(v) for v in trial_table(f).groupby(["engine", "D_high"])["success"].sum()
                      .loc[["pybullet", "mujoco"]]]),
    Sample("engines missions succeeding on one engine only", "engines",
           rf"{_NUM} of the \d+ paired missions succeed only on MuJoCo and {_NUM} only on PyBullet",
           _one_engine_only),
    Sample("lunar-soil regolith against rigid ground", "lunar-soil",
           rf"missions succeed {_NUM} points less often on PyBullet and {_NUM} on MuJoCo", _soil_effect_per_engine),
    Sample("lunar-soil entrapped soil trials", "lunar-soil", rf"{_NUM} of the {_NUM} soil trials end `entrapped`",
           lambda f: [float(((t := trial_table(f))["failure_reason"] == "entrapped").sum()),
                      float((t["tyre_model"] == "terramechanics").sum())]),
    Sample("soil-map plan: terrains, means, effect, interval, p, Holm p, power", "soil-map",
           "".join(rf"\| {name} \| {_NUM} \| {_NUM} \| {_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\] \| {_SCI} \| {_SCI} \| no \| "
                   rf"{_NUM} \|\n" for name in SOIL_MAP_TESTS),
           lambda f: [v for row in _soil_map_plan(f) for v in row]),
    Sample("soil-map outcomes per soil layout", "soil-map",
           "".join(rf"\| {label} \|" + rf" {_NUM} \(\d+\) \|" * 5 + "\n" for label in SOIL_MAP_ROWS),
           lambda f: [v for r in SOIL_MAP_ROWS.values() for v in _soil_map_outcomes(f, r)]),
    Sample("soil-map missions that flip on the deposit", "soil-map",
           rf"Mission by mission, {_NUM} missions that succeed on one soil fail\s+on the deposit and {_NUM} go the other way "
           r"\(old \d+ and \d+\)", lambda f: _soil_map_flips(f, SOIL_MAP_SNOW)),
    Sample("soil-map simulant floors: flips and slip of the successful trials", "soil-map",
           rf"The simulant floors lose {_NUM} of the control's successes and gain {_NUM}[\s\S]*?over the successful trials "
           rf"alone the per-terrain difference is {_NUM}\.",
           lambda f: _soil_map_flips(f, SOIL_MAP_SIMULANT) + [float(
               (lambda m: (m[SOIL_MAP_SIMULANT] - m["lunar-mare"]).mean())(
                   trial_table(f).query("success").groupby(["recipe", "terrain"])["mean_slip"].median().unstack("recipe")))]),
    Sample("soil-map deposit trials outside the model", "soil-map",
           rf"Outside the soil model: {_NUM} of the 144 deposit trials[^\n]*at most\s+{_NUM} % of the trial",
           lambda f: (lambda t: [float((t["outside_model_fraction"] > 0).sum()),
                                 100 * float(t["outside_model_fraction"].max())])(
                                     trial_table(f).query("recipe == @SOIL_MAP_SNOW"))),
    Sample("lunar-soil table rows", "lunar-soil",
           "".join(rf"\| {e} \| {m} \| {g} \| {a} \| {_NUM}{old[e]} \|[^|\n]*\|[^|\n]*\| {_NUM}{old[e]} \| "
                   + (rf"{_NUM}{old[e]} \| {_NUM} / {_NUM}{oldsink[e]} \|\n" if m == "terramechanics"
                      else r"- \| [^|\n]+ \|\n")
                   for e, m, g, a in LUNAR_SOIL_CELLS
                   for old, oldsink in [({"pybullet": r" \([\d.]+\)", "mujoco": ""},
                                         {"pybullet": r" \([\d./ ]+\)", "mujoco": ""})]), _lunar_soil_rows),
    Sample("lunar-soil success on regolith by gravity", "lunar-soil",
           rf"more missions succeed \(PyBullet {_NUM} against {_NUM} %, MuJoCo {_NUM}\s+against {_NUM} %",
           _soil_success_by_gravity),
    Sample("crater-density successes and medians per density", "crater-density",
           "".join(rf"\| {c} \| {_NUM} \(\d+\) \|[^|\n]*\|[^|\n]*\| {_NUM} \([\d.]+\) \| {_NUM} \([\d.]+\) \| "
                   rf"{_NUM} \([\d.]+\) \| {_NUM} \(\d+\) \|\n" for c in ("0", "0.03", "0.1", "0.3")),
           _crater_density_rows),
    Sample("crater-density failures at c = 0.3", "crater-density",
           rf"How the vehicle fails at c = 0.3\*\*: {_NUM} `stuck`, {_NUM} `timeout`, {_NUM} tipped of",
           lambda f: _failure_counts(f, "c == 0.3", ("stuck", "timeout", "tipped"))),
    Sample("crater-density plan: terrains, means, effect, interval, p, Holm p, power", "crater-density",
           "".join(rf"\| {re.escape(name)} \| {_NUM} \| {_NUM} -> {_NUM} \| \**\+?{_NUM} \[{_NUM}, {_NUM}\]\** "
                   rf"\| {_SCI} \| {_SCI} \| (?:yes|no) \| {_NUM} at [+-][\d.]+ \|\n" for name in CRATER_TESTS),
           lambda f: [v for row in _crater_density_plan(f) for v in row]),
    Sample("majhor2023 successful trials", "majhor2023",
           rf"successful trials \(of 400\) \|[^|]*\| \*\*{_NUM} / {_NUM} / {_NUM}\*\*", _successes),
    Sample("majhor2023 median per-terrain success", "majhor2023",
           rf"median success rate per terrain \|[^|]*\| {_NUM} / {_NUM} / {_NUM} %", _median_rates),
    Sample("majhor2023 failures per D", "majhor2023",
           rf"\| failures \|[^|]*\| stuck {_NUM} / {_NUM} / {_NUM}, timeout {_NUM}, tipped {_NUM} \|",
           lambda f: [*(float(n) for n in trial_table(f).query("failure_reason == 'stuck'").groupby("D_high").size()),
                      *_failure_counts(f, "D_high > 0", ("timeout", "tipped"))]),
    Sample("majhor2023 pooled fall 2.45 -> 2.6", "majhor2023", rf"our pooled rate falls {_NUM} points", _pooled_fall),
    Sample("majhor2023 per-terrain correlation and counts", "majhor2023",
           rf"correlates at {_NUM}; going from 2.3 to 2.6,\s+{_NUM} terrains lose success, {_NUM} are unchanged "
           rf"and {_NUM} gain", _correlation_and_counts),
    Sample("majhor2023 low-area changes", "majhor2023",
           rf"low area {_NUM} and {_NUM} points against", _low_area_changes),
    Sample("majhor2023 RMS vertical acceleration medians", "majhor2023",
           rf"median RMS vertical acceleration, m/s² \|[^|]*\| {_NUM} / {_NUM} / {_NUM} \(",
           _metric_medians("rms_vertical_accel_m_s2")),
    Sample("majhor2023 traversal time medians", "majhor2023",
           rf"median traversal time, s \|[^|]*\| {_NUM} / {_NUM} / {_NUM} \(", _metric_medians("traversal_time_s")),
    Sample("majhor2023 terrain-level success changes", "majhor2023",
           rf"Per-terrain success falls by {_NUM} points \[{_NUM}, {_NUM}\] from 2.3 to 2.45 \({_NUM} terrains down,"
           rf"\s+{_NUM} up; Wilcoxon p = {_NUM}, Holm {_NUM}\)", _terrain_success_changes),
    Sample("vehicle-sensitivity successes per setting", "vehicle-sensitivity",
           r"\| torque N m / spin inertia kg m\^2 \|[^\n]*\n\|[-|]+\|\n"
           + r"".join(r"\| [^|]+ \| \**(\d+)\** / \d+ \|[^\n]*\n" for _ in range(6)), _vehicle_setting_successes),
    Sample("vehicle-sensitivity pitch-rate drop at 16.5 N m", "vehicle-sensitivity",
           rf"16.5 N m lowers the per-terrain\s+median pitch rate by {_NUM} deg/s", _torque_pitch_rate_drop),
    Sample("vehicle-sensitivity plan: means, effect, interval, p, Holm p, power", "vehicle-sensitivity",
           "".join(rf"\| {torque:g} / {inertia} \| {'success, points' if m == 'success' else 'RMS pitch rate, deg/s'} \| "
                   rf"{_NUM} \| {_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\] \| {_SCI} \| {_SCI} \| no \| {_NUM} at [+-][\d.]+ \|[^\n]*\n"
                   for torque, inertia, m in VS_TESTS),
           lambda f: [v for row in _vehicle_sensitivity_plan(f) for v in row]),
    Sample("vehicle-sensitivity failures per setting", "vehicle-sensitivity",
           rf"Every failure is `stuck` \({_NUM}-{_NUM} of 200 per setting",
           lambda f: (lambda t: [float(t.groupby(["wheel_torque_limit_nm", "wheel_spin_inertia_kg_m2"]).size().min()),
                                 float(t.groupby(["wheel_torque_limit_nm", "wheel_spin_inertia_kg_m2"]).size().max())]
                      if (t["failure_reason"] == "stuck").all() else [np.nan, np.nan])(
                          trial_table(f).query("not success"))),
    Sample("vehicle-sensitivity missions alike in every setting", "vehicle-sensitivity",
           rf"{_NUM} of the 200 missions end alike in all six\s+settings",
           lambda f: (lambda w: [float((w.all(axis=1) | (~w).all(axis=1)).sum())])(
               trial_table(f).pivot_table(index=["terrain", "mission"], columns=["wheel_torque_limit_nm", "wheel_spin_inertia_kg_m2"],
                                          values="success", aggfunc="first").astype(bool))),
    Sample("majhor2023-mujoco successful trials", "majhor2023-mujoco",
           rf"successful trials \(of 400\) \| \*\*{_NUM} / {_NUM} / {_NUM}\*\*", _successes),
    Sample("majhor2023-mujoco RMS vertical acceleration medians", "majhor2023-mujoco",
           rf"median RMS vertical acceleration, m/s² \| {_NUM} / {_NUM} / {_NUM} \|",
           _metric_medians("rms_vertical_accel_m_s2")),
    Sample("majhor2023-mujoco quotes PyBullet's successes and vertical acceleration", "majhor2023-mujoco",
           rf"successful trials \(of 400\) \|[^|]*\|[^|]*\|[^|]*\| {_NUM} / {_NUM} / {_NUM} \({_NUM}\) \|\n[^\n]*\n"
           rf"\| median RMS vertical acceleration, m/s² \|[^|]*\|[^|]*\|[^|]*\| {_NUM} / {_NUM} / {_NUM} \|",
           lambda f: [*_successes(f.parent / "majhor2023"), sum(_successes(f.parent / "majhor2023")),
                      *_metric_medians("rms_vertical_accel_m_s2")(f.parent / "majhor2023")]),
    Sample("majhor2023-mujoco plan: terrains, means, effect, interval, p, Holm p, power, the other summary",
           "majhor2023-mujoco", _majhor_plan_pattern(), lambda f: [v for row in _majhor_plan(f) for v in row]),
    Sample("majhor2023-mujoco each planned test on both engines", "majhor2023-mujoco", _majhor_both_rows(),
           _majhor_both_plans),
    Sample("vehicle-comparison successes per vehicle and terrain", "vehicle-comparison",
           "".join(rf"\| {v} \| {r} \| {_NUM} / 32 \|[^\n]*\n" for v in VEHICLES for r in TERRAIN_KINDS),
           _vehicle_successes),
    Sample("vehicle-comparison jackal on the paper terrains", "vehicle-comparison",
           rf"succeeds on {_NUM} of 96 missions against the Husky's {_NUM}",
           lambda f: [float(trial_table(f).query("recipe != 'lunar-mare'").groupby("vehicle")["success"].sum()[v])
                      for v in ("jackal", "husky")]),
    Sample("planner-stress plan per engine: terrains, means, effect, interval, p, Holm p, power", "planner-stress",
           "".join(rf"\| {re.escape(name)} \| {lv} \| {e} \| {_NUM} \| {_NUM} \| {_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\] "
                   rf"\| {_SCI} \| {_SCI} \| (?:yes|no) \| {_NUM} at \+\d+ \|\n"
                   for name, lv in PS_TESTS for e in PS_ENGINES),
           lambda f: [v for row in _planner_stress_plan(f) for v in row]),
    Sample("planner-stress new beside old: the previous run's effect, p and Holm p", "planner-stress",
           "".join(rf"\| {re.escape(name)} \| {lv} \| \+?{_NUM}, {_SCI}, {_SCI}, [^|]+\|[^\n]*\n" for name, lv in PS_TESTS),
           _planner_stress_old_plan),
    Sample("planner-stress the sensor's cost to the planners", "planner-stress",
           r"[\s\S]*?".join(rf"\| {p} \| aliased \(paper\) \| {lv} \| {e} \| [\d.]+ -> [\d.]+ \| \+?{_NUM} \[{_NUM}, {_NUM}\]"
                              for p in ("astar", "lattice") for lv in (2.95, 2.99) for e in PS_ENGINES),
           _planner_stress_sensor_cost),
    Sample("planner-stress shared missions", "planner-stress",
           rf"all\s+{_NUM}\s+band-limited\s+trials\s+have\s+the\s+start\s+and\s+goal\s+of\s+their\s+aliased\s+twin",
           _shared_missions),
    Sample("planner-stress above-Nyquist variance per D_high", "planner-stress",
           "".join(rf"\| {d} \| {_NUM} % \|[^\n]*\n" for d in ("2.9", "2.95", "2.99")), _above_nyquist_share),
    *(Sample(f"vehicle-comparison {v} against the husky (plan)", "vehicle-comparison",
             rf"\| {re.escape(label)} \| {_NUM} \| {_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\] \| {_SCI} \| {_SCI} \| (?:yes|no) \| "
             rf"{_NUM} \|",
             _vehicle_comparison_plan(i)) for i, (v, label) in enumerate(COMPARED_VEHICLES)),
    Sample("vehicle-comparison totals per vehicle", "vehicle-comparison",
           rf"Totals of 128: sojourner {_NUM}, husky {_NUM}, hunter {_NUM}, talon {_NUM}, jackal {_NUM}",
           lambda f: [float(trial_table(f).groupby("vehicle")["success"].sum()[v])
                      for v in ("sojourner", "husky", "hunter", "talon", "jackal")]),
    Sample("vehicle-comparison stuck on the paper terrains", "vehicle-comparison",
           rf"are `stuck` \(jackal {_NUM}, talon {_NUM}, hunter {_NUM}, husky {_NUM}, sojourner {_NUM};",
           lambda f: [float(trial_table(f).query("recipe != 'lunar-mare' and failure_reason == 'stuck'")
                            .groupby("vehicle").size().get(v, 0))
                      for v in ("jackal", "talon", "hunter", "husky", "sojourner")]),
    *(Sample(f"vehicle-comparison {v} against the husky per terrain kind", "vehicle-comparison",
             pattern, _vehicle_kind_differences(v)) for v, pattern in (
        ("talon", rf"Per terrain kind against the Husky \(points,\s+each kind's mean per-terrain difference\): {_NUM} at "
                  rf"D 2.3, {_NUM} at 2.45, {_NUM} at 2.6, {_NUM} on lunar\s+mare"),
        ("jackal", rf"\*\*The Jackal loses everywhere, most on lunar mare\*\*: {_NUM} / {_NUM} / {_NUM} points at D 2.3 / "
                   rf"2.45\s+/ 2.6 and {_NUM} on lunar mare"))),
    Sample("vehicle-comparison jackal tip-overs on lunar mare", "vehicle-comparison",
           rf"Its {_NUM} lunar failures are tip-overs {_NUM}-{_NUM} s into the",
           lambda f: (lambda x: [float(len(x)), float(x["sim_time_s"].min()), float(x["sim_time_s"].max())])(
               trial_table(f).query("vehicle == 'jackal' and recipe == 'lunar-mare' and failure_reason == 'tipped'"))),
    *(Sample(f"vehicle-comparison {v} ride per terrain", "vehicle-comparison",
             "".join(rf"\| {v} \| {r} \| \d+ / 32 \| [^|]+ \| {_NUM} \[[^]]+\] \| {_NUM} \[[^]]+\] "
                     rf"\| {_NUM} \[[^]]+\] \|[^\n]*\n" for r in TERRAIN_KINDS),
             _vehicle_ride_medians(v)) for v in ("talon", "hunter")),
    Sample("vehicle-planner plan per engine: terrains, means, effect, interval, p, Holm p, power", "vehicle-planner",
           "".join(rf"\| {re.escape(name)} \| {e} \| {_NUM} \| {_NUM} \| {_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\] "
                   rf"\| {_SCI} \| {_SCI} \| (?:yes|no) \| {_NUM} at [+-]\d+ \|\n" for _, name in VP_TESTS for e in VP_ENGINES),
           lambda f: [v for row in _vp_plan(f) for v in row]),
    Sample("vehicle-planner engine difference per planned test", "vehicle-planner",
           r"[\s\S]*?".join(rf"\*\*{re.escape(name)}: holds on [^*]+\*\* \([^)]*\)\. Engine difference \+?{_NUM} points "
                            rf"\[{_NUM}, {_NUM}\] over {_NUM} terrains" for _, name in VP_TESTS), _vp_engine_differences),
    Sample("vehicle-planner new beside old", "vehicle-planner",
           "".join(rf"\| {re.escape(name)} \| \+?{_NUM} \[{_NUM}, {_NUM}\], {_SCI}, not rejected \| "
                   + (r"- \| not in the new plan[^\n]*\n" if tr is None else
                      rf"\+?{_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\], {_SCI}, [^|]+ \| \+?{_NUM} \[{_NUM}, {_NUM}\], {_SCI}, [^|]+ \|\n")
                   for tr, name in (("mppi", VP_TESTS[0][1]), ("astar", VP_TESTS[1][1]),
                                    (None, "the sensor's cost to astar (mast against oracle)"), ("ppo", VP_TESTS[2][1]))),
           _vp_new_beside_old),
    Sample("vehicle-planner successes per vehicle, planner and engine", "vehicle-planner",
           "".join(rf"\| {v} \| {p} \| {_NUM} \| {_NUM} \[{_NUM}, {_NUM}\] \| {_NUM} \| {_NUM} \[{_NUM}, {_NUM}\] \|[^\n]*\n"
                   for v in VP_VEHICLES for p in VP_PLANNERS), _vp_successes),
    Sample("vehicle-planner pooled per planner and engine", "vehicle-planner",
           "".join(rf"\| {p} \| {_NUM} \| {_NUM} \[{_NUM}, {_NUM}\] \| {_NUM} \| {_NUM} \[{_NUM}, {_NUM}\] "
                   rf"\| \+?{_NUM} \[\+?{_NUM}, \+?{_NUM}\] \|\n" for p in VP_PLANNERS), _vp_pooled),
    Sample("vehicle-planner totals", "vehicle-planner",
           rf"Totals: {_NUM} of the {_NUM} trials succeed \(PyBullet {_NUM} of \d+, MuJoCo {_NUM} of \d+; "
           rf"Husky {_NUM} / {_NUM},\s+Jackal {_NUM} / {_NUM}, TALON {_NUM} /\s+{_NUM} of \d+, PyBullet / MuJoCo\); "
           rf"failures `stuck` {_NUM} / {_NUM}, `timeout` {_NUM} / {_NUM}, `off_map` {_NUM} / {_NUM}, `tipped` {_NUM} / {_NUM} "
           r"\(PyBullet / MuJoCo\)", _vp_totals),
    Sample("vehicle-planner paired missions on the two engines", "vehicle-planner",
           rf"Of the {_NUM} paired missions \(same vehicle, planner, terrain\s+and mission\), {_NUM} succeed on both, "
           rf"{_NUM} on neither,\s+{_NUM} only on MuJoCo and {_NUM} only on PyBullet; by planner \(only\s+MuJoCo / only "
           rf"PyBullet\): " + r",\s+".join(rf"{p} {_NUM} / {_NUM}" for p in VP_PLANNERS), _vp_paired_missions),
    Sample("vehicle-planner earlier: successes per vehicle, planner and sensor", VP_EARLIER,
           "".join(r"\| hunter \| astar \| refused \|[^\n]*\n" if (v, p) == ("hunter", "astar")
                   else rf"\| {v} \| {p} \| {_NUM} \| [^|]+ \| {_NUM} \|[^\n]*\n"
                   for v in VEHICLE_PLANNER_VEHICLES for p in PLANNERS), _vehicle_planner_successes),
    Sample("vehicle-planner earlier: refused pair", VP_EARLIER,
           r"\| hunter \| astar \| refused \| refused \| refused \| refused \| refused \((\d+) faults / (\d+) faults\) \|",
           _vp_refused),
    *(Sample(f"vehicle-planner earlier: plan: {name}", VP_EARLIER,
             rf"\| {re.escape(name)} \| {_NUM} / {_NUM} \| \+?{_NUM} \[{_NUM}, {_NUM}\] \| {_NUM} \| {_NUM} \| no \|",
             _vehicle_planner_plan(i))
      for i, name in enumerate(["mppi against the line, through the sensor",
                                "astar against the line, through the sensor",
                                "the sensor's cost to astar (mast against oracle)",
                                "ppo against the line, through the sensor"])),
    Sample("vehicle-planner earlier: pooled per planner and sensor", VP_EARLIER,
           "".join(rf"\| {p} \| {_NUM} of \d+ \| {_NUM} \[{_NUM}, {_NUM}\] \| {_NUM} of \d+ \| {_NUM} \[{_NUM}, {_NUM}\] "
                   rf"\| \+?{_NUM} \[\+?{_NUM}, \+?{_NUM}\] \|\n" for p in PLANNERS), _vehicle_planner_pooled),
    Sample("vehicle-planner earlier: totals", VP_EARLIER,
           rf"Totals: {_NUM} of the {_NUM} trials with an outcome succeed \(Husky {_NUM} of 96, Sojourner {_NUM} of 96, "
           rf"TALON {_NUM}\s+of 96, Jackal {_NUM} of 96, HUNTER {_NUM} of 80\); {_NUM} end `stuck`, {_NUM} `timeout`, "
           rf"{_NUM} `tipped`",
           lambda f: (lambda t: [float(t["success"].sum()), float(len(t))]
                      + [float(t.groupby("vehicle")["success"].sum()[v])
                         for v in ("husky", "sojourner", "talon", "jackal", "hunter")]
                      + [float((t["failure_reason"] == r).sum()) for r in ("stuck", "timeout", "tipped")])(_vp_trials(f))),
    Sample("vehicle-planner earlier: totals at D_high 2.6", VP_EARLIER,
           rf"Totals at 2.6: {_NUM} of the {_NUM} trials with an outcome succeed \(Sojourner {_NUM} of 96, Husky {_NUM}, "
           rf"TALON {_NUM},\s+Jackal {_NUM} of 96, HUNTER {_NUM} of 80\); {_NUM} end `stuck`, {_NUM} `timeout`, {_NUM} `off_map`",
           lambda f: (lambda t: [float(t["success"].sum()), float(len(t))]
                      + [float(t.groupby("vehicle")["success"].sum()[v])
                         for v in ("sojourner", "husky", "talon", "jackal", "hunter")]
                      + [float((t["failure_reason"] == r).sum()) for r in ("stuck", "timeout", "off_map")])(
                          trial_table(f).query("D_high == 2.6"))),
    *[Sample(f"vehicle-planner earlier: the Husky's success intervals at {lv}", VP_EARLIER,
             rf"{head}[\s\S]*?" + "".join(rf"\| husky \| {p} \| {_NUM} \| {_NUM} \[{_NUM}, {_NUM}\] \| {_NUM} \| "
                                           rf"{_NUM} \[{_NUM}, {_NUM}\] \|[^\n]*\n"
                                           for p in ("straight", "astar", "lattice", "reactive", "mppi", "ppo")),
             _vp_success_intervals(lv))
      for lv, head in ((2.95, "## Success per vehicle, planner and sensor at D_high 2.95"), (2.6, "## D_high 2.6"))],
    Sample("majhor2023 plan: terrains, means, effect, interval, p, Holm p, power, the other summary", "majhor2023",
           _majhor_plan_pattern(), lambda f: [v for row in _majhor_plan(f) for v in row]),
    Sample("majhor2023 each planned test on both engines", "majhor2023", _majhor_both_rows(), _majhor_both_plans),
    Sample("planner-stress straight-line breaking point per engine", "planner-stress",
           r"[\s\S]*?".join(rf"\| straight \| oracle \| {e} \| {_NUM} \[{_NUM}, {_NUM}\] \|" for e in PS_ENGINES),
           _straight_breaking_point),
    Sample("planner-stress successes per engine, surface, level, sensor and planner", "planner-stress",
           r"\| engine \| D_high \| W-M surface \| mast: straight \| astar \| lattice \| oracle: straight \| astar \| lattice \|[^\n]*\n"
           r"\|[-|]+\|\n" + r"".join(rf"\| {e} \| [\d.]+ \| [^|]+ \|" + rf" {_NUM} \|" * 6 + r"[^\n]*\n"
                                     for e in PS_ENGINES for _ in range(6)),
           _planner_successes),
    Sample("engines-warp plan: terrains, means, effect, interval, p, Holm p, power", "engines-warp",
           "".join(rf"\| {re.escape(label)} \| {_NUM} \| {_NUM} -> {_NUM} \| \**\+?{_NUM} \[{_NUM}, {_NUM}\]\** "
                   rf"\| {_SCI} \| {_SCI} \| (?:yes|no) \| {_NUM} at [+-][\d.]+ \|\n" for _, label in WARP_TESTS),
           lambda f: [v for row in _warp_plan(f) for v in row]),
    Sample("engines-warp successes per engine and D_high", "engines-warp",
           rf"successful trials \(of \d+\) \| {_NUM} / {_NUM} / {_NUM} \| {_NUM} / {_NUM} / {_NUM} \|",
           lambda f: [float(v) for v in trial_table(f).groupby(["engine", "D_high"])["success"].sum()
                      .loc[["mujoco", "mujoco_warp"]]]),
    Sample("engines-warp failures per engine and reason", "engines-warp",
           rf"failures `stuck` \| {_NUM} / {_NUM} / {_NUM} \| {_NUM} / {_NUM} / {_NUM} \|\n"
           rf"\| failures `tipped` \| {_NUM} / {_NUM} / {_NUM} \| {_NUM} / {_NUM} / {_NUM} \|",
           lambda f: [float(((t := trial_table(f))["engine"].eq(e) & t["D_high"].eq(d) & t["failure_reason"].eq(r)).sum())
                      for r in ("stuck", "tipped") for e in ("mujoco", "mujoco_warp") for d in (2.3, 2.45, 2.6)]),
    Sample("engines-warp paired missions by engine", "engines-warp",
           rf"{_NUM} succeed on both, {_NUM} on MuJoCo Warp only, {_NUM} on MuJoCo only and {_NUM} on neither",
           _warp_one_engine_only),
    Sample("engines-warp ride of the missions both engines complete", "engines-warp",
           rf"On the {_NUM} missions both engines complete, MuJoCo Warp's values differ from MuJoCo's by a median of\s+"
           rf"\+?{_NUM} % \(RMS vertical acceleration\), \+?{_NUM} % \(pitch rate\) and \+?{_NUM} % \(roll rate\)",
           _warp_ride_ratios),
    Sample("engines-warp side-by-side medians", "engines-warp",
           r"".join(rf"\| median {m}, [^|]+ \| {_NUM} / {_NUM} / {_NUM} \| {_NUM} / {_NUM} / {_NUM} \|\n"
                    for m in ("RMS vertical acceleration", "RMS pitch rate", "RMS roll rate", "traversal time")),
           _warp_medians),
    Sample("engines-warp terrains where MuJoCo Warp's success is higher, lower, equal", "engines-warp",
           rf"success is higher on {_NUM} of 10 terrains, lower on {_NUM}, equal on {_NUM}", _warp_terrains_up_down),
    Sample("engines-warp trials with a dropped contact, and by the MuJoCo twin's outcome", "engines-warp",
           rf"\*\*{_NUM} of the 300 MuJoCo Warp trials had a contact dropped\*\* \({_NUM} in all; median {_NUM} in such a\s+"
           rf"trial, at most {_NUM}\), {_NUM} / {_NUM} / {_NUM} of 100 at D 2.3 / 2.45 / 2.6\.[\s\S]*?"
           rf"{_NUM} of the {_NUM} missions that get `stuck` on\s+MuJoCo had one on MuJoCo Warp, against {_NUM} of the "
           rf"{_NUM} MuJoCo completes\.[\s\S]*?{_NUM} of {_NUM} with a\s+drop and {_NUM} of {_NUM} without get `stuck` "
           rf"on MuJoCo Warp; of those MuJoCo gets `stuck` on, {_NUM} of {_NUM} with and {_NUM}\s+of {_NUM} without succeed",
           _warp_dropped),
]


def _decimals(text: str) -> int:
    return len(text.split(".")[1]) if "." in text else 0


@pytest.mark.parametrize("sample", SAMPLES, ids=[s.name for s in SAMPLES])
def test_readme_number_recomputes_from_the_committed_tables(sample: Sample):
    folder = RESULTS / sample.folder
    readme = (folder / "README.md").read_text()
    hit = re.search(sample.pattern, readme)
    assert hit, f"{sample.folder}/README.md no longer states '{sample.name}': re-point the sample"
    stated = hit.groups()
    computed = sample.compute(folder)
    assert len(computed) == len(stated)
    for text, value in zip(stated, computed, strict=True):
        half_unit = 0.5 * 10.0 ** -_decimals(text)
        assert abs(float(text) - value) <= half_unit + sample.tol + 1e-9, (
            f"{sample.name}: README says {text}, the tables give {value:.4g}")


def test_trials_rebuilt_from_terrain_counts_keep_every_count():
    folder = RESULTS / "majhor2023"
    ter = pd.read_csv(folder / "terrains.csv")
    t = trial_table(folder)
    assert len(t) == ter["trials"].sum() and t["success"].sum() == ter["successes"].sum()
    rates = per_terrain_rate(t, "D_high")
    expect = ter.pivot(index="terrain", columns="D_high", values="success_rate_pct")
    assert np.allclose(rates.to_numpy(), expect.to_numpy())


def test_vehicle_planner_verdicts_and_rejections_are_its_tables():
    """vehicle-planner/README.md's per-test verdicts and yes/no are engine_verdicts.csv's and confirmatory.csv's, and
    every planned test had power >= 0.8 at its stated effect before the run (issue 42)."""
    folder = RESULTS / "vehicle-planner"
    text = (folder / "README.md").read_text()
    conf = pd.read_csv(folder / "confirmatory.csv")
    assert conf["power"].min() >= 0.8 and not conf["exploratory"].any()
    for c in conf.itertuples():
        engine = re.search(r"engine = (\w+)", c.stratum).group(1)
        row = rf"\| {re.escape(c.comparison)} \| {engine} \|[^\n]*\| {'yes' if c.reject else 'no'} \| [\d.]+ at [+-]\d+ \|"
        assert re.search(row, text), (c.comparison, engine)
    eng = pd.read_csv(folder / "engine_verdicts.csv")
    assert set(eng["engine"]) == set(VP_ENGINES)
    for name, verdict in eng.groupby("comparison", sort=False)["verdict"].first().items():
        assert f"**{name}: {verdict}**" in text, name
    assert (RESULTS / VP_EARLIER / "README.md").read_text().split("\n")[2].startswith(
        "**The earlier, exploratory table, superseded for the plan by the [parent folder](../README.md).**")


def test_planner_stress_verdicts_and_rejections_are_its_tables():
    """planner-stress/README.md's yes/no per planned test and engine are confirmatory.csv's, every planned test had
    power >= 0.8 at its stated effect before the run, and each test's cross-engine verdict line is
    engine_verdicts.csv's, in the new-beside-old table too (issue 42)."""
    folder = RESULTS / "planner-stress"
    text = (folder / "README.md").read_text()
    conf = pd.read_csv(folder / "confirmatory.csv")
    assert conf["power"].min() >= 0.8 and not conf["exploratory"].any()
    for c in conf.itertuples():
        engine = re.search(r"engine = (\w+)", c.stratum).group(1)
        level = re.search(r"D_high = ([\d.]+)", c.stratum).group(1)
        row = (rf"\| {re.escape(c.comparison)} \| {level} \| {engine} \|[^\n]*\| {'yes' if c.reject else 'no'} "
               rf"\| {c.power:.2f} at \+\d+ \|")
        assert re.search(row, text), (c.comparison, level, engine)
    eng = pd.read_csv(folder / "engine_verdicts.csv")
    assert set(eng["engine"]) == set(PS_ENGINES)
    for (name, stratum), verdict in eng.groupby(["comparison", "stratum"], sort=False)["verdict"].first().items():
        level = re.search(r"D_high = ([\d.]+)", stratum).group(1)
        assert f"**{name}, D_high {level}: {verdict}**" in text, (name, level)
        assert re.search(rf"\| {re.escape(name)} \| {level} \|[^\n]*\| {verdict} \|\n", text), (name, level)


@pytest.mark.parametrize("study", ["majhor2023", "majhor2023-mujoco"])
def test_majhor_verdicts_are_their_tables(study: str):
    """The majhor2023 READMEs' yes/no per planned test are confirmatory.csv's, every planned test had power >= 0.8
    at its stated effect before the run (issue 42), and the both-engine table's verdicts are the two studies'
    rejections and majhor2023-engines' engine_verdicts.csv."""
    text = (RESULTS / study / "README.md").read_text()
    conf = {s: pd.read_csv(RESULTS / s / "confirmatory.csv") for s in ("majhor2023", "majhor2023-mujoco")}
    assert conf[study]["power"].min() >= 0.8 and not conf[study]["exploratory"].any()
    verdicts = pd.read_csv(RESULTS / "majhor2023-engines" / "engine_verdicts.csv").groupby("comparison")["verdict"].first()
    for i, (name, *_) in enumerate(MAJHOR_TESTS):
        reject = [bool(conf[s]["reject"].iloc[i]) for s in ("majhor2023", "majhor2023-mujoco")]
        mark = "yes" if conf[study]["reject"].iloc[i] else "no"
        assert re.search(rf"\| {re.escape(name)} \| \d+ \|[^\n]*\| {mark} \| [\d.]+ at ", text), (study, name)
        on = {(True, True): "both", (False, False): "neither", (True, False): "PyBullet only",
              (False, True): "MuJoCo only"}[tuple(reject)]
        cells = "".join(rf"[^|]*{'yes' if r else 'no'}[^|]*\|" for r in reject)
        assert re.search(rf"\| {re.escape(name)} \|{cells} {on} \| {verdicts[name]} \|", text), (study, name)


PLAN_ROW_LABELS = {"soil-map": lambda name: name.removesuffix(": success"),
                   "vehicle-comparison": lambda name: name.removesuffix(" against the husky"),
                   "vehicle-sensitivity": lambda name: (lambda m: f"{m[1]} / {float(m[2])} | "
                                                        + ("success, points" if m[3] == "success" else "RMS pitch rate, deg/s"))(
                       re.match(r"([\d.]+) N m, ([\d.]+) kg m\^2 against the shipped vehicle: (success|pitch rate)", name))}
"""Studies re-run on issue 42's powered plans whose README gives one plan row per test: confirmatory.csv's
comparison name -> the README row's label."""


@pytest.mark.parametrize("study", sorted(PLAN_ROW_LABELS))
def test_plan_rows_state_the_tables_verdict_and_power(study: str):
    """Each planned test's README row says rejected yes / no as confirmatory.csv does, with the power the plan
    stated before the run, which is >= 0.8 for every test (issue 42)."""
    folder = RESULTS / study
    text = (folder / "README.md").read_text()
    conf = pd.read_csv(folder / "confirmatory.csv")
    assert conf["power"].min() >= 0.8 and not conf["exploratory"].any()
    for c in conf.itertuples():
        row = (rf"\| {re.escape(PLAN_ROW_LABELS[study](c.comparison))} \|[^\n]*\| {'yes' if c.reject else 'no'} "
               rf"\| {c.power:.2f}(?: at [+-][\d.]+)? \|")
        assert re.search(row, text), (study, c.comparison)
        verdict = "rejected" if c.reject else "not rejected"
        assert f"**{c.comparison}: {verdict} on PyBullet; MuJoCo not run.**" in text, (study, c.comparison)


def test_the_warp_arms_mujoco_trials_are_the_engines_studys():
    """engines-warp (issue 48) is paired with the committed engines study: its root seed is the engines study's
    resolved blind seed, and every one of its MuJoCo trials (terrains 0-9) is the engines study's MuJoCo trial of the same D_high,
    terrain and mission, bit for bit (seeds, outcome, every metric); MuJoCo Warp drove the same missions."""
    from offroadbench.config import load_toml
    from offroadbench.study.spec.config import study_from_dict

    root = RESULTS.parent
    warp = study_from_dict(load_toml(root / "engines-warp.toml"), where="engines-warp.toml")
    engines = study_from_dict(load_toml(root / "engines.toml"), where="engines.toml")
    assert warp.root_seed == engines.root_seed and warp.paired_terrains and engines.paired_terrains
    key = ["D_high", "terrain", "mission"]
    new, old = (trial_table(RESULTS / n) for n in ("engines-warp", "engines"))
    cols = [c for c in old.columns if c in new.columns and c != "cell"]
    mine = new[new["engine"] == "mujoco"][cols].sort_values(key).reset_index(drop=True)
    assert warp.terrains_per_cell == 10 and engines.terrains_per_cell == 12  # its terrains 0-9 of the engines study's
    theirs = old[(old["engine"] == "mujoco") & (old["terrain"] < 10)][cols].sort_values(key).reset_index(drop=True)
    assert len(mine) == len(theirs) == 300
    pd.testing.assert_frame_equal(mine, theirs, check_exact=True)
    arm = new[new["engine"] == "mujoco_warp"].set_index(key).sort_index()
    twin = mine.set_index(key).sort_index()
    assert arm.index.equals(twin.index)
    for c in ("terrain_seed", "mission_seed", "start_x_m", "start_y_m", "goal_x_m", "goal_y_m"):
        assert (arm[c] == twin[c]).all(), c


def test_the_warp_arms_plan_has_the_power_its_toml_states():
    """engines-warp's 2 planned tests have the power experiments/engines-warp.toml's comments state (0.95 and 1.00 at
    10 terrains, from its committed pilot), what `study run` checked, and confirmatory.csv kept it."""
    from offroadbench.study import load_study
    from offroadbench.study.stats.power import check_power

    path = RESULTS.parent / "engines-warp.toml"
    study, _ = load_study(path)
    table = check_power(study, path.parent)
    assert [float(v) for v in table["power"]] == pytest.approx([0.95, 1.00], abs=0.011)
    assert list(pd.read_csv(RESULTS / "engines-warp" / "confirmatory.csv")["power"]) == list(table["power"])


def test_the_warp_arms_new_beside_old_recomputes_from_both_runs(tmp_path: Path):
    """engines-warp/README.md's "New beside old" table: the old column from the first run's tables as committed in
    WARP_FIRST_RUN (git history), the new column from the committed folder, every number to the README's rounding;
    and the first run's MuJoCo trials are this run's, bit for bit."""
    import subprocess

    old = tmp_path / "engines-warp"
    old.mkdir()
    for name in ("trials.parquet", "confirmatory.csv"):
        got = subprocess.run(["git", "show", f"{WARP_FIRST_RUN}:experiments/results/engines-warp/{name}"],
                             cwd=RESULTS, capture_output=True)
        if got.returncode != 0:
            pytest.skip(f"the first engines-warp run is not in this checkout's git history ({WARP_FIRST_RUN})")
        (old / name).write_bytes(got.stdout)
    readme = (RESULTS / "engines-warp" / "README.md").read_text()
    hit = re.search(_warp_beside_pattern(), readme)
    assert hit, "engines-warp/README.md no longer has its New beside old table: re-point the test"
    computed = [v for o, n in zip(_warp_beside(old), _warp_beside(RESULTS / "engines-warp"), strict=True)
                for v in o + n]
    stated = hit.groups()
    assert len(stated) == len(computed)
    for text, value in zip(stated, computed, strict=True):
        assert abs(float(text) - value) <= 0.5 * 10.0 ** -_decimals(text) + 1e-9, (
            f"engines-warp New beside old: README says {text}, the tables give {value:.4g}")
    fix = re.search(r"The {n} missions that tipped on MuJoCo Warp now end {n} successful and {n} `stuck`\s+"
                    r"\(their MuJoCo twins: {n} successful, {n} `stuck`; {n} now succeed where MuJoCo gets stuck\)\. "
                    r"Of the {n} MuJoCo Warp\s+trials that did not tip, {n} are the first run's bit for bit and {n} "
                    r"differ: {n} in outcome \({n} successes now\s+`stuck`, {n} `stuck` now successful\)"
                    .replace("{n}", r"(\d+)"), readme)
    assert fix, "engines-warp/README.md no longer says what the fix changed: re-point the test"
    assert [float(v) for v in fix.groups()] == _warp_fix_changes(old, RESULTS / "engines-warp")
    key = ["D_high", "terrain", "mission"]
    a, b = (trial_table(f) for f in (old, RESULTS / "engines-warp"))
    a, b = (x[x["engine"] == "mujoco"].sort_values(key).reset_index(drop=True) for x in (a, b))
    assert b["dropped_contacts"].isna().all()  # the MuJoCo engine drops nothing
    pd.testing.assert_frame_equal(a, b[a.columns], check_exact=True)
    drops = re.search(r"Against the first run: all {n} missions\s+that tipped there and all {n} that changed had one; "
                      r"of the {n} that are the first run's bit for bit, {n} had\s+none and {n} had some"
                      .replace("{n}", r"(\d+)"), readme)
    assert drops, "engines-warp/README.md no longer compares the dropped contacts with the first run: re-point the test"
    assert [float(v) for v in drops.groups()] == _warp_drops_against_first_run(old, RESULTS / "engines-warp")
