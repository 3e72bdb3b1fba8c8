"""The entrapped rule: slip above a threshold with sinkage above a fraction of the wheel radius for a window."""

import pytest

from offroadbench.errors import InputError
from offroadbench.navigation.rules import FAILURE_REASONS, FailureRules, RuleChecker

RULES = FailureRules(entrap_slip=0.8, entrap_sinkage_fraction=0.3, entrap_window_s=2.0)
R = 0.165


def _checker(radius=R):
    return RuleChecker(RULES, (50.0, 50.0, 0.0), (40.0, 40.0), timeout_s=100.0, sample_rate_hz=10.0,
                       mission_length_m=40.0, wheel_radius_m=radius)


def _feed(checker, samples):
    """samples: (slip, sinkage) per 0.1 s at a fixed spot; the reason the trial ends, or None."""
    for slip, sink in samples:
        reason = checker.check((5.0, 5.0, 0.2), 0.0, 0.0, slip, sink)
        if reason is not None:
            return reason
    return None


def test_entrapped_after_the_window_of_slip_and_sinkage():
    assert "entrapped" in FAILURE_REASONS
    dug = (0.95, 0.4 * R)
    assert _feed(_checker(), [dug] * 19) is None
    assert _feed(_checker(), [dug] * 20) == "entrapped"


@pytest.mark.parametrize("sample", [(0.7, 0.5 * R), (0.95, 0.2 * R), (None, 0.5 * R), (0.95, None)])
def test_not_entrapped_below_either_limit_or_without_soil_data(sample):
    assert _feed(_checker(), [sample] * 40) is None


def test_an_interruption_restarts_the_window_and_no_radius_disables_the_rule():
    dug = (0.95, 0.4 * R)
    assert _feed(_checker(), [dug] * 15 + [(0.1, 0.4 * R)] + [dug] * 15) is None
    assert _feed(_checker(radius=None), [dug] * 40) is None


def test_entrapped_before_stuck_when_both_hold():
    checker = RuleChecker(FailureRules(stuck_window_s=1.0, entrap_window_s=1.0), (50.0, 50.0, 0.0), (40.0, 40.0),
                          timeout_s=100.0, sample_rate_hz=10.0, mission_length_m=40.0, wheel_radius_m=R)
    assert _feed(checker, [(0.95, 0.4 * R)] * 30) == "entrapped"


def test_bad_entrapment_settings_are_refused():
    with pytest.raises(InputError, match="entrap_slip"):
        FailureRules(entrap_slip=1.5)
