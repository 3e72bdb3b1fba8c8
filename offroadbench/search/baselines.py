"""What the falsifier is measured against: streams of naive search, and the measured boundary that
stands in for trials where a trial's outcome is a function of one parameter.

**Trials to the k-th failure.** A search stream is judged by the trials it spends until its k-th
failure (:func:`trials_to_k`; with ``min_distance``, its k-th *distinct* failure under the study's
rule, offroadbench.search.estimators.distinct_failures). The falsifier's baseline is the naive
search a search expert would pick: uniform random draws on the falsifier's own search box (the
``uniform`` method; the primary baseline), and, beside it, draws from the nominal distribution
(the ``random`` method, whose job is estimating P(failure), not finding failures, so it favours
the falsifier wherever failures sit in the nominal's tail). Independent draws make any order of
a pool of them a stream (:func:`pool_streams`); streams from a *different* pool than the one
measured carry no information about each other, so a stream's spread is the spread of draws.

**The median and its interval.** Over S independent streams the median's distribution-free
interval is [X_(r), X_(S+1-r)], the order statistics with the largest r such that
P(r <= Bin(S, 1/2) <= S - r) >= level (:func:`median_interval`; Conover 1999, Sec. 3.2, the
confidence interval for a quantile; David & Nagaraja 2003, Sec. 7.1, for the coverage of
[X_(r), X_(s)]); a stream that never reached its k-th failure counts as +inf (the interval stays
valid: the order statistics are of the censored values too). The falsifier's gain over a baseline
is the ratio of the medians, with the interval of the ratio from the two medians' intervals (the
baseline's from its own streams); the two are independent, so the pair of intervals holds both
medians with probability at least the product of their levels (:func:`ratio_interval`).

**A measured boundary.** Where the trials show that failure is a function of one parameter u
outside a band (every trial with u below ``low``, the smallest u at which any trial passed,
failed; every trial above ``high``, the largest u at which any failed, passed), the outcome of a
fresh draw is known outside the band and random inside it. :class:`MeasuredBoundary` holds that
model: inside the band, the failure rate p(u) as the isotonic (non-increasing) fit to the band's
trials (the pool-adjacent-violators algorithm, Barlow et al. 1972, Ch. 1; Robertson, Wright &
Dykstra 1988, Ch. 1), since failure is more likely on slicker ground. Then

    P = F(low) + integral_low^high p(u) dF(u),

F the nominal CDF of u (:meth:`MeasuredBoundary.probability`), bracketed without any model of the
band by [F(low), F(high)] (:meth:`MeasuredBoundary.bracket`: the band all passing, or all
failing); the same with F the uniform CDF on the range gives the box's failure probability, and
:meth:`MeasuredBoundary.sample_outcomes` draws the outcomes of fresh points (Bernoulli(p(u))),
which stand in for trials in :func:`model_streams`. The model is as good as its two assumptions:
that no trial outside the band would have gone the other way (checked on every committed trial:
a later trial outside the band widens it), and that p(u) is the only dependence (the other
parameters inactive: offroadbench.search.modes.sensitivity).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import stats

from offroadbench.search.estimators import distinct_failure_indices
from offroadbench.search.space import SearchConfig, SearchParam

__all__ = ["trials_to_k", "median_interval", "ratio_interval", "pool_streams", "MeasuredBoundary",
           "measured_boundary", "isotonic_decreasing", "model_streams", "uniform_box", "nominal_draws"]


def trials_to_k(failed: np.ndarray, k: int, unit_x: np.ndarray | None = None,
                min_distance: float | None = None) -> float:
    """Trials a stream (in its order) spent until its k-th failure, or its k-th distinct failure
    when ``unit_x`` (parameters scaled to [0, 1]) and ``min_distance`` are given; inf if never."""
    f = np.asarray(failed, dtype=bool).ravel()
    if min_distance is None or k < 1:
        hit = np.nonzero(np.cumsum(f) >= k)[0]
        return float(hit[0] + 1) if len(hit) else math.inf
    # the distinct failures one by one, up to the k-th: the trials after it are not compared
    kth = next(itertools.islice(distinct_failure_indices(np.asarray(unit_x, dtype=float), f, float(min_distance)),
                                k - 1, None), None)
    return math.inf if kth is None else float(kth + 1)


def median_interval(values: np.ndarray, level: float = 0.95) -> tuple[float, float, float]:
    """(lower, upper, coverage) of the distribution-free interval for the median of S independent
    values: [X_(r), X_(S+1-r)] with the largest r whose coverage 1 - 2 P(Bin(S, 1/2) <= r - 1)
    is at least ``level`` (module docstring); with too few values for ``level`` the widest
    interval [min, max] and its coverage 1 - 2^(1-S)."""
    v = np.sort(np.asarray(values, dtype=float).ravel())
    s = len(v)
    if s == 0:
        return math.nan, math.nan, math.nan
    best = 1
    for r in range(1, s // 2 + 1):
        if 1 - 2 * stats.binom.cdf(r - 1, s, 0.5) >= level:
            best = r
    cover = 1 - 2 * stats.binom.cdf(best - 1, s, 0.5)
    return float(v[best - 1]), float(v[s - best]), float(cover)


def ratio_interval(baseline: np.ndarray, search: np.ndarray, level: float = 0.95) -> tuple[float, float, float, float]:
    """(ratio of medians baseline / search, lower, upper, joint coverage): the ends from the two
    medians' distribution-free intervals (:func:`median_interval`), lower = baseline's lower over
    the search's upper; both hold their medians with probability >= the product of their
    coverages (independent streams), and then the ratio lies between the ends."""
    b_lo, b_hi, b_cov = median_interval(baseline, level)
    s_lo, s_hi, s_cov = median_interval(search, level)
    ratio = float(np.median(baseline) / np.median(search))
    return ratio, b_lo / s_hi, b_hi / s_lo, b_cov * s_cov


def pool_streams(failed: np.ndarray, k: int, n_streams: int, rng: np.random.Generator, unit_x: np.ndarray | None = None,
                 min_distance: float | None = None) -> np.ndarray:
    """Trials to the k-th (distinct) failure of ``n_streams`` random orders of a pool of independent
    draws (each order is a stream of real trials; the orders share the pool, so their spread is
    the spread of one stream, not an interval for the median). A stream that does not reach k
    within the pool counts as inf."""
    f = np.asarray(failed, dtype=bool)
    out = np.empty(n_streams)
    for i in range(n_streams):
        order = rng.permutation(len(f))
        out[i] = trials_to_k(f[order], k, None if unit_x is None else np.asarray(unit_x)[order], min_distance)
    return out


def isotonic_decreasing(u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The non-increasing least-squares fit of y (0/1) on u (pool-adjacent-violators; module
    docstring): (sorted u, fitted p at each)."""
    order = np.argsort(u, kind="stable")
    us, ys = np.asarray(u, dtype=float)[order], np.asarray(y, dtype=float)[order]
    blocks: list[list[float]] = []  # [sum, count]
    for v in ys:
        blocks.append([v, 1.0])
        while len(blocks) > 1 and blocks[-2][0] / blocks[-2][1] < blocks[-1][0] / blocks[-1][1]:
            s, c = blocks.pop()
            blocks[-1][0] += s
            blocks[-1][1] += c
    fit = np.concatenate([np.full(int(c), s / c) for s, c in blocks]) if blocks else np.zeros(0)
    return us, fit


@dataclass(frozen=True)
class MeasuredBoundary:
    """Failure as a function of one parameter: certain below ``low``, never above ``high``, the
    isotonic failure rate in between (module docstring), in v = ``sign`` u: where failure lies at
    high values of the parameter (``sign`` -1) the boundary is held in -u, so that failure is
    below it there too."""

    index: int
    """Which searched parameter (its index in the search config)."""
    low: float
    """The smallest value of v at which a trial passed."""
    high: float
    """The largest value of v at which a trial failed."""
    band_u: np.ndarray
    """The band's trials' values of v, sorted."""
    band_p: np.ndarray
    """The isotonic failure rate at each of them."""
    band_failed: int
    band_trials: int
    trials: int
    """Trials the boundary was measured on."""
    sign: int = 1
    """1: failure at low values of the parameter; -1: at high values (v = -u)."""

    def edges(self) -> tuple[float, float]:
        """The band's ends in the parameter's own values, in increasing order."""
        return (self.low, self.high) if self.sign > 0 else (-self.high, -self.low)

    def describe(self) -> str:
        """The boundary in words, in the parameter's own values."""
        if self.sign > 0:
            return f"every trial below {self.low:.4g} failed, every one above {self.high:.4g} passed"
        return f"every trial above {-self.low:.4g} failed, every one below {-self.high:.4g} passed"

    def _cdf(self, cdf: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
        """The CDF of v from the parameter's CDF (continuous: P(-u <= v) = 1 - F(-v))."""
        return cdf if self.sign > 0 else (lambda v: 1.0 - cdf(-np.asarray(v, dtype=float)))

    def certain_mass(self, param: SearchParam) -> float:
        """The nominal mass where failure is certain (beyond the band on the failing side)."""
        return float(self._cdf(param.cdf)(np.array([self.low]))[0])

    def certain(self, u: np.ndarray) -> np.ndarray:
        """Whether each value lies where every trial failed (below the band in v)."""
        return self.sign * np.asarray(u, dtype=float) < self.low

    def failure_rate(self, u: np.ndarray) -> np.ndarray:
        """p(u): 1 below ``low``, 0 above ``high`` (in v), the isotonic step function in between
        (its value at the nearest band trial at or below v; at ``low`` itself the first one's)."""
        u = self.sign * np.asarray(u, dtype=float)
        idx = np.clip(np.searchsorted(self.band_u, u, side="right") - 1, 0, len(self.band_u) - 1)
        inside = self.band_p[idx] if len(self.band_u) else np.zeros_like(u)
        return np.where(u < self.low, 1.0, np.where(u > self.high, 0.0, inside))

    def _integral(self, cdf: Callable[[np.ndarray], np.ndarray]) -> float:
        if not len(self.band_u):
            return float(cdf(np.array([self.low]))[0])
        edges = np.concatenate([[self.low], self.band_u[1:], [self.high]])
        f = cdf(edges)
        return float(cdf(np.array([self.low]))[0] + np.sum(self.band_p * np.diff(f)))

    def probability(self, param: SearchParam) -> float:
        """P(failure) under ``param``'s nominal distribution: F(low) + integral of p dF over the band."""
        return self._integral(self._cdf(param.cdf))

    def box_probability(self, param: SearchParam) -> float:
        """P(failure) of a uniform draw on ``param``'s range."""
        return self._integral(self._cdf(lambda x: np.clip((np.asarray(x) - param.low) / (param.high - param.low), 0, 1)))

    def bracket(self, param: SearchParam) -> tuple[float, float]:
        """[F(low), F(high)]: P(failure) whatever the band does (nominal F, in v)."""
        lo, hi = self._cdf(param.cdf)(np.array([self.low, self.high]))
        return float(lo), float(hi)

    def sample_outcomes(self, u: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Failed or not for fresh draws at ``u``: Bernoulli(p(u))."""
        u = np.asarray(u, dtype=float)
        return rng.random(u.shape) < self.failure_rate(u)


def measured_boundary(u: np.ndarray, failed: np.ndarray, index: int = 0) -> MeasuredBoundary:
    """The boundary of failure in one parameter's values ``u`` of finished trials (module
    docstring); failure lies at low values when the failing trials' median is below the passing
    ones' (else at high values: ``sign`` -1). A ValueError when nothing failed or nothing passed."""
    u = np.asarray(u, dtype=float).ravel()
    f = np.asarray(failed, dtype=bool).ravel()
    if not f.any() or f.all():
        raise ValueError("a boundary needs failing and passing trials")
    sign = 1 if np.median(u[f]) <= np.median(u[~f]) else -1
    v = sign * u
    low, high = float(v[~f].min()), float(v[f].max())
    if high < low:  # a clean cut: no band
        return MeasuredBoundary(index, high, high, np.zeros(0), np.zeros(0), 0, 0, len(u), sign)
    band = (v >= low) & (v <= high)
    us, fit = isotonic_decreasing(v[band], f[band])
    return MeasuredBoundary(index, low, high, us, fit, int(f[band].sum()), int(band.sum()), len(u), sign)


def uniform_box(cfg: SearchConfig) -> Callable[[int, np.random.Generator], np.ndarray]:
    """A sampler of n uniform draws on the search box (parameter values, (n, d))."""
    lo = np.array([p.low for p in cfg.params])
    hi = np.array([p.high for p in cfg.params])
    return lambda n, rng: lo + rng.random((n, cfg.dim)) * (hi - lo)


def nominal_draws(cfg: SearchConfig) -> Callable[[int, np.random.Generator], np.ndarray]:
    """A sampler of n nominal draws (parameter values, (n, d))."""
    return lambda n, rng: cfg.from_z(rng.standard_normal((n, cfg.dim)))


def model_streams(cfg: SearchConfig, boundary: MeasuredBoundary, sampler: Callable[[int, np.random.Generator], np.ndarray],
                  k: int, n_streams: int, rng: np.random.Generator, distinct: bool = False,
                  max_trials: int = 100_000) -> np.ndarray:
    """Trials to the k-th (distinct, the study's rule, when ``distinct``) failure of ``n_streams``
    streams of ``sampler``'s draws whose outcomes are the boundary's (:meth:`MeasuredBoundary.
    sample_outcomes`): streams of the naive search computed, not run. inf past ``max_trials``."""
    out = np.empty(n_streams)
    for i in range(n_streams):
        xs: list[np.ndarray] = []
        fs: list[np.ndarray] = []
        n, t = 0, math.inf
        while n < max_trials:  # the same stream, drawn on in chunks until it reaches k
            chunk = min(max(64, n), max_trials - n)
            xs.append(sampler(chunk, rng))
            fs.append(boundary.sample_outcomes(xs[-1][:, boundary.index], rng))
            n += chunk
            x, failed = np.vstack(xs), np.concatenate(fs)
            t = trials_to_k(failed, k, cfg.unit(x) if distinct else None, cfg.distinct_distance if distinct else None)
            if math.isfinite(t):
                break
        out[i] = t
    return out
