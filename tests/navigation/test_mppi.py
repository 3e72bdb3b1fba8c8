"""The ``mppi`` policy: its slip model, its noise, its costs on unknown ground, its own seeded stream
(a trial replays bit for bit) and, closed loop on its own model, a way round a wall to the goal."""

import math

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.drivers import PolicyContext
from offroadbench.navigation.planners import planner_from_table
from offroadbench.navigation.policies.mppi import MppiConfig, MppiPolicy, cost_window, rollout
from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope

CELL = 0.05


def _policy(cfg=MppiConfig(), hm=None, start=(2.0, 5.0), goal=(8.0, 5.0)):
    hm = hm or Heightmap.flat(201, 201, CELL)
    policy = MppiPolicy(cfg, PolicyContext())
    policy.reset(PlanningProblem(hm=hm, classes=None, start_xy=start, goal_xy=goal))
    return policy, hm


def _drive(policy, hm, pose, ticks):
    """Closed loop on the policy's own kinematics without slip: the poses and the actions."""
    poses, actions = [pose.copy()], []
    for _ in range(ticks):
        v, w = policy.act({"pose": pose, "elevation_m": hm.z})
        actions.append((v, w))
        pose = pose + [v * 0.05 * math.cos(pose[2]), v * 0.05 * math.sin(pose[2]), w * 0.05]
        poses.append(pose.copy())
    return np.array(poses), actions


def test_the_same_mission_replays_bit_for_bit_and_another_seed_differs():
    a, hm = _policy()
    b, _ = _policy()
    pose = np.array([2.0, 5.0, 0.3])
    pa, acts_a = _drive(a, hm, pose, 15)
    pb, acts_b = _drive(b, hm, pose, 15)
    assert acts_a == acts_b and np.array_equal(pa, pb)
    a.reset(PlanningProblem(hm=hm, classes=None, start_xy=(2.0, 5.0), goal_xy=(8.0, 5.0)))
    assert _drive(a, hm, pose, 15)[1] == acts_a  # reset restarts the mission's stream
    c, _ = _policy(MppiConfig(seed=1))
    assert _drive(c, hm, pose, 15)[1] != acts_a


def test_noise_is_a_stationary_ornstein_uhlenbeck_process():
    cfg = MppiConfig(samples=20_000, noise_v_m_s=0.3, noise_omega_rad_s=0.6, noise_corr_s=0.4)
    policy, _ = _policy(cfg)
    eps = policy.noise(cfg.samples).astype(float)  # (K, T, 2)
    a = math.exp(-0.05 / 0.4)
    for j, sigma in enumerate((0.3, 0.6)):
        sd = eps[:, :, j].std(axis=0)
        assert sd == pytest.approx(np.full(sd.shape, sigma), rel=0.04)  # every step, the first included
        lag1 = np.mean(eps[:, 1:, j] * eps[:, :-1, j]) / sigma**2
        assert lag1 == pytest.approx(a, abs=0.01)


def test_rollout_slows_by_the_slip_of_the_uphill_grade():
    grade = 0.2
    x = np.arange(201) * CELL
    hm = Heightmap(np.tile(grade * x, (201, 1)), CELL)  # rises along +x
    cfg = MppiConfig(slip_base=0.05, slip_per_grade=0.5)
    win = cost_window(hm.z, CELL, (5.0, 5.0), 3.0, VehicleEnvelope(), cfg.unknown_hazard)
    u = np.zeros((2, 20, 2), dtype=np.float32)
    u[:, :, 0] = 0.8
    up, _, _ = rollout((4.0, 5.0, 0.0), u[:1], 0.05, win, cfg)
    down, _, _ = rollout((6.0, 5.0, math.pi), u[1:], 0.05, win, cfg)
    assert up[0, -1] == pytest.approx((1 - 0.05 - 0.5 * grade) * 0.8 * 1.0, rel=1e-4)  # 20 x 0.05 s
    assert -down[0, -1] == pytest.approx((1 - 0.05) * 0.8 * 1.0, rel=1e-4)  # downhill: no grade slip
    u[:, :, 1] = 1.0
    _, _, th = rollout((4.0, 5.0, 0.0), u[:1], 0.05, win, cfg)
    assert th[0, -1] == pytest.approx((1 - cfg.yaw_slip) * 1.0 * 1.0, rel=1e-5)


def test_unknown_ground_is_neither_flat_nor_forbidden_and_off_the_map_is_lethal():
    z = np.zeros((201, 201))
    z[:, 120:] = np.nan  # unseen beyond x = 6 m
    win = cost_window(z, CELL, (5.0, 5.0), 3.0, VehicleEnvelope(), 0.5)
    col = lambda x_m: int(round(x_m / CELL)) - win.c0  # noqa: E731
    row = int(round(5.0 / CELL)) - win.r0
    assert win.static[row, col(4.0)] == 0.0 and win.step[row, col(4.0)] == 0.0  # seen, flat
    assert win.static[row, col(7.0)] == 0.5 and win.step[row, col(7.0)] == 0.5  # unknown
    edge = cost_window(np.zeros((201, 201)), CELL, (1.0, 5.0), 3.0, VehicleEnvelope(), 0.5)
    assert math.isinf(edge.static[row - edge.r0 + win.r0, 0])  # x = -2 m: off the map


def test_mppi_goes_round_a_wall_to_the_goal():
    z = np.zeros((201, 201))
    z[60:141, 95:101] = 0.5  # a 0.5 m wall at x = 4.75-5 m from y = 3 to 7 m, across the direct line
    hm = Heightmap(z, CELL)
    policy, _ = _policy(hm=hm, start=(2.0, 5.0), goal=(8.0, 5.0))
    poses, _ = _drive(policy, hm, np.array([2.0, 5.0, 0.0]), 400)  # 20 s
    d = np.hypot(poses[:, 0] - 8.0, poses[:, 1] - 5.0)
    assert d.min() < 0.5  # it arrives
    near_wall = (poses[:, 0] > 4.2) & (poses[:, 0] < 5.55)
    assert np.all((poses[near_wall, 1] < 3.0 - 0.3) | (poses[near_wall, 1] > 7.0 + 0.3))  # round, not over


def test_config_is_validated_and_selectable_from_a_planner_table():
    choice = planner_from_table({"name": "mppi", "samples": 256, "horizon_s": 2.0, "sensor": "mast"})
    assert choice.kind == "policy" and choice.config.samples == 256 and choice.perception.sensor == "mast"
    with pytest.raises(InputError, match="samples"):
        MppiConfig(samples=1)
    with pytest.raises(InputError, match="yaw_slip"):
        MppiConfig(yaw_slip=1.0)


def test_a_trial_with_mppi_and_the_mast_sensor_succeeds_and_replays_bit_for_bit():
    from offroadbench.navigation.missions import Mission
    from offroadbench.sim import World
    from offroadbench.sim.trial.runner import drive_mission

    hm = Heightmap.flat(161, 161, CELL, z_m=0.3)  # 8 m square
    mission = Mission.between(0, (2.0, 2.0), (6.0, 5.0))
    choice = planner_from_table({"name": "mppi", "samples": 256, "sensor": "mast"})
    with World(hm) as world:
        a = drive_mission(world, mission, planner=choice, border_m=1.0)
        b = drive_mission(world, mission, planner=choice, border_m=1.0)
    assert a.result.success and a.result == b.result
    assert all(np.array_equal(a.telemetry[k], b.telemetry[k]) for k in a.telemetry)
    assert a.belief is not None and np.array_equal(a.belief.trail_xy, b.belief.trail_xy)
    assert a.belief.seen[40, 40] and not a.belief.seen.all()  # the start's ground seen, not the whole map


def test_cost_to_go_is_the_distance_on_open_ground_and_the_detour_behind_a_wall():
    from offroadbench.navigation.policies.mppi import cost_to_go

    flat = Heightmap.flat(201, 201, CELL)
    problem = PlanningProblem(hm=flat, classes=None, start_xy=(2.0, 5.0), goal_xy=(8.0, 5.0), border_m=0.5)
    ctg = cost_to_go(problem, 0.25)
    pts = np.array([[2.0, 5.0], [5.0, 8.0], [7.0, 3.0]], dtype=np.float32)
    d = np.hypot(pts[:, 0] - 8.0, pts[:, 1] - 5.0)
    got = ctg.at(pts[:, 0], pts[:, 1])
    assert np.all(got >= d - 0.26) and np.all(got <= 1.09 * d + 0.26)  # octile metric on 0.25 m cells
    assert ctg.forbidden_at(np.float32([5.0]), np.float32([5.0]))[0] == 0
    z = np.zeros((201, 201))
    z[20:181, 118:122] = 0.5  # a wall at x = 5.9-6.05 m from y = 1 to 9 m
    walled = cost_to_go(PlanningProblem(hm=Heightmap(z, CELL), classes=None, start_xy=(2.0, 5.0),
                                        goal_xy=(8.0, 5.0), border_m=0.5), 0.25)
    behind = walled.at(np.float32([5.0]), np.float32([5.0]))[0]
    assert behind > 3.0 + 6.0  # round an end of the wall (about 2 x 4.1 m), not 3 m through it
    assert walled.forbidden_at(np.float32([6.0]), np.float32([5.0]))[0] == 1


def test_a_stalled_vehicle_backs_up_then_drives_on():
    policy, hm = _policy()
    pose = np.array([2.0, 5.0, 0.0])
    state = np.zeros(10, dtype=np.float32)  # measured forward speed 0: held by something the map hides
    vs = [policy.act({"pose": pose, "elevation_m": hm.z, "state": state})[0] for _ in range(80)]
    stall = int(MppiConfig().stall_s * 20)
    assert min(vs[:stall - 1]) > 0.3  # driving on while the stall is timed
    assert max(vs[stall + 1 : stall + 25]) <= 0.0 and min(vs[stall + 1 : stall + 25]) < -0.1  # backing up
    assert vs[stall + 32] > 0.3  # forward again
    blind, _ = _policy(MppiConfig(stall_s=0.0))
    assert min(blind.act({"pose": pose, "elevation_m": hm.z, "state": state})[0] for _ in range(60)) > 0.3


def test_cos_sin_is_the_c_librarys_rounded_to_float32_with_and_without_numba(monkeypatch):
    """The headings' cosines and sines are libm's double ``cos``/``sin`` rounded to float32 (not
    numpy's SIMD loops, whose bits depend on the CPU), and numba's pass gives the Python pass's bits."""
    import offroadbench.navigation.policies.mppi as mppi

    th = np.concatenate([(np.random.default_rng(0).normal(0.0, 4.0, (64, 50))).astype(np.float32).ravel(),
                         np.array([0.0, -0.0, 1e-30, 1e4, -1e5, np.pi, 3e38, np.inf, -np.inf, np.nan], np.float32)])  # 3210 = 107 x 30
    out = {}
    for use in (False, True):
        monkeypatch.setattr(mppi, "USE_COMPILED_TRIG", use)
        out[use] = mppi.cos_sin(th.reshape(-1, 30))
    expect = [np.array([np.float32(f(float(a))) if math.isfinite(a) else np.nan for a in th], np.float32).reshape(-1, 30)
              for f in (math.cos, math.sin)]
    for got in (out[False], out[True]):
        assert all(np.array_equal(g.view(np.int32), e.view(np.int32)) for g, e in zip(got, expect, strict=True))


def test_a_tick_is_the_same_with_and_without_numba(monkeypatch):
    """Whole MPPI ticks on a rough map (rollouts, costs, weights, update) with the compiled and the
    Python headings: the same mean sequences to the bit."""
    import offroadbench.navigation.policies.mppi as mppi
    from offroadbench.terrain.recipe import load_terrain

    pytest.importorskip("numba")
    hm = load_terrain("paper-d2.6", seed=11, overrides={"grid.rows": 201, "grid.cols": 201})[0]
    runs = []
    for use in (True, False):
        monkeypatch.setattr(mppi, "USE_COMPILED_TRIG", use)
        policy, _ = _policy(MppiConfig(samples=256), hm=hm)
        poses, actions = _drive(policy, hm, np.array([2.0, 5.0, 0.3]), 8)
        runs.append((poses, actions, policy.U.copy()))
    assert runs[0][1] == runs[1][1] and np.array_equal(runs[0][2], runs[1][2])
    assert len({a for a in runs[0][1]}) > 1  # the ticks act, not one repeated action
