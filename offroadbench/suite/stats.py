"""The score card's statistics: pure functions of arrays, no files.

* **Task score** (the BARN challenge's metric: Perille et al. 2020, "Benchmarking Metric Ground
  Navigation", and Xiao et al. 2022, "Autonomous Ground Navigation in Highly Constrained Spaces:
  Lessons learned from the BARN Challenge at ICRA 2022"): ``success x nominal / clip(actual,
  low x nominal, high x nominal)``, in [0, 1 / low]; a failed task scores 0.
* **Aggregate** (Agarwal et al. 2021, "Deep Reinforcement Learning at the Edge of the Statistical
  Precipice", the method of rliable): the interquartile mean (IQM, the mean of the middle 50 %) of
  per-terrain scores, with a stratified bootstrap interval (terrains resampled within each
  category: ``scipy.stats.bootstrap`` with one sample per stratum) and the performance profile
  (the fraction of terrains scoring above tau, for tau in [0, 1]).
* **Terrain-level intervals**: a terrain's missions are not independent, so every interval
  resamples terrains (percentile bootstrap of the mean of per-terrain values).
* **Paired comparison**: per-terrain differences on the same tasks, their mean with a stratified
  bootstrap interval and the exact sign-flip test (``scipy.stats.permutation_test``).
"""

from __future__ import annotations

import inspect
import math
from typing import Callable, Sequence

import numpy as np
from scipy import stats as _st

__all__ = [
    "CONFIDENCE",
    "N_RESAMPLES",
    "barn_score",
    "iqm",
    "mean_interval",
    "performance_profile",
    "sign_flip_p",
    "stratified_interval",
]

#: bootstrap resamples of every interval (and permutations of the sign-flip test, where not exact)
N_RESAMPLES = 4000
#: two-sided confidence level of every interval
CONFIDENCE = 0.95


def barn_score(success: bool, actual_s: float, nominal_s: float, low: float = 1.0, high: float = 3.0) -> float:
    """One task's score: ``success x nominal_s / clip(actual_s, low x nominal_s, high x nominal_s)``.

    ``nominal_s``: the task's nominal time, s (its start-goal distance over the cruise speed; BARN's
    "optimal time"); ``actual_s``: the traversal time, s; ``low``/``high``: the clip, in nominal
    times (BARN: 2 and 8 for their optimistic optimal time; here 1 and the timeout factor 3). A
    failure, or a task without a finite time, scores 0."""
    if not success or not (math.isfinite(actual_s) and math.isfinite(nominal_s)) or nominal_s <= 0:
        return 0.0
    return nominal_s / min(max(actual_s, low * nominal_s), high * nominal_s)


def iqm(values: Sequence[float], axis: int | None = None):
    """Interquartile mean: the mean of the middle 50 % (``scipy.stats.trim_mean(x, 0.25)``); with
    ``axis``, an array of them along that axis (what a vectorized bootstrap calls)."""
    x = np.asarray(values, dtype=float)
    if axis is not None:
        return _st.trim_mean(x, 0.25, axis=axis)
    return float(_st.trim_mean(x, 0.25)) if x.size else math.nan


def _takes_axis(fn: Callable) -> bool:
    try:
        return "axis" in inspect.signature(fn).parameters
    except (TypeError, ValueError):  # a builtin without a signature
        return False


def _rng_kw(fn: Callable, rng: np.random.Generator) -> dict:
    """scipy >= 1.15 takes ``rng``; older releases ``random_state``."""
    name = "rng" if "rng" in inspect.signature(fn).parameters else "random_state"
    return {name: rng}


def stratified_interval(strata: Sequence[Sequence[float]], statistic: Callable[[np.ndarray], float],
                        seed: int = 0, n_resamples: int = N_RESAMPLES,
                        confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Percentile bootstrap interval of ``statistic`` over the values of all strata pooled, each
    stratum resampled on its own (a stratum of one value is kept as it is). (nan, nan) if no stratum
    has two values. A ``statistic`` that takes ``axis`` (``np.mean``, :func:`iqm`) gets every
    resample at once, one per row (the same resamples and numbers as one call per resample)."""
    arrays = [np.asarray(s, dtype=float) for s in strata if len(s)]
    varied = tuple(a for a in arrays if a.size >= 2)
    fixed = [a for a in arrays if a.size < 2]
    if not varied:
        return math.nan, math.nan
    vectorized = _takes_axis(statistic)

    def pooled(*samples: np.ndarray, axis: int = -1) -> float:
        if not vectorized:
            return statistic(np.concatenate([*samples, *fixed]))
        rows = samples[0].shape[:-1]  # the resamples' shape; each fixed value repeated on every row
        return statistic(np.concatenate([*samples, *(np.broadcast_to(f, rows + f.shape) for f in fixed)], axis=-1),
                         axis=-1)

    res = _st.bootstrap(varied, pooled, vectorized=vectorized, paired=False, method="percentile",
                        n_resamples=n_resamples, confidence_level=confidence, **_rng_kw(_st.bootstrap, np.random.default_rng(seed)))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def mean_interval(values: Sequence[float], seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of per-terrain values (NaNs dropped); (nan, nan)
    under two values."""
    x = np.asarray(values, dtype=float)
    return stratified_interval([x[np.isfinite(x)]], np.mean, seed=seed)


def performance_profile(scores: Sequence[float], taus: Sequence[float]) -> list[float]:
    """Fraction of terrains whose score exceeds each tau (Agarwal et al. 2021, Sec. 4.1)."""
    x = np.asarray(scores, dtype=float)
    return [float(np.mean(x > t)) if x.size else math.nan for t in taus]


def sign_flip_p(differences: Sequence[float], seed: int = 0) -> float:
    """Two-sided p of the sign-flip test of mean difference 0 over per-terrain differences (exact
    when 2^n is within :data:`N_RESAMPLES`); 1.0 when every difference is 0, nan when empty."""
    d = np.asarray(differences, dtype=float)
    if d.size == 0:
        return math.nan
    if not np.any(d):
        return 1.0
    res = _st.permutation_test((d,), lambda x, axis: np.mean(x, axis=axis), permutation_type="samples",
                               n_resamples=N_RESAMPLES, alternative="two-sided",
                               **_rng_kw(_st.permutation_test, np.random.default_rng(seed)))
    return float(min(1.0, res.pvalue))
