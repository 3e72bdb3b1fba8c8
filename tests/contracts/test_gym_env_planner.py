"""The Gymnasium env's reference planner plans as a study's trial does (offroadbench.sim.gym_env,
Planner): ``TraverseEnv(planner=name)`` is ``[planner] name = ...``, whose default limits are the
maker's published ones (offroadbench.navigation.perception ``limits = "sheet"``: the Husky's 30 deg
side slope, tan 30 deg = 0.577, not the 0.8 friction slope measured in the world). Before this the
env planned with the measured limits while the trial runner used the published ones."""

from __future__ import annotations

import math


from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.planners import PLANNERS, PlannerChoice, PlannerSpec, planner_from_table
from offroadbench.navigation.rules import FailureRules
from offroadbench.sim.gym_env import TraverseConfig, TraverseEnv
from offroadbench.sim.trial.runner import drive_mission

FLAT = Heightmap.flat(161, 161, 0.05, z_m=0.3)  # 8 m square


def test_the_env_plans_a_named_planner_with_the_limits_a_study_gives_it():
    seen: list = []

    def spy(problem, cfg):  # a planner that drives the straight line and keeps the limits it was given
        seen.append(problem.vehicle)
        return problem.endpoints()

    PLANNERS.add("_test_limits", PlannerSpec(spy))
    try:
        mission = Mission.between(0, (2.0, 4.0), (5.0, 4.0))
        with TraverseEnv(FLAT, config=TraverseConfig(mission_length_m=3.0, border_m=1.0), planner="_test_limits") as env:
            env.reset(options={"mission": mission})
            drive_mission(env._world, mission, planner=planner_from_table({"name": "_test_limits"}), border_m=1.0,
                          classes=env.closed_classes, rules=FailureRules(timeout_factor=1.0))
        with TraverseEnv(FLAT, config=TraverseConfig(mission_length_m=3.0, border_m=1.0),
                         planner=PlannerChoice("_test_limits")) as env:  # no perception: the measured limits
            env.reset(options={"mission": mission})
    finally:
        PLANNERS._entries.pop("_test_limits")
    env_named, runner, env_bare = seen
    assert env_named == runner
    assert math.isclose(runner.max_slope, math.tan(math.radians(30.0)))
    assert env_bare.max_slope == 0.8 and env_bare != runner
