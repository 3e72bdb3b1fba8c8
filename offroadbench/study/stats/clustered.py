"""Statistics with the terrain as the unit of analysis.

The missions of one terrain are not independent: they share its bumps, and a planner that fails on
one terrain tends to fail on its other missions. A study with K terrains per level therefore has K
independent units, not K x missions. Everything here works on per-terrain (per-cluster) numbers:

* **Paired per-terrain differences.** When terrain j is paired between two conditions (two planners
  on the same missions, or two levels of a study with ``paired_terrains``), the unit is the
  per-terrain difference d_j. :func:`sign_flip_test` is the exact randomisation test of
  H0: d_j symmetric about 0 (Fisher 1935; every one of the 2^K sign patterns is equally likely
  under H0), with the mean as statistic, from ``scipy.stats.permutation_test``;
  :func:`wilcoxon_test` is the Wilcoxon (1945) signed-rank test from ``scipy.stats.wilcoxon``. With
  K terrains the smallest two-sided p of either is 2 / 2^K (0.031 for K = 6).
* **Cluster-adjusted McNemar.** For missions paired within terrains, with b_k missions of terrain k
  that only A completed, c_k that only B completed and n_k missions, Durkalski et al. (2003)
  replace McNemar's (b - c)^2 / (b + c) by the statistic

      X^2 = (sum_k (b_k - c_k) / n_k)^2 / sum_k ((b_k - c_k) / n_k)^2,

  referred to chi-square with 1 df (:func:`durkalski_mcnemar`). With one pair per cluster it is
  McNemar's statistic. Obuchowski's (1998) test, in the form Yang et al. (2010) give for it,
  is (K - 1) / K (sum_k (b_k - c_k))^2 / sum_k (b_k - c_k)^2 (:func:`obuchowski_mcnemar`). In Yang
  et al.'s simulations Obuchowski's test is the most conservative and Durkalski's suits few
  clusters (K < 50); the reports use Durkalski's beside the exact per-terrain tests, which are
  the primary ones (they need no large-K approximation).
* **Cluster bootstrap.** :func:`cluster_bootstrap` resamples whole terrains (Davison & Hinkley 1997,
  Sec. 3.8) and says how many distinct resamples it drew: K terrains allow only
  C(2K - 1, K) of them (462 for K = 6), so 2000 draws of 6 terrains are not 2000 samples.
* **Multiple comparisons.** :func:`holm` is Holm's (1979) step-down adjustment, which controls the
  family-wise error rate under any dependence between the tests.
* **Designs with power.** :func:`paired_power` is the power of the two-sided paired t-test of K
  per-terrain differences with standardised effect d_z = mean / sd (the noncentral t, Cohen 1988,
  Ch. 2); the sign-flip test on the mean has the same asymptotic efficiency, the Wilcoxon test
  0.955 of it for normal differences (Hodges & Lehmann 1956). :func:`terrains_needed` is the
  smallest K that reaches a power at a (Holm/Bonferroni-adjusted) alpha.
* **Breaking points from a fitted model.** :func:`fit_logistic` fits success ~ logistic(a + b x) to
  trial outcomes by iteratively reweighted least squares, with a cluster-robust (sandwich)
  covariance (Liang & Zeger 1986; the CR1 small-sample factor G / (G - 1) (N - 1) / (N - 2) as in
  Cameron & Miller 2015) that lets the missions of one terrain be correlated.
  :func:`breaking_point_logistic` is the x where the fitted success crosses a threshold,
  x50 = (logit(p) - a) / b, with Fieller's (1954) interval, which can be one-sided or unbounded when
  the slope is not clearly non-zero (then the data do not locate the breaking point, and the
  interval says so instead of inventing an end).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Z95",
    "keyed_rng",
    "sign_flip_power",
    "fieller_set",
    "isotonic_decreasing",
    "logistic_fit_check",
    "BootstrapInterval",
    "LogisticFit",
    "breaking_point_logistic",
    "cluster_bootstrap",
    "durkalski_mcnemar",
    "fit_logistic",
    "holm",
    "obuchowski_mcnemar",
    "paired_power",
    "sign_flip_test",
    "terrains_needed",
    "wilcoxon_test",
]

#: the two-sided 95 % normal quantile
Z95 = 1.959963984540054
#: largest K for which :func:`sign_flip_test` enumerates all 2^K sign patterns
EXACT_MAX_CLUSTERS = 20


def keyed_rng(seed: int, *key: object) -> np.random.Generator:
    """A generator of its own for one cell (or one row) of a table: seeded by ``seed`` and the cell's
    key (its grid values, its planner, its level, ...), so a cell's bootstrap draws are the same
    whatever the other cells are and in whatever order they are computed (one stream drawn in cell
    order would change every later cell's interval when a cell is added or removed). The key is
    hashed with SHA-256 of its ``repr`` (numbers normalised: 2.0 and 2 are one key) into the
    entropy of a ``SeedSequence`` beside ``seed``."""
    import hashlib

    def norm(v: object) -> object:
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        if isinstance(v, (int, float, np.integer, np.floating)):
            f = float(v)
            return int(f) if f.is_integer() else f
        if isinstance(v, (tuple, list)):
            return tuple(norm(x) for x in v)
        return str(v)

    digest = hashlib.sha256(repr(tuple(norm(k) for k in key)).encode()).digest()
    words = [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 16, 4)]
    return np.random.default_rng(np.random.SeedSequence([int(seed), *words]))


def _clean(d: Sequence[float]) -> np.ndarray:
    x = np.asarray(d, dtype=float)
    return x[np.isfinite(x)]


def sign_flip_test(d: Sequence[float], *, rng: np.random.Generator | None = None, n_resamples: int = 99_999) -> float:
    """Two-sided p of the sign-flip (paired randomisation) test of mean(d) = 0.

    Exact for K <= 20 clusters: the sums of all 2^K sign patterns are built one difference at a
    time and p = P(|sum| >= |observed sum|) (the null is symmetric, so this is twice the smaller
    one-sided p). Beyond that a Monte Carlo test (``scipy.stats.permutation_test``) with
    ``n_resamples`` draws from ``rng``. NaNs are dropped; no non-zero difference gives p = 1.
    """
    x = _clean(d)
    if x.size == 0 or not np.any(x != 0):
        return 1.0
    if x.size <= EXACT_MAX_CLUSTERS:
        sums = np.zeros(2 ** x.size)  # filled in place: after k differences, the first 2^k
        n = 1
        for v in x:  # [s + v for s in sums] then [s - v for s in sums], as a concatenation would give
            np.subtract(sums[:n], v, out=sums[n:2 * n])
            np.add(sums[:n], v, out=sums[:n])
            n *= 2
        obs = abs(float(x.sum()))
        return float(np.mean(np.abs(sums) >= obs * (1 - 1e-12) - 1e-300))
    from scipy.stats import permutation_test

    res = permutation_test((x,), lambda v, axis: np.mean(v, axis=axis), permutation_type="samples", vectorized=True,
                           n_resamples=n_resamples, alternative="two-sided",
                           rng=np.random.default_rng(0) if rng is None else rng)
    return float(min(1.0, res.pvalue))


def wilcoxon_test(d: Sequence[float]) -> float:
    """Two-sided p of the Wilcoxon signed-rank test of the differences ``d`` (``scipy.stats.wilcoxon``,
    zero differences dropped as in Wilcoxon 1945; exact for small samples without ties). No
    non-zero difference gives p = 1."""
    from scipy.stats import wilcoxon

    x = _clean(d)
    if not np.any(x != 0):
        return 1.0
    return float(wilcoxon(x, zero_method="wilcox", alternative="two-sided").pvalue)


def durkalski_mcnemar(b: Sequence[float], c: Sequence[float], n: Sequence[float] | None = None) -> tuple[float, float]:
    """Durkalski et al. (2003) cluster-adjusted McNemar statistic and its chi-square(1) p.

    ``b[k]``, ``c[k]``: discordant pairs of cluster k (only A / only B succeeded); ``n[k]``: pairs in
    cluster k (default 1 each, which gives sum(b - c)^2 / sum((b - c)^2)). No discordant pair: (0, 1).
    """
    from scipy.stats import chi2

    b, c = np.asarray(b, dtype=float), np.asarray(c, dtype=float)
    n = np.ones_like(b) if n is None else np.asarray(n, dtype=float)
    w = (b - c) / n
    den = float(np.sum(w * w))
    if den == 0.0:
        return 0.0, 1.0
    stat = float(np.sum(w)) ** 2 / den
    return stat, float(chi2.sf(stat, 1))


def obuchowski_mcnemar(b: Sequence[float], c: Sequence[float]) -> tuple[float, float]:
    """Obuchowski's (1998) clustered-proportions statistic in Yang et al.'s (2010) form,
    (K - 1) / K (sum (b_k - c_k))^2 / sum (b_k - c_k)^2, and its chi-square(1) p."""
    from scipy.stats import chi2

    b, c = np.asarray(b, dtype=float), np.asarray(c, dtype=float)
    k = b.size
    den = float(np.sum((b - c) ** 2))
    if den == 0.0 or k < 2:
        return 0.0, 1.0
    stat = (k - 1) / k * float(np.sum(b - c)) ** 2 / den
    return stat, float(chi2.sf(stat, 1))


@dataclass(frozen=True)
class BootstrapInterval:
    """A percentile interval from a cluster bootstrap, with what it was made of."""

    estimate: float
    low: float
    high: float
    #: resamples drawn
    n_boot: int
    #: distinct multisets of clusters among them
    distinct: int
    #: distinct multisets that exist, C(2K - 1, K)
    possible: int
    #: clusters
    clusters: int


def cluster_bootstrap(values: np.ndarray, statistic: Callable[[np.ndarray], float], rng: np.random.Generator,
                      n_boot: int = 2000, level: float = 0.95) -> BootstrapInterval:
    """Percentile bootstrap interval of ``statistic`` over clusters.

    ``values``: one row (or one value) per cluster; each resample draws K rows with replacement and
    applies ``statistic`` to them. NaN statistics of a resample are left out of the percentiles.
    """
    v = np.asarray(values, dtype=float)
    k = v.shape[0]
    est = float(statistic(v)) if k else math.nan
    if k == 0:
        return BootstrapInterval(estimate=est, low=math.nan, high=math.nan, n_boot=0, distinct=0, possible=0, clusters=0)
    draws = rng.integers(0, k, size=(n_boot, k))
    stats = np.array([statistic(v[i]) for i in draws], dtype=float)
    distinct = int(np.unique(np.sort(draws, axis=1), axis=0).shape[0])
    finite = stats[~np.isnan(stats)]
    a = (1.0 - level) / 2.0
    lo, hi = (np.percentile(finite, [100 * a, 100 * (1 - a)], method="inverted_cdf") if finite.size
              else (math.nan, math.nan))
    return BootstrapInterval(estimate=est, low=float(lo), high=float(hi), n_boot=n_boot, distinct=distinct,
                             possible=math.comb(2 * k - 1, k), clusters=k)


def holm(pvalues: Sequence[float]) -> np.ndarray:
    """Holm's (1979) step-down adjusted p-values (NaNs stay NaN and do not count as tests)."""
    p = np.asarray(pvalues, dtype=float)
    out = np.full(p.shape, np.nan)
    ok = np.flatnonzero(~np.isnan(p))
    m = ok.size
    if m == 0:
        return out
    order = ok[np.argsort(p[ok], kind="stable")]
    adj = np.maximum.accumulate((m - np.arange(m)) * p[order])
    out[order] = np.minimum(1.0, adj)
    return out


@dataclass(frozen=True)
class LogisticFit:
    """success ~ 1 / (1 + exp(-(intercept + slope x))) with a cluster-robust covariance."""

    intercept: float
    slope: float
    #: 2 x 2 cluster-robust covariance of (intercept, slope)
    cov: np.ndarray
    n: int
    clusters: int
    converged: bool


def fit_logistic(x: Sequence[float], y: Sequence[float], clusters: Sequence | None = None,
                 max_iter: int = 100, tol: float = 1e-10) -> LogisticFit:
    """Maximum-likelihood logistic regression of 0/1 ``y`` on ``x`` (IRLS), with the CR1
    cluster-robust sandwich covariance over ``clusters`` (default: every trial its own cluster).

    ``x`` is centred and scaled inside for a stable fit. ``converged`` is False when the outcomes are
    separated by x (then the MLE does not exist and the slope runs off to infinity), and when x takes
    fewer than two distinct values (no slope is identified: intercept, slope and covariance are NaN;
    rounding in the centring would otherwise turn a constant x into a slope of order 1e15).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    g = np.arange(x.size) if clusters is None else np.asarray(clusters)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y, g = x[ok], y[ok], g[ok]
    n = x.size
    if np.unique(x).size < 2:
        return LogisticFit(intercept=math.nan, slope=math.nan, cov=np.full((2, 2), math.nan), n=int(n),
                           clusters=int(np.unique(g).size), converged=False)
    mu_x, sd_x = float(x.mean()) if n else 0.0, float(x.std()) if n else 1.0
    sd_x = sd_x if sd_x > 0 else 1.0
    X = np.column_stack([np.ones(n), (x - mu_x) / sd_x])
    beta = np.zeros(2)
    converged = False
    for _ in range(max_iter):
        eta = X @ beta
        p = 1.0 / (1.0 + np.exp(-eta))
        w = np.clip(p * (1 - p), 1e-12, None)
        step = np.linalg.lstsq(X.T @ (w[:, None] * X), X.T @ (y - p), rcond=None)[0]
        beta = beta + step
        if np.max(np.abs(step)) < tol * (1 + np.max(np.abs(beta))):
            converged = True
            break
    p = 1.0 / (1.0 + np.exp(-(X @ beta)))
    converged = converged and bool(np.max(np.abs(X @ beta)) < 30)
    bread = np.linalg.pinv(X.T @ ((p * (1 - p))[:, None] * X))
    scores = X * (y - p)[:, None]
    labels, inv = np.unique(g, return_inverse=True)
    G = labels.size
    u = np.zeros((G, 2))
    np.add.at(u, inv, scores)
    factor = (G / (G - 1)) * ((n - 1) / (n - 2)) if G > 1 and n > 2 else math.nan
    cov_s = factor * bread @ (u.T @ u) @ bread
    # back to the unscaled x: a = b0 - b1 mu / sd, b = b1 / sd
    T = np.array([[1.0, -mu_x / sd_x], [0.0, 1.0 / sd_x]])
    coef = T @ beta
    return LogisticFit(intercept=float(coef[0]), slope=float(coef[1]), cov=T @ cov_s @ T.T, n=int(n), clusters=int(G),
                       converged=converged)


def breaking_point_logistic(fit: LogisticFit, threshold: float = 0.5, z: float = Z95) -> tuple[float, float, float]:
    """(x where the fitted success equals ``threshold``, Fieller interval low, high).

    Fieller (1954): the set of x with (a + b x - L)^2 <= z^2 var(a + b x), L = logit(threshold). When
    the slope is not significantly non-zero the set is unbounded, and an end is -inf or +inf (or the
    whole line: (-inf, inf)). A fit that did not converge gives NaNs.
    """
    if not fit.converged or not math.isfinite(fit.slope) or fit.slope == 0:
        return math.nan, math.nan, math.nan
    if not np.all(np.isfinite(fit.cov)):  # e.g. one cluster: no robust covariance, no interval
        return -(fit.intercept - math.log(threshold / (1 - threshold))) / fit.slope, math.nan, math.nan
    L = math.log(threshold / (1 - threshold))
    a, b = fit.intercept - L, fit.slope
    vaa, vab, vbb = fit.cov[0, 0], fit.cov[0, 1], fit.cov[1, 1]
    point = -a / b
    z2 = z * z
    # (b^2 - z^2 vbb) x^2 + 2 (a b - z^2 vab) x + (a^2 - z^2 vaa) <= 0
    qa, qb, qc = b * b - z2 * vbb, 2 * (a * b - z2 * vab), a * a - z2 * vaa
    disc = qb * qb - 4 * qa * qc
    if qa > 0:
        r = math.sqrt(max(disc, 0.0))
        return point, (-qb - r) / (2 * qa), (-qb + r) / (2 * qa)
    # slope not significant: the set is the outside of two roots (or everything)
    if disc <= 0 or qa == 0:
        return point, -math.inf, math.inf
    r1, r2 = sorted(((-qb - math.sqrt(disc)) / (2 * qa), (-qb + math.sqrt(disc)) / (2 * qa)))
    # the point itself lies in one of the two unbounded pieces
    return (point, -math.inf, r1) if point <= r1 else (point, r2, math.inf)


def paired_power(n: int, effect: float, sd: float, alpha: float = 0.05) -> float:
    """Power of the two-sided paired t-test with ``n`` clusters, mean difference ``effect`` and
    per-cluster standard deviation ``sd`` at level ``alpha`` (noncentral t)."""
    from scipy.stats import nct, t

    if n < 2:
        return 0.0
    if sd <= 0:
        return 1.0 if effect != 0 else alpha
    df = n - 1
    crit = float(t.ppf(1 - alpha / 2, df))
    nc = effect / sd * math.sqrt(n)
    power = float(nct.sf(crit, df, nc) + nct.cdf(-crit, df, nc))
    if not math.isfinite(power):  # scipy's noncentral t fails far in the tail: the normal limit
        from scipy.stats import norm

        z = float(norm.ppf(1 - alpha / 2))
        power = float(norm.sf(z - nc) + norm.cdf(-z - nc))
    return min(1.0, power)


def terrains_needed(effect: float, sd: float, alpha: float = 0.05, power: float = 0.8, n_max: int = 10_000) -> int:
    """Smallest number of terrains whose paired test reaches ``power`` (``n_max + 1`` if none does)."""
    for n in range(2, n_max + 1):
        if paired_power(n, effect, sd, alpha) >= power:
            return n
    return n_max + 1


def fieller_set(fit: LogisticFit, threshold: float = 0.5, z: float = Z95) -> list[tuple[float, float]]:
    """Fieller's (1954) confidence set of the x where the fitted success equals ``threshold``, as a
    list of intervals: one bounded interval, two rays ((-inf, r1] and [r2, inf), when the slope is
    not clearly non-zero), the whole line, or empty (no fit)."""
    if not fit.converged or not math.isfinite(fit.slope) or fit.slope == 0 or not np.all(np.isfinite(fit.cov)):
        return []
    L = math.log(threshold / (1 - threshold))
    a, b = fit.intercept - L, fit.slope
    vaa, vab, vbb = fit.cov[0, 0], fit.cov[0, 1], fit.cov[1, 1]
    z2 = z * z
    qa, qb, qc = b * b - z2 * vbb, 2 * (a * b - z2 * vab), a * a - z2 * vaa
    disc = qb * qb - 4 * qa * qc
    if qa > 0:
        r = math.sqrt(max(disc, 0.0))
        return [((-qb - r) / (2 * qa), (-qb + r) / (2 * qa))]
    if disc <= 0 or qa == 0:
        return [(-math.inf, math.inf)]
    r1, r2 = sorted(((-qb - math.sqrt(disc)) / (2 * qa), (-qb + math.sqrt(disc)) / (2 * qa)))
    return [(-math.inf, r1), (r2, math.inf)]


def logistic_fit_check(fit: LogisticFit, x: Sequence[float], y: Sequence[float]) -> tuple[float, int, float]:
    """Goodness of fit of a logistic fit over the distinct x levels: Pearson's X^2 = sum over levels
    of (observed - expected successes)^2 / (n p (1 - p)), its degrees of freedom (levels - 2) and the
    chi-square p. It treats trials as independent (clustered trials inflate X^2), so a small p says
    the curve misses the level means even before the clustering is counted."""
    from scipy.stats import chi2

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    stat = 0.0
    levels = np.unique(x[np.isfinite(x)])
    for lv in levels:
        sel = x == lv
        n = int(sel.sum())
        p = 1.0 / (1.0 + math.exp(-(fit.intercept + fit.slope * lv)))
        var = n * p * (1 - p)
        stat += (float(y[sel].sum()) - n * p) ** 2 / var if var > 0 else 0.0
    df = levels.size - 2
    return stat, df, float(chi2.sf(stat, df)) if df > 0 else math.nan


def isotonic_decreasing(y: Sequence[float], w: Sequence[float] | None = None) -> np.ndarray:
    """The non-increasing sequence closest to ``y`` in weighted least squares (pool-adjacent-violators,
    Ayer et al. 1955): the fitted success at ordered levels when success may only fall."""
    y = np.asarray(y, float)
    w = np.ones_like(y) if w is None else np.asarray(w, float)
    blocks: list[list[float]] = []  # [weighted mean, weight, count]
    for v, wt in zip(y, w, strict=True):
        blocks.append([v, wt, 1])
        while len(blocks) > 1 and blocks[-2][0] < blocks[-1][0]:
            m2, w2, c2 = blocks.pop()
            m1, w1, c1 = blocks.pop()
            blocks.append([(m1 * w1 + m2 * w2) / (w1 + w2), w1 + w2, c1 + c2])
    return np.concatenate([np.full(int(c), m) for m, _, c in blocks]) if blocks else np.array([])


def sign_flip_power(pilot: Sequence[float], n_terrains: int, alpha: float, rng: np.random.Generator,
                    n_sim: int = 1000, exact_max: int = 16, n_flips: int = 4000) -> float:
    """Power of the two-sided exact sign-flip test of the mean (:func:`sign_flip_test`) at level
    ``alpha``, by simulation: each simulated study draws ``n_terrains`` per-terrain differences with
    replacement from ``pilot`` (the pilot's terrains taken as the truth, ties and skew included) and
    tests them; power = the share with p <= alpha. Exact p for up to ``exact_max`` terrains, else
    from ``n_flips`` random sign patterns (the same patterns for every simulated study). A test
    whose smallest possible p, 2 / 2^K, exceeds ``alpha`` has power 0."""
    d = _clean(pilot)
    if d.size == 0 or n_terrains < 1:
        return 0.0
    if 2.0 / 2.0 ** n_terrains > alpha * (1 + 1e-12):
        return 0.0
    if n_terrains <= exact_max:
        signs = 1 - 2 * ((np.arange(2 ** n_terrains)[:, None] >> np.arange(n_terrains)) & 1)
    else:
        signs = rng.choice([-1.0, 1.0], size=(n_flips, n_terrains))
        signs[0] = 1.0
    signs = signs.astype(float)
    hits = 0
    for _ in range(n_sim):
        x = rng.choice(d, size=n_terrains, replace=True)
        obs = abs(float(x.sum()))
        if obs == 0:
            continue
        p = float(np.mean(np.abs(signs @ x) >= obs * (1 - 1e-12)))
        hits += p <= alpha
    return hits / n_sim
