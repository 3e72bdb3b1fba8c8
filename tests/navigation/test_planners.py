"""Planner plug-ins: the registry, A* on the roughness cost grid, the path tracker and trials."""

import logging
import math

import numpy as np
import pytest

from offroadbench.analysis.roughness import HIGH, LOW, SEMI
from offroadbench.config import from_dict
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.planners import (
    PLANNERS,
    PlannerConfig,
    _astar,
    _segment_cost,
    get_planner,
    path_cost_grid,
    plan_astar,
    plan_path,
    plan_straight,
    planning_classes,
)
from offroadbench.sim import ControllerConfig, FailureRules, World, load_vehicle, run_mission
from offroadbench.sim.controller import LineTracker, PathTracker, make_tracker

CELL = 0.05
FLAT = Heightmap.flat(161, 241, CELL)  # 12 x 8 m


def _wall_classes(gap: bool = True) -> np.ndarray:
    """HIGH cells along x = 6 m from y = 0 to 5 m (to the top edge without the gap)."""
    classes = np.full(FLAT.shape, LOW, dtype=np.uint8)
    y_top = 5.0 if gap else 8.0
    classes[: int(round(y_top / CELL)) + 1, 118:123] = HIGH
    return classes


def _dense(points: np.ndarray, step: float = 0.01) -> np.ndarray:
    out = [points[0]]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, int(math.ceil(np.hypot(*(b - a)) / step)))
        out.extend(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    return np.array(out)


def _length(points: np.ndarray) -> float:
    return float(np.hypot(*np.diff(points, axis=0).T).sum())


# ---------------------------------------------------------------------------- registry
def test_registry_and_straight_plan():
    assert set(PLANNERS) >= {"straight", "astar"}
    wp = plan_straight(FLAT, None, (1.0, 2.0), (9.5, 3.25))
    assert wp.shape == (2, 2) and np.array_equal(wp, [[1.0, 2.0], [9.5, 3.25]])
    with pytest.raises(InputError, match="known planners: astar, straight"):
        get_planner("rrt")
    with pytest.raises(InputError, match="planner"):
        ControllerConfig(planner="rrt")
    assert from_dict(ControllerConfig, {"planner": "astar"}).planner == "astar"
    assert ControllerConfig().planner == "straight"


# ---------------------------------------------------------------------------- A*
def test_astar_cost_on_a_uniform_grid_is_the_octile_distance():
    cells = _astar(np.ones((10, 10)), (0, 0), (3, 5))
    assert cells[0] == (0, 0) and cells[-1] == (3, 5)
    steps = np.diff(np.array(cells), axis=0)
    assert np.hypot(steps[:, 0], steps[:, 1]).sum() == pytest.approx(3 * math.sqrt(2) + 2)
    blocked = np.ones((5, 5))
    blocked[:, 2] = np.inf
    assert _astar(blocked, (0, 0), (0, 4)) is None


def test_segment_cost_integrates_cell_costs():
    cost = np.ones((4, 4))
    cost[:, 2] = 3.0  # x in [0.5, 0.75) m at 0.25 m cells
    c = _segment_cost(cost, 0.25, np.array([0.0, 0.1]), np.array([1.0, 0.1]))
    assert c == pytest.approx(0.75 * 1.0 + 0.25 * 3.0, rel=0.05)


def test_astar_on_open_ground_is_the_straight_line():
    classes = np.full(FLAT.shape, LOW, dtype=np.uint8)
    wp = plan_astar(FLAT, classes, (1.0, 2.0), (10.0, 6.0))
    assert np.array_equal(wp, [[1.0, 2.0], [10.0, 6.0]])


def test_astar_goes_through_the_gap_in_a_wall_of_high_cells():
    classes = _wall_classes()
    cfg = PlannerConfig()
    wp = plan_astar(FLAT, classes, (2.0, 2.5), (10.0, 2.5), cfg)
    assert np.array_equal(wp[0], [2.0, 2.5]) and np.array_equal(wp[-1], [10.0, 2.5])
    dense = _dense(wp)
    r = np.rint(dense[:, 1] / CELL).astype(int)
    c = np.rint(dense[:, 0] / CELL).astype(int)
    assert not np.any(classes[r, c] == HIGH)
    # over the wall's end (y = 5 m) with the clearance, and no longer than needed
    assert dense[:, 1].max() > 5.0 + cfg.clearance_m - 0.25
    assert 8.0 < _length(wp) < 2 * math.hypot(4.0, 3.5) + 1.0
    assert len(wp) <= 6  # string pulling left a few corners, not one per cell
    # the straight line crosses the wall
    line = _dense(plan_straight(FLAT, classes, (2.0, 2.5), (10.0, 2.5)))
    assert np.any(classes[np.rint(line[:, 1] / CELL).astype(int), np.rint(line[:, 0] / CELL).astype(int)] == HIGH)


def test_astar_goes_round_a_semi_patch_but_crosses_a_semi_band():
    classes = np.full(FLAT.shape, LOW, dtype=np.uint8)
    classes[60:101, 100:141] = SEMI  # 2 m square on the line y = 4 m
    cost, f = path_cost_grid(FLAT, classes)
    assert f == 5
    assert cost.min() == pytest.approx(1.0) and cost.max() == pytest.approx(1.0 + PlannerConfig().semi_cost)

    def path_cost(points):
        return sum(_segment_cost(cost, f * CELL, a, b) for a, b in zip(points[:-1], points[1:]))

    # planning cells of 5 px: the patch fills cells 20..27 (x = 5 .. 7 m, extra cost 2) and one
    # pixel column in five of cell 28; the footprint's box filter keeps that integral across it
    straight = plan_straight(FLAT, classes, (2.0, 4.0), (10.0, 4.0))
    assert path_cost(straight) == pytest.approx(8.0 + 2.0 * (2.0 + 0.2 * 0.25), rel=0.01)
    wp = plan_astar(FLAT, classes, (2.0, 4.0), (10.0, 4.0))
    d = _dense(wp)  # 1 cm steps
    in_semi = classes[np.rint(d[:, 1] / CELL).astype(int), np.rint(d[:, 0] / CELL).astype(int)] == SEMI
    assert in_semi.sum() * 0.01 < 0.8  # a corner clipped at most, not 2 m through it
    assert _length(wp) < 8.6 and path_cost(wp) < 0.8 * path_cost(straight)
    classes[:, 100:141] = SEMI  # now a band across the whole map: semi is dear, not forbidden
    wp = plan_astar(FLAT, classes, (2.0, 4.0), (10.0, 4.0))
    assert _length(wp) == pytest.approx(8.0, abs=0.1)


def test_astar_without_a_way_round_falls_back_or_raises(caplog):
    classes = _wall_classes(gap=False)
    with caplog.at_level(logging.WARNING, logger="offroadbench.navigation.planners"):
        wp = plan_astar(FLAT, classes, (2.0, 2.5), (10.0, 2.5))
    assert np.array_equal(wp, [[2.0, 2.5], [10.0, 2.5]]) and "no path" in caplog.text
    with pytest.raises(InputError, match="no path"):
        plan_astar(FLAT, classes, (2.0, 2.5), (10.0, 2.5), PlannerConfig(fallback_to_straight=False))


def test_plan_path_classes_default_to_the_closed_map_and_are_cached():
    hm = Heightmap.flat(61, 61, CELL)
    assert planning_classes(hm) is planning_classes(hm)
    assert not planning_classes(hm).flags.writeable
    assert np.array_equal(plan_path("astar", hm, (0.5, 0.5), (2.5, 2.5)), [[0.5, 0.5], [2.5, 2.5]])


# ---------------------------------------------------------------------------- tracking
def test_two_waypoints_use_the_line_tracker_unchanged():
    spec = load_vehicle("husky")
    cfg = ControllerConfig()
    wp = plan_straight(FLAT, None, (1.0, 2.0), (9.0, 5.0))
    tr = make_tracker(wp, spec, cfg)
    ref = LineTracker((1.0, 2.0), (9.0, 5.0), spec, cfg)
    assert isinstance(tr, LineTracker)
    for k in range(40):
        state = (np.array([1.0 + 0.1 * k, 2.0 + 0.02 * k]), 0.3, np.array([0.8, 0.3]))
        assert tr.command(*state) == ref.command(*state)


def test_path_tracker_follows_arc_length_and_does_not_short_cut_a_u_turn():
    spec = load_vehicle("husky")
    u = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 1.0], [0.0, 1.0]])
    tr = PathTracker(u, spec, ControllerConfig(lookahead_m=1.5))
    assert tr.length_m == pytest.approx(21.0)
    assert tr.progress(np.array([1.0, 0.6])) == pytest.approx(1.0)  # nearer the return leg, but at its start
    assert tr.progress(np.array([-0.5, 0.0])) == pytest.approx(-0.5)  # before the start, as LineTracker
    assert np.allclose(tr.point_at(10.5), [10.0, 0.5])
    for x in np.arange(1.0, 10.0, 0.5):
        tr.progress(np.array([x, 0.0]))
    assert tr.progress(np.array([9.9, 0.9])) == pytest.approx(10.9, abs=0.11)
    assert tr.progress(np.array([5.0, 1.0])) == pytest.approx(16.0)
    # at the corner (9.5, 0) heading +x the lookahead point is up the side: turn left
    tr2 = PathTracker(u, spec, ControllerConfig(lookahead_m=1.5))
    for _ in range(40):
        v, w, s = tr2.command(np.array([9.5, 0.0]), 0.0, np.array([0.5, 0.0]))
    assert s == pytest.approx(9.5) and v > 0 and w > 0


def test_path_tracker_arcs_round_toward_a_target_behind():
    spec = load_vehicle("husky")
    back = np.array([[0.0, 0.0], [-5.0, 0.5], [-10.0, 0.5]])  # the path leaves behind the vehicle
    tr = PathTracker(back, spec, ControllerConfig(lookahead_m=1.5))
    for _ in range(40):
        v, w, s = tr.command(np.array([0.0, 0.0]), 0.0, np.array([0.0, 0.0]))
    # target at a bearing of about +174 deg: full-curvature arc (2 / l) to the left, not a stop
    assert s == 0.0 and v > 0.1 and w == pytest.approx(min(2.0 * v / 1.5, spec.max_yaw_rate_rad_s), rel=0.02)


# ---------------------------------------------------------------------------- trials
def _wall_terrain() -> Heightmap:
    z = np.zeros(FLAT.shape)
    x = np.arange(FLAT.cols) * CELL
    y = np.arange(FLAT.rows) * CELL
    z[(y <= 5.0)[:, None] & (np.abs(x - 6.0) <= 0.1)[None, :]] = 0.5  # a 0.5 m wall with a 3 m gap
    return Heightmap(z, CELL)


def test_astar_drives_round_a_wall_the_straight_line_is_stopped_by():
    hm = _wall_terrain()
    mission = Mission.between(0, (2.0, 2.5), (10.0, 2.5))
    rules = FailureRules(stuck_window_s=5.0)
    with World(hm) as world:
        straight, tel_s = run_mission(world, mission, rules=rules)
        astar, tel_a = run_mission(world, mission, controller=ControllerConfig(planner="astar"), rules=rules)
    assert straight.failure_reason == "stuck" and tel_s["x_m"].max() < 6.0
    assert astar.success
    assert astar.path_length_m > 9.0  # the detour
    assert tel_a["y_m"].max() > 5.3  # round the wall's end, which is at y = 5 m
    near_wall = np.abs(tel_a["x_m"] - 6.0) < 0.6
    assert np.all(tel_a["y_m"][near_wall] > 5.0)
