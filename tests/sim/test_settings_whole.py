"""The trial loop takes the TrialSettings whole: its pieces given by keyword make the same settings
and drive the same trial; giving both is refused; the failure rules in the settings decide the end."""

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.rules import FailureRules
from offroadbench.sim import World
from offroadbench.sim.config import ControllerConfig
from offroadbench.sim.trial.runner import drive_mission, settings_of

RULES = FailureRules(timeout_factor=1.2, goal_tolerance_m=0.3)
CONTROLLER = ControllerConfig(cruise_speed_m_s=0.6)


@pytest.fixture(scope="module")
def world():
    y, x = np.mgrid[0:81, 0:241] * 0.05
    hm = Heightmap(0.03 * np.sin(2 * np.pi * x / 1.1) + 0.02 * np.sin(2 * np.pi * (x + y) / 0.7), 0.05)
    with World(hm) as w:
        yield w


def test_pieces_by_keyword_and_the_settings_whole_drive_the_same_trial(world):
    mission = Mission.between(0, (2, 2), (8, 2))
    by_pieces = drive_mission(world, mission, rules=RULES, controller=CONTROLLER, border_m=0.5)
    settings = settings_of(world, rules=RULES, controller=CONTROLLER, border_m=0.5)
    assert settings.rules is RULES and settings.controller is CONTROLLER and settings.missions.border_m == 0.5
    assert settings.vehicle is world.spec and settings.sim is world.sim
    whole = drive_mission(world, mission, settings=settings)
    assert whole.result == by_pieces.result
    for k, col in by_pieces.telemetry.items():
        np.testing.assert_array_equal(whole.telemetry[k], col)


def test_the_rules_in_the_settings_end_the_trial(world):
    mission = Mission.between(0, (2, 2), (8, 2))
    settings = settings_of(world, controller=CONTROLLER)
    free = drive_mission(world, mission, settings=settings)
    assert free.result.success
    # a goal tolerance of 3 m, given whole in the rules: the trial ends as a success 3 m short
    near = drive_mission(world, mission, settings=settings.replace(rules=FailureRules(goal_tolerance_m=3.0)))
    assert near.result.success
    x, y = near.telemetry["x_m"][-1], near.telemetry["y_m"][-1]
    assert 2.7 < np.hypot(8 - x, 2 - y) <= 3.0
    assert near.result.traversal_time_s < free.result.traversal_time_s - 3.0


def test_settings_and_their_pieces_are_not_given_twice(world):
    with pytest.raises(InputError, match="rules"):
        drive_mission(world, Mission.between(0, (2, 2), (8, 2)), settings=settings_of(world), rules=RULES)
