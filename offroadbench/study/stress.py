"""Statistics of a planner stress test: success against a difficulty axis per planner, the
breaking point, and paired comparisons on the same missions.

* **Success with its interval.** The Wilson score interval (Wilson 1927) of a binomial proportion,
  ``(p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)``: it stays inside [0, 1] and keeps its
  coverage for small n and for p near 0 or 1, where the normal (Wald) interval fails.
* **Breaking point.** The value of the difficulty axis (e.g. ``D_high``) at which a planner's
  success rate first falls below 50 %, by linear interpolation between the two neighbouring axis
  values. Its 95 % interval is a percentile bootstrap over terrains: terrain j is resampled as a
  whole, with the same draw at every axis value (the study's terrains are paired, so terrain j of
  every cell shares its seed). A resample that never falls below 50 % has no breaking point inside
  the studied range; the interval's end is then reported as ``> max``.
* **Paired comparisons.** Every planner drove the same missions (same terrain seed and mission
  seed), so two planners are compared on the pairs where exactly one of them succeeded: with n10
  missions that only A completed and n01 that only B completed, the exact McNemar test is the
  two-sided binomial test of n10 against n10 + n01 trials at p = 1/2 (McNemar 1947; the exact form
  is the sign test on the discordant pairs).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pandas as pd

__all__ = ["wilson_interval", "breaking_point", "bootstrap_breaking_point", "mcnemar_exact", "success_by_level",
           "paired_table", "breaking_points"]

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


def breaking_point(levels: Sequence[float], rates: Sequence[float], threshold: float = 0.5) -> float:
    """First level at which ``rates`` falls below ``threshold``, linearly interpolated; ``-inf`` if
    the first level is already below it, ``+inf`` if no level is."""
    x = np.asarray(levels, dtype=float)
    y = np.asarray(rates, dtype=float)
    if len(y) == 0:
        return math.nan
    if y[0] < threshold:
        return -math.inf
    for i in range(1, len(y)):
        if y[i] < threshold:
            return float(x[i - 1] + (y[i - 1] - threshold) / (y[i - 1] - y[i]) * (x[i] - x[i - 1]))
    return math.inf


def bootstrap_breaking_point(success: np.ndarray, levels: Sequence[float], rng: np.random.Generator,
                             n_boot: int = 2000, threshold: float = 0.5) -> tuple[float, float]:
    """95 % percentile interval of the breaking point, resampling terrains.

    ``success[t, l, m]``: outcome (0/1, NaN = missing) of mission m on terrain t at level l.
    Infinite breaking points (never / always below the threshold) sort to the ends.
    """
    s = np.asarray(success, dtype=float)
    n_t = s.shape[0]
    draws = rng.integers(0, n_t, size=(n_boot, n_t))
    points = np.empty(n_boot)
    for b in range(n_boot):
        sample = s[draws[b]]
        rates = np.nanmean(sample.reshape(n_t, len(levels), -1).transpose(1, 0, 2).reshape(len(levels), -1), axis=1)
        points[b] = breaking_point(levels, rates, threshold)
    lo, hi = np.percentile(points, [2.5, 97.5], method="inverted_cdf")
    return float(lo), float(hi)


def mcnemar_exact(n10: int, n01: int) -> float:
    """Two-sided exact McNemar p-value of n10 against n01 discordant pairs (1.0 with none)."""
    from scipy.stats import binomtest

    n = n10 + n01
    if n == 0:
        return 1.0
    return float(binomtest(n10, n, 0.5, alternative="two-sided").pvalue)


def success_by_level(trials: pd.DataFrame, group: str, level: str) -> pd.DataFrame:
    """Per group (planner) and level (D): trials, successes, rate and its Wilson interval."""
    rows = []
    for (g, x), t in trials.groupby([group, level], sort=True):
        n, k = len(t), int(t["success"].astype(bool).sum())
        lo, hi = wilson_interval(k, n)
        rows.append({group: g, level: x, "trials": n, "successes": k, "success_rate": k / n,
                     "ci95_low": lo, "ci95_high": hi})
    return pd.DataFrame(rows)


def breaking_points(trials: pd.DataFrame, group: str, level: str, seed: int = 0, n_boot: int = 2000) -> pd.DataFrame:
    """Breaking point and bootstrap interval per group (see the module docstring)."""
    rng = np.random.default_rng(seed)
    levels = sorted(trials[level].unique())
    rows = []
    for g, t in trials.groupby(group, sort=True):
        by = success_by_level(t, group, level)
        point = breaking_point(by[level], by["success_rate"])
        terrains = sorted(t["terrain"].unique())
        missions = sorted(t["mission"].unique())
        cube = np.full((len(terrains), len(levels), len(missions)), np.nan)
        ti = {v: i for i, v in enumerate(terrains)}
        li = {v: i for i, v in enumerate(levels)}
        mi = {v: i for i, v in enumerate(missions)}
        for r in t.itertuples(index=False):
            cube[ti[r.terrain], li[getattr(r, level)], mi[r.mission]] = float(bool(r.success))
        lo, hi = bootstrap_breaking_point(cube, levels, rng, n_boot)
        rows.append({group: g, "breaking_point": point, "ci95_low": lo, "ci95_high": hi,
                     "levels": f"{min(levels):g}-{max(levels):g}"})
    return pd.DataFrame(rows)


def paired_table(trials: pd.DataFrame, group: str, level: str | None, baseline: str) -> pd.DataFrame:
    """Each group against ``baseline`` on the same (terrain, mission) at each level and pooled:
    both / only this / only baseline / neither succeeded, and the exact McNemar p-value."""
    key = ["terrain", "mission"] + ([level] if level else [])
    base = trials[trials[group] == baseline].set_index(key)["success"].astype(bool)
    rows = []
    for g in sorted(trials[group].unique()):
        if g == baseline:
            continue
        other = trials[trials[group] == g].set_index(key)["success"].astype(bool)
        both = other.to_frame("a").join(base.to_frame("b"), how="inner")
        parts = list(both.groupby(level, sort=True)) if level else []
        parts.append(("all", both))
        for x, p in parts:
            n10 = int((p["a"] & ~p["b"]).sum())
            n01 = int((~p["a"] & p["b"]).sum())
            rows.append({group: g, "versus": baseline, level or "level": x, "pairs": len(p),
                         "both": int((p["a"] & p["b"]).sum()), "only this": n10, "only baseline": n01,
                         "neither": int((~p["a"] & ~p["b"]).sum()),
                         "success_diff_pct": 100.0 * (p["a"].mean() - p["b"].mean()),
                         "mcnemar_p": mcnemar_exact(n10, n01)})
    return pd.DataFrame(rows)
