"""The falsifier's baselines (offroadbench.search.baselines) and failure modes
(offroadbench.search.modes) on problems whose answers are known."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from offroadbench.search.baselines import (isotonic_decreasing, measured_boundary, median_interval, model_streams,
                                           nominal_draws, pool_streams, ratio_interval, trials_to_k, uniform_box)
from offroadbench.search.modes import correlation_ratio, failure_modes, mode_table, sensitivity, single_linkage
from offroadbench.search.space import SearchConfig, SearchParam

FRICTION = SearchParam(key="sim.terrain_friction", low=0.1, high=1.0, nominal="normal", mean=0.6, sd=0.2)
SPEED = SearchParam(key="controller.cruise_speed_m_s", low=0.5, high=1.0, nominal="normal", mean=0.8, sd=0.1)
CFG = SearchConfig(params=(FRICTION, SPEED), distinct_distance=0.05)


def test_trials_to_k_counts_failures_and_distinct_ones():
    f = np.array([0, 1, 0, 1, 1, 0, 1], bool)
    assert trials_to_k(f, 1) == 2 and trials_to_k(f, 3) == 5 and math.isinf(trials_to_k(f, 5))
    u = np.array([[0, 0], [0.1, 0.1], [0, 0], [0.12, 0.1], [0.5, 0.5], [0, 0], [0.9, 0.9]])
    assert trials_to_k(f, 2, u, 0.05) == 5  # the failure at trial 4 is within 0.05 of trial 2's


def test_median_interval_has_its_binomial_coverage():
    lo, hi, cov = median_interval(np.arange(1, 6))  # 5 values: only [min, max], 1 - 2 / 32
    assert (lo, hi) == (1, 5) and cov == pytest.approx(1 - 2 / 32)
    lo, hi, cov = median_interval(np.arange(1, 21))  # 20 values: [X_(6), X_(15)], 95.9 %
    assert (lo, hi) == (6, 15) and cov == pytest.approx(1 - 2 * stats.binom.cdf(5, 20, 0.5))
    # it holds the median of a skewed distribution at least at its rate (exponential, median log 2)
    rng = np.random.default_rng(0)
    held = [lo <= math.log(2) <= hi for lo, hi, _ in (median_interval(rng.exponential(size=20)) for _ in range(2000))]
    assert np.mean(held) >= 0.95 - 3 * np.sqrt(0.05 * 0.95 / 2000)
    r, lo, hi, cov = ratio_interval(np.full(9, 100.0), np.array([10.0, 20, 25, 40, 50]))
    assert r == pytest.approx(4.0) and lo == pytest.approx(2.0) and hi == pytest.approx(10.0)


def test_pool_orders_of_independent_draws_follow_the_negative_binomial():
    rng = np.random.default_rng(1)
    pool = rng.random(20000) < 0.05
    n = pool_streams(pool, 3, 3000, rng)
    # trials to the 3rd failure: 3 + NegBin(3, p)
    assert np.median(n) == pytest.approx(3 + stats.nbinom(3, 0.05).median(), rel=0.05)


def test_isotonic_fit_pools_violators():
    u = np.array([0.1, 0.2, 0.3, 0.4])
    _, fit = isotonic_decreasing(u, np.array([1, 0, 1, 0]))
    assert fit.tolist() == [1.0, 0.5, 0.5, 0.0]
    assert np.all(np.diff(isotonic_decreasing(*np.random.default_rng(2).random((2, 50)))[1]) <= 0)


def _threshold_trials(rng, n, cut=0.2, band=(0.19, 0.22), frac=0.6):
    x = uniform_box(CFG)(n, rng)
    f = x[:, 0] < band[0]
    inside = (x[:, 0] >= band[0]) & (x[:, 0] <= band[1])
    f[inside] = rng.random(inside.sum()) < frac
    return x, f


def test_the_measured_boundary_gives_the_probability_of_a_threshold_failure():
    rng = np.random.default_rng(3)
    x, f = _threshold_trials(rng, 4000)
    b = measured_boundary(x[:, 0], f)
    assert 0.19 <= b.low <= 0.192 and 0.218 <= b.high <= 0.22
    lo, hi = b.bracket(FRICTION)
    truth = float(FRICTION.cdf(np.array([0.19]))[0] + 0.6 * np.diff(FRICTION.cdf(np.array([0.19, 0.22])))[0])
    assert lo <= truth <= hi
    assert b.probability(FRICTION) == pytest.approx(truth, abs=0.15 * (hi - lo))
    assert b.box_probability(FRICTION) == pytest.approx((0.09 + 0.6 * 0.03) / 0.9, abs=0.003)
    # streams computed from it: trials to the first failure of uniform draws ~ Geometric(box P)
    n = model_streams(CFG, b, uniform_box(CFG), 1, 4000, rng)
    assert np.mean(n) == pytest.approx(1 / b.box_probability(FRICTION), rel=0.06)
    # nominal draws need more: their P is the nominal one
    m = model_streams(CFG, b, nominal_draws(CFG), 1, 2000, rng)
    assert np.mean(m) == pytest.approx(1 / b.probability(FRICTION), rel=0.08)
    with pytest.raises(ValueError):
        measured_boundary(x[:, 0], np.zeros(len(x), bool))


def test_a_failure_at_high_values_is_measured_on_the_mirrored_parameter():
    """Failure above a cruise speed of 0.95 (uniform draws, a clean cut): P = 1 - F(0.95) under the
    nominal, the box's 0.05 / 0.5, and the certain region is above the cut."""
    rng = np.random.default_rng(6)
    x = uniform_box(CFG)(3000, rng)
    failed = x[:, 1] > 0.95
    b = measured_boundary(x[:, 1], failed, index=1)
    assert b.sign == -1 and "above" in b.describe()
    truth = 1 - float(SPEED.cdf(np.array([0.95]))[0])
    assert b.probability(SPEED) == pytest.approx(truth, abs=2e-3)
    assert b.box_probability(SPEED) == pytest.approx(0.1, abs=2e-3)
    assert b.certain(np.array([0.99, 0.5])).tolist() == [True, False]
    assert b.certain_mass(SPEED) == pytest.approx(truth, abs=2e-3)


def test_sensitivity_finds_the_parameter_that_carries_the_failure_and_only_it():
    rng = np.random.default_rng(4)
    z = rng.standard_normal((1600, 2))
    x = CFG.from_z(z)
    failed = x[:, 0] < 0.21  # friction decides, the speed does not
    sens = sensitivity(x, failed, CFG.keys, "random", permutations=199)
    assert [s.active for s in sens] == [True, False]
    assert sens[0].eta2 > 10 * sens[0].threshold
    assert sens[1].eta2 < sens[1].threshold
    # under independence eta^2 is about (B - 1) / (n - 1)
    null = [correlation_ratio(rng.random(1600), rng.random(1600) < 0.03) for _ in range(300)]
    assert np.mean(null) == pytest.approx(9 / 1599, rel=0.15)


def test_failures_at_one_friction_and_many_speeds_are_one_mode_and_two_frictions_are_two():
    x = np.column_stack([np.r_[np.full(10, 0.15), np.full(3, 0.8)], np.r_[np.linspace(0.5, 1.0, 10), [0.6, 0.7, 0.8]]])
    df = pd.DataFrame({"sim.terrain_friction": x[:, 0], "controller.cruise_speed_m_s": x[:, 1],
                       "failure_reason": "stuck", "method": "falsify", "cell": np.arange(len(x))})
    one = failure_modes(df, CFG, ["sim.terrain_friction"])
    assert one.nunique() == 2 and one.iloc[:10].nunique() == 1
    both = failure_modes(df, CFG, list(CFG.keys))  # the speed kept: ten points 0.11 of its range apart
    assert both.nunique() == 10 + 3
    table = mode_table(df, one, CFG, ["sim.terrain_friction"])
    assert table["failures"].tolist() == [10, 3]
    assert table.loc[0, "representative cell"] in range(10)


def test_single_linkage_chains_close_points():
    u = np.array([[0.0], [0.04], [0.08], [0.3]])
    assert single_linkage(u, 0.05).tolist() == [0, 0, 0, 1]
    assert single_linkage(u, 0.03).tolist() == [0, 1, 2, 3]


def test_the_gain_from_repeats_is_one_for_plain_monte_carlo_and_its_interval_holds_it():
    from offroadbench.search.evaluate import spread_gain

    rng = np.random.default_rng(5)
    p, n = 0.02, 200
    ps = rng.binomial(n, p, size=400) / n  # 400 repeats of plain Monte Carlo on 200 trials
    rmse, gain, lo, hi = spread_gain(ps, p, n)
    assert gain == pytest.approx(1.0, rel=0.15) and lo < 1.0 < hi
    assert rmse == pytest.approx(np.sqrt((1 - p) / (n * p)), rel=0.1)
    # twenty repeats of an estimator with a tenth of that variance: a gain near 10, an honest interval
    ps = p + rng.normal(0, np.sqrt(p * (1 - p) / n / 10), size=20)
    _, gain, lo, hi = spread_gain(ps, p, n)
    assert lo < 10 < hi and lo > 4
