"""Contract of every registered planner and policy (built-in or installed): a planner's path runs
from exactly the start to exactly the goal and stays inside the mission border; a policy returns a
finite (v, omega) for the env's observations."""

import numpy as np
import pytest

from offroadbench.analysis.roughness import RoughnessConfig, classify_terrain
from offroadbench.navigation.missions import MissionConfig, sample_missions
from offroadbench.navigation.observation import ObservationConfig, observation
from offroadbench.navigation.planners import PLANNERS, PlannerChoice, PlanningProblem, plan
from offroadbench.navigation.policies import POLICIES, PolicyContext, make_policy

BORDER = 1.5


@pytest.fixture(scope="module")
def terrain():
    """A steep small terrain (D = 2.6, 1.5 m relief over 10 m) with many high cells."""
    from offroadbench.terrain.recipe import apply_overrides, generate_terrain, load_recipe

    recipe = apply_overrides(load_recipe("paper-d2.6"),
                             {"grid.rows": 201, "grid.cols": 201, "layers.base.relief_m": 1.5})
    hm = generate_terrain(recipe, 3)
    closed = classify_terrain(hm, RoughnessConfig(border_m=BORDER)).closed
    missions = sample_missions(hm, closed, MissionConfig(count=4, length_m=6.0, border_m=BORDER),
                               np.random.default_rng(0))
    return hm, closed, missions


def _dense(points, step=0.02):
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:], strict=True):
        n = max(1, int(np.ceil(np.hypot(*(b - a)) / step)))
        out.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    return np.vstack(out)


@pytest.mark.parametrize("name", PLANNERS.names())
def test_planner_contract(name, terrain):
    hm, closed, missions = terrain
    spec = PLANNERS.get(name)
    choice = PlannerChoice(name, spec.config())
    for m in missions:
        problem = PlanningProblem(hm=hm, classes=closed, start_xy=m.start_xy_m, goal_xy=m.goal_xy_m, border_m=BORDER)
        wp = spec.plan(problem, choice.config)
        assert wp.ndim == 2 and wp.shape[1] == 2 and len(wp) >= 2 and np.all(np.isfinite(wp))
        assert tuple(wp[0]) == m.start_xy_m and tuple(wp[-1]) == m.goal_xy_m  # exactly
        assert np.all(problem.inside_border(_dense(wp)))
        assert np.array_equal(plan(choice, problem), wp)  # deterministic, and passes plan()'s checks
    assert spec.summary


@pytest.mark.parametrize("name", POLICIES.names())
def test_policy_contract(name, terrain):
    hm, closed, missions = terrain
    spec = POLICIES.get(name)
    obs_cfg = ObservationConfig()
    policy = make_policy(name, spec.config(), PolicyContext(observation=obs_cfg))
    m = missions[0]
    policy.reset(PlanningProblem(hm=hm, classes=closed, start_xy=m.start_xy_m, goal_xy=m.goal_xy_m))
    z = float(hm.height_at(*m.start_xy_m))
    for yaw in (m.heading_rad, m.heading_rad + np.pi):
        obs = observation(hm, obs_cfg, m.goal_xy_m, (*m.start_xy_m, z), 0.0, 0.0, yaw, (0.0, 0.0, 0.0),
                          (0.0, 0.0, 0.0), hm.z_min_m)
        if "map" in spec.needs:  # the runner adds the believed pose and the perceived map (drivers.NEEDS)
            obs["pose"], obs["elevation_m"] = np.array([*m.start_xy_m, yaw]), hm.z
        v, w = policy.act(obs)
        assert np.isfinite(v) and np.isfinite(w)
    assert spec.summary
    assert name not in PLANNERS  # one namespace for [planner] name
