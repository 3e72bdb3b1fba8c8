"""The Gymnasium environment: API conformance, seeding, the failure rules, reward and observations."""

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import offroadbench.envs  # noqa: F401  (registers offroadbench/Traverse-v0)
from offroadbench.analysis.roughness import RoughnessConfig, classify, close_rough
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission, MissionConfig, sample_missions
from offroadbench.navigation.observation import nan_observation
from offroadbench.sim import FailureRules, SimConfig
from offroadbench.sim.gym_env import STATE_FIELDS, UNKNOWN_FILL_M, TraverseConfig, TraverseEnv, height_patch
from offroadbench.sim.trial.vehicle import list_vehicles

CELL = 0.05
FLAT = Heightmap.flat(161, 161, CELL, z_m=0.3)  # 8 m square
SHORT = TraverseConfig(mission_length_m=3.0, border_m=1.0)
QUIET = TraverseConfig(mission_length_m=3.0, border_m=1.0, accel_weight=0.0, rate_weight=0.0, success_bonus=0.0)


def _trench() -> Heightmap:
    """An 8 m square with a 1 m deep trench across it, 0.4 m ahead of TRENCH_MISSION's start: from the
    start the mast sensor cannot see its floor behind the rim."""
    z = np.zeros((161, 161))
    x = np.arange(161) * CELL
    z[:, (x > 2.4) & (x < 3.0)] = -1.0
    return Heightmap(z + 1.0, CELL)


TRENCH = _trench()
TRENCH_MISSION = Mission.between(0, (2.0, 4.0), (6.0, 4.0))


def _goal_seeker(obs) -> np.ndarray:
    gx, gy = obs["state"][:2]
    return np.array([1.0, np.clip(2.0 * math.atan2(gy, gx), -2.0, 2.0)], dtype=np.float32)


def _run(env, policy, seed):
    obs, info = env.reset(seed=seed)
    rewards, states = [], [obs["state"]]
    while True:
        obs, r, term, trunc, info = env.step(policy(obs))
        rewards.append(r)
        states.append(obs["state"])
        if term or trunc:
            return np.array(rewards), np.array(states), term, trunc, info


def test_check_env_passes_on_the_registered_env():
    from gymnasium.utils.env_checker import check_env

    env = gym.make("offroadbench/Traverse-v0")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # unbounded observation Boxes and unnormalised actions: advice only
            check_env(env.unwrapped)
        assert env.unwrapped.hm.shape == (241, 241)
    finally:
        env.close()


def test_spaces_follow_the_vehicle_limits():
    with TraverseEnv(FLAT, config=SHORT) as env:
        v = env.vehicle
        assert np.allclose(env.action_space.high, [v.max_speed_m_s, v.max_yaw_rate_rad_s])
        assert np.allclose(env.action_space.low, -env.action_space.high)
        assert env.observation_space["state"].shape == (len(STATE_FIELDS),)
        assert env.observation_space["height_patch"].shape == (16, 16)
        assert env.observation_space["known"].shape == (16, 16)


def test_check_env_passes_under_the_mast_sensor():
    """Every reset under the mast sensor has unmeasured patch samples (at least the sensor's own foot
    cell): they are a finite fill, inside the observation space."""
    from gymnasium.utils.env_checker import check_env

    with TraverseEnv(TRENCH, config=SHORT, perception="mast") as env:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # unbounded observation Boxes and unnormalised actions: advice only
            check_env(env)


@pytest.mark.parametrize("sensor", ["oracle", "mast"])
@pytest.mark.parametrize("vehicle", list_vehicles())
def test_every_observation_is_finite_and_inside_the_space(vehicle, sensor):
    with TraverseEnv(TRENCH, vehicle=vehicle, config=SHORT, perception=sensor) as env:
        env.action_space.seed(0)
        obs, _ = env.reset(seed=0, options={"mission": TRENCH_MISSION})
        seen = [obs]
        for _ in range(20):
            obs, _, term, trunc, _ = env.step(env.action_space.sample())
            seen.append(obs)
            if term or trunc:
                break
        for o in seen:
            assert all(np.all(np.isfinite(v)) for v in o.values()) and env.observation_space.contains(o)
    unknown = sum(int((o["known"] == 0).sum()) for o in seen)
    assert (unknown > 0) == (sensor == "mast")


def test_known_is_zero_exactly_where_the_mast_sensor_has_no_measurement():
    """The patch is the sensor's map read at the believed pose; where a sample needs a cell the
    sensor has not seen, ``known`` is 0 and the patch reads the fill; nan_observation gives the
    trial runner's form (NaN there) bit for bit."""
    from offroadbench.navigation.perception import PerceptionConfig, perception_seed
    from offroadbench.navigation.sensor import MastSensor

    mission = TRENCH_MISSION
    with TraverseEnv(TRENCH, config=SHORT, perception="mast") as env:
        obs, info = env.reset(seed=0, options={"mission": mission})
        known = obs["known"]
        # the sensor's own map, replayed from the mission's perception stream, read at the believed pose
        sensor = MastSensor(TRENCH, PerceptionConfig(sensor="mast"), np.random.default_rng(perception_seed(mission)),
                            mission.start_xy_m, mission.heading_rad)
        bx, by, byaw = sensor.update(np.array([info["pose"]["x_m"], info["pose"]["y_m"]]), info["pose"]["yaw_rad"])
        assert (bx, by, byaw) == tuple(info["believed_pose"].values())
        ref = height_patch(TRENCH, bx, by, byaw, 16, 0.1, 0.0, sensor.z)
        hidden = np.isnan(ref)
        assert hidden.any() and not hidden.all()
        assert np.array_equal(known == 0, hidden) and set(np.unique(known)) == {0.0, 1.0}
        assert np.all(obs["height_patch"][hidden] == UNKNOWN_FILL_M)
        runner = (ref - info["pose"]["z_m"]).astype(np.float32)
        assert np.array_equal(nan_observation(obs)["height_patch"], runner, equal_nan=True)
        assert np.array_equal(obs["height_patch"][~hidden], runner[~hidden])
        ahead = (np.arange(16) - 7.5) * 0.1  # body-frame x of the patch's columns, m
        assert hidden[:, ahead > 0.5].any()  # the trench floor
        rows, cols = np.nonzero(hidden[:, ahead < 0.3])  # before the rim: only the sensor's own foot cell
        assert np.all(np.hypot(ahead[cols], ahead[rows]) < 0.1)
    with TraverseEnv(TRENCH, config=SHORT) as env:  # the oracle stays the default
        obs, info = env.reset(seed=0, options={"mission": mission})
        assert np.all(obs["known"] == 1.0) and env.perception is None
        assert info["believed_pose"] == {k: info["pose"][k] for k in ("x_m", "y_m", "yaw_rad")}
    with pytest.raises(InputError):
        TraverseEnv(TRENCH, config=SHORT, perception="lidar")


def test_same_seed_same_episode_and_missions_come_from_the_sampler(small_paper_recipe):
    from offroadbench.terrain.recipe import generate_terrain

    hm = generate_terrain(small_paper_recipe, 3)
    with TraverseEnv(hm, config=SHORT) as env:
        a = _run(env, _goal_seeker, 7)
        mission_a = env.mission
        b = _run(env, _goal_seeker, 7)
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and a[4] == b[4]
        _run(env, _goal_seeker, 8)
        assert env.mission != mission_a
    rc = RoughnessConfig()
    closed = close_rough(classify(hm, rc), rc.closing_radius_m, CELL)
    expected = sample_missions(hm, closed, MissionConfig(count=1, length_m=3.0, border_m=1.0), np.random.default_rng(7))
    assert mission_a == expected[0]


def test_goal_seeker_succeeds_and_progress_reward_telescopes():
    with TraverseEnv(FLAT, config=QUIET) as env:
        obs, info = env.reset(seed=1)
        # the vehicle is spawned facing the goal, mission length away
        assert obs["state"][0] == pytest.approx(3.0, abs=0.05) and abs(obs["state"][1]) < 0.05
        d0 = info["distance_to_goal_m"]
        rewards, _, term, trunc, info = _run(env, _goal_seeker, 1)
    assert term and not trunc and info["success"] and info["failure_reason"] == ""
    assert info["distance_to_goal_m"] <= FailureRules().goal_tolerance_m
    # only the progress term is on: the sum is d0 - d_end
    assert rewards.sum() == pytest.approx(d0 - info["distance_to_goal_m"], abs=1e-9)
    # 2.5 m to the goal circle at up to 1 m/s (20 Hz ticks)
    assert 2.5 <= info["t_s"] < 4.0


def test_success_bonus_and_comfort_penalty():
    bonus = TraverseConfig(mission_length_m=3.0, border_m=1.0, success_bonus=5.0)
    with TraverseEnv(FLAT, config=QUIET) as env:
        plain, *_ = _run(env, _goal_seeker, 1)
    with TraverseEnv(FLAT, config=bonus) as env:
        rewards, *_ , info = _run(env, _goal_seeker, 1)
    assert info["success"]
    penalty = plain.sum() + 5.0 - rewards.sum()
    # starting from rest, the vehicle pitches and bounces a little: a small positive penalty
    assert 0.0 < penalty < 0.5
    assert rewards[-1] == pytest.approx(plain[-1] + 5.0, abs=0.1)


def test_standing_still_ends_stuck_with_the_failure_penalty():
    rules = FailureRules(stuck_window_s=1.0)
    with TraverseEnv(FLAT, config=SHORT, rules=rules) as env:
        rewards, _, term, trunc, info = _run(env, lambda obs: np.zeros(2, dtype=np.float32), 2)
    assert term and not trunc and info["failure_reason"] == "stuck" and not info["success"]
    assert len(rewards) == 20  # 1 s window at 20 Hz, checked as in the trial runner
    assert rewards[-1] == pytest.approx(-SHORT.failure_penalty, abs=0.01)


def test_default_rules_end_a_standing_vehicle_stuck_before_the_timeout():
    with TraverseEnv(FLAT, config=SHORT) as env:  # 3 m mission: 9 s timeout, stuck window 4.5 s
        rewards, _, term, trunc, info = _run(env, lambda obs: np.zeros(2, dtype=np.float32), 2)
    assert term and not trunc and info["failure_reason"] == "stuck"
    assert len(rewards) == 90


def test_timeout_truncates(caplog):
    rules = FailureRules(stuck_window_max_fraction=2.0)  # window min(30 s, 18 s) > 9 s timeout: stuck cannot fire
    with caplog.at_level("WARNING", logger="offroadbench.navigation.rules"), \
            TraverseEnv(FLAT, config=SHORT, rules=rules) as env:
        rewards, _, term, trunc, info = _run(env, lambda obs: np.zeros(2, dtype=np.float32), 2)
    assert trunc and not term and info["failure_reason"] == "timeout"
    assert len(rewards) == 180  # 3 x 3 m / 1 m/s at 20 Hz
    assert abs(rewards.sum()) < 0.1  # no bonus or penalty on timeout
    assert "stuck" in caplog.text and "cannot fire" in caplog.text


def test_rgb_array_render_draws_classes_path_goal_and_vehicle():
    """rgb_array is the replay animation's view (offroadbench.plots.animate.TrialView): the
    footprint (dark) is drawn where the vehicle is, and it moves with it."""
    from gymnasium.utils.env_checker import check_env

    with TraverseEnv(FLAT, config=SHORT, planner="astar", render_mode="rgb_array") as env:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            check_env(env)
        obs, info = env.reset(seed=3)
        img = env.render()
        assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
        assert np.array_equal(info["path_xy"][0], env.mission.start_xy_m)
        sx, sy = env.mission.start_xy_m
        r, c = env._view.pixel_of(sx, sy)
        assert img[r - 1:r + 2, c - 1:c + 2].max() < 90  # the (black) footprint over the start
        for _ in range(30):
            obs, *_ , info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        moved = env.render()
        assert moved.shape == img.shape
        pose = info["pose"]
        r2, c2 = env._view.pixel_of(pose["x_m"], pose["y_m"])
        assert (r2, c2) != (r, c) and moved[r2 - 1:r2 + 2, c2 - 1:c2 + 2].max() < 90
    with TraverseEnv(FLAT, config=SHORT) as env:
        env.reset(seed=0)
        assert env.render() is None


def test_make_vec_env_style_construction_needs_no_extra_arguments():
    """What stable-baselines3's make_vec_env does: gym.make(id, render_mode=...) and reset/step."""
    env = gym.make("offroadbench/Traverse-v0", render_mode="rgb_array")
    try:
        env.reset(seed=0)
        env.step(env.action_space.sample())
        assert env.render().ndim == 3
    finally:
        env.close()


def test_reversing_off_the_edge_ends_off_map():
    rules = FailureRules(timeout_factor=10.0)
    with TraverseEnv(FLAT, config=SHORT, rules=rules) as env:
        _, states, term, _, info = _run(env, lambda obs: np.array([-1.0, 0.0], dtype=np.float32), 4)
    assert term and info["failure_reason"] == "off_map"
    assert states[-1][0] > 3.0  # it moved away from the goal


def test_tilted_plane_beyond_the_tip_angle_ends_tipped():
    x = np.arange(161) * CELL
    plane = Heightmap(np.tile(0.2 * x, (161, 1)), CELL)  # 11.3 deg
    with TraverseEnv(plane, config=SHORT, rules=FailureRules(tip_angle_deg=5.0)) as env:
        obs, _ = env.reset(seed=0)
        tilt = math.degrees(max(abs(obs["state"][2]), abs(obs["state"][3])))
        assert tilt > 5.0
        _, _, term, _, info = env.step(np.zeros(2, dtype=np.float32))
    assert term and info["failure_reason"] == "tipped"


def test_height_patch_is_heading_aligned():
    x = np.arange(101) * CELL
    ramp = Heightmap(np.tile(0.1 * x, (101, 1)), CELL)  # z = 0.1 x
    p = height_patch(ramp, 2.0, 2.5, math.pi / 2, 5, 0.2, fill_m=-9.0)  # facing +y
    c = 2.0
    i = np.arange(5)[:, None]
    # body left (rows) points to world -x; forward (columns) to +y, along which z is constant
    assert np.allclose(p, 0.1 * (2.0 - (i - c) * 0.2) * np.ones((1, 5)), atol=1e-12)
    edge = height_patch(ramp, 0.1, 2.5, 0.0, 5, 0.2, fill_m=-9.0)
    assert np.all(edge[:, :2] == -9.0) and np.all(edge[:, 2:] >= 0.0)


def test_env_rejects_bad_settings():
    with pytest.raises(InputError, match="control_rate_hz"):
        TraverseEnv(FLAT, config=TraverseConfig(control_rate_hz=7), sim=SimConfig())
    with pytest.raises(InputError, match="patch_cells"):
        TraverseConfig(patch_cells=0)
    with pytest.raises(InputError, match="render_mode"):
        TraverseEnv(FLAT, render_mode="human")


def test_reset_can_replay_a_given_mission():
    from offroadbench.navigation.missions import Mission

    m = Mission.between(5, (2.0, 2.0), (2.0, 6.0))
    with TraverseEnv(FLAT, config=QUIET) as env:
        obs, info = env.reset(seed=0, options={"mission": m})
        assert env.mission == m and info["distance_to_goal_m"] == pytest.approx(4.0, abs=0.02)
        assert obs["state"][0] == pytest.approx(4.0, abs=0.05)  # spawned facing the goal
        with pytest.raises(InputError, match="mission"):
            env.reset(options={"mission": (2.0, 2.0)})


def test_info_pose_is_the_ground_truth_at_reset_and_every_step():
    import pybullet as pb

    keys = {"x_m", "y_m", "z_m", "roll_rad", "pitch_rad", "yaw_rad"}
    with TraverseEnv(FLAT, config=QUIET) as env:
        _, info = env.reset(seed=2)
        assert set(info["pose"]) == keys
        assert (info["pose"]["x_m"], info["pose"]["y_m"]) == pytest.approx(env.mission.start_xy_m, abs=0.02)
        wrapped = (env.mission.heading_rad + np.pi) % (2 * np.pi) - np.pi
        assert info["pose"]["yaw_rad"] == pytest.approx(wrapped, abs=0.02)
        yaws = [info["pose"]["yaw_rad"]]
        for _ in range(20):  # 1 s turning in place at 0.5 rad/s
            _, _, _, _, info = env.step(np.array([0.0, 0.5], dtype=np.float32))
            pos, quat = pb.getBasePositionAndOrientation(env._world.vehicle_id, physicsClientId=env._world.client_id)
            pose = info["pose"]
            assert set(pose) == keys and all(isinstance(v, float) for v in pose.values())
            assert (pose["x_m"], pose["y_m"], pose["z_m"]) == pytest.approx(pos, abs=1e-12)
            roll, pitch, yaw = pb.getEulerFromQuaternion(quat)
            # the project's pitch is nose-up positive (navigation.metrics): minus Bullet's
            assert (pose["roll_rad"], pose["pitch_rad"], pose["yaw_rad"]) == pytest.approx((roll, -pitch, yaw), abs=1e-9)
            yaws.append(pose["yaw_rad"])
    turned = np.unwrap(yaws)
    # the commanded 0.5 rad/s, after the wheels spin up: the yaw rate of the last half second
    assert (turned[-1] - turned[10]) / 0.5 == pytest.approx(0.5, rel=0.15)


class _Replay:
    """A policy that plays a fixed list of actions, whatever it observes (then stands still)."""

    def __init__(self, actions) -> None:
        self.actions = list(actions)
        self.i = 0

    def reset(self, problem) -> None:
        self.i = 0

    def act(self, obs):
        a = self.actions[self.i] if self.i < len(self.actions) else (0.0, 0.0)
        self.i += 1
        return a


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_the_env_and_the_trial_runner_drive_the_same_trial_for_the_same_actions(small_paper_recipe, engine):
    """Issue 35: one mission, the same actions through the env and through the trial runner (the
    actions as a policy): the same trial row, and the same telemetry up to the command the runner
    chooses at the tick the trial ends (it is never applied; the env cannot know it)."""
    import importlib.util

    from offroadbench.navigation.drivers import POLICIES, PlannerChoice, PolicySpec
    from offroadbench.navigation.missions import Mission
    from offroadbench.sim.engine import open_world
    from offroadbench.sim.trial.pipeline import TrialSettings
    from offroadbench.sim.trial.runner import TELEMETRY_COLUMNS, drive_mission
    from offroadbench.terrain.recipe import generate_terrain

    if engine == "mujoco" and importlib.util.find_spec("mujoco") is None:
        pytest.skip("mujoco not installed")
    hm = generate_terrain(small_paper_recipe, 3)
    settings = TrialSettings(sim=SimConfig(engine=engine), missions=MissionConfig(count=1, length_m=4.0, border_m=1.0))
    mission = Mission.between(0, (2.0, 2.5), (5.5, 4.5))
    actions = []
    with TraverseEnv(hm, settings=settings, config=QUIET) as env:
        obs, _ = env.reset(options={"mission": mission})
        while True:
            a = _goal_seeker(obs) * np.array([1.5, 1.0], dtype=np.float32)  # over the top speed: clipped alike
            actions.append(tuple(float(x) for x in a))
            obs, _, term, trunc, _ = env.step(a)
            if term or trunc:
                break
        got = env.trial_record()
    POLICIES.add("replay-test", PolicySpec(lambda cfg, context: _Replay(actions), summary="test: replays actions",
                                           needs=frozenset()))
    try:
        with open_world(hm, settings.vehicle, settings.sim.for_terrain()) as world:
            want = drive_mission(world, mission, planner=PlannerChoice("replay-test", kind="policy"),
                                 controller=settings.controller, rules=settings.rules,
                                 observation=settings.observation)
    finally:
        POLICIES._entries.pop("replay-test", None)
    assert got.result == want.result and got.result.as_row().keys() == want.result.as_row().keys()
    assert len(actions) > 20 and got.result.success
    for name in TELEMETRY_COLUMNS:
        a, b = got.telemetry[name], want.telemetry[name]
        if name in ("cmd_v_m_s", "cmd_omega_rad_s"):
            a, b = a[:-1], b[:-1]
        assert np.array_equal(a, b), name


def test_a_lunar_preset_runs_in_lunar_gravity_on_its_soil():
    """Issue 35: the env prepares its terrain as a study does, the recipe's [body] and [soil] included."""
    with TraverseEnv("lunar-mare", overrides={"grid.rows": 129, "grid.cols": 129}, config=SHORT) as env:
        assert env.sim.gravity_m_s2 == pytest.approx(1.62)
        assert env.sim.soil == "lunar-regolith"
        _, info = env.reset(seed=0)
        z0 = info["pose"]["z_m"]
    with TraverseEnv("lunar-mare", overrides={"grid.rows": 129, "grid.cols": 129}, config=SHORT,
                     sim=SimConfig(gravity_m_s2=9.81)) as env:  # the settings win where they name it
        assert env.sim.gravity_m_s2 == 9.81
        _, info = env.reset(seed=0)
    assert info["pose"]["z_m"] < z0  # the same vehicle sits lower on its tyres in Earth gravity


def test_settings_and_their_parts_are_not_given_twice():
    from offroadbench.sim.trial.pipeline import TrialSettings

    with pytest.raises(InputError, match="inside settings"):
        TraverseEnv(FLAT, settings=TrialSettings(), sim=SimConfig())


def test_the_env_config_and_the_trial_settings_share_their_fields_both_ways():
    """The five TraverseConfig fields that are the settings' own map to them through one table
    (gym_env.SETTINGS_FIELDS): settings made from a config give that config back."""
    from offroadbench.analysis.roughness import RoughnessConfig
    from offroadbench.navigation.rules import FailureRules
    from offroadbench.sim import gym_env

    cfg = TraverseConfig(mission_length_m=4.0, border_m=1.5, control_rate_hz=10, patch_cells=8, patch_spacing_m=0.2,
                         success_bonus=3.0)
    settings = gym_env._settings(cfg, "husky", SimConfig(), FailureRules(), RoughnessConfig())
    assert (settings.missions.length_m, settings.missions.border_m, settings.controller.control_rate_hz,
            settings.observation.patch_cells, settings.observation.patch_spacing_m) == (4.0, 1.5, 10, 8, 0.2)
    assert gym_env._config_of(TraverseConfig(success_bonus=3.0), settings) == cfg


def test_mission_sites_are_computed_once_per_terrain_and_episodes_are_unchanged(small_paper_recipe, monkeypatch):
    """The start cells and goal map (mission_sites) are the terrain's, computed at the first draw and
    reused by every reset (as a study computes them once per terrain); each episode's mission and
    observations are those of sampling without them (a fresh env, the sampler's own computation)."""
    import offroadbench.navigation.missions as missions_module
    import offroadbench.sim.gym_env as gym_env_module
    from offroadbench.terrain.recipe import generate_terrain

    hm = generate_terrain(small_paper_recipe, 3)
    calls = []
    original = missions_module.mission_sites

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    def episode(env, seed):
        obs, info = env.reset(seed=seed)
        first = obs
        for _ in range(3):
            obs, *_ = env.step(np.array([1.0, 0.3], dtype=np.float32))
        return info["mission"], first, obs

    fresh = {}
    for seed in (7, 8):  # each in a fresh env: the first draw computes the sites
        with TraverseEnv(hm, config=SHORT) as env:
            fresh[seed] = episode(env, seed)
    monkeypatch.setattr(missions_module, "mission_sites", counted)
    monkeypatch.setattr(gym_env_module, "mission_sites", counted)
    with TraverseEnv(hm, config=SHORT) as env:
        assert not calls  # nothing drawn yet
        runs = [(seed, episode(env, seed)) for seed in (7, 8, 7, 8)]
        env.reset(options={"mission": fresh[7][0]})
    assert len(calls) == 1
    for seed, (mission, first, last) in runs:
        want = fresh[seed]
        assert mission == want[0]
        for got, ref in ((first, want[1]), (last, want[2])):
            assert all(np.array_equal(got[k], ref[k]) for k in ref)
    rc = RoughnessConfig()
    closed = close_rough(classify(hm, rc), rc.closing_radius_m, CELL)
    cfg = MissionConfig(count=1, length_m=3.0, border_m=1.0)
    assert fresh[8][0] == sample_missions(hm, closed, cfg, np.random.default_rng(8))[0]
