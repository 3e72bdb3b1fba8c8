"""Planners on a degraded map: coarse cells hide thin obstacles, noise is seeded by the mission, a
limited sensing radius re-plans as the vehicle sees more, and the physics still drives the truth."""

import math

import numpy as np
import pytest

from offroadbench.analysis.roughness import LOW
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.perception import (
    PerceptionConfig,
    Replanner,
    degrade,
    perception_seed,
    seen_map,
    split_perception,
)
from offroadbench.navigation.planners import (
    PlannerChoice,
    PlanningProblem,
    plan,
    planner_from_table,
)

CELL = 0.05


def _ridge_map(height=0.4, gap=True) -> Heightmap:
    """12 x 8 m flat ground with a ridge 5 pixels wide along x = 6 m, from y = 0 to 5 m (a gap above)."""
    z = np.zeros((161, 241))
    z[: 101 if gap else 161, 118:123] = height
    return Heightmap(z, CELL)


def _mission(index=0, start=(2.0, 2.0), goal=(10.0, 2.0)):
    return Mission(index=index, start_xy_m=start, goal_xy_m=goal,
                   heading_rad=math.atan2(goal[1] - start[1], goal[0] - start[0]) % (2 * math.pi))


def _problem(hm, m):
    return PlanningProblem(hm=hm, classes=np.full(hm.shape, LOW, dtype=np.uint8), start_xy=m.start_xy_m,
                           goal_xy=m.goal_xy_m, border_m=0.5)


def _max_dy(path):
    return float(np.max(np.abs(np.asarray(path)[:, 1] - 2.0)))


def test_the_true_map_makes_astar_go_round_the_ridge():
    hm, m = _ridge_map(), _mission()
    path = plan("astar", _problem(hm, m))
    assert _max_dy(path) > 2.5  # through the gap above y = 5 m


def test_a_coarse_map_hides_a_thin_ridge():
    hm, m = _ridge_map(), _mission()
    coarse = degrade(hm, PerceptionConfig(map_cell_m=1.0), np.random.default_rng(0))
    assert coarse.shape == hm.shape
    # block means of 20 x 20 pixels: a 5-pixel ridge of 0.4 m averages to at most 0.1 m
    assert coarse.z.max() <= 0.4 * 5 / 20 + 1e-12
    assert coarse.z.mean() == pytest.approx(hm.z.mean(), rel=0.05)
    path = plan("astar", _problem(coarse, m))
    assert _max_dy(path) < 0.5  # straight through the ridge it no longer sees


def test_height_noise_has_its_standard_deviation_and_is_seeded_by_the_mission():
    hm = Heightmap.flat(201, 201, CELL)
    cfg = PerceptionConfig(map_noise_m=0.05)
    a = degrade(hm, cfg, np.random.default_rng(perception_seed(_mission(0))))
    b = degrade(hm, cfg, np.random.default_rng(perception_seed(_mission(0))))
    c = degrade(hm, cfg, np.random.default_rng(perception_seed(_mission(1))))
    assert np.array_equal(a.z, b.z) and not np.array_equal(a.z, c.z)
    assert a.z.std() == pytest.approx(0.05, rel=0.05)
    smooth = degrade(hm, PerceptionConfig(map_noise_m=0.05, map_noise_corr_m=0.5), np.random.default_rng(1))
    assert smooth.z.std() == pytest.approx(0.05, rel=1e-6)
    # correlated: neighbouring pixels nearly agree, unlike the white field
    assert np.abs(np.diff(smooth.z, axis=1)).mean() < 0.1 * np.abs(np.diff(a.z, axis=1)).mean()
    assert degrade(hm, PerceptionConfig(), np.random.default_rng(0)) is hm


def test_unseen_ground_is_a_smooth_guess_from_what_was_seen():
    # the guess is a weighted mean of seen heights: never outside their range, and smooth
    z = np.add.outer(np.arange(60.0), np.arange(80.0)) * 0.01
    hm = Heightmap(z, CELL)
    seen = np.zeros(hm.shape, dtype=bool)
    seen[20:40, 20:50] = True
    out = seen_map(hm, seen)
    assert np.array_equal(out.z[seen], hm.z[seen])
    assert hm.z[seen].min() <= out.z.min() and out.z.max() <= hm.z[seen].max()
    assert np.abs(np.diff(np.where(seen, np.nan, out.z), axis=1))[:, :19].max() < 0.01
    # a seen ridge is not stretched across the unknown: beyond the seen block the guess is low
    r = np.zeros((100, 100))
    r[:, 48:52] = 0.4
    seen = np.zeros(r.shape, dtype=bool)
    seen[40:60, 30:70] = True
    out = seen_map(Heightmap(r, CELL), seen)
    assert out.z[seen].max() == 0.4 and out.z[~seen].max() < 0.1
    assert np.isfinite(out.z).all()


def test_sensing_radius_replans_round_the_ridge_once_it_is_seen():
    hm, m = _ridge_map(gap=True), _mission()
    cfg = PerceptionConfig(sensing_radius_m=1.5, replan_every_m=0.5)
    rp = Replanner(lambda p: plan("astar", p), _problem(hm, m), m, cfg)
    assert _max_dy(rp.waypoints) < 0.5  # the ridge 4 m ahead is not seen yet: straight on
    turned = None
    for x in np.arange(2.0, 5.6, 0.25):
        if rp.update((x, 2.0)) is not None and _max_dy(rp.waypoints) > 2.5:
            turned = x
            break
    assert turned is not None and turned >= 6.0 - 1.5 - 0.5 - 1e-9
    assert rp.replans >= 1 and np.array_equal(rp.trace[0], m.start_xy_m) and np.array_equal(rp.trace[-1], m.goal_xy_m)


def test_the_planner_table_takes_the_map_keys():
    choice = planner_from_table({"name": "astar", "grid_m": 0.25, "map_noise_m": 0.02, "sensing_radius_m": 3.0})
    assert choice.perception == PerceptionConfig(map_noise_m=0.02, sensing_radius_m=3.0)
    assert choice.config.grid_m == 0.25
    # the default limits are the spec sheet's (issue 42): a planner that plans with the vehicle keeps them; the
    # truth with the measured limits is None (as runs before the default stored it), and so is the straight line's
    assert planner_from_table({"name": "astar", "map_noise_m": 0.0}).perception == PerceptionConfig(limits="sheet")
    assert planner_from_table({"name": "astar", "limits": "measured"}).perception is None
    assert planner_from_table({"name": "straight"}).perception is None
    assert planner_from_table({"name": "straight", "limits": "sheet"}).perception == PerceptionConfig()
    with pytest.raises(InputError, match="map_noise_m"):
        planner_from_table({"name": "astar", "map_noise_m": -1.0})
    with pytest.raises(InputError):
        planner_from_table({"name": "astar", "map_nosie_m": 0.1})
    cfg, rest = split_perception({"name": "x", "map_cell_m": 0.5})
    assert cfg.map_cell_m == 0.5 and rest == {"name": "x"}


def test_a_trial_drives_the_true_terrain_while_the_planner_replans():
    from offroadbench.sim import World
    from offroadbench.sim.trial.runner import drive_mission

    hm = _ridge_map(gap=True)
    m = _mission(start=(2.0, 2.0), goal=(5.0, 2.0))
    choice = PlannerChoice("astar", perception=PerceptionConfig(sensing_radius_m=1.0, replan_every_m=0.5,
                                                                 map_noise_m=0.005))
    with World(hm) as world:
        rec = drive_mission(world, m, planner=choice, classes=np.full(hm.shape, LOW, dtype=np.uint8), border_m=0.5)
    assert rec.result.success
    assert np.array_equal(rec.path_xy[0], m.start_xy_m) and np.array_equal(rec.path_xy[-1], m.goal_xy_m)
    assert len(rec.path_xy) > 2  # the start, re-planning positions and the last plan
