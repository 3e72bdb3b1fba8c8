"""Physics sanity tests of the traversal trials (issue 3): short missions on small maps, on every
physics engine (offroadbench.sim.engine; MuJoCo when installed)."""

import importlib.util
import math

import numpy as np
import pytest

from offroadbench.analysis.roughness import RoughnessConfig, classify, close_rough
from offroadbench.heightmap import Heightmap
from offroadbench.io.telemetry import load_telemetry
from offroadbench.navigation.missions import Mission, MissionConfig, sample_missions
from offroadbench.sim import (FAILURE_REASONS, TELEMETRY_COLUMNS, ControllerConfig, FailureRules, SimConfig, World,
                              open_world, run_mission, run_missions)
from offroadbench.sim.trial.skid_steer import achievable_twist, wheel_speeds

CELL = 0.05

#: every engine, MuJoCo skipped when its package is missing
ENGINES = ["pybullet", pytest.param("mujoco", marks=pytest.mark.skipif(
    importlib.util.find_spec("mujoco") is None, reason="mujoco not installed (pip install 'offroadbench[mujoco]')"))]


def _strip(z_of_x: np.ndarray, rows: int = 81) -> Heightmap:
    """A 4 m wide strip whose height depends on x only."""
    return Heightmap(np.tile(z_of_x, (rows, 1)), CELL)


def _drive(hm, mission, engine="pybullet", **kw):
    with open_world(hm, "husky", SimConfig(engine=engine)) as world:
        return run_mission(world, mission, **kw)


@pytest.mark.parametrize("engine", ENGINES)
def test_flat_ground_10_m_in_about_10_s_with_quiet_attitude(engine):
    r, tel = _drive(Heightmap.flat(81, 321, CELL, z_m=0.4), Mission.between(0, (3, 2), (13, 2)), engine)
    assert r.success and r.failure_reason == ""
    # 9.5 m to the 0.5 m goal circle at 1 m/s plus the jerk-limited ramps at both ends
    assert 9.5 <= r.traversal_time_s <= 11.5
    assert r.path_length_m == pytest.approx(9.5, abs=0.2)
    assert r.max_abs_roll_deg < 1 and r.max_abs_pitch_deg < 2
    assert r.rms_pitch_rate_deg_s < 2.5 and r.rms_roll_rate_deg_s < 2.5  # paper's smoothest terrain: ~17, ~11
    assert r.rms_vertical_accel_m_s2 < 0.4
    assert np.abs(tel["y_m"] - 2.0).max() < 0.1  # stays on the line
    assert 0.99 < tel["cmd_v_m_s"].max() <= 1.0
    assert np.allclose(np.diff(tel["t_s"]), 0.05)  # 20 Hz telemetry
    assert set(tel) == set(TELEMETRY_COLUMNS)


@pytest.mark.parametrize("engine", ENGINES)
def test_15_degree_ramp_is_climbed(engine):
    x = np.arange(321) * CELL
    hm = _strip(np.tan(np.radians(15)) * np.clip(x - 4.0, 0, None))
    r, tel = _drive(hm, Mission.between(0, (2, 2), (13, 2)), engine)
    assert r.success
    assert r.max_abs_pitch_deg == pytest.approx(15, abs=2.5)  # it really was on the ramp
    assert tel["z_m"][-1] - tel["z_m"][0] > 2.0


@pytest.mark.parametrize("engine", ENGINES)
def test_vertical_wall_ends_stuck(engine):
    x = np.arange(501) * CELL
    hm = _strip(np.where(x >= 8.0, 1.0, 0.0))  # a 1 m step across the path
    r, tel = _drive(hm, Mission.between(0, (3, 2), (23, 2)), engine)
    assert r.failure_reason == "stuck" and not r.success
    assert math.isnan(r.traversal_time_s)
    # stuck is declared once the vehicle has stayed within 0.2 m for 30 s
    assert 30.0 < r.sim_time_s < 40.0
    assert tel["x_m"].max() < 8.0


@pytest.mark.parametrize("engine", ENGINES)
def test_vehicle_spawned_on_its_side_ends_tipped(engine):
    r, _ = _drive(Heightmap.flat(81, 321, CELL), Mission.between(0, (3, 2), (13, 2)), engine, spawn_roll_rad=math.pi / 2)
    assert r.failure_reason == "tipped"
    assert r.max_abs_roll_deg > 75


@pytest.mark.parametrize("engine", ENGINES)
def test_driving_off_the_edge_ends_off_map(engine):
    r, tel = _drive(Heightmap.flat(81, 321, CELL), Mission.between(0, (3, 2), (25, 2)), engine)  # goal beyond x = 16 m
    assert r.failure_reason == "off_map"
    assert tel["x_m"][-1] > 16.0 - 0.5


def test_stuck_fires_on_a_6_m_mission():
    """The paper's 30 s window would never fire before the 18 s timeout; the capped window (9 s) does."""
    x = np.arange(241) * CELL
    hm = _strip(np.where(x >= 5.0, 1.0, 0.0))  # a 1 m step 3 m ahead
    r, tel = _drive(hm, Mission.between(0, (2, 2), (8, 2)))
    assert r.failure_reason == "stuck"
    assert 9.0 < r.sim_time_s < 18.0 and tel["x_m"].max() < 5.0


def test_timeout_is_a_multiple_of_the_nominal_time():
    x = np.arange(501) * CELL
    hm = _strip(np.where(x >= 8.0, 1.0, 0.0))
    rules = FailureRules(stuck_window_s=1000.0, stuck_window_max_fraction=2.0)  # never stuck: held at the wall until 3 x 20 s
    r, _ = _drive(hm, Mission.between(0, (3, 2), (23, 2)), rules=rules)
    assert r.failure_reason == "timeout" and r.sim_time_s == pytest.approx(60.0, abs=0.02)


@pytest.mark.parametrize("engine", ENGINES)
def test_a_small_step_is_climbed_and_a_high_one_is_not(engine):
    """The Husky climbs 6 cm (well under its 0.13 m belly and 0.165 m tyre radius) and not 30 cm
    (above both), driving at cruise speed from 3 m away."""
    x = np.arange(321) * CELL
    for height, climbs in ((0.06, True), (0.30, False)):
        r, tel = _drive(_strip(np.where(x >= 5.0, height, 0.0)), Mission.between(0, (2, 2), (12, 2)), engine)
        assert r.success == climbs, (height, r.failure_reason)
        assert (tel["x_m"].max() > 6.0) == climbs


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("heading_deg", [0.0, 22.5, 45.0])
def test_yaw_rate_tracks_the_command_at_any_heading(engine, heading_deg):
    """A 1 rad/s turn in place, and a 0.5 rad/s turn at 1 m/s, give the commanded yaw rate (after
    the wheel-speed saturation) within 15 %, whatever the heading against the world axes."""
    with open_world(Heightmap.flat(121, 121, 0.1), "husky", SimConfig(engine=engine)) as world:
        for v, w in ((0.0, 1.0), (1.0, 0.5)):
            world.spawn(6.0, 6.0, math.radians(heading_deg))
            world.command_wheels(*wheel_speeds(v, w, world.spec))
            yaws = []
            for k in range(180):  # 3 s at 60 Hz; the second half counts
                world.step()
                if k >= 90:
                    q = world.base_state()[1]
                    r = world.rotation_matrix(q)
                    yaws.append(math.atan2(r[3], r[0]))
            rate = (np.unwrap(yaws)[-1] - np.unwrap(yaws)[0]) / ((len(yaws) - 1) * world.dt_s)
            expected = achievable_twist(v, w, world.spec)[1]
            assert 0.85 <= rate / expected <= 1.15, (v, w, rate, expected)


@pytest.fixture(scope="module")
def rough():
    """A small D = 2.6 terrain, steeper than the paper's (1.5 m relief over 12 m), and 3 missions."""
    from offroadbench.terrain.recipe import apply_overrides, generate_terrain, load_recipe

    recipe = apply_overrides(load_recipe("paper-d2.6"),
                             {"grid.rows": 241, "grid.cols": 241, "layers.base.relief_m": 1.5})
    hm = generate_terrain(recipe, 11)
    rc = RoughnessConfig()
    closed = close_rough(classify(hm, rc), rc.closing_radius_m, hm.cell_size_m)
    missions = sample_missions(hm, closed, MissionConfig(count=3, length_m=6.0, border_m=2.0), np.random.default_rng(4))
    return hm, missions


def test_wheel_penetration_stays_under_3_cm_on_rough_terrain(rough):
    hm, missions = rough
    results = run_missions(hm, missions)
    assert max(r.max_penetration_m for r in results) < 0.03
    assert all(r.failure_reason in ("", *FAILURE_REASONS) and r.success == (r.failure_reason == "") for r in results)
    # the terrain is rough for the vehicle: it shakes far more than on flat ground
    assert np.median([r.rms_pitch_rate_deg_s for r in results]) > 5.0


@pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")
def test_mujoco_results_are_bit_identical_in_any_mission_order(rough):
    """MuJoCo's world resets all its state before a mission (mj_resetData): a mission's result is
    the same bit for bit whatever ran before it, in a fresh world or a used one."""
    hm, missions = rough
    sim = SimConfig(engine="mujoco")
    forward = run_missions(hm, missions, sim=sim)
    backward = run_missions(hm, missions[::-1], sim=sim)
    assert backward[::-1] == forward
    assert run_missions(hm, missions[1:2], sim=sim)[0] == forward[1]


def test_results_do_not_depend_on_earlier_missions_and_repeat_exactly(rough, tmp_path):
    hm, missions = rough
    all_three = run_missions(hm, missions, telemetry_dir=tmp_path)
    alone = run_missions(hm, missions[2:])
    assert alone[0] == all_three[2]
    again = run_missions(hm, missions)
    assert again == all_three
    tel = load_telemetry(tmp_path / f"mission_{missions[2].index:03d}.npz")
    assert set(tel) == set(TELEMETRY_COLUMNS)
    assert tel["t_s"][-1] == pytest.approx(all_three[2].sim_time_s)


def test_control_rate_must_divide_physics_rate():
    from offroadbench.errors import InputError

    with World(Heightmap.flat(41, 41, CELL)) as world, pytest.raises(InputError, match="control_rate_hz"):
        run_mission(world, Mission.between(0, (0.5, 1), (1.5, 1)), controller=ControllerConfig(control_rate_hz=25))
