"""Terrain-level statistics against worked examples from the literature and against their definitions."""

import math

import numpy as np
import pytest

from offroadbench.study.stats.clustered import (
    breaking_point_logistic,
    cluster_bootstrap,
    durkalski_mcnemar,
    fit_logistic,
    holm,
    obuchowski_mcnemar,
    paired_power,
    terrains_needed,
    sign_flip_test,
    wilcoxon_test,
)

# Obuchowski (1998): PET and SPECT on the parathyroid glands of 21 patients (true negatives per
# gland), as distributed in the R package clust.bin.pair (data "thyroids"). Per patient: b = glands
# only PET called negative, c = glands only SPECT called negative.
THYROID_B = [0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
THYROID_C = [2, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 1, 0, 0, 0]


def test_obuchowski_matches_the_published_thyroid_example():
    # clust.bin.pair's documented example on this data: chi-square = 2.8571, df = 1, p = 0.09097
    stat, p = obuchowski_mcnemar(THYROID_B, THYROID_C)
    assert stat == pytest.approx(2.8571, abs=1e-4)
    assert p == pytest.approx(0.09097, abs=1e-5)


def test_durkalski_is_mcnemar_with_one_pair_per_cluster():
    # McNemar (1947): (b - c)^2 / (b + c); Durkalski et al. (2003) reduce to it for clusters of size 1
    b = [1] * 9 + [0] * 3 + [0] * 10
    c = [0] * 9 + [1] * 3 + [0] * 10
    stat, p = durkalski_mcnemar(b, c)
    assert stat == pytest.approx((9 - 3) ** 2 / (9 + 3))
    assert p == pytest.approx(math.erfc(math.sqrt(stat / 2)))


def test_durkalski_with_equal_cluster_sizes_is_obuchowski_times_k_over_k_minus_1():
    # Yang et al. (2010): the two differ only by (K - 1) / K when every cluster has the same size
    stat_d, _ = durkalski_mcnemar(THYROID_B, THYROID_C, [3] * 21)
    stat_o, _ = obuchowski_mcnemar(THYROID_B, THYROID_C)
    assert stat_d == pytest.approx(stat_o * 21 / 20)


def test_durkalski_on_the_planner_stress_pilot():
    # per-terrain discordant pairs of astar vs straight at D_high 2.9 (issue 22): differences
    # [7, 1, 1, 1, 1, 2] of 8 missions each: X^2 = 13^2 / 57, p = 0.085
    stat, p = durkalski_mcnemar([7, 1, 1, 1, 1, 2], [0] * 6, [8] * 6)
    assert stat == pytest.approx(169 / 57)
    assert p == pytest.approx(0.085, abs=5e-4)
    assert durkalski_mcnemar([0, 0], [0, 0]) == (0.0, 1.0)


def test_sign_flip_is_exact_and_bounded_by_the_number_of_clusters():
    # all 6 differences positive: only 2 of the 2^6 sign patterns are as extreme: p = 2 / 64
    assert sign_flip_test([7, 1, 1, 1, 1, 2]) == pytest.approx(2 / 64)
    # Fisher's (1935) enumeration by hand for a small case: d = [3, -1, 2]; |mean| >= 4/3 for the
    # patterns (+,-,+), (-,+,-), (+,+,+), (-,-,-): 4 of 8
    assert sign_flip_test([3, -1, 2]) == pytest.approx(4 / 8)
    assert sign_flip_test([0, 0, 0]) == 1.0
    p = sign_flip_test(np.r_[np.ones(30), -np.ones(5)], rng=np.random.default_rng(1))
    assert p < 1e-3


def test_wilcoxon_signed_rank_exact_values():
    # n = 6 all positive: the exact two-sided p is 2 / 2^6
    assert wilcoxon_test([7, 1.5, 1, 3, 4, 2]) == pytest.approx(2 / 64)
    # W+ = 0 of n = 8 distinct ranks: 2 / 256
    assert wilcoxon_test([-1, -2, -3, -4, -5, -6, -7, -8]) == pytest.approx(2 / 256)
    assert wilcoxon_test([0, 0]) == 1.0


def test_holm_worked_example():
    # Holm (1979) step-down: sorted p 0.005, 0.01, 0.03, 0.04 times 4, 3, 2, 1 -> 0.02, 0.03, 0.06,
    # 0.04 -> monotone 0.02, 0.03, 0.06, 0.06
    adj = holm([0.01, 0.04, 0.03, 0.005])
    assert adj == pytest.approx([0.03, 0.06, 0.06, 0.02])
    adj = holm([0.5, math.nan, 0.9])
    assert math.isnan(adj[1]) and adj[0] == pytest.approx(1.0) and adj[2] == pytest.approx(1.0)


def test_cluster_bootstrap_counts_distinct_resamples():
    rng = np.random.default_rng(0)
    res = cluster_bootstrap(np.array([7, 1, 1, 1, 1, 2.0]), np.mean, rng, n_boot=2000)
    assert res.possible == 462 and res.clusters == 6
    assert res.distinct <= 462 and res.distinct > 300
    assert 1.0 <= res.low <= res.estimate <= res.high <= 7.0
    big = cluster_bootstrap(np.arange(40.0), np.mean, rng, n_boot=500)
    assert big.distinct == 500


def test_logistic_fit_recovers_a_known_breaking_point_and_covers_it():
    # 40 terrains x 5 levels x 8 missions, success ~ logistic(12 (2.9 - D)) plus a terrain effect
    rng = np.random.default_rng(3)
    levels = np.array([2.3, 2.6, 2.8, 2.9, 3.0, 3.1])
    terr = rng.normal(0, 0.5, 40)
    x, y, g = [], [], []
    for j in range(40):
        for d in levels:
            p = 1 / (1 + np.exp(-(12 * (2.9 - d) + terr[j])))
            for _ in range(8):
                x.append(d)
                y.append(rng.random() < p)
                g.append(j)
    fit = fit_logistic(x, y, g)
    assert fit.converged and fit.clusters == 40 and fit.n == 40 * 6 * 8
    assert fit.slope < 0
    point, lo, hi = breaking_point_logistic(fit)
    assert lo < point < hi and lo < 2.9 < hi and hi - lo < 0.1


def test_copies_of_a_trial_inside_its_cluster_add_no_information():
    # 8 identical copies of every trial, each copy in its trial's cluster: the estimate is the same,
    # and the cluster-robust covariance stays that of the originals (up to the CR1 factor), while
    # treating the copies as independent would shrink it 8-fold
    rng = np.random.default_rng(5)
    x = np.repeat([2.3, 2.6, 2.9, 3.0], 30)
    y = rng.random(x.size) < 1 / (1 + np.exp(-8 * (2.85 - x)))
    one = fit_logistic(x, y)
    g = np.arange(x.size)
    copies = fit_logistic(np.repeat(x, 8), np.repeat(y, 8), np.repeat(g, 8))
    naive = fit_logistic(np.repeat(x, 8), np.repeat(y, 8))
    assert copies.slope == pytest.approx(one.slope, rel=1e-6)
    n = x.size
    cr1_one, cr1_copies = (n - 1) / (n - 2), (8 * n - 1) / (8 * n - 2)
    assert copies.cov / cr1_copies == pytest.approx(one.cov / cr1_one, rel=1e-6)
    assert naive.cov[1, 1] == pytest.approx(one.cov[1, 1] / 8, rel=0.03)  # CR1 factors of n and 8n


def test_breaking_point_is_unbounded_when_success_does_not_move():
    rng = np.random.default_rng(4)
    x = np.repeat([2.3, 2.6, 2.9], 200)
    y = rng.random(x.size) < 0.9
    _, lo, hi = breaking_point_logistic(fit_logistic(x, y))
    assert math.isinf(lo) or math.isinf(hi)
    # separated data have no MLE: no breaking point is claimed
    sep = fit_logistic([1, 1, 2, 2], [1, 1, 0, 0])
    assert not sep.converged
    assert all(math.isnan(v) for v in breaking_point_logistic(sep))


def test_one_level_identifies_no_slope():
    # one studied level (vehicle-planner's single D_high): 2.95 repeated is not centred to exact zeros,
    # and the old fit returned a slope of order 1e15 there; no slope, no crossing, no interval
    y = np.random.default_rng(5).random(240) < 0.7
    fit = fit_logistic(np.full(240, 2.95), y, np.repeat(np.arange(24), 10))
    assert not fit.converged and math.isnan(fit.slope) and math.isnan(fit.intercept)
    assert fit.clusters == 24 and fit.n == 240
    assert all(math.isnan(v) for v in breaking_point_logistic(fit))


def test_power_of_the_paired_test_matches_cohens_tables():
    # the textbook one-sample / paired t-test sample sizes (Cohen 1988; G*Power): d = 0.5, two-sided
    # alpha 0.05, power 0.80 -> 34 pairs; d = 0.8 -> 15
    assert terrains_needed(0.5, 1.0) == 34
    assert terrains_needed(0.8, 1.0) == 15
    assert paired_power(34, 0.5, 1.0) >= 0.8 > paired_power(33, 0.5, 1.0)
    # a stricter alpha needs more terrains; no effect has power alpha
    assert terrains_needed(0.5, 1.0, alpha=0.005) > 34
    assert paired_power(20, 0.0, 1.0) == pytest.approx(0.05)
