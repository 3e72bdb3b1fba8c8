"""Policies: the runner drives a policy exactly as the Gymnasium env does, and the built-in
``reactive`` policy reaches goals on flat ground and bends away from a step."""

import math

import numpy as np
import pytest

from offroadbench.navigation.perception import PerceptionConfig

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.observation import nan_observation
from offroadbench.navigation.planners import PlannerChoice, planner_from_table
from offroadbench.navigation.policies import POLICIES, PolicyContext, ReactiveConfig, make_policy
from offroadbench.sim import World
from offroadbench.sim.gym_env import TraverseConfig, TraverseEnv
from offroadbench.sim.trial.runner import drive_mission


def roll_out(env, policy, obs):
    """Step ``env`` with ``policy``'s actions from ``obs`` to the episode's end: (the true (x, y) after
    each step, the last info). The policy reads the observation in the trial runner's form
    (offroadbench.navigation.observation.nan_observation), as in a trial."""
    xy = []
    while True:
        obs, _, term, trunc, info = env.step(np.array(policy.act(nan_observation(obs))))
        xy.append(tuple(env._state["pos"][:2]))
        if term or trunc:
            return xy, info

CELL = 0.05
FLAT = Heightmap.flat(161, 161, CELL, z_m=0.3)  # 8 m square


def _classes(hm):
    return np.zeros(hm.shape, dtype=np.uint8)


def test_the_runner_and_the_env_drive_a_policy_bit_for_bit_alike():
    mission = Mission.between(0, (2.0, 2.0), (6.0, 5.0))
    # the env's vehicle envelope is the measured one (its settings' planner is the straight line): the runner
    # plans with the same limits (the default since issue 42 is the spec sheet's)
    choice = planner_from_table({"name": "reactive", "limits": "measured"})
    with World(FLAT) as world:
        rec = drive_mission(world, mission, planner=choice, classes=_classes(FLAT), border_m=1.0)
    assert rec.result.success
    with TraverseEnv(FLAT, config=TraverseConfig(mission_length_m=5.0, border_m=1.0)) as env:
        obs, _ = env.reset(seed=0, options={"mission": mission})
        policy = make_policy("reactive", choice.config, PolicyContext(
            observation=env.settings.observation, vehicle=env.envelope, track_m=env.vehicle.track_m, control_rate_hz=20))
        xy, info = roll_out(env, policy, obs)
    assert info["success"] and info["failure_reason"] == ""
    tel = rec.telemetry
    assert len(xy) == len(tel["x_m"]) - 1  # the runner also records the start
    assert np.array_equal(np.array(xy), np.column_stack([tel["x_m"], tel["y_m"]])[1:])


def test_reactive_policy_on_flat_ground_runs_the_missions_the_straight_line_runs():
    missions = [Mission.between(i, (2.0, 2.0 + i), (7.0, 2.5 + 1.5 * i)) for i in range(3)]
    with World(FLAT) as world:
        line = [drive_mission(world, m).result for m in missions]
        pol = [drive_mission(world, m, planner=planner_from_table({"name": "reactive"}), classes=_classes(FLAT)).result
               for m in missions]
    for a, b in zip(line, pol, strict=True):
        assert a.success and b.success
        assert (a.start_x_m, a.start_y_m, a.goal_x_m, a.goal_y_m) == (b.start_x_m, b.start_y_m, b.goal_x_m, b.goal_y_m)
        # both drive the start-goal line: similar path length, times within a second or so
        assert b.path_length_m == pytest.approx(a.path_length_m, abs=0.3)
        assert abs(b.traversal_time_s - a.traversal_time_s) < 2.0


def test_reactive_policy_bends_away_from_rising_ground():
    ctx = PolicyContext()
    policy = make_policy("reactive", ReactiveConfig(), ctx)
    n, ds = ctx.observation.patch_cells, ctx.observation.patch_spacing_m
    y = (np.arange(n) - (n - 1) / 2) * ds  # rows run to the left
    state = np.zeros(10, dtype=np.float32)
    state[0] = 10.0  # the goal straight ahead
    flat = np.zeros((n, n), dtype=np.float32)
    v0, w0 = policy.act({"state": state, "height_patch": flat})
    assert w0 == pytest.approx(0.0, abs=1e-9) and v0 > 0.9
    right_up = np.tile((0.6 * np.clip(-y, 0, None))[:, None], (1, n)).astype(np.float32)  # rises to the right
    v1, w1 = policy.act({"state": state, "height_patch": right_up})
    v2, w2 = policy.act({"state": state, "height_patch": right_up[::-1].copy()})
    assert w1 > 0.05 and w2 == pytest.approx(-w1)  # turns left, and right for the mirror image
    assert v1 < v0  # slower on the tilted ground
    blind = make_policy("reactive", ReactiveConfig(roughness_weight=0.0), ctx)
    assert blind.act({"state": state, "height_patch": right_up})[1] == pytest.approx(0.0, abs=1e-9)
    state[0], state[1] = -3.0, 1.0  # goal behind, to the left: the tightest left arc
    v, w = policy.act({"state": state, "height_patch": flat})
    assert w > 0 and math.isclose(w, v * ReactiveConfig().max_curvature_1_m)


def test_policy_names_are_looked_up_with_did_you_mean():
    from offroadbench.errors import InputError

    assert "reactive" in POLICIES
    with pytest.raises(InputError, match="reactiv"):
        planner_from_table({"name": "reactiv"})
    assert planner_from_table({"name": "reactive", "cruise_speed_m_s": 0.5}) == PlannerChoice(
        "reactive", ReactiveConfig(cruise_speed_m_s=0.5), "policy", PerceptionConfig(limits="sheet"))
