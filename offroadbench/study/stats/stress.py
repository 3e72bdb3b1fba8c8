"""Statistics of a planner stress test: success against a difficulty axis per planner, the
breaking point, and paired comparisons on the same missions, with the terrain as the unit.

* **Success with its interval.** The Wilson score interval (Wilson 1927) of a binomial proportion,
  ``(p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)``: it stays inside [0, 1] and keeps its
  coverage for small n and for p near 0 or 1, where the normal (Wald) interval fails. It treats the
  missions as independent, so it is a lower bound on the uncertainty (the terrain-level tests below
  are what claims rest on).
* **Success with its interval.** The report's interval is a terrain-cluster bootstrap (terrains
  resampled with all their missions); the Wilson interval is kept beside it for comparison.
* **Breaking point.** The value of the difficulty axis (e.g. ``D_high``) at which a planner's
  success falls below 50 %, measured inside the studied levels only: an isotonic (non-increasing)
  fit of success on the level, interpolated between the two studied levels around the crossing, with
  a terrain-cluster bootstrap interval. Where the fit does not fall below 50 % up to the last level
  the point is "not reached up to D = x", with the success there. A logistic fit (clustered
  covariance, Fieller's 1954 interval and a goodness-of-fit p) is kept for comparison only, and only
  where the data locate it: its crossing is given only inside the studied levels and its Fieller
  interval only when it is one bounded interval inside them (three levels rarely pin a logistic
  curve; a crossing outside them is an extrapolation and an unbounded set says the data do not
  locate it, so neither is printed). The first studied level with under 50 % success is listed
  beside it.
* **A generator per cell.** Every bootstrap here draws from a generator of its own, seeded by the
  table's seed and the cell's key (``offroadbench.study.stats.clustered.keyed_rng``): a cell's
  interval does not depend on which other cells the table holds or their order.
* **Paired comparisons.** Every planner drove the same missions (same terrain seed and mission
  seed). The unit is the terrain: per terrain k, b_k missions only A completed and c_k only B
  completed out of n_k; the difference (b_k - c_k) / n_k is tested with the exact sign-flip test
  and the Wilcoxon signed-rank test, and the missions with Durkalski et al.'s (2003)
  cluster-adjusted McNemar test; the mean difference has a terrain-bootstrap interval (with its
  number of distinct resamples). Holm's (1979) adjustment runs over all rows of the table (the
  family of comparisons a report makes). The exact McNemar test that treats the missions as
  independent (McNemar 1947) is kept for comparison only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

__all__ = [
    "arm_table",
    "breaking_points",
    "describe_breaking_point",
    "isotonic_crossing",
    "first_level_below",
    "mcnemar_exact",
    "paired_table",
    "success_by_level",
    "wilson_interval",
]

#: the two-sided 95 % normal quantile
Z95 = 1.959963984540054


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of ``successes / n`` (NaNs for n = 0)."""
    if n <= 0:
        return math.nan, math.nan
    p = successes / n
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    # the interval contains p; rounding can put an end a few ulps inside it at p = 0 or 1
    return max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half))


def first_level_below(levels: Sequence[float], rates: Sequence[float], threshold: float = 0.5) -> float:
    """The first studied level whose rate is below ``threshold`` (``+inf`` if none is); no interpolation."""
    for x, y in zip(levels, rates, strict=True):
        if y < threshold:
            return float(x)
    return math.inf


def mcnemar_exact(n10: int, n01: int) -> float:
    """Two-sided exact McNemar p-value of n10 against n01 discordant pairs (1.0 with none)."""
    from scipy.stats import binomtest

    n = n10 + n01
    if n == 0:
        return 1.0
    return float(binomtest(n10, n, 0.5, alternative="two-sided").pvalue)


def success_by_level(trials: pd.DataFrame, group: str, level: str, by: Sequence[str] = (), seed: int = 0,
                     n_boot: int = 2000) -> pd.DataFrame:
    """Per group (planner), stratum (the other grid axes ``by``) and level (D): trials, successes,
    rate, its terrain-cluster bootstrap 95 % interval (``ci95_low``/``ci95_high``: terrains resampled,
    the rate recomputed from their pooled missions) and, for comparison only, the Wilson interval
    that treats missions as independent (``wilson_low``/``wilson_high``). Each row's bootstrap has its
    own generator (:func:`~offroadbench.study.stats.clustered.keyed_rng` of ``seed`` and the row's values)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, keyed_rng

    keys = [group, *by, level]
    rows = []
    for vals, t in trials.groupby(keys, sort=True):
        n, k = len(t), int(t["success"].astype(bool).sum())
        per = t.groupby("terrain")["success"].agg(["sum", "size"]).to_numpy(float)
        rng = keyed_rng(seed, "success_by_level", *vals)
        boot = cluster_bootstrap(per, lambda v: v[:, 0].sum() / v[:, 1].sum(), rng, n_boot)
        lo, hi = wilson_interval(k, n)
        rows.append({**dict(zip(keys, vals, strict=True)), "trials": n, "successes": k, "terrains": len(per),
                     "success_rate": k / n, "ci95_low": boot.low, "ci95_high": boot.high,
                     "wilson_low": lo, "wilson_high": hi})
    return pd.DataFrame(rows)


def isotonic_crossing(levels: Sequence[float], successes: Sequence[float], trials: Sequence[float],
                      threshold: float = 0.5) -> float:
    """The level where the non-increasing (isotonic) fit of success on the level falls below
    ``threshold``, linearly interpolated between the two studied levels around it; ``+inf`` when it
    does not fall below it up to the last level, ``-inf`` when it is below already at the first.
    Never outside the studied levels."""
    from offroadbench.study.stats.clustered import isotonic_decreasing

    x = np.asarray(levels, float)
    n = np.asarray(trials, float)
    ok = n > 0
    x, rate, n = x[ok], np.asarray(successes, float)[ok] / n[ok], n[ok]
    if x.size == 0:
        return math.nan
    f = isotonic_decreasing(rate, n)
    if f[0] < threshold:
        return -math.inf
    below = np.flatnonzero(f < threshold)
    if below.size == 0:
        return math.inf
    i = int(below[0])
    return float(x[i - 1] + (f[i - 1] - threshold) / (f[i - 1] - f[i]) * (x[i] - x[i - 1]))


def breaking_points(trials: pd.DataFrame, group: str, level: str, threshold: float = 0.5,
                    by: Sequence[str] = (), seed: int = 0, n_boot: int = 2000) -> pd.DataFrame:
    """Breaking point per group (and stratum ``by``): where success falls below ``threshold``,
    measured inside the studied levels only.

    The fit is isotonic (success may only fall as the level rises; pool-adjacent-violators weighted
    by trials) and the crossing is interpolated between the two studied levels around it
    (:func:`isotonic_crossing`); the 95 % interval comes from a terrain-cluster bootstrap of the
    crossing (terrain j resampled with all its missions at every level). Columns: the group,
    ``breaking_point`` (``+inf``: not reached up to the last level, ``-inf``: below already at the
    first), ``ci95_low``, ``ci95_high`` (percentiles of the bootstrap crossings, ``+inf``/``-inf``
    meaning the same), ``not_reached_share`` (resamples with no crossing up to the last level),
    ``success_at_last`` (observed success at the last level), ``terrains``, ``first_level_below``
    (observed), ``levels``; and for comparison a logistic fit with a cluster-robust covariance, only
    where the data locate it: ``logistic_point`` (NaN when the crossing lies outside the studied
    levels: an extrapolation), ``fieller_low``/``fieller_high`` (Fieller's 95 % interval, NaN unless it
    is one bounded interval inside the studied levels; an unbounded set, two rays or the whole line,
    says the slope is not clearly non-zero), ``logistic_slope``, ``logistic_gof_p`` (Pearson's X^2
    over the levels; small: the logistic curve does not follow the data). Each group's bootstrap has
    its own generator (:func:`~offroadbench.study.stats.clustered.keyed_rng` of ``seed`` and the group).
    """
    from offroadbench.study.stats.clustered import (
        breaking_point_logistic,
        fieller_set,
        fit_logistic,
        keyed_rng,
        logistic_fit_check,
    )

    levels = sorted(trials[level].unique())
    keys = [group, *by]
    rows = []
    for vals, t in trials.groupby(keys, sort=True):
        rng = keyed_rng(seed, "breaking_points", *(vals if isinstance(vals, tuple) else (vals,)))
        rates = t.groupby(level, sort=True)["success"].mean()
        s = t.assign(ok=t["success"].astype(float))
        cube = s.pivot_table(index="terrain", columns=level, values="ok", aggfunc="sum", fill_value=0.0)
        cnt = s.pivot_table(index="terrain", columns=level, values="ok", aggfunc="size", fill_value=0.0)
        cube, cnt = cube.reindex(columns=levels, fill_value=0.0), cnt.reindex(columns=levels, fill_value=0.0)
        succ, tri = cube.to_numpy(float), cnt.to_numpy(float)
        point = isotonic_crossing(levels, succ.sum(0), tri.sum(0), threshold)
        draws = rng.integers(0, succ.shape[0], size=(n_boot, succ.shape[0]))
        boot = np.array([isotonic_crossing(levels, succ[d].sum(0), tri[d].sum(0), threshold) for d in draws])
        boot = boot[~np.isnan(boot)]
        lo, hi = (np.percentile(boot, [2.5, 97.5], method="inverted_cdf") if boot.size else (math.nan, math.nan))
        x, y = t[level].to_numpy(float), t["success"].astype(float).to_numpy()
        fit = fit_logistic(x, y, t["terrain"].to_numpy())
        lpoint, _, _ = breaking_point_logistic(fit, threshold)
        pieces = fieller_set(fit, threshold) if fit.slope < 0 else []
        lo_lv, hi_lv = float(min(levels)), float(max(levels))
        if not (fit.slope < 0 and math.isfinite(lpoint) and lo_lv <= lpoint <= hi_lv):
            lpoint = math.nan  # no crossing, or one outside the studied levels: not a measurement
        inside = (len(pieces) == 1 and math.isfinite(lpoint) and all(math.isfinite(v) for v in pieces[0])
                  and lo_lv <= pieces[0][0] and pieces[0][1] <= hi_lv)
        f_lo, f_hi = pieces[0] if inside else (math.nan, math.nan)
        _, _, gof_p = logistic_fit_check(fit, x, y) if fit.converged else (math.nan, 0, math.nan)
        rows.append({**dict(zip(keys, vals if isinstance(vals, tuple) else (vals,), strict=True)), "breaking_point": point,
                     "ci95_low": float(lo), "ci95_high": float(hi),
                     "not_reached_share": float(np.mean(boot == math.inf)) if boot.size else math.nan,
                     "success_at_last": float(rates.iloc[-1]), "terrains": int(succ.shape[0]),
                     "first_level_below": first_level_below(rates.index, rates.to_numpy(float), threshold),
                     "levels": f"{min(levels):g}-{max(levels):g}", "logistic_point": lpoint,
                     "fieller_low": float(f_lo), "fieller_high": float(f_hi), "logistic_slope": fit.slope,
                     "logistic_gof_p": gof_p})
    return pd.DataFrame(rows)


def describe_breaking_point(point: float, low: float, high: float, levels: Sequence[float], success_at_last: float,
                            name: str = "D") -> str:
    """The breaking point in words, inside the studied range only: ``2.944 [2.93, 2.96]``, or
    ``not reached up to D = 2.99 (success there 68 %)``, with open interval ends said as such."""
    lo_lv, hi_lv = min(levels), max(levels)

    def end(v: float) -> str:
        if v == math.inf:
            return f"not reached up to {hi_lv:g}"
        if v == -math.inf:
            return f"below already at {lo_lv:g}"
        return f"{v:.3f}"

    if math.isnan(point):
        return "–"
    if point == math.inf:
        head = f"not reached up to {name} = {hi_lv:g} (success there {100 * success_at_last:.0f} %)"
    elif point == -math.inf:
        head = f"below 50 % already at {name} = {lo_lv:g}"
    else:
        head = f"{point:.3f}"
    if low == high == math.inf:
        return f"{head}; not reached in 97.5 % or more of the terrain resamples either"
    return f"{head}; 95 % interval [{end(low)}, {end(high)}]"


def _terrain_row(p: pd.DataFrame, rng: np.random.Generator, n_boot: int) -> dict:
    """Terrain-level statistics of one comparison; ``p`` has columns terrain, a, b (booleans)."""
    from offroadbench.study.stats.clustered import (
        cluster_bootstrap,
        durkalski_mcnemar,
        sign_flip_test,
        wilcoxon_test,
    )

    per = p.assign(b10=p["a"] & ~p["b"], b01=~p["a"] & p["b"]).groupby("terrain").agg(
        n=("a", "size"), b10=("b10", "sum"), b01=("b01", "sum"))
    d = 100.0 * (per["b10"] - per["b01"]).to_numpy(float) / per["n"].to_numpy(float)
    boot = cluster_bootstrap(d, np.mean, rng, n_boot)
    _, p_durk = durkalski_mcnemar(per["b10"], per["b01"], per["n"])
    return {"terrains": len(per), "terrain_diff_pct": boot.estimate, "terrain_ci95_low": boot.low,
            "terrain_ci95_high": boot.high, "bootstrap_distinct": f"{boot.distinct} of {min(boot.possible, n_boot)}",
            "p_sign_flip": sign_flip_test(d, rng=rng), "p_wilcoxon": wilcoxon_test(d), "p_durkalski": p_durk}


def paired_table(trials: pd.DataFrame, group: str, level: str | None, baseline: str, seed: int = 0,
                 n_boot: int = 2000, by: Sequence[str] = ()) -> pd.DataFrame:
    """Each group against ``baseline`` on the same (terrain, mission) at each level and pooled.

    Mission counts (both / only this / only baseline / neither) and the exact McNemar p that treats
    missions as independent (``mcnemar_p_missions``, for comparison only); then the terrain-level
    statistics: ``terrains``, the mean per-terrain success difference in points with its terrain
    bootstrap interval and distinct resamples, ``p_sign_flip``, ``p_wilcoxon``, ``p_durkalski``, and
    ``p_holm`` (Holm over the sign-flip p of every row) with ``significant`` = p_holm < 0.05.
    ``by``: the other grid axes (strata); each stratum is compared within itself, at each level and
    pooled over its levels. Each row draws from a generator of its own (``keyed_rng``).
    """
    from offroadbench.study.stats.clustered import keyed_rng

    by = list(by)
    key = ["terrain", "mission", *by] + ([level] if level else [])
    base = trials[trials[group] == baseline].set_index(key)["success"].astype(bool)
    rows = []
    for g in sorted(trials[group].unique()):
        if g == baseline:
            continue
        other = trials[trials[group] == g].set_index(key)["success"].astype(bool)
        both = other.to_frame("a").join(base.to_frame("b"), how="inner").reset_index()
        strata = list(both.groupby(by, sort=True)) if by else [((), both)]
        parts = []
        for sv, sp in strata:
            sv = sv if isinstance(sv, tuple) else (sv,)
            parts += [(sv, x, p) for x, p in (sp.groupby(level, sort=True) if level else [])]
            parts.append((sv, "all", sp))
        for sv, x, p in parts:
            n10 = int((p["a"] & ~p["b"]).sum())
            n01 = int((~p["a"] & p["b"]).sum())
            rows.append({group: g, "versus": baseline, **dict(zip(by, sv, strict=True)), level or "level": x, "pairs": len(p),
                         "both": int((p["a"] & p["b"]).sum()), "only this": n10, "only baseline": n01,
                         "neither": int((~p["a"] & ~p["b"]).sum()),
                         "success_diff_pct": 100.0 * (p["a"].mean() - p["b"].mean()),
                         "mcnemar_p_missions": mcnemar_exact(n10, n01),
                         **_terrain_row(p, keyed_rng(seed, "paired_table", g, baseline, *sv, x), n_boot)})
    out = pd.DataFrame(rows)
    if not out.empty:
        from offroadbench.study.stats.clustered import holm

        out["p_holm"] = holm(out["p_sign_flip"])
        out["significant"] = out["p_holm"] < 0.05
    return out


def arm_table(trials: pd.DataFrame, arm: str, control, treatment, by: Sequence[str], seed: int = 0,
              n_boot: int = 2000, terrains: pd.DataFrame | None = None, resolution: str = "twin_unexplained_var"
              ) -> pd.DataFrame:
    """Two arms of one axis (e.g. ``band_limited`` false / true, ``map_noise_m`` 0 / 0.05) compared
    within every stratum ``by`` (planner, level, ...), with the terrain as the unit.

    Per terrain: the success rate of each arm over its missions, the difference (treatment -
    control, points); their mean with a terrain-bootstrap 95 % interval, the exact sign-flip p, and
    ``same_missions``: the share of the stratum's missions whose start and goal are the same in both
    arms (1.0: the arms are paired mission by mission). With ``terrains`` holding ``resolution`` (the
    treatment arm's per-terrain statistic, e.g. the share of the aliased surface's variance above the
    grid's Nyquist frequency), its mean over the stratum's terrains and its Spearman correlation with
    the per-terrain difference are added. ``p_holm``: Holm over the rows of this table. Each row draws
    from a generator of its own (``keyed_rng``).
    """
    from scipy.stats import spearmanr

    from offroadbench.study.stats.clustered import cluster_bootstrap, holm, keyed_rng, sign_flip_test

    ends = ["start_x_m", "start_y_m", "goal_x_m", "goal_y_m"]
    a = trials[trials[arm] == control]
    b = trials[trials[arm] == treatment]
    rows = []
    for sv, tb in b.groupby(list(by), sort=True):
        sv = sv if isinstance(sv, tuple) else (sv,)
        ta = a
        for col, v in zip(by, sv, strict=True):
            ta = ta[ta[col] == v]
        if ta.empty:
            continue
        keys = ["terrain", "mission"]
        have = [c for c in ends if c in tb and c in ta]
        pair = pd.merge(tb.set_index(keys)[["success", *have]], ta.set_index(keys)[["success", *have]], how="inner",
                        left_index=True, right_index=True, suffixes=("_t", "_c"))
        same = (np.all([np.isclose(pair[f"{c}_t"], pair[f"{c}_c"]) for c in have], axis=0).mean()
                if have and len(pair) else math.nan)
        per = pair.groupby(level="terrain").agg(t=("success_t", "mean"), c=("success_c", "mean"))
        d = 100.0 * (per["t"] - per["c"]).to_numpy(float)
        rng = keyed_rng(seed, "arm_table", arm, treatment, control, *sv)
        boot = cluster_bootstrap(d, np.mean, rng, n_boot)
        row = {**dict(zip(by, sv, strict=True)), arm: f"{treatment} vs {control}", "terrains": d.size, "missions": len(pair),
               "same_missions": float(same), "success_control_pct": 100 * per["c"].mean(),
               "success_treatment_pct": 100 * per["t"].mean(), "diff_pct": boot.estimate, "ci95_low": boot.low,
               "ci95_high": boot.high, "p_sign_flip": sign_flip_test(d, rng=rng)}
        if terrains is not None and "area_high" in terrains:
            for side, part in (("control", ta), ("treatment", tb)):
                row[f"area_high_{side}_pct"] = 100 * float(terrains[terrains["cell"].isin(part["cell"].unique())]
                                                          ["area_high"].mean())
        if terrains is not None and resolution in terrains:
            cells = tb["cell"].unique()
            res = terrains[terrains["cell"].isin(cells)].groupby("terrain")[resolution].mean().reindex(per.index)
            row[f"mean_{resolution}"] = float(res.mean())
            ok = res.notna().to_numpy()
            row[f"spearman_{resolution}_vs_diff"] = (float(spearmanr(res.to_numpy()[ok], d[ok]).statistic)
                                                     if ok.sum() > 2 and np.ptp(d[ok]) > 0 else math.nan)
        rows.append(row)
    out = pd.DataFrame(rows)
    if not out.empty:
        out["p_holm"] = holm(out["p_sign_flip"])
    return out
