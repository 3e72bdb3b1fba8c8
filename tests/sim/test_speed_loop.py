"""The speed loop in the engines (issue 28): on flat lunar regolith a 15 m mission at 1 m/s takes at
most 1.3x its rigid-ground time in lunar and Earth gravity, and on rigid flat ground the loop holds
the commanded speed within 2 % and stops at the goal."""

import math

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.metrics import roll_pitch_yaw_from_quat
from offroadbench.navigation.missions import Mission

ENGINES = ("pybullet", "mujoco")
#: the done-when bound of issue 28: soil time / rigid time on the same flat map
SOIL_TIME_RATIO = 1.3


@pytest.fixture(scope="module")
def flat():
    return Heightmap.flat(81, 221, 0.1)  # 8 m x 22 m


def _sim(engine: str, tyre_model: str, gravity: float):
    from offroadbench.sim import SimConfig

    if engine == "mujoco":
        pytest.importorskip("mujoco")
    try:
        return SimConfig(engine=engine, tyre_model=tyre_model, soil="lunar-regolith", gravity_m_s2=gravity)
    except InputError as exc:  # the soil on MuJoCo is issue 28 item 5 (helper "arch"); refused until it lands
        if engine == "mujoco" and tyre_model == "terramechanics":
            pytest.skip(f"the terramechanics tyre model is refused on MuJoCo here: {exc}")
        raise


def _trial(hm, sim):
    from offroadbench.sim import open_world
    from offroadbench.sim.trial.runner import drive_mission

    with open_world(hm, "husky", sim) as world:
        result = drive_mission(world, Mission.between(0, (2.5, 4.0), (17.5, 4.0))).result
    assert result.success, result.failure_reason
    return result


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("gravity", [1.62, 9.81])
def test_flat_regolith_costs_at_most_30_percent_over_rigid_ground(flat, engine, gravity):
    """Before the reference-tracking loop: 29.6 s against 15.5 s (lunar), 22.6 s against 15.0 s
    (Earth) on PyBullet, the command throttled to 0.6-0.7 m/s by the slip."""
    soil = _trial(flat, _sim(engine, "terramechanics", gravity))
    rigid = _trial(flat, _sim(engine, "coulomb", gravity))
    assert soil.traversal_time_s <= SOIL_TIME_RATIO * rigid.traversal_time_s, (soil, rigid)
    # the soil metrics of the trial row: over the moving samples, the median below the 95th percentile
    # below the transient maximum; slip finite on soil, NaN on rigid ground
    assert 0.0 < soil.sinkage_median_m <= soil.sinkage_p95_m <= soil.max_penetration_m
    assert 0.0 < soil.mean_slip < 0.5 and math.isnan(rigid.mean_slip) and math.isnan(rigid.sinkage_median_m)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("vehicle", ["husky", "jackal"])
def test_rigid_ground_holds_the_commanded_speed_and_stops_at_the_goal(flat, engine, vehicle):
    """Coulomb tyres, Earth gravity, 1 m/s cruise (the Husky's top speed; the Jackal's is 2 m/s): the
    mean speed along the path over 3-12 m is within 2 % of 1 m/s, and the vehicle comes to rest
    within 0.15 m of the goal (no goal tolerance ends this run: the loop alone stops it). Single
    samples are not bounded: the Jackal bounces on PyBullet's contacts (2 % standard deviation of
    the speed with the old loop as with this one)."""
    from offroadbench.sim import ControllerConfig, open_world
    from offroadbench.sim.trial.controller import LineTracker
    from offroadbench.sim.trial.skid_steer import wheel_speeds

    sim = _sim(engine, "coulomb", 9.81)
    start, goal = np.array([2.5, 4.0]), np.array([17.5, 4.0])
    with open_world(flat, vehicle, sim) as world:
        world.spawn(*start, 0.0)
        tracker = LineTracker(start, goal, world.spec, ControllerConfig())
        every = sim.physics_rate_hz // 20
        speeds, prog = [], []
        for k in range(25 * sim.physics_rate_hz):
            if k % every == 0:
                pos, quat, lin, _ = world.base_state()
                yaw = float(roll_pitch_yaw_from_quat(np.array(quat))[2])
                v, w, s = tracker.command(np.array(pos[:2]), yaw, np.array(lin[:2]))
                world.command_wheels(*wheel_speeds(v, w, world.spec))
                speeds.append(lin[0])
                prog.append(s)
            world.step()
        pos, _, lin, _ = world.base_state()
    speeds, prog = np.array(speeds), np.array(prog)
    cruise = speeds[(prog > 3.0) & (prog < 12.0)]
    assert len(cruise) > 100 and cruise.mean() == pytest.approx(1.0, rel=0.02)
    assert math.hypot(pos[0] - goal[0], pos[1] - goal[1]) < 0.15
    assert math.hypot(lin[0], lin[1]) < 0.02
