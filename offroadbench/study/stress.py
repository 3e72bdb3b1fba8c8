"""Statistics of a planner stress test: success against a difficulty axis per planner, the
breaking point, and paired comparisons on the same missions, with the terrain as the unit.

* **Success with its interval.** The Wilson score interval (Wilson 1927) of a binomial proportion,
  ``(p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)``: it stays inside [0, 1] and keeps its
  coverage for small n and for p near 0 or 1, where the normal (Wald) interval fails. It treats the
  missions as independent, so it is a lower bound on the uncertainty (the terrain-level tests below
  are what claims rest on).
* **Breaking point.** The value of the difficulty axis (e.g. ``D_high``) at which a planner's fitted
  success probability is 50 %: a logistic regression of trial success on the axis value, with a
  covariance robust to the missions of one terrain being correlated (clustered by terrain index;
  terrain j of every cell shares its seed when the study pairs terrains), and Fieller's interval
  (offroadbench.study.clustered). An end of the interval may be unbounded (the data do not locate
  the crossing); a fitted crossing outside the studied range is an extrapolation and the report
  says so. The first studied level with under 50 % success is listed beside it, without
  interpolation.
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
    "breaking_points",
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
    for x, y in zip(levels, rates):
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


def success_by_level(trials: pd.DataFrame, group: str, level: str, by: Sequence[str] = ()) -> pd.DataFrame:
    """Per group (planner), stratum (the other grid axes ``by``) and level (D): trials, successes,
    rate and its Wilson interval."""
    keys = [group, *by, level]
    rows = []
    for vals, t in trials.groupby(keys, sort=True):
        n, k = len(t), int(t["success"].astype(bool).sum())
        lo, hi = wilson_interval(k, n)
        rows.append({**dict(zip(keys, vals)), "trials": n, "successes": k, "success_rate": k / n,
                     "ci95_low": lo, "ci95_high": hi})
    return pd.DataFrame(rows)


def breaking_points(trials: pd.DataFrame, group: str, level: str, threshold: float = 0.5,
                    by: Sequence[str] = ()) -> pd.DataFrame:
    """Logistic breaking point per group (and stratum ``by``) with its Fieller interval (see the
    module docstring).

    Columns: the group, ``breaking_point`` (NaN when the fit does not exist: success or failure is
    separated by the level, or the fitted success does not fall with the level), ``ci95_low``, ``ci95_high``, ``slope`` (per unit of the level),
    ``extrapolated`` (the point lies outside the studied levels), ``terrains`` (clusters),
    ``first_level_below`` (observed), ``levels``.
    """
    from offroadbench.study.clustered import breaking_point_logistic, fit_logistic

    levels = sorted(trials[level].unique())
    keys = [group, *by]
    rows = []
    for vals, t in trials.groupby(keys, sort=True):
        rates = t.groupby(level, sort=True)["success"].mean()
        fit = fit_logistic(t[level].to_numpy(float), t["success"].astype(float).to_numpy(), t["terrain"].to_numpy())
        point, lo, hi = breaking_point_logistic(fit, threshold)
        if not fit.slope < 0:  # success does not fall as the level rises: no level at which it crosses down
            point, lo, hi = math.nan, math.nan, math.nan
        rows.append({**dict(zip(keys, vals if isinstance(vals, tuple) else (vals,))), "breaking_point": point,
                     "ci95_low": lo, "ci95_high": hi, "slope": fit.slope,
                     "extrapolated": bool(math.isfinite(point) and not (min(levels) <= point <= max(levels))),
                     "terrains": fit.clusters,
                     "first_level_below": first_level_below(rates.index, rates.to_numpy(float), threshold),
                     "levels": f"{min(levels):g}-{max(levels):g}"})
    return pd.DataFrame(rows)


def _terrain_row(p: pd.DataFrame, rng: np.random.Generator, n_boot: int) -> dict:
    """Terrain-level statistics of one comparison; ``p`` has columns terrain, a, b (booleans)."""
    from offroadbench.study.clustered import (
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
    pooled over its levels.
    """
    rng = np.random.default_rng(seed)
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
            rows.append({group: g, "versus": baseline, **dict(zip(by, sv)), level or "level": x, "pairs": len(p),
                         "both": int((p["a"] & p["b"]).sum()), "only this": n10, "only baseline": n01,
                         "neither": int((~p["a"] & ~p["b"]).sum()),
                         "success_diff_pct": 100.0 * (p["a"].mean() - p["b"].mean()),
                         "mcnemar_p_missions": mcnemar_exact(n10, n01), **_terrain_row(p, rng, n_boot)})
    out = pd.DataFrame(rows)
    if not out.empty:
        from offroadbench.study.clustered import holm

        out["p_holm"] = holm(out["p_sign_flip"])
        out["significant"] = out["p_holm"] < 0.05
    return out
