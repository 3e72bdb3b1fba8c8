"""The drive train's reflected inertia reacts on the chassis as through a gearbox
(offroadbench.sim.engines.pybullet.drivetrain): launching in lunar gravity does not rear the
vehicle up, while the old model (all of it on the wheel link) did."""

import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.sim import SimConfig, World
from offroadbench.sim.trial.runner import drive_mission

FLAT = Heightmap.flat(81, 221, 0.1)
MISSION = Mission.between(0, (2.5, 4.0), (17.5, 4.0))


def launch(vehicle: str, reaction: str, gravity: float = 1.62):
    with World(FLAT, vehicle, SimConfig(gravity_m_s2=gravity, drive_train_reaction=reaction)) as world:
        return drive_mission(world, MISSION).result


@pytest.mark.parametrize("vehicle", ["husky", "jackal"])
def test_a_launch_in_lunar_gravity_stays_level_with_the_geared_drive_train(vehicle):
    # the traction limit mu g = 1.3 m/s^2 holds the acceleration; without the false reaction of
    # the spun-up drive train nothing lifts the nose (MuJoCo's armature: under 1 deg)
    result = launch(vehicle, "gear")
    assert result.success and result.max_abs_pitch_deg < 5.0


def test_the_old_link_model_reared_the_husky_up():
    assert launch("husky", "link").max_abs_pitch_deg > 30.0  # 45 deg: what the gear model removes


def test_on_earth_the_two_models_agree_on_a_level_launch():
    gear, link = launch("husky", "gear", 9.81), launch("husky", "link", 9.81)
    assert gear.success and link.success
    assert abs(gear.traversal_time_s - link.traversal_time_s) < 0.2
    assert max(gear.max_abs_pitch_deg, link.max_abs_pitch_deg) < 2.0


def test_the_link_model_is_pybullet_only():
    with pytest.raises(InputError, match="drive_train_reaction"):
        SimConfig(engine="mujoco", drive_train_reaction="link")
    with pytest.raises(InputError, match="drive_train_reaction"):
        SimConfig(drive_train_reaction="armature")
