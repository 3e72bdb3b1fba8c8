"""Failure probabilities: plain Monte Carlo, and cross-entropy importance sampling (pure numpy/scipy).

Everything works in standard-normal coordinates ``z`` (offroadbench.search.space: the nominal
distribution is N(0, I)); a trial's *margin* m(z) is negative exactly when it fails, and
P(failure) = P(m(Z) <= 0), Z ~ N(0, I).

**Plain Monte Carlo.** n nominal draws, k failures: p = k / n, relative error
sqrt((1 - p) / (n p)), and the exact Clopper-Pearson interval (Clopper & Pearson 1934).

**Cross-entropy importance sampling** (Rubinstein & Kroese 2004, Alg. 3.4.1 with the Gaussian
update of their Sec. 3.5; de Boer et al. 2005, Alg. 2.1). The proposal is N(mu, diag sd^2).
The first adaptive stage draws from N(0, s0^2 I) (``initial_sd`` s0; 1: the nominal itself; the
method allows any starting parameter, Rubinstein & Kroese 2004, Alg. 3.4.1 step 1, and a wider
one puts some draws in a tail whose failures the margin does not announce). Stage t draws n_s
points from the current proposal q_t, sets the level gamma_t = max(rho-quantile of the margins
of every stage so far, 0), and refits mu and sd to the elite points of every stage so far
(m <= gamma_t), each weighted by its own likelihood ratio w = phi(z) / q_s(z): the
cross-entropy-optimal Gaussian is the weighted moment match (de Boer et al. 2005, Eq. 37-38),
and pooling the stages is the same program on more draws (each stage's weighted elite sum
estimates the same cross-entropy objective at a given level, so their union does too; this
project's variant, which keeps a noisy margin from steering the proposal on a handful of elites;
``pool_weights = "mixture"`` weights every pooled draw by the nominal over the stages' mixture
instead, :func:`mixture_log_weight`, which keeps a wide first stage's few heavy elites from
fixing the proposal). Adaptation stops at the first stage, from the ``min_stages``-th on, whose
level reaches 0 (at least rho of the draws so far failed) or after ``max_stages``. The rest
of the budget is drawn from the *defensive mixture* q = alpha phi + (1 - alpha) q_T
(Hesterberg 1995; Owen 2013, Ch. 9, mixture importance sampling), whose weights are bounded by 1/alpha, and

    p_IS = mean(1{m_i <= 0} w_i),   se = sd(1{m <= 0} w) / sqrt(n),   RE = se / p_IS,

the plain (not self-normalised) importance-sampling estimate over the n final draws only, with
the normal interval p_IS +- z_{(1+level)/2} se (clipped at 0). The adaptive stages' draws steer the
proposal and are counted in the trials spent, never in the estimate (so the estimate is unbiased
whatever the stages did, and no trial is counted twice). The weights are exact: phi is the
nominal density in standard-normal coordinates, in which every truncated or uniform nominal of
offroadbench.search.space is N(0, I), and the map to the parameters is the same for the nominal
and the proposal, so its Jacobian cancels in the ratio. Bounded weights keep the
central limit theorem (tests/search/test_estimators.py checks the stated coverage on Gaussian
tails of known probability). Where a failure is random given the parameters and the proposal
adapts on few failures, the interval falls short of it: the same tests measure 81 % for a 95 %
interval at 200 trials on the committed study's failure model, and a single run's relative error
understating the spread of the estimates about twofold.

**What importance sampling over the parameters can gain.** Write P = E[p(theta)] with
p(theta) = P(fail | theta) over the nuisance (terrain, mission). Importance sampling over theta
removes only the theta part of the variance: with failures confined to a region R of nominal mass
m_R with failure rate pbar inside, the best proposal (the nominal restricted to R) has relative
variance (1 - pbar) / pbar per draw against plain Monte Carlo's (1 - P) / P with P = m_R pbar, a
gain of about 1 / (m_R (1 - pbar)). Where failures are spread over the parameters (p(theta) small
everywhere), there is nothing to gain (the variance of an importance-sampling estimate: Owen
2013, Ch. 9).

How close a domain lets any importance sampling over the parameters come to that:
:func:`best_is_gain` (with p(theta) from :func:`binned_failure_rate`). The variance of the best
estimator of this kind is (E_phi[sqrt(p(theta))])^2 - P^2 (the optimal proposal of a random
integrand is q* proportional to phi(theta) sqrt(E[1{fail}^2 | theta]) = phi(theta) sqrt(p(theta)); Owen 2013,
Ch. 9, Sec. 9.1, applied to the indicator), so its gain over plain Monte Carlo is
P (1 - P) / ((E sqrt p)^2 - P^2): 1 where p(theta) is constant, unbounded where failure is a
deterministic function of theta.

Efficiency. Plain MC needs n_MC(r) = (1 - p) / (p r^2) draws for relative error r; IS needs
its adaptive stages plus var(1{m <= 0} w) / (p^2 r^2) final draws (:func:`trials_for_rel_error`).

**The gain of importance sampling** (:func:`is_gain`) is the standard work-normalised variance
ratio, the relative efficiency of IS against plain Monte Carlo (Hammersley & Handscomb 1964,
Sec. 5.1; Glynn & Whitt 1992, the efficiency 1 / (variance x work); Owen 2013, Sec. 8.1), at one
common p for both:

    gain = (p (1 - p) / N_MC x N_MC) / (V_IS x N_IS) = p (1 - p) / (N_IS V_IS),

p (1 - p) / N_MC the variance of plain Monte Carlo on N_MC trials (so the product is p (1 - p)
whatever N_MC), V_IS the variance of the IS estimate and N_IS every trial it spent, adaptive
stages included. A trial costs the same in both (a simulation run). V_IS is either one run's
stated se^2 (a single run's figure, optimistic where its weights are skewed) or the mean squared
error of repeated runs about the reference (the honest figure); p is a reference both are judged
at (never plain Monte Carlo's own noisy estimate against IS's relative error, which mixes two
probabilities).

**A skew-aware interval** (:func:`bootstrap_t_interval`). With few failures among the final draws
the terms y = 1{fail} w are skewed and the normal interval's ends are off on both sides. The
studentized (bootstrap-t) interval (Efron 1982; Hall 1988; Davison & Hinkley 1997, Sec. 5.2.1,
Eq. 5.7) resamples the final draws B times, computes t* = (ybar* - ybar) / se* on each and
takes

    [ybar - t*_(1 - a/2) se, ybar - t*_(a/2) se],

second-order accurate for a mean (its coverage error O(1/n) against the normal interval's
O(1/sqrt(n)), Hall 1988), and it follows the skew: the upper end moves out when a few heavy
terms carry the estimate.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

import numpy as np
from scipy import special, stats

__all__ = ["Estimate", "GaussianProposal", "POOL_WEIGHTS", "mixture_log_weight", "ce_update", "ce_update_pooled", "ce_adapt", "initial_proposal", "mc_estimate", "is_estimate", "ce_is",
           "CEResult", "trials_for_rel_error", "distinct_failures", "distinct_failure_indices", "best_is_gain", "binned_failure_rate",
           "Z_BIN_EDGES", "is_gain", "bootstrap_t_interval", "N_BOOT"]

_LOG_2PI = math.log(2 * math.pi)


@dataclass(frozen=True)
class Estimate:
    """An estimate of P(failure) with its relative error and a confidence interval."""

    p: float
    """The estimate."""
    rel_error: float
    """Standard error over the estimate (NaN when the estimate is 0)."""
    low: float
    """Lower end of the interval."""
    high: float
    """Upper end of the interval (NaN: unknown, e.g. importance sampling with no failure seen)."""
    n: int
    """Trials the estimate used (the whole budget spent for it, adaptive stages included: ``trials``)."""
    failures: int
    """Failures among them."""
    trials: int
    """Every trial spent to get the estimate (for IS: the adaptive stages too)."""
    var_per_trial: float
    """Variance of one term of the estimator (p (1 - p) for MC; var(1{fail} w) for IS)."""
    method: str
    """``mc`` or ``ce-is``."""
    level: float = 0.95

    @property
    def se(self) -> float:
        return math.sqrt(self.var_per_trial / self.n) if self.n else float("nan")

    def covers(self, p: float) -> bool:
        """Whether the interval holds ``p``."""
        return self.low <= p <= self.high


def mc_estimate(failed: Sequence[bool] | np.ndarray, level: float = 0.95) -> Estimate:
    """Plain Monte Carlo estimate from nominal draws: p = k/n with the Clopper-Pearson interval."""
    f = np.asarray(failed, dtype=bool).ravel()
    n, k = int(f.size), int(f.sum())
    if n == 0:
        return Estimate(float("nan"), float("nan"), 0.0, 1.0, 0, 0, 0, float("nan"), "mc", level)
    p = k / n
    a = 1 - level
    low = 0.0 if k == 0 else float(stats.beta.ppf(a / 2, k, n - k + 1))
    high = 1.0 if k == n else float(stats.beta.ppf(1 - a / 2, k + 1, n - k))
    re = math.sqrt((1 - p) / (n * p)) if k else float("nan")
    return Estimate(p, re, low, high, n, k, n, p * (1 - p), "mc", level)


def is_estimate(failed: np.ndarray, log_w: np.ndarray, trials: int | None = None, level: float = 0.95) -> Estimate:
    """Importance-sampling estimate mean(1{fail} w) with the normal interval (clipped at 0).

    ``log_w`` are the log likelihood ratios log(phi(z) / q(z)) of the draws; ``trials`` is the
    whole budget spent (adaptive stages included; default the number of draws)."""
    f = np.asarray(failed, dtype=bool).ravel()
    lw = np.asarray(log_w, dtype=float).ravel()
    n = int(f.size)
    if n == 0:
        return Estimate(float("nan"), float("nan"), 0.0, float("nan"), 0, 0, trials or 0, float("nan"), "ce-is", level)
    y = np.where(f, np.exp(lw), 0.0)
    p = float(y.mean())
    var = float(y.var(ddof=1)) if n > 1 else float("nan")
    se = math.sqrt(var / n) if n > 1 else float("nan")
    zq = float(special.ndtri(0.5 + level / 2))
    if f.sum() == 0:
        return Estimate(0.0, float("nan"), 0.0, float("nan"), n, 0, trials or n, var, "ce-is", level)
    return Estimate(p, se / p, max(p - zq * se, 0.0), p + zq * se, n, int(f.sum()), trials or n, var, "ce-is", level)


#: bootstrap resamples of :func:`bootstrap_t_interval`
N_BOOT = 2000


def is_gain(p: float, var_is: float, trials_is: int) -> float:
    """The work-normalised variance ratio of importance sampling over plain Monte Carlo at the common
    probability ``p``: p (1 - p) / (trials_is var_is) (module docstring); NaN without a variance."""
    if not (0 < p < 1 and var_is > 0 and trials_is > 0):
        return float("nan")
    return p * (1 - p) / (trials_is * var_is)


def bootstrap_t_interval(failed: np.ndarray, log_w: np.ndarray, level: float = 0.95, n_boot: int = N_BOOT,
                         seed: int = 0) -> tuple[float, float]:
    """The studentized bootstrap interval of the importance-sampling estimate mean(1{fail} w) over
    its final draws (module docstring), clipped at 0; deterministic (``seed``). (NaN, NaN) when
    fewer than two draws failed (the resampled standard error is then 0 too often to studentize)."""
    f = np.asarray(failed, dtype=bool).ravel()
    y = np.where(f, np.exp(np.asarray(log_w, dtype=float).ravel()), 0.0)
    n = len(y)
    if int(f.sum()) < 2:
        return float("nan"), float("nan")
    mean, se = float(y.mean()), float(y.std(ddof=1)) / math.sqrt(n)
    if se == 0:  # every term equal (every draw failed, weights 1): no spread to resample
        return mean, mean
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, n, size=(n_boot, n))
    yb = y[idx]
    mb = yb.mean(axis=1)
    sb = yb.std(axis=1, ddof=1) / math.sqrt(n)
    # a resample without a failure has mean 0 and se 0: t = -inf (below every other), which the
    # order-statistic quantile keeps (a few such resamples push the upper end out, as they should)
    t = np.full(n_boot, -np.inf)
    ok = sb > 0
    t[ok] = (mb[ok] - mean) / sb[ok]
    a = 1 - level
    t_lo, t_hi = np.quantile(t, [a / 2, 1 - a / 2], method="inverted_cdf")
    return max(mean - float(t_hi) * se, 0.0), mean - float(t_lo) * se


def trials_for_rel_error(est: Estimate, rel_error: float) -> float:
    """Trials an estimator like ``est`` needs for relative error ``rel_error`` at its estimated p:
    (1 - p) / (p r^2) for MC; the adaptive stages plus var / (p^2 r^2) final draws for IS."""
    if not est.p > 0:
        return float("inf")
    if est.method == "mc":
        return (1 - est.p) / (est.p * rel_error ** 2)
    return (est.trials - est.n) + est.var_per_trial / (est.p ** 2 * rel_error ** 2)


# ---------------------------------------------------------------------------- proposals
@dataclass(frozen=True)
class GaussianProposal:
    """q(z) = alpha phi(z) + (1 - alpha) N(z; mean, diag sd^2), phi the standard normal density of dimension d."""

    mean: tuple[float, ...]
    sd: tuple[float, ...]
    defensive: float = 0.0
    """alpha, the weight of the nominal density in the mixture (0: a plain Gaussian)."""

    @classmethod
    def nominal(cls, d: int) -> "GaussianProposal":
        return cls((0.0,) * d, (1.0,) * d, 0.0)

    @property
    def dim(self) -> int:
        return len(self.mean)

    def with_defensive(self, alpha: float) -> "GaussianProposal":
        return GaussianProposal(self.mean, self.sd, float(alpha))

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n draws (n, d): from the nominal with probability alpha, else from the Gaussian."""
        d = self.dim
        base = rng.standard_normal((n, d))
        if self.defensive > 0:
            pick = rng.random(n) < self.defensive
        else:
            pick = np.zeros(n, dtype=bool)
        z = np.asarray(self.mean) + np.asarray(self.sd) * base
        return np.where(pick[:, None], base, z)

    def log_weight(self, z: np.ndarray) -> np.ndarray:
        """log(phi(z) / q(z)) of each row of ``z``."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        d = self.dim
        log_phi = -0.5 * (z ** 2).sum(axis=1) - 0.5 * d * _LOG_2PI
        mu, sd = np.asarray(self.mean), np.asarray(self.sd)
        log_g = (-0.5 * (((z - mu) / sd) ** 2).sum(axis=1) - np.log(sd).sum() - 0.5 * d * _LOG_2PI)
        if self.defensive > 0:
            log_q = np.logaddexp(math.log(self.defensive) + log_phi, math.log1p(-self.defensive) + log_g)
        else:
            log_q = log_g
        return log_phi - log_q


def ce_update(z: np.ndarray, margin: np.ndarray, proposal: GaussianProposal, quantile: float,
              min_sd: float) -> tuple[GaussianProposal, float]:
    """One cross-entropy step on draws of one ``proposal`` (:func:`ce_update_pooled` with their
    likelihood ratios against it). Returns (new proposal, gamma)."""
    z = np.atleast_2d(np.asarray(z, dtype=float))
    return ce_update_pooled(z, margin, proposal.log_weight(z), quantile, min_sd)


def initial_proposal(d: int, initial_sd: float = 1.0) -> GaussianProposal:
    """The proposal of the first adaptive stage: N(0, initial_sd^2 I) (1: the nominal)."""
    return GaussianProposal((0.0,) * d, (float(initial_sd),) * d, 0.0)


#: how :func:`ce_adapt` weights the pooled draws of its stages: each by the likelihood ratio of the
#: proposal it came from (``own``), or every draw by the nominal over the stages' mixture (``mixture``)
POOL_WEIGHTS = ("own", "mixture")


def mixture_log_weight(z: np.ndarray, proposals: Sequence[GaussianProposal], sizes: Sequence[int]) -> np.ndarray:
    """log(phi(z) / sum_s (n_s / N) q_s(z)) of each row of ``z``: the likelihood ratio of the nominal
    against the mixture of ``proposals`` in the proportions of their draws ``sizes`` (the balance
    heuristic of Veach & Guibas 1995, Eq. 7-8; deterministic-mixture weights, Owen & Zhou 2000,
    Sec. 3; the reweighting of adaptive multiple importance sampling, Cornuet et al. 2012, Sec. 2)."""
    z = np.atleast_2d(np.asarray(z, dtype=float))
    total = float(sum(sizes))
    # log q_s = log phi - log(phi / q_s): each proposal's own log ratio gives its density
    log_ratios = np.stack([p.log_weight(z) for p in proposals])
    log_mix_over_phi = np.logaddexp.reduce(-log_ratios + np.log(np.asarray(sizes, dtype=float) / total)[:, None], axis=0)
    return -log_mix_over_phi


def ce_adapt(stages: Sequence[tuple[np.ndarray, np.ndarray]], d: int, *, quantile: float, min_sd: float,
             max_stages: int, initial_sd: float = 1.0, min_failures: int = 0, min_stages: int = 1,
             pool_weights: str = "own") -> tuple[GaussianProposal, bool]:
    """The proposal after the adaptive stages ``stages`` ((z, margin) of each, in order, stage t
    drawn from the proposal this function gives for stages[:t]; stage 0 from
    :func:`initial_proposal`). Each update pools the elites of every stage so far, weighted by the
    likelihood ratio of the proposal each was drawn from (``pool_weights = "own"``, module
    docstring) or by that of the stages' mixture (``"mixture"``, :func:`mixture_log_weight`: a draw
    of a wide first stage no longer outweighs the later stages' draws near the failures, where the
    later proposals put their mass; each stage's weighted elite sum stays an unbiased estimate of
    the same cross-entropy objective in either case). Returns (proposal, adapted): ``adapted`` once
    at least ``min_stages`` stages ran and a level reached 0, or ``max_stages`` stages ran; the
    proposal is then the final one (without the defensive mixture, which the caller adds)."""
    if pool_weights not in POOL_WEIGHTS:
        raise ValueError(f"pool_weights = {pool_weights!r}; allowed: {', '.join(POOL_WEIGHTS)}")
    prop = initial_proposal(d, initial_sd)
    zs: list[np.ndarray] = []
    ms: list[np.ndarray] = []
    lws: list[np.ndarray] = []
    props: list[GaussianProposal] = []
    for t, (z, m) in enumerate(stages):
        z = np.atleast_2d(np.asarray(z, dtype=float))
        zs.append(z)
        ms.append(np.asarray(m, dtype=float))
        props.append(prop)
        lws.append(prop.log_weight(z))
        pooled = np.vstack(zs)
        lw = (mixture_log_weight(pooled, props, [len(x) for x in zs]) if pool_weights == "mixture"
              else np.concatenate(lws))
        prop, gamma = ce_update_pooled(pooled, np.concatenate(ms), lw, quantile, min_sd, min_failures)
        if (gamma <= 0 and t + 1 >= min_stages) or t + 1 >= max_stages:
            return prop, True
    return prop, False


def ce_update_pooled(z: np.ndarray, margin: np.ndarray, log_w: np.ndarray, quantile: float,
                     min_sd: float, min_failures: int = 0) -> tuple[GaussianProposal, float]:
    """One cross-entropy step on draws with known log likelihood ratios ``log_w`` (each against the
    proposal it came from): the level gamma = max(rho-quantile of ``margin``, 0) (0 outright once
    ``min_failures`` > 0 draws failed) and the Gaussian fitted to the elite points
    (margin <= gamma) weighted by exp(log_w) (de Boer et al. 2005, Eq. 37-38); the new sd is at
    least ``min_sd``. Returns (new proposal, gamma)."""
    z = np.atleast_2d(np.asarray(z, dtype=float))
    m = np.asarray(margin, dtype=float)
    gamma = max(float(np.quantile(m, quantile, method="inverted_cdf")), 0.0)
    if 0 < min_failures <= int((m <= 0).sum()):
        gamma = 0.0
    elite = m <= gamma
    lw = np.asarray(log_w, dtype=float)[elite]
    w = np.exp(lw - lw.max())
    w = w / w.sum()
    mean = (w[:, None] * z[elite]).sum(axis=0)
    var = (w[:, None] * (z[elite] - mean) ** 2).sum(axis=0)
    sd = np.maximum(np.sqrt(var), min_sd)
    return GaussianProposal(tuple(float(v) for v in mean), tuple(float(v) for v in sd), 0.0), gamma


@dataclass(frozen=True)
class CEResult:
    """What :func:`ce_is` did: the estimate and the proposals of its stages."""

    estimate: Estimate
    proposals: tuple[GaussianProposal, ...]
    """The proposal of every adaptive stage, then the final (defensive) one."""
    final_failed: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=bool))
    """Whether each final draw failed (the estimate's terms, for :func:`bootstrap_t_interval`)."""
    final_log_w: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    """The final draws' log likelihood ratios."""


def ce_is(margin_fn: Callable[[np.ndarray], np.ndarray], d: int, budget: int, rng: np.random.Generator, *,
          stage_size: int = 100, quantile: float = 0.1, max_stages: int = 6, defensive: float = 0.1,
          min_sd: float = 1.0, initial_sd: float = 1.0, min_failures: int = 0, min_stages: int = 1,
          pool_weights: str = "own", level: float = 0.95) -> CEResult:
    """Cross-entropy importance sampling of P(margin_fn(Z) <= 0), Z ~ N(0, I_d), on ``budget``
    evaluations of ``margin_fn`` (vectorised: (n, d) -> (n,)). The in-memory twin of what
    ``search run`` does with method ``ce-is`` (same :func:`ce_adapt`, same estimator)."""
    stages: list[tuple[np.ndarray, np.ndarray]] = []
    props = []
    used = 0
    prop, adapted = initial_proposal(d, initial_sd), False
    while not adapted and used + stage_size < budget:
        props.append(prop)
        z = prop.sample(stage_size, rng)
        stages.append((z, margin_fn(z)))
        used += stage_size
        prop, adapted = ce_adapt(stages, d, quantile=quantile, min_sd=min_sd, max_stages=max_stages,
                                 initial_sd=initial_sd, min_failures=min_failures, min_stages=min_stages,
                                 pool_weights=pool_weights)
    final = prop.with_defensive(defensive)
    props.append(final)
    z = final.sample(budget - used, rng)
    failed = margin_fn(z) <= 0
    log_w = final.log_weight(z)
    est = is_estimate(failed, log_w, trials=budget, level=level)
    return CEResult(est, tuple(props), np.asarray(failed, dtype=bool), log_w)


# ---------------------------------------------------------------------------- what IS can gain at best
#: bin edges in standard-normal units for :func:`binned_failure_rate`: finer in the tails, where
#: rare failures sit (nominal mass per bin 2.3 %, 4.4 %, 9.2 %, 34 %, 34 %, 9.2 %, 4.4 %, 2.3 %)
Z_BIN_EDGES = (-2.0, -1.5, -1.0, 0.0, 1.0, 1.5, 2.0)


def best_is_gain(p_theta: np.ndarray) -> float:
    """The most any importance sampling over the parameters can gain over plain Monte Carlo (the
    ratio of their variances per trial), given P(fail | theta) at nominal draws of theta (module
    docstring): P (1 - P) / (mean(sqrt p)^2 - P^2), P = mean(p). inf where failure is a
    deterministic function of theta (p in {0, 1}), 1 where p is constant, NaN where nothing fails."""
    p = np.clip(np.asarray(p_theta, dtype=float).ravel(), 0.0, 1.0)
    big_p = float(p.mean()) if p.size else float("nan")
    if not 0 < big_p < 1:
        return float("nan")
    var_best = float(np.sqrt(p).mean()) ** 2 - big_p ** 2
    return big_p * (1 - big_p) / var_best if var_best > 1e-15 * big_p else float("inf")


def binned_failure_rate(z: np.ndarray, failed: np.ndarray, edges: Sequence[float] = Z_BIN_EDGES) -> np.ndarray:
    """P(fail | theta) estimated at each of n nominal draws from one parameter: the failure
    fraction of the draws in the same bin of ``z`` (standard-normal units, bins split at ``edges``).
    A coarse model: within a bin it takes the failure rate as constant, so :func:`best_is_gain` of
    it is what importance sampling over that parameter gains at best if the failure rate varied
    no more within the bins (finer structure would gain more; sampling noise in sparse bins gains
    less or more)."""
    zz = np.asarray(z, dtype=float).ravel()
    f = np.asarray(failed, dtype=bool).ravel()
    idx = np.searchsorted(np.asarray(edges, dtype=float), zz)
    fails = np.bincount(idx, weights=f.astype(float), minlength=len(edges) + 1)
    counts = np.bincount(idx, minlength=len(edges) + 1)
    rate = np.divide(fails, counts, out=np.zeros_like(fails), where=counts > 0)
    return rate[idx]


# ---------------------------------------------------------------------------- falsification counts
def distinct_failure_indices(unit_x: np.ndarray, failed: np.ndarray, min_distance: float) -> Iterator[int]:
    """The trials (indices, in the given order) that are distinct failures: a failure is distinct
    when its parameters (scaled to [0, 1]) differ from every earlier distinct failure by at least
    ``min_distance`` in some coordinate (Chebyshev distance). Lazy: a caller that needs only the
    first k stops there."""
    x = np.atleast_2d(np.asarray(unit_x, dtype=float))
    f = np.asarray(failed, dtype=bool).ravel()
    seen = np.empty((int(f.sum()), x.shape[1]))
    n = 0
    for i in np.flatnonzero(f):
        if n == 0 or bool((np.max(np.abs(x[i] - seen[:n]), axis=1) >= min_distance).all()):
            seen[n] = x[i]
            n += 1
            yield int(i)


def distinct_failures(unit_x: np.ndarray, failed: np.ndarray, min_distance: float) -> np.ndarray:
    """Cumulative count of distinct failures after each trial (in the given order), under the rule
    of :func:`distinct_failure_indices`."""
    f = np.asarray(failed, dtype=bool).ravel()
    new = np.zeros(len(f), dtype=int)
    new[list(distinct_failure_indices(unit_x, f, min_distance))] = 1
    return np.cumsum(new)
