"""Faults are not outcomes (issue 23, Deliver 1): a non-finite action from a plug-in policy is an
error naming it and the value, never a ``tipped`` row; the world is clean after a failed trial;
the Gymnasium env refuses NaN actions, steps after the end and malformed reset options."""

from __future__ import annotations

import copy
import math

import numpy as np
import pandas as pd
import pytest

from offroadbench.errors import InputError, PluginError
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.planners import PlannerChoice
from offroadbench.navigation.policies import POLICIES, PolicySpec
from offroadbench.sim import World
from offroadbench.sim.gym_env import TraverseConfig, TraverseEnv
from offroadbench.sim.trial.runner import drive_mission

#: what the test policy does: return NaN at its ``at``-th action of episode number ``episode``
POISON = {"armed": True, "episode": 1, "at": 10}
_COUNT = {"episodes": 0}


class GoalSeeker:
    """Drive at the goal (a tiny plug-in policy); poisoned by POISON while armed."""

    def __init__(self, cfg, context) -> None:
        self.acts = 0

    def reset(self, problem) -> None:
        self.episode = _COUNT["episodes"]
        _COUNT["episodes"] += 1
        self.acts = 0

    def act(self, obs):
        self.acts += 1
        if POISON["armed"] and self.episode == POISON["episode"] and self.acts == POISON["at"]:
            return (float("nan"), 0.0)
        gx, gy = obs["state"][:2]
        return (0.8, max(-1.5, min(1.5, 2.0 * math.atan2(gy, gx))))


@pytest.fixture
def nan_policy():
    POLICIES.add("nan-test", PolicySpec(GoalSeeker, summary="test policy"))
    _COUNT["episodes"] = 0
    POISON["armed"] = True
    yield PlannerChoice("nan-test", kind="policy")
    POLICIES._entries.pop("nan-test", None)  # keep the registry's contract tests clean


@pytest.fixture(scope="module")
def terrain():
    from offroadbench.analysis.roughness import RoughnessConfig, classify_terrain
    from offroadbench.terrain.recipe import (
        apply_overrides,
        generate_terrain,
        load_recipe,
    )

    hm = generate_terrain(apply_overrides(load_recipe("paper-d2.45"), {"grid.rows": 161, "grid.cols": 161}), 3)
    return hm, classify_terrain(hm, RoughnessConfig(border_m=1.0)).closed


def missions(hm):
    a = Mission(index=0, start_xy_m=(2.0, 2.0), goal_xy_m=(5.5, 2.5), heading_rad=math.atan2(0.5, 3.5))
    b = Mission(index=1, start_xy_m=(2.5, 5.5), goal_xy_m=(5.0, 3.0), heading_rad=math.atan2(-2.5, 2.5))
    return a, b


def same_record(r1, r2) -> bool:
    return r1.result == r2.result and all(np.array_equal(r1.telemetry[k], r2.telemetry[k], equal_nan=True)
                                          for k in r1.telemetry)


def test_a_nan_action_is_an_error_naming_the_policy_and_the_world_stays_clean(terrain, nan_policy):
    hm, classes = terrain
    a, b = missions(hm)
    kw = {"planner": nan_policy, "classes": classes, "border_m": 1.0}
    with World(hm) as world:
        drive_mission(world, a, **kw)  # episode 0: clean
        with pytest.raises(PluginError, match=r"policy 'nan-test' returned a non-finite action \(nan, 0.0\)"):
            drive_mission(world, b, **kw)  # episode 1: NaN at its 10th action
        after = drive_mission(world, b, **kw)  # episode 2: clean, on the world the fault ran in
    _COUNT["episodes"] = 0
    with World(hm) as fresh:
        drive_mission(fresh, a, **kw)
        POISON["armed"] = False
        again = drive_mission(fresh, b, **kw)
    assert same_record(after, again)  # the failed trial left nothing behind
    assert all(np.isfinite(v) for v in after.telemetry["x_m"])


def test_a_malformed_action_is_an_error_too(terrain):
    hm, classes = terrain
    a, _ = missions(hm)

    class Bad(GoalSeeker):
        def act(self, obs):
            return "fast"

    POLICIES.add("bad-test", PolicySpec(Bad))
    try:
        with World(hm) as world, pytest.raises(PluginError, match="policy 'bad-test' returned 'fast'"):
            drive_mission(world, a, planner=PlannerChoice("bad-test", kind="policy"), classes=classes, border_m=1.0)
    finally:
        POLICIES._entries.pop("bad-test", None)


STUDY_TOML = {
    "study": {"name": "nan-study", "recipe": "paper-d2.45", "root_seed": 4, "terrains_per_cell": 1,
              "missions_per_terrain": 3},
    "recipe_overrides": {"grid.rows": 161, "grid.cols": 161},
    "roughness": {"border_m": 1.0},
    "missions": {"length_m": 3.0, "border_m": 1.0},
    "planner": {"name": "nan-test"},
}


def test_a_nan_policys_study_fixed_and_resumed_equals_the_fixed_run(tmp_path, nan_policy):
    from offroadbench.study import load, load_meta, run_study, study_from_dict
    from offroadbench.study.spec.config import plan_cells

    study = study_from_dict(copy.deepcopy(STUDY_TOML))
    cells = plan_cells(study)
    with pytest.raises(PluginError, match="nan-test"):
        run_study(study, cells, tmp_path / "a", executor="inline")
    partial = load(tmp_path / "a")
    assert list(partial["mission"]) == [0]  # the faulty trial is not stored, as tipped or otherwise
    session = load_meta(tmp_path / "a")["runs"][0]
    assert session["status"] == "failed" and "PluginError: policy 'nan-test' returned a non-finite" in session["error"]
    POISON["armed"] = False  # the plug-in is fixed
    resumed = run_study(study, cells, tmp_path / "a", executor="inline")
    assert resumed.ran == 2
    run_study(study, cells, tmp_path / "b", executor="inline")
    pd.testing.assert_frame_equal(load(tmp_path / "a"), load(tmp_path / "b"))


# ---------------------------------------------------------------------------- gymnasium env
SHORT = TraverseConfig(mission_length_m=3.0, border_m=1.0)


def _episode(env, seed, n=15):
    obs, _ = env.reset(seed=seed)
    out = [obs["state"].copy()]
    for _ in range(n):
        gx, gy = obs["state"][:2]
        obs, r, term, trunc, info = env.step(np.array([0.8, np.clip(2 * math.atan2(gy, gx), -1.5, 1.5)], np.float32))
        out.append(obs["state"].copy())
        if term or trunc:
            break
    return np.array(out), info["failure_reason"]


@pytest.fixture(scope="module")
def env(terrain):
    hm, _ = terrain
    e = TraverseEnv(hm, config=SHORT)
    yield e
    e.close()


def test_the_env_refuses_a_nan_action_and_stays_clean(env):
    before, reason = _episode(env, 3)
    env.reset(seed=3)
    for bad in ([np.nan, 0.0], [0.0, np.inf], [1.0]):
        with pytest.raises(InputError, match="action"):
            env.step(np.array(bad, dtype=np.float32))
    after, reason2 = _episode(env, 3)
    assert np.array_equal(before, after) and reason == reason2
    assert reason2 != "off_map"


def test_the_env_refuses_a_step_after_the_end(env):
    env.reset(seed=1)
    while True:
        *_, term, trunc, _ = env.step(np.array([0.0, 0.0], np.float32))
        if term or trunc:
            break
    with pytest.raises(RuntimeError, match="episode has ended"):
        env.step(np.array([0.0, 0.0], np.float32))
    env.reset(seed=1)
    env.step(np.array([0.0, 0.0], np.float32))  # a new episode steps again


@pytest.mark.parametrize("options", [[1, 2], "mission", {"bogus": 1}, {"mission": (2.0, 2.0)}])
def test_the_env_validates_reset_options(env, options):
    with pytest.raises(InputError, match="options"):
        env.reset(options=options)


# ---------------------------------------------------------------------------- planner limits
def _register(name, fn):
    from offroadbench.navigation.planners import register_planner

    register_planner(name)(fn)
    return PlannerChoice(name)


@pytest.fixture
def cleanup_planners():
    from offroadbench.navigation.planners import PLANNERS

    yield
    for name in ("sleepy-test", "long-test", "many-test", "raise-test"):
        PLANNERS._entries.pop(name, None)


def test_a_planner_beyond_its_limits_is_a_plugin_error(terrain, cleanup_planners, monkeypatch):
    import time

    from offroadbench.sim.trial import limits

    hm, classes = terrain
    a, _ = missions(hm)
    monkeypatch.setattr(limits, "PLANNING_LIMIT_S", 0.5)

    def sleepy(problem, cfg):
        time.sleep(60)

    def long_way(problem, cfg):  # back and forth 30 times: 210 m for a 3.5 m mission
        s, g = np.asarray(problem.start_xy), np.asarray(problem.goal_xy)
        return np.array([s, *([g, s] * 30), g])

    def many(problem, cfg):
        return np.linspace(problem.start_xy, problem.goal_xy, limits.MAX_WAYPOINTS + 1)

    with World(hm) as world:
        t0 = time.monotonic()
        with pytest.raises(PluginError, match="planner 'sleepy-test' took longer than 0.5 s"):
            drive_mission(world, a, planner=_register("sleepy-test", sleepy), classes=classes, border_m=1.0)
        assert time.monotonic() - t0 < 30
        with pytest.raises(PluginError, match=r"planner 'long-test' returned a path of 2\d\d.\d m for a 3.5 m mission"):
            drive_mission(world, a, planner=_register("long-test", long_way), classes=classes, border_m=1.0)
        with pytest.raises(PluginError, match="planner 'many-test' returned 100001 waypoints"):
            drive_mission(world, a, planner=_register("many-test", many), classes=classes, border_m=1.0)
        def broken(problem, cfg):
            return 1 / 0

        with pytest.raises(PluginError, match="planner 'raise-test' failed: ZeroDivisionError: division by zero"):
            drive_mission(world, a, planner=_register("raise-test", broken), classes=classes, border_m=1.0)
        import signal

        assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)
        assert signal.getsignal(signal.SIGALRM) == signal.SIG_DFL
