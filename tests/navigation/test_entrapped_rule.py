"""The entrapped rule: the wheels turn (slip above a threshold) with little progress towards the goal
over a window, sunk deeper than a multiple of the settled sinkage."""

import pytest

from offroadbench.errors import InputError
from offroadbench.navigation.rules import FAILURE_REASONS, FailureRules, RuleChecker

RULES = FailureRules(entrap_slip=0.6, entrap_progress_radii=1.0, entrap_sinkage_ratio=1.5, entrap_window_s=2.0)
R = 0.165
SETTLED = 0.01  # m: the sinkage at the first sample
GOAL = (40.0, 5.0)


def _checker(radius=R, rules=RULES):
    return RuleChecker(rules, (50.0, 50.0, 0.0), GOAL, timeout_s=100.0, sample_rate_hz=10.0,
                       mission_length_m=35.0, wheel_radius_m=radius)


def _feed(checker, samples, speed_m_s=0.0):
    """A settled sample at rest, then samples (slip, sinkage) every 0.1 s with the base moving
    towards the goal (+x) at ``speed_m_s``; the reason the trial ends, or None."""
    checker.check((5.0, 5.0, 0.2), 0.0, 0.0, 0.0, SETTLED)
    for k, (slip, sink) in enumerate(samples):
        reason = checker.check((5.0 + 0.1 * (k + 1) * speed_m_s, 5.0, 0.2), 0.0, 0.0, slip, sink)
        if reason is not None:
            return reason
    return None


DUG = (0.95, 2.5 * SETTLED)


def test_entrapped_after_the_window_of_slip_no_progress_and_sinkage():
    assert "entrapped" in FAILURE_REASONS
    assert _feed(_checker(), [DUG] * 20) is None  # the window (2 s, 20 samples) needs 21 samples
    assert _feed(_checker(), [DUG] * 21) == "entrapped"


@pytest.mark.parametrize("sample", [(0.5, 2.5 * SETTLED), (0.95, 1.2 * SETTLED), (None, 2.5 * SETTLED),
                                    (0.95, None)])
def test_not_entrapped_below_either_limit_or_without_soil_data(sample):
    assert _feed(_checker(), [sample] * 60) is None


def test_progress_towards_the_goal_is_not_entrapment_but_sliding_back_is():
    # 0.1 m/s towards the goal: 0.2 m per 2 s window, more than one radius (0.165 m)
    assert _feed(_checker(), [DUG] * 60, speed_m_s=0.1) is None
    assert _feed(_checker(), [DUG] * 60, speed_m_s=0.05) == "entrapped"  # 0.1 m per window
    assert _feed(_checker(), [DUG] * 60, speed_m_s=-0.3) == "entrapped"  # sliding back down a slope


def test_an_interruption_restarts_the_window_and_no_radius_disables_the_rule():
    assert _feed(_checker(), [DUG] * 15 + [(0.1, 2.5 * SETTLED)] + [DUG] * 15) is None
    assert _feed(_checker(radius=None), [DUG] * 60) is None


def test_the_median_sinkage_of_the_window_counts_not_a_spike():
    spiky = [(0.95, 1.1 * SETTLED)] * 15 + [(0.95, 10 * SETTLED)] * 6
    assert _feed(_checker(), spiky) is None


def test_entrapped_before_stuck_when_both_hold():
    # both fire at the 12th sample (the stuck window also counts the settled sample at rest)
    rules = FailureRules(stuck_window_s=1.1, entrap_window_s=1.0)
    assert _feed(_checker(rules=rules, radius=None), [DUG] * 11) == "stuck"
    assert _feed(_checker(rules=rules), [DUG] * 11) == "entrapped"


def test_bad_entrapment_settings_are_refused():
    with pytest.raises(InputError, match="entrap_slip"):
        FailureRules(entrap_slip=1.5)
    with pytest.raises(InputError, match="entrap_progress_radii"):
        FailureRules(entrap_progress_radii=0.0)
