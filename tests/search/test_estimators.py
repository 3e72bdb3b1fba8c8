"""The estimators against problems whose failure probability is known exactly.

Coverage checks are binomial: R independent runs (fixed seeds, so the test is deterministic) of
an interval stated at 95 % must cover the truth a number of times inside the central 99.8 % of
Binomial(R, 0.95). The same check is run on a deliberately miscalibrated interval to show it can
fail."""

import numpy as np
import pytest
from scipy import special, stats

from offroadbench.search.estimators import (GaussianProposal, best_is_gain, binned_failure_rate, ce_is,
                                            distinct_failures, is_estimate, mc_estimate, mixture_log_weight,
                                            trials_for_rel_error)

P = 1e-3
C = float(special.ndtri(1 - P))  # P(Z > C) = 1e-3
REPS = 300


def binomial_ok(covered: int, reps: int, level: float = 0.95) -> bool:
    lo, hi = stats.binom.ppf([0.001, 0.999], reps, level)
    return lo <= covered <= hi


#: (dimension, margin function) with P(margin <= 0) = 1e-3 under N(0, I)
PROBLEMS = {
    "tail-1d": (1, lambda z: C - z[:, 0]),
    "plane-2d": (2, lambda z: C * np.sqrt(2) - z.sum(axis=1)),
    "tail-3d-two-idle": (3, lambda z: C - z[:, 0]),
}


#: the adaptive schemes: the likelihood ratio of each stage's own proposal, and the mixture
#: weights (balance heuristic) with two stages at least, from a wide first stage
SCHEMES = {"own": {}, "mixture": dict(pool_weights="mixture", min_stages=2, initial_sd=2.5, min_failures=3)}


def _runs(name, budget=2000, scheme="own"):
    d, fn = PROBLEMS[name]
    return [ce_is(fn, d, budget, np.random.default_rng([d, budget, r]), stage_size=100, **SCHEMES[scheme]).estimate
            for r in range(REPS)]


@pytest.mark.parametrize("name,scheme", [(n, "own") for n in sorted(PROBLEMS)] + [("plane-2d", "mixture"),
                                                                                  ("tail-3d-two-idle", "mixture")])
def test_ce_is_interval_covers_the_known_probability_at_its_stated_rate(name, scheme):
    ests = _runs(name, scheme=scheme)
    covered = sum(e.covers(P) for e in ests)
    assert binomial_ok(covered, REPS), f"{name}: {covered} of {REPS} 95 % intervals hold p = {P}"
    # not trivially: the intervals are tight (median relative error under 8 % on 2,000 trials) ...
    assert np.median([e.rel_error for e in ests]) < 0.08
    # ... the estimator is unbiased within its Monte Carlo error ...
    ps = np.array([e.p for e in ests])
    assert abs(ps.mean() - P) < 4 * ps.std() / np.sqrt(REPS)
    # ... and the same check refuses intervals a third as wide (z = 0.65 instead of 1.96)
    narrow = sum(abs(e.p - P) <= e.p * e.rel_error * 0.65 for e in ests)
    assert not binomial_ok(narrow, REPS)


def test_ce_is_beats_plain_monte_carlo_by_far_at_1e_3():
    est = _runs("tail-1d")[0]
    mc_n = trials_for_rel_error(mc_estimate([True] * 1 + [False] * 999), 0.1)  # p = 1e-3
    assert mc_n == pytest.approx(0.999 / (1e-3 * 0.01))
    assert trials_for_rel_error(est, 0.1) * 20 < mc_n


def test_mc_clopper_pearson_covers_at_least_its_level():
    rng = np.random.default_rng(0)
    p, n = 0.02, 500
    ests = [mc_estimate(rng.random(n) < p) for _ in range(REPS)]
    covered = sum(e.covers(p) for e in ests)
    assert covered >= stats.binom.ppf(0.001, REPS, 0.95)
    assert all(e.rel_error == pytest.approx(np.sqrt((1 - e.p) / (n * e.p))) for e in ests if e.p > 0)


def test_mc_estimate_with_no_failures_has_the_rule_of_three_bound():
    e = mc_estimate(np.zeros(1000, dtype=bool))
    assert e.p == 0 and e.low == 0
    assert e.high == pytest.approx(1 - 0.025 ** (1 / 1000))  # exact one-sided 97.5 % bound, ~3.7/n


def test_importance_weights_of_the_nominal_proposal_are_one():
    z = np.random.default_rng(1).standard_normal((50, 3))
    assert np.allclose(GaussianProposal.nominal(3).log_weight(z), 0.0)


def test_defensive_mixture_bounds_every_weight():
    prop = GaussianProposal((3.0, -2.0), (0.2, 0.2), defensive=0.1)
    z = np.random.default_rng(2).normal(0, 4, (2000, 2))
    assert np.exp(prop.log_weight(z)).max() <= 10.0 + 1e-9


def test_is_estimate_of_nominal_draws_is_the_mc_estimate():
    failed = np.random.default_rng(3).random(400) < 0.1
    a, b = is_estimate(failed, np.zeros(400)), mc_estimate(failed)
    assert a.p == pytest.approx(b.p)
    assert a.rel_error == pytest.approx(b.rel_error, rel=0.01)


def test_distinct_failures_counts_failures_apart_in_some_coordinate():
    x = np.array([[0.0, 0.0], [0.05, 0.05], [0.5, 0.0], [0.9, 0.9], [0.2, 0.2]])
    failed = np.array([True, True, True, False, True])
    assert distinct_failures(x, failed, 0.1).tolist() == [1, 1, 2, 2, 3]


# ---------------------------------------------------------------- the committed study's estimator
STUDY_CE = dict(stage_size=40, quantile=0.1, max_stages=3, min_failures=3, initial_sd=2.5, defensive=0.1)
"""The cross-entropy settings of experiments/failure-search.toml (checked below)."""
SITE_CE = dict(stage_size=30, quantile=0.1, max_stages=3, min_failures=3, initial_sd=2.5, defensive=0.1, min_stages=2,
               pool_weights="mixture")
"""Those of experiments/failure-search-site.toml (checked below)."""


def test_the_study_file_uses_the_settings_tested_here():
    from pathlib import Path

    from offroadbench.search import load_search

    cfg = load_search(Path(__file__).resolve().parents[2] / "experiments" / "failure-search.toml").search
    assert dict(stage_size=cfg.ce_stage_size, quantile=cfg.ce_quantile, max_stages=cfg.ce_max_stages,
                min_failures=cfg.ce_min_failures, initial_sd=cfg.ce_initial_sd, defensive=cfg.ce_defensive) == STUDY_CE
    assert (cfg.method_budget("ce-is"), cfg.ce_min_sd, cfg.dim) == (200, 1.0, 2)


def test_weights_are_the_density_ratio_of_the_study_files_truncated_nominals():
    """exp(log_w) = nominal density / proposal density in the parameters themselves: the truncated
    normal of each [[search.params]] (scipy's truncnorm, its normaliser included) against the
    proposal pushed through the map z -> x (its density times |dz/dx|, dz/dx by finite differences)."""
    from pathlib import Path

    from offroadbench.search import load_search

    cfg = load_search(Path(__file__).resolve().parents[2] / "experiments" / "failure-search.toml").search
    prop = GaussianProposal((0.4, -2.1), (1.3, 1.0), defensive=0.1)
    x = np.array([[2.2, 0.15], [3.0, 0.6], [4.1, 0.25], [3.4, 0.9]])
    z = cfg.to_z(x)
    nominal, proposal = np.ones(len(x)), np.zeros(len(x))
    dens_g = np.ones(len(x))
    for i, p in enumerate(cfg.params):
        a, b = (p.low - p.mean) / p.sd, (p.high - p.mean) / p.sd
        nominal *= stats.truncnorm.pdf(x[:, i], a, b, loc=p.mean, scale=p.sd)
        h = 1e-6 * (p.high - p.low)
        dzdx = (p.to_z(x[:, i] + h) - p.to_z(x[:, i] - h)) / (2 * h)
        dens_g *= stats.norm.pdf(z[:, i], prop.mean[i], prop.sd[i]) * dzdx
    phi_x = np.prod([stats.norm.pdf(z[:, i]) * (p.to_z(x[:, i] + 1e-6) - p.to_z(x[:, i] - 1e-6)) / 2e-6
                     for i, p in enumerate(cfg.params)], axis=0)
    proposal = 0.1 * phi_x + 0.9 * dens_g
    assert np.allclose(phi_x, nominal, rtol=1e-5)  # the map carries N(0, I) onto the declared nominal
    assert np.allclose(np.exp(prop.log_weight(z)), nominal / proposal, rtol=1e-5)


#: a failure that the parameters carry but do not decide: in standard-normal units, z0 (the ground's
#: friction, low = slick) below ZF fails 80 % of the time and between ZF and ZB 20 %, if z1 (the
#: relief) is above ZR; the rest never fails (the 2026-11-26 pilots of the committed study, A*)
ZF, ZB, ZR = -2.13, -1.65, -0.75
P_RANDOM = float((0.8 * special.ndtr(ZF) + 0.2 * (special.ndtr(ZB) - special.ndtr(ZF))) * special.ndtr(-ZR))


def _random_failure(rng, p_of_z):
    def margin(z):
        fail = rng.random(len(z)) < p_of_z(z)
        return np.where(fail, -0.5, np.clip(rng.normal(0.6, 0.06, len(z)), 1e-6, 0.667))
    return margin


def _region(z):
    return np.where(z[:, 1] > ZR, np.where(z[:, 0] < ZF, 0.8, np.where(z[:, 0] < ZB, 0.2, 0.0)), 0.0)


def test_a_failure_the_parameters_carry_is_estimated_without_bias_and_with_a_gain_over_monte_carlo():
    """The committed study's estimator (200 trials) on a failure that is random given the
    parameters (P = 0.0153). Measured on these seeds: the estimate is unbiased, but its 95 %
    interval holds P in only 81 % of runs, and one run's relative error (median 0.24, which would
    be 5.5x fewer trials than plain Monte Carlo's for that error) understates the true spread of
    the estimates (0.46 over the runs: 1.5x fewer trials than plain Monte Carlo). One bad
    adaptation in a dozen draws a proposal that misses part of the failure region, and its few
    failures there carry weights up to 1 / defensive = 10. The ideal proposal (the nominal
    restricted to the region) would gain 1 / (m_R (1 - pbar)), about 40x, here."""
    reps = 300
    ests = []
    for r in range(reps):
        rng = np.random.default_rng([r, 34])
        ests.append(ce_is(_random_failure(rng, _region), 2, 200, rng, **STUDY_CE).estimate)
    ps = np.array([e.p for e in ests])
    assert abs(ps.mean() - P_RANDOM) < 4 * ps.std() / np.sqrt(reps)  # unbiased
    covered = np.mean([e.covers(P_RANDOM) for e in ests])
    assert 0.75 <= covered <= 0.9  # under-covers: the stated 95 % is not met here
    true_re = ps.std() / P_RANDOM
    mc_trials = (1 - P_RANDOM) / (P_RANDOM * true_re ** 2)
    assert 1.0 < mc_trials / 200 < 3.0  # a real gain over plain Monte Carlo, far below the ideal
    reported = np.median([e.rel_error for e in ests if e.p > 0])
    assert reported < 0.6 * true_re  # one run's relative error is optimistic


def test_a_failure_the_parameters_do_not_move_leaves_nothing_to_gain():
    """p(theta) = 0.03 everywhere (failure decided by the nuisance alone): importance sampling over
    the parameters is no better than plain Monte Carlo on the same trials (the old domain's case)."""
    reps, n = 300, 200
    ps = []
    for r in range(reps):
        rng = np.random.default_rng([r, 35])
        ps.append(ce_is(_random_failure(rng, lambda z: np.full(len(z), 0.03)), 2, n, rng, **STUDY_CE).estimate.p)
    true_re = np.std(ps) / 0.03
    assert true_re > 0.9 * np.sqrt(0.97 / (0.03 * n))  # at least plain Monte Carlo's relative error


def test_best_is_gain_matches_the_closed_forms():
    # failure a deterministic function of theta: the best proposal (the nominal restricted to the
    # failure region) has zero variance
    assert best_is_gain(np.r_[np.ones(3), np.zeros(97)]) == np.inf
    # the same failure rate everywhere: nothing to gain
    assert best_is_gain(np.full(50, 0.02)) == pytest.approx(1.0)
    # a region of nominal mass m failing at rate a, nothing elsewhere: (1 - m a) / (m (1 - a))
    m, a = 0.05, 0.4
    p = np.r_[np.full(50, a), np.zeros(950)]
    assert best_is_gain(p) == pytest.approx((1 - m * a) / (m * (1 - a)))
    assert np.isnan(best_is_gain(np.zeros(10)))


def test_binned_failure_rate_sees_a_tail_and_ignores_what_is_not_in_the_parameter():
    rng = np.random.default_rng(7)
    z = rng.standard_normal(20000)
    tail = z < -2.0  # fails exactly in the first bin
    rate = binned_failure_rate(z, tail)
    assert np.array_equal(rate, tail.astype(float))
    assert best_is_gain(rate) == np.inf
    # failures drawn independently of the parameter (the terrain carries them): the bound stays near 1
    coin = rng.random(z.size) < 0.03
    assert 1.0 <= best_is_gain(binned_failure_rate(z, coin)) < 1.1


def test_mixture_weights_are_the_nominal_over_the_stages_mixture():
    rng = np.random.default_rng(3)
    props = [GaussianProposal((0.0, 0.0), (2.5, 2.5)), GaussianProposal((-2.0, 0.3), (1.0, 1.2))]
    sizes = [30, 10]
    z = rng.standard_normal((50, 2)) * 2
    phi = stats.multivariate_normal(np.zeros(2), np.eye(2)).pdf(z)
    q = [stats.multivariate_normal(p.mean, np.diag(np.square(p.sd))).pdf(z) for p in props]
    mix = (30 * q[0] + 10 * q[1]) / 40
    assert np.allclose(np.exp(mixture_log_weight(z, props, sizes)), phi / mix, rtol=1e-12)
    # one stage: its own likelihood ratio
    assert np.allclose(mixture_log_weight(z, props[:1], [30]), props[0].log_weight(z), rtol=1e-12, atol=1e-12)


def test_the_site_study_uses_the_settings_tested_here_and_they_beat_the_first_ones_on_its_model():
    """experiments/failure-search-site.toml: a fixed site, where failure is a function of the
    parameters (its pilot: failure below a friction of about 0.23 at every cruise speed). On that
    model, over 200 runs of 200 trials, the mixture-weighted two-stage scheme has the smaller
    spread of estimates (the honest relative error, not one run's stated one) and its 95 %
    intervals cover at their rate."""
    from pathlib import Path

    from offroadbench.config import load_toml
    from offroadbench.search import search_from_data

    cfg = search_from_data(load_toml(Path(__file__).resolve().parents[2] / "experiments" / "failure-search-site.toml")).search
    assert dict(stage_size=cfg.ce_stage_size, quantile=cfg.ce_quantile, max_stages=cfg.ce_max_stages,
                min_failures=cfg.ce_min_failures, initial_sd=cfg.ce_initial_sd, defensive=cfg.ce_defensive,
                min_stages=cfg.ce_min_stages, pool_weights=cfg.ce_pool_weights) == SITE_CE
    truth = float(cfg.params[0].cdf(np.array([0.23]))[0])

    def margin(z):
        return cfg.from_z(z)[:, 0] - 0.23

    spread = {}
    for name, kw in (("site", SITE_CE), ("first", STUDY_CE)):
        ests = [ce_is(margin, 2, 200, np.random.default_rng([7, r]), **kw).estimate for r in range(200)]
        ps = np.array([e.p for e in ests])
        spread[name] = float(np.sqrt(np.mean((ps - truth) ** 2)) / truth)
        if name == "site":
            assert stats.binom.ppf(0.001, 200, 0.95) <= sum(e.covers(truth) for e in ests)
    assert spread["site"] < spread["first"]
    # plain Monte Carlo needs (1 - p) / (p r^2) trials for the site scheme's spread r: over 5x its 200
    assert (1 - truth) / (truth * spread["site"] ** 2) > 5 * 200


# ---------------------------------------------------------------- the standard gain and the skew-aware interval
def test_the_gain_is_the_work_normalised_variance_ratio_at_a_common_p():
    from offroadbench.search.estimators import is_gain

    # plain Monte Carlo judged as an importance sampler (weights 1) gains nothing over itself
    p, n = 0.02, 500
    assert is_gain(p, p * (1 - p) / n, n) == pytest.approx(1.0)
    # the committed site run's A* stream at the boundary reference 0.0224: se = 0.156 x 0.02326 on 200 trials
    se = 0.15591928694133889 * 0.023255874292580917
    assert is_gain(0.0224, se ** 2, 200) == pytest.approx(0.0224 * 0.9776 / (200 * se ** 2))
    assert 8.2 < is_gain(0.0224, se ** 2, 200) < 8.4  # the reviewer's 8.3x, not the mixed-probability 6.8x
    assert np.isnan(is_gain(0.0, 1e-6, 200)) and np.isnan(is_gain(0.02, 0.0, 200))


#: analytic problems at small budgets, where the final draws' terms are skewed (few failures, weights
#: up to 1 / defensive): (dimension, margin, p, ce_is settings, budget)
SKEWED = {
    "tail-1d, 300 trials": (1, PROBLEMS["tail-1d"][1], P, dict(stage_size=100), 300),
    "plane-2d, 400 trials": (2, PROBLEMS["plane-2d"][1], P, dict(stage_size=100), 400),
    "tail-1d, 150 trials": (1, PROBLEMS["tail-1d"][1], P, dict(stage_size=50), 150),
}


def _site_problem():
    from pathlib import Path

    from offroadbench.config import load_toml
    from offroadbench.search import search_from_data

    cfg = search_from_data(load_toml(Path(__file__).resolve().parents[2] / "experiments" / "failure-search-site.toml")).search
    return (2, lambda z: cfg.from_z(z)[:, 0] - 0.23, float(cfg.params[0].cdf(np.array([0.23]))[0]), SITE_CE, 200)


@pytest.mark.parametrize("name", [*SKEWED, "site model, 200 trials"])
def test_the_bootstrap_t_interval_covers_at_its_stated_rate_where_the_terms_are_skewed(name):
    """The studentized bootstrap over the final draws (estimators.bootstrap_t_interval) holds the
    known p in 95 % of 300 runs (binomial check), on problems where the normal interval's ends are
    off (measured on these seeds: the normal interval covers 91-93 %)."""
    from offroadbench.search.estimators import bootstrap_t_interval

    d, fn, p, kw, budget = SKEWED[name] if name in SKEWED else _site_problem()
    runs = [ce_is(fn, d, budget, np.random.default_rng([d, budget, r]), **kw) for r in range(REPS)]
    intervals = [bootstrap_t_interval(r.final_failed, r.final_log_w) for r in runs]
    covered = sum(lo <= p <= hi for lo, hi in intervals)
    assert binomial_ok(covered, REPS), f"{name}: {covered} of {REPS} bootstrap-t intervals hold p = {p}"
    # it follows the skew: the upper end lies further from the estimate than the lower one, on the median run
    ups = np.array([hi - r.estimate.p for r, (lo, hi) in zip(runs, intervals, strict=True)])
    downs = np.array([r.estimate.p - lo for r, (lo, hi) in zip(runs, intervals, strict=True)])
    assert np.median(ups / downs) > 1.0
    # and the same check refuses the intervals shrunk to a third about the estimate
    shrunk = sum(r.estimate.p - (r.estimate.p - lo) / 3 <= p <= r.estimate.p + (hi - r.estimate.p) / 3
                 for r, (lo, hi) in zip(runs, intervals, strict=True))
    assert not binomial_ok(shrunk, REPS)


def test_the_bootstrap_t_interval_of_equal_terms_is_the_point_and_needs_two_failures():
    from offroadbench.search.estimators import bootstrap_t_interval

    lo, hi = bootstrap_t_interval(np.ones(50, bool), np.zeros(50))  # every term 1: no spread
    assert lo == pytest.approx(1.0) and hi == pytest.approx(1.0)
    assert all(np.isnan(bootstrap_t_interval(np.r_[True, np.zeros(99, bool)], np.zeros(100))))
    # a symmetric case: nominal draws (weights 1) at p = 0.3 on 400 draws, close to the normal interval
    f = np.random.default_rng(4).random(400) < 0.3
    lo, hi = bootstrap_t_interval(f, np.zeros(400))
    e = is_estimate(f, np.zeros(400))
    assert lo == pytest.approx(e.low, abs=0.006) and hi == pytest.approx(e.high, abs=0.006)
