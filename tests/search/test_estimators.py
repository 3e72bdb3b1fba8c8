"""The estimators against problems whose failure probability is known exactly.

Coverage checks are binomial: R independent runs (fixed seeds, so the test is deterministic) of
an interval stated at 95 % must cover the truth a number of times inside the central 99.8 % of
Binomial(R, 0.95). The same check is run on a deliberately miscalibrated interval to show it can
fail."""

import numpy as np
import pytest
from scipy import special, stats

from offroadbench.search.estimators import (GaussianProposal, ce_is, distinct_failures, is_estimate, mc_estimate,
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


def _runs(name, budget=2000):
    d, fn = PROBLEMS[name]
    return [ce_is(fn, d, budget, np.random.default_rng([d, budget, r]), stage_size=100).estimate for r in range(REPS)]


@pytest.mark.parametrize("name", sorted(PROBLEMS))
def test_ce_is_interval_covers_the_known_probability_at_its_stated_rate(name):
    ests = _runs(name)
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
