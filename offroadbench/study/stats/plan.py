"""A study's analysis plan (``[analysis]``): the confirmatory tests, fixed before the run.

A study file declares, before any trial runs, which comparisons its claims rest on; the store keeps
the plan with the run (inside the stored study config); the report computes exactly these tests in
its "Confirmatory" section and marks every other number exploratory. A plan changed after trials
were stored is refused (:func:`check_unchanged`), as a changed grid is.

TOML::

    [analysis]
    alpha = 0.05                    # family-wise error rate of the whole plan
    multiplicity = "holm"           # holm (Holm 1979) | bonferroni
    confidence = 0.95               # level of the effect intervals
    n_boot = 2000                   # terrain-cluster bootstrap resamples
    seed = 0                        # seed of the bootstrap (and of Monte Carlo tests)
    pilot = "results/x/trials.parquet"   # optional: an earlier run's trials, for the power of each test
    pilot_select = { sensor = "mast" }   # optional: the pilot's rows to use (a setting fixed outside the grid)
    min_power = 0.8                 # study run refuses a planned test under it (unless exploratory)
    power_sims = 1000               # simulated studies per power

    [[analysis.comparisons]]
    name = "astar against the line"
    metric = "success_rate_pct"     # a per-terrain quantity (see METRIC_HELP)
    treatment = { "planner.name" = "astar" }
    control = { "planner.name" = "straight" }
    where = { "recipe.layers.base.D_high" = [2.95, 2.99] }   # optional: restrict the other axes
    test = "sign_flip"              # sign_flip (default) | wilcoxon | permutation (unpaired terrains)
    pool = ["recipe.layers.base.D_high"]   # optional: average the per-terrain values over these axes
    effect = 20.0                   # the effect the test is meant to detect (metric's unit, treatment - control)
    exploratory = false             # true: computed and shown, but its power is not required
    summary = "median"              # per-terrain summary of a traversal or soil metric: median | mean
    pilot_where = { "recipe.layers.base.D_high" = 2.95 }   # optional: read these strata at the pilot's values

Each comparison expands into one test per stratum: every cell whose grid values match
``treatment`` (and ``where``) against the cell with the same values except ``control``'s. Axes in
``pool`` are not strata: each terrain's value is the mean of its per-terrain values over the pooled
cells (for the success rate with equal missions per cell: its success over all of them); a pair of
pooled cells where one side has no value at all (all its trials faults, e.g. a planner that refuses
one of the pooled vehicles) is left out of both sides, so both means pool the same cells. The
unit is the terrain (the missions of a terrain are not independent). Per terrain j the metric's
value in each cell (the success rate of its missions, Eq. 5 of Majhor & Bos 2023; a class area; a
traversal metric's median over its successful trials; a soil metric's median over all its trials)
gives the difference d_j = treatment - control (paired terrains: terrain j of every cell shares its
seed). The effect is the mean of d_j with a percentile terrain-cluster bootstrap interval
(Davison & Hinkley 1997, Sec. 3.8; not adjusted for multiplicity); the test is the exact sign-flip
test of the mean (Fisher 1935; offroadbench.study.stats.clustered.sign_flip_test), or the Wilcoxon
signed-rank test, or for unpaired terrains the two-sample permutation test of the difference of
means. The multiplicity rule runs over every expanded test of the plan. ``min_p`` is the smallest p
the test can give with the stratum's terrains (2 / 2^K for the sign-flip test): a row with
min_p above its adjusted level cannot reject, whatever the data.

Power (offroadbench.study.stats.power): with a ``pilot``, every test's power at its ``effect``, under the
plan's multiplicity rule, is simulated from the pilot's per-terrain differences before the run;
``study run`` refuses a test under ``min_power`` unless its comparison is ``exploratory``, and the
confirmatory table gains a ``power`` column. A traversal or soil metric is summarised per terrain by
the comparison's ``summary`` (the plan's; the other one is computed beside it as exploratory:
``effect_other``, ``p_other``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from offroadbench.config import check_choice, check_int, check_range, to_dict
from offroadbench.errors import InputError

if TYPE_CHECKING:  # the functions that build frames import pandas: a study's plan is read without it (issue 41)
    import pandas as pd

__all__ = ["TESTS", "MULTIPLICITY", "Comparison", "AnalysisPlan", "plan_from_dict", "check_plan", "expand",
           "terrain_metric", "confirmatory_table", "check_unchanged", "min_p", "stored_plan",
           "cell_label", "terrain_differences"]

#: tests a comparison may use
TESTS = ("sign_flip", "wilcoxon", "permutation")
#: multiplicity rules over the plan's tests
MULTIPLICITY = ("holm", "bonferroni")
#: per-terrain summaries of a traversal or soil metric
SUMMARIES = ("median", "mean")
METRIC_HELP = ("success_rate_pct, area_<low|semi|high>_pct, a traversal metric (median of the terrain's successful "
               "trials: rms_vertical_accel_m_s2, rms_pitch_rate_deg_s, rms_roll_rate_deg_s, traversal_time_s) or a "
               "soil metric (median of all its trials: mean_slip, max_penetration_m)")


def _known_metric(name: str) -> bool:
    from offroadbench.study.stats.metrics import CLASSES, METRICS, SOIL_METRICS

    return name == "success_rate_pct" or name in METRICS or name in SOIL_METRICS or name in {
        f"area_{c}_pct" for c in CLASSES}


@dataclass(frozen=True, kw_only=True)
class Comparison:
    """One planned comparison: treatment cells against control cells on one per-terrain metric."""

    name: str
    """Short name shown in the report."""
    treatment: Mapping[str, Any]
    """Grid key -> value selecting the treatment cells."""
    control: Mapping[str, Any]
    """The same grid keys -> the control's values (every other axis equal)."""
    metric: str = "success_rate_pct"
    """Per-terrain quantity compared: ``success_rate_pct``, ``area_<low|semi|high>_pct``, a traversal metric
    (``rms_vertical_accel_m_s2``, ``rms_pitch_rate_deg_s``, ``rms_roll_rate_deg_s``, ``traversal_time_s``: median
    of the terrain's successful trials) or a soil metric (``mean_slip``, ``max_penetration_m``: median of all
    its trials)."""
    where: Mapping[str, Any] = field(default_factory=dict)
    """Other grid keys -> a value or a list of values: only these strata are tested (default: all)."""
    test: str = "sign_flip"
    """``sign_flip`` (exact, paired terrains), ``wilcoxon`` (paired) or ``permutation`` (unpaired)."""
    pool: tuple[str, ...] = ()
    """Grid keys averaged over (per terrain) instead of tested per value."""
    effect: float | None = None
    """The effect the test is meant to detect (the metric's unit, treatment - control): its power is
    computed at this effect (offroadbench.study.stats.power)."""
    exploratory: bool = False
    """True: the test is computed and shown, but ``study run`` does not require its power."""
    summary: str = "median"
    """Per-terrain summary of a traversal or soil metric over its trials: ``median`` or ``mean``."""
    pilot_where: Mapping[str, Any] = field(default_factory=dict)
    """Grid key -> the pilot's value to read a stratum at when the pilot lacks the study's (power only)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "pool", tuple(self.pool))
        if not isinstance(self.pilot_where, Mapping):
            raise InputError(f"analysis comparison {self.name!r}: pilot_where must be a table of grid key = value")
        object.__setattr__(self, "pilot_where", dict(self.pilot_where))
        if self.effect is not None and (isinstance(self.effect, bool) or not isinstance(self.effect, (int, float))
                                        or not math.isfinite(self.effect)):
            raise InputError(f"analysis comparison {self.name!r}: effect = {self.effect!r}; give a finite number")
        if not isinstance(self.exploratory, bool):
            raise InputError(f"analysis comparison {self.name!r}: exploratory = {self.exploratory!r}; true or false")
        check_choice(self, "summary", self.summary, SUMMARIES)
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"analysis.comparisons: name = {self.name!r}; give each comparison a name")
        for side in ("treatment", "control", "where"):
            if not isinstance(getattr(self, side), Mapping):
                raise InputError(f"analysis comparison {self.name!r}: {side} must be a table of grid key = value")
            object.__setattr__(self, side, dict(getattr(self, side)))
        if not self.treatment or set(self.treatment) != set(self.control):
            raise InputError(f"analysis comparison {self.name!r}: treatment and control must set the same grid keys "
                             f"(treatment: {sorted(self.treatment)}, control: {sorted(self.control)})")
        if self.treatment == self.control:
            raise InputError(f"analysis comparison {self.name!r}: treatment and control are the same cells")
        both = (set(self.where) | set(self.pool)) & set(self.treatment)
        if both:
            raise InputError(f"analysis comparison {self.name!r}: where and pool may not name the compared key(s) "
                             f"{', '.join(sorted(both))}")
        if not _known_metric(self.metric):
            raise InputError(f"analysis comparison {self.name!r}: metric = {self.metric!r} is not known; "
                             f"allowed: {METRIC_HELP}")
        check_choice(self, "test", self.test, TESTS)


@dataclass(frozen=True, kw_only=True)
class AnalysisPlan:
    """The confirmatory analysis of a study (``[analysis]``), fixed before the run."""

    comparisons: tuple[Comparison, ...] = ()
    """The planned comparisons (``[[analysis.comparisons]]``)."""
    alpha: float = 0.05
    """Family-wise error rate over every test of the plan."""
    multiplicity: str = "holm"
    """``holm`` (Holm 1979, step-down) or ``bonferroni`` (alpha / number of tests)."""
    confidence: float = 0.95
    """Level of the terrain-bootstrap interval of each effect."""
    n_boot: int = 2000
    """Terrain-cluster bootstrap resamples per effect."""
    seed: int = 0
    """Seed of the bootstrap and of Monte Carlo tests (more than 20 terrains)."""
    pilot: str = ""
    """An earlier run's trial table (Parquet or CSV; relative to the study TOML's folder) from which each
    test's power is simulated (offroadbench.study.stats.power); empty: no power is computed."""
    min_power: float = 0.8
    """``study run`` refuses a non-exploratory test whose power is under this."""
    power_sims: int = 1000
    """Simulated studies per power."""
    pilot_select: Mapping[str, Any] = field(default_factory=dict)
    """Pilot column -> value: the pilot's rows the power is simulated from (the pilot's values of a setting
    the study fixes outside its grid, e.g. ``{ sensor = "mast" }``)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "comparisons", tuple(self.comparisons))
        if not isinstance(self.pilot, str):
            raise InputError(f"analysis.pilot = {self.pilot!r}; give a path to a trial table")
        check_range(self, "min_power", self.min_power, lo=0, hi=1)
        if not isinstance(self.pilot_select, Mapping):
            raise InputError(f"analysis.pilot_select = {self.pilot_select!r}; give a table of pilot column = value")
        object.__setattr__(self, "pilot_select", dict(self.pilot_select))
        check_int(self, "power_sims", self.power_sims, lo=100)
        check_range(self, "alpha", self.alpha, lo=0, hi=0.5, lo_open=True)
        check_choice(self, "multiplicity", self.multiplicity, MULTIPLICITY)
        check_range(self, "confidence", self.confidence, lo=0.5, hi=1, hi_open=True)
        check_int(self, "n_boot", self.n_boot, lo=100)
        check_int(self, "seed", self.seed, lo=0)
        names = [c.name for c in self.comparisons]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"analysis.comparisons: name(s) used twice: {', '.join(dup)}")


_PLAN_KEYS = ("alpha", "multiplicity", "confidence", "n_boot", "seed", "pilot", "min_power", "power_sims",
              "pilot_select", "comparisons")
_COMP_KEYS = ("name", "treatment", "control", "metric", "where", "test", "pool", "effect", "exploratory", "summary",
              "pilot_where")


def plan_from_dict(data: Mapping[str, Any] | None, where: str = "analysis") -> AnalysisPlan | None:
    """The plan of an ``[analysis]`` table (None without one), refusing unknown keys."""
    if data is None:
        return None
    if not isinstance(data, Mapping):
        raise InputError(f"{where}: [analysis] must be a table")
    bad = sorted(set(data) - set(_PLAN_KEYS))
    if bad:
        raise InputError(f"{where}: [analysis]: unknown key(s) {', '.join(bad)}; known: {', '.join(_PLAN_KEYS)}")
    comps = data.get("comparisons", [])
    if not isinstance(comps, list) or not comps:
        raise InputError(f"{where}: [analysis] needs at least one [[analysis.comparisons]] table")
    built = []
    for i, c in enumerate(comps):
        if not isinstance(c, Mapping):
            raise InputError(f"{where}: analysis.comparisons[{i}] must be a table")
        bad = sorted(set(c) - set(_COMP_KEYS))
        if bad:
            raise InputError(f"{where}: analysis.comparisons[{i}]: unknown key(s) {', '.join(bad)}; "
                             f"known: {', '.join(_COMP_KEYS)}")
        try:
            built.append(Comparison(**c))
        except TypeError as exc:
            raise InputError(f"{where}: analysis.comparisons[{i}]: {exc}") from None
    return AnalysisPlan(**{k: v for k, v in data.items() if k != "comparisons"}, comparisons=tuple(built))


def _as_list(v: Any) -> list:
    return list(v) if isinstance(v, (list, tuple)) else [v]


def check_plan(plan: AnalysisPlan, grid: Sequence[Any], paired_terrains: bool) -> None:
    """Refuse a plan that names a grid key or value the study does not have, a paired test of
    unpaired terrains, or a comparison that selects no cell."""
    axes = {a.key: tuple(a.values) for a in grid}
    for c in plan.comparisons:
        where = f"analysis comparison {c.name!r}"
        for side in ("treatment", "control", "where"):
            for key, value in getattr(c, side).items():
                if key not in axes:
                    raise InputError(f"{where}: {side} key {key!r} is not a grid axis; axes: {', '.join(axes) or 'none'}")
                for v in _as_list(value) if side == "where" else [value]:
                    if v not in axes[key]:
                        raise InputError(f"{where}: {side} {key} = {v!r} is not a value of the axis "
                                         f"{list(axes[key])}")
        for key in c.pilot_where:
            if key not in axes:
                raise InputError(f"{where}: pilot_where key {key!r} is not a grid axis; axes: {', '.join(axes) or 'none'}")
        for key in c.pool:
            if key not in axes:
                raise InputError(f"{where}: pool key {key!r} is not a grid axis; axes: {', '.join(axes) or 'none'}")
        if c.test in ("sign_flip", "wilcoxon") and not paired_terrains:
            raise InputError(f"{where}: test = {c.test!r} needs paired terrains ([study] paired_terrains = true); "
                             "use test = \"permutation\"")
        if c.test == "permutation" and paired_terrains:
            raise InputError(f"{where}: test = \"permutation\" is for unpaired terrains; with paired terrains use "
                             "sign_flip or wilcoxon")


def expand(plan: AnalysisPlan, cells: Sequence[Mapping[str, Any]]
           ) -> list[tuple[Comparison, dict, list[int], list[int]]]:
    """Every test of the plan: (comparison, stratum {other grid key: value}, treatment cells,
    control cells), in plan order then cell order; the cell lists have more than one cell only
    with ``pool``. ``cells``: grid values of each cell, by index."""
    def key(v: Mapping[str, Any]) -> tuple:
        return tuple(sorted(v.items(), key=lambda kv: kv[0]))

    index = {key(v): i for i, v in enumerate(cells)}
    out = []
    for c in plan.comparisons:
        strata: dict[tuple, tuple[dict, list[int], list[int]]] = {}
        for i, values in enumerate(cells):
            if any(values.get(k) != v for k, v in c.treatment.items()):
                continue
            if any(values.get(k) not in _as_list(v) for k, v in c.where.items()):
                continue
            j = index.get(key({**values, **c.control}))
            if j is None:
                continue
            stratum = {k: v for k, v in values.items() if k not in c.treatment and k not in c.pool}
            entry = strata.setdefault(key(stratum), (stratum, [], []))
            entry[1].append(i)
            entry[2].append(j)
        out += [(c, st, ts, cs) for st, ts, cs in strata.values()]
    return out


def _pooled(vals: pd.Series, cells: Sequence[int]) -> pd.Series:
    """Per terrain: the mean of its values over ``cells`` (NaN, so the terrain is left out, where one cell has
    no value: a metric of successful trials on a terrain without a success there)."""
    import pandas as pd

    have = set(vals.index.get_level_values(0)) if len(vals) else set()
    parts = [vals.xs(c, level="cell") for c in cells if c in have]
    if not parts:
        return pd.Series(dtype=float)
    return pd.concat(parts, axis=1).mean(axis=1, skipna=False) if len(parts) > 1 else parts[0]


def terrain_metric(trials: pd.DataFrame, terrains: pd.DataFrame | None, metric: str, summary: str = "median"
                   ) -> pd.Series:
    """Per (cell, terrain): the metric's per-terrain value (see the module docstring); a traversal or soil
    metric summarised by ``summary`` (median or mean) over the terrain's trials."""
    import pandas as pd

    from offroadbench.study.stats.terrain import METRICS, SOIL_METRICS, terrain_success

    if metric == "success_rate_pct":
        return terrain_success(trials).set_index(["cell", "terrain"])["success_rate_pct"]
    if metric.startswith("area_"):
        if terrains is None or metric[:-4] not in terrains:
            return pd.Series(dtype=float)
        return 100.0 * terrains.set_index(["cell", "terrain"])[metric[:-4]].astype(float)
    if metric not in trials:
        return pd.Series(dtype=float)
    rows = trials[trials["success"].astype(bool)] if metric in METRICS else trials
    assert metric in METRICS or metric in SOIL_METRICS
    return rows.groupby(["cell", "terrain"])[metric].agg(summary).astype(float)


def min_p(test: str, k: int, n_control: int = 0) -> float:
    """The smallest two-sided p the test can reach with k terrains (paired) or k and n_control
    terrains (permutation): 2 / 2^k, or 2 / C(k + n_control, k)."""
    if k <= 0:
        return math.nan
    if test == "permutation":
        return min(1.0, 2.0 / math.comb(k + n_control, k))
    return min(1.0, 2.0 / 2.0 ** k)


def _permutation_test(x: np.ndarray, y: np.ndarray, rng: np.random.Generator, n_resamples: int = 99_999) -> float:
    """Two-sided p of the two-sample permutation test of mean(x) - mean(y) (exact when small)."""
    from scipy.stats import permutation_test

    if x.size == 0 or y.size == 0:
        return math.nan
    res = permutation_test((x, y), lambda a, b, axis: np.mean(a, axis=axis) - np.mean(b, axis=axis),
                           permutation_type="independent", vectorized=True, n_resamples=n_resamples,
                           alternative="two-sided", rng=rng)
    return float(min(1.0, res.pvalue))


def cell_label(values: Mapping[str, Any], columns: Mapping[str, str]) -> str:
    return ", ".join(f"{columns.get(k, k)} = {v}" for k, v in values.items()) or "all"


def terrain_differences(vals: pd.Series, ti: Sequence[int], ci: Sequence[int]) -> tuple[pd.DataFrame, np.ndarray]:
    """Per terrain the treatment's and the control's (pooled) values and their difference."""
    import pandas as pd

    have = set(vals.index.get_level_values(0)) if len(vals) else set()
    kept = [(t, c) for t, c in zip(ti, ci, strict=True) if t in have and c in have] if len(ti) > 1 else list(zip(ti, ci, strict=True))
    a, b = _pooled(vals, [t for t, _ in kept]), _pooled(vals, [c for _, c in kept])
    both = pd.concat([a.rename("t"), b.rename("c")], axis=1, join="inner").dropna()
    return both, (both["t"] - both["c"]).to_numpy(float)


def confirmatory_table(plan: AnalysisPlan, meta: Mapping[str, Any], trials: pd.DataFrame,
                       terrains: pd.DataFrame | None, power: pd.DataFrame | None = None) -> pd.DataFrame:
    """Exactly the plan's tests on a run's tables: one row per expanded test (see the module docstring).

    Columns: comparison, metric, treatment, control, stratum, terrains, treatment_mean,
    control_mean, effect (mean per-terrain difference), ci_low, ci_high, test, p, min_p, p_adjusted
    (Holm or Bonferroni over every row), reject (p_adjusted < alpha); exploratory (the plan marks the
    comparison so), power (from ``power``, offroadbench.study.stats.power.plan_power, in the same
    order; NaN without one); for a traversal or soil metric, summary (the plan's per-terrain summary)
    and effect_other / p_other: the same test with the other summary (exploratory, in no adjustment).
    """
    import pandas as pd

    from offroadbench.study.stats.clustered import cluster_bootstrap, holm, keyed_rng, sign_flip_test, wilcoxon_test

    rng = np.random.default_rng(plan.seed)
    columns = meta.get("columns", {})
    cells = [c["values"] for c in sorted(meta["cells"], key=lambda c: c["index"])]
    cache: dict[tuple[str, str], pd.Series] = {}
    rows = []
    for comp, stratum, ti, ci in expand(plan, cells):
        for summ in ((comp.summary, "mean" if comp.summary == "median" else "median")
                     if comp.metric not in ("success_rate_pct",) and not comp.metric.startswith("area_") else ("median",)):
            if (comp.metric, summ) not in cache:
                cache[comp.metric, summ] = terrain_metric(trials, terrains, comp.metric, summ)
        vals = cache[comp.metric, comp.summary if (comp.metric, comp.summary) in cache else "median"]
        # a pooled pair of cells with no value on one side (every trial a fault: a planner that refuses
        # a vehicle) is left out of both sides, so both means pool the same vehicles, levels, ...
        have = set(vals.index.get_level_values(0)) if len(vals) else set()
        kept = [(t, c) for t, c in zip(ti, ci, strict=True) if t in have and c in have] if len(ti) > 1 else list(zip(ti, ci, strict=True))
        a, b = _pooled(vals, [t for t, _ in kept]), _pooled(vals, [c for _, c in kept])
        pooled = f"; pooled over {', '.join(columns.get(k, k) for k in comp.pool)}" if comp.pool else ""
        row: dict[str, Any] = {"comparison": comp.name, "metric": comp.metric,
                               "treatment": cell_label(comp.treatment, columns), "control": cell_label(comp.control, columns),
                               "stratum": cell_label(stratum, columns) + pooled, "test": comp.test}
        if comp.test == "permutation":
            x, y = a.dropna().to_numpy(float), b.dropna().to_numpy(float)
            diffs = (x[rng.integers(0, x.size, (plan.n_boot, x.size))].mean(axis=1)
                     - y[rng.integers(0, y.size, (plan.n_boot, y.size))].mean(axis=1)) if x.size and y.size else []
            q = 100 * (1 - plan.confidence) / 2
            lo, hi = np.percentile(diffs, [q, 100 - q]) if len(diffs) else (math.nan, math.nan)
            row.update(terrains=f"{x.size} / {y.size}", treatment_mean=float(np.mean(x)) if x.size else math.nan,
                       control_mean=float(np.mean(y)) if y.size else math.nan,
                       effect=float(np.mean(x) - np.mean(y)) if x.size and y.size else math.nan,
                       ci_low=float(lo), ci_high=float(hi), p=_permutation_test(x, y, rng),
                       min_p=min_p("permutation", x.size, y.size))
        else:
            both = pd.concat([a.rename("t"), b.rename("c")], axis=1, join="inner").dropna()
            d = (both["t"] - both["c"]).to_numpy(float)
            boot = cluster_bootstrap(d, np.mean, rng, plan.n_boot, level=plan.confidence)
            p = (sign_flip_test(d, rng=rng) if comp.test == "sign_flip" else wilcoxon_test(d)) if d.size else math.nan
            row.update(terrains=int(d.size), treatment_mean=float(both["t"].mean()) if d.size else math.nan,
                       control_mean=float(both["c"].mean()) if d.size else math.nan, effect=boot.estimate,
                       ci_low=boot.low, ci_high=boot.high, p=p, min_p=min_p(comp.test, int(d.size)))
        other = next((v for (m, sm), v in cache.items() if m == comp.metric and sm != comp.summary), None)
        if other is not None and comp.test != "permutation":  # the other per-terrain summary, exploratory
            _, d2 = terrain_differences(other, ti, ci)
            orng = keyed_rng(plan.seed, "other summary", comp.name, row["stratum"])
            row.update(summary=comp.summary, effect_other=float(d2.mean()) if d2.size else math.nan,
                       p_other=((sign_flip_test(d2, rng=orng) if comp.test == "sign_flip" else wilcoxon_test(d2))
                                if d2.size else math.nan))
        row["exploratory"] = comp.exploratory
        rows.append(row)
    out = pd.DataFrame(rows, columns=["comparison", "metric", "treatment", "control", "stratum", "terrains",
                                      "treatment_mean", "control_mean", "effect", "ci_low", "ci_high", "test", "p",
                                      "min_p"])
    p = out["p"].to_numpy(float)
    m = int(np.isfinite(p).sum())
    if plan.multiplicity == "holm":
        out["p_adjusted"] = holm(p)
    else:
        out["p_adjusted"] = np.minimum(1.0, p * m)
    out["reject"] = out["p_adjusted"] < plan.alpha
    out["exploratory"] = [bool(r.get("exploratory", False)) for r in rows]
    out["power"] = (power["power"].to_numpy(float) if power is not None and len(power) == len(out)
                    else np.full(len(out), math.nan))
    if any("summary" in r for r in rows):
        for col in ("summary", "effect_other", "p_other"):
            out[col] = [r.get(col, "" if col == "summary" else math.nan) for r in rows]
    return out


def stored_plan(meta: Mapping[str, Any]) -> AnalysisPlan | None:
    """The plan stored with a run (None when its study had none, or was run before plans existed)."""
    data = (meta.get("study") or {}).get("analysis")
    if not data:
        return None
    comps = tuple(Comparison(**{k: v for k, v in c.items() if not (k == "pool" and not v)})
                  for c in data.get("comparisons", []))
    return AnalysisPlan(**{k: v for k, v in data.items() if k != "comparisons"}, comparisons=comps)


def check_unchanged(old_meta: Mapping[str, Any], new_meta: Mapping[str, Any], trials_stored: int, where: str) -> bool:
    """Refuse (one InputError) a plan that differs from the one stored with trials already run.
    Returns whether the plan changed (with no trial stored yet: the store may take the new one)."""
    def plain(meta: Mapping[str, Any]) -> Any:  # with every key a later version added at its default
        plan = stored_plan(meta)
        return None if plan is None else to_dict(plan)

    changed = plain(old_meta) != plain(new_meta)
    if trials_stored and changed:
        raise InputError(f"{where}: the [analysis] plan differs from the one stored with its {trials_stored} trials; "
                         "a plan is fixed before the run (restore it, or run the new plan into another --out)")
    return changed
