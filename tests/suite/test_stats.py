"""The score card's statistics against hand-computed values."""

import math

import numpy as np
import pytest

from offroadbench.suite import stats


def test_barn_score_is_nominal_over_the_clipped_time():
    assert stats.barn_score(True, 12.0, 10.0, 1.0, 3.0) == pytest.approx(10 / 12)
    assert stats.barn_score(True, 8.0, 10.0, 1.0, 3.0) == 1.0  # faster than nominal: clipped up to it
    assert stats.barn_score(True, 50.0, 10.0, 1.0, 3.0) == pytest.approx(1 / 3)  # clipped at 3x
    assert stats.barn_score(True, 12.0, 10.0, 2.0, 8.0) == pytest.approx(0.5)  # BARN's own clip
    assert stats.barn_score(False, 12.0, 10.0) == 0.0
    assert stats.barn_score(True, math.nan, 10.0) == 0.0


def test_iqm_is_the_mean_of_the_middle_half():
    assert stats.iqm([0, 1, 2, 3, 4, 5, 6, 100]) == pytest.approx(np.mean([2, 3, 4, 5]))
    assert math.isnan(stats.iqm([]))


def test_stratified_interval_resamples_within_strata():
    # two strata far apart: a stratified resample always holds both, so the pooled mean stays between
    a, b = np.array([0.0, 0.1, 0.2, 0.1]), np.array([1.0, 0.9, 0.8, 0.9])
    lo, hi = stats.stratified_interval([a, b], np.mean, seed=1)
    assert 0.4 < lo <= 0.5 <= hi < 0.6
    pooled_lo, pooled_hi = stats.stratified_interval([np.concatenate([a, b])], np.mean, seed=1)
    assert pooled_hi - pooled_lo > hi - lo  # an unstratified resample varies the mix too
    assert all(math.isnan(x) for x in stats.stratified_interval([[0.3], [0.4]], np.mean))
    lo, hi = stats.stratified_interval([[0.5, 0.5, 0.5], [0.2]], np.mean)  # a single-value stratum stays fixed
    assert lo == pytest.approx(0.425) and hi == pytest.approx(0.425)


def test_sign_flip_p_is_exact_for_few_terrains():
    assert stats.sign_flip_p([0.1, 0.2, 0.3, 0.4]) == pytest.approx(2 / 16)
    assert stats.sign_flip_p([0.0, 0.0]) == 1.0
    assert stats.sign_flip_p([0.1, -0.1]) == pytest.approx(1.0)


def test_performance_profile_counts_scores_above_tau():
    assert stats.performance_profile([0.0, 0.5, 0.9, 1.0], [0.0, 0.5, 0.95]) == [0.75, 0.5, 0.25]
