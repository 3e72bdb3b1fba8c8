"""Planner plug-ins: the registry, A* and hybrid A* on the hazard and class cost grids, the path tracker and trials."""

import dataclasses
import logging
import math

import numpy as np
import pytest

from offroadbench.navigation.perception import PerceptionConfig

from offroadbench.analysis.roughness import HIGH, LOW, SEMI
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.planners import (
    PLANNERS,
    AStarConfig,
    LatticeConfig,
    PlannerChoice,
    PlanningProblem,
    VehicleEnvelope,
    cost_grid,
    footprint_hazard,
    plan,
    plan_astar,
    plan_lattice,
    plan_straight,
    planner_from_table,
)
from offroadbench.navigation.planners.astar import _astar
from offroadbench.sim import ControllerConfig, FailureRules, World, load_vehicle, run_mission
from offroadbench.sim.trial.controller import LineTracker, PathTracker, make_tracker

CELL = 0.05
FLAT = Heightmap.flat(161, 241, CELL)  # 12 x 8 m


def _wall_classes(gap: bool = True) -> np.ndarray:
    """HIGH cells along x = 6 m from y = 0 to 5 m (to the top edge without the gap)."""
    classes = np.full(FLAT.shape, LOW, dtype=np.uint8)
    y_top = 5.0 if gap else 8.0
    classes[: int(round(y_top / CELL)) + 1, 118:123] = HIGH
    return classes


def _problem(classes, start, goal, hm=None, border_m=0.0, vehicle=VehicleEnvelope()):
    return PlanningProblem(hm=hm or FLAT, classes=classes, start_xy=start, goal_xy=goal, border_m=border_m,
                           vehicle=vehicle)


def _by_classes(planner):
    """The planner's config with the paper's roughness-class cost grid (the class-map tests)."""
    return (AStarConfig if planner is plan_astar else LatticeConfig)(hazard="classes")


CLASSES = AStarConfig(hazard="classes")


def _open():
    return np.full(FLAT.shape, LOW, dtype=np.uint8)


def _dense(points: np.ndarray, step: float = 0.01) -> np.ndarray:
    out = [points[0]]
    for a, b in zip(points[:-1], points[1:], strict=True):
        n = max(1, int(math.ceil(np.hypot(*(b - a)) / step)))
        out.extend(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    return np.array(out)


def _length(points: np.ndarray) -> float:
    return float(np.hypot(*np.diff(points, axis=0).T).sum())


# ---------------------------------------------------------------------------- registry
def test_registry_and_the_planner_table():
    assert set(PLANNERS) >= {"straight", "astar", "lattice"}
    wp = plan_straight(_problem(_open(), (1.0, 2.0), (9.5, 3.25)))
    assert wp.shape == (2, 2) and np.array_equal(wp, [[1.0, 2.0], [9.5, 3.25]])
    with pytest.raises(InputError, match=r"unknown planner or policy 'astra'; did you mean 'astar'.*policies: mppi, ppo, reactive"):
        planner_from_table({"name": "astra"})
    choice = planner_from_table({"name": "astar", "grid_m": 0.5})
    # A* plans with the vehicle: the default limits (the spec sheet's, issue 42) come with it
    assert choice == PlannerChoice("astar", AStarConfig(grid_m=0.5), "planner", PerceptionConfig(limits="sheet"))
    assert choice.params["grid_m"] == 0.5
    with pytest.raises(InputError, match="turn_radius_m"):
        planner_from_table({"name": "astar", "turn_radius_m": 2.0})  # a lattice field
    assert planner_from_table({}).name == "straight"
    assert planner_from_table({"name": "reactive"}).kind == "policy"


def test_a_bare_choice_gets_the_default_config_and_a_wrong_one_is_refused():
    """``PlannerChoice("astar")`` (no config) plans as ``plan("astar")``; another entry's config is an
    InputError naming both classes, for planners and policies alike."""
    from offroadbench.navigation.observation import ObservationConfig
    from offroadbench.navigation.policies import PolicyContext, make_policy

    problem = _problem(_wall_classes(), (2.0, 2.0), (10.0, 2.5))
    assert np.array_equal(plan(PlannerChoice("astar"), problem), plan("astar", problem))
    assert np.array_equal(plan(PlannerChoice("astar"), problem), plan(PlannerChoice("astar", AStarConfig()), problem))
    with pytest.raises(InputError, match="planner 'astar' takes config class AStarConfig, got LatticeConfig"):
        plan(PlannerChoice("astar", LatticeConfig()), problem)
    context = PolicyContext(observation=ObservationConfig(), vehicle=VehicleEnvelope(), track_m=0.55, control_rate_hz=20)
    assert make_policy("reactive", PlannerChoice("reactive").config, context) is not None
    with pytest.raises(InputError, match="policy 'reactive' takes config class ReactiveConfig, got AStarConfig"):
        make_policy("reactive", AStarConfig(), context)


def test_plan_checks_the_contract_of_a_plug_in():
    from offroadbench.navigation.planners import PlannerSpec

    PLANNERS.add("_test_bad", PlannerSpec(lambda problem, cfg: np.array([[0.0, 0.0], [1.0, 1.0]])))
    try:
        with pytest.raises(RuntimeError, match="not from the start"):
            plan("_test_bad", _problem(_open(), (1.0, 2.0), (3.0, 2.0)))
    finally:
        PLANNERS._entries.pop("_test_bad")



def test_entries_declare_what_they_need_and_the_runner_gives_exactly_that():
    """What a driver needs beyond the mission (class map, vehicle envelope) is declared on its
    registry entry, not inferred from its name: ``straight`` needs neither, the cost-grid planners
    both, ``reactive`` the vehicle; a plug-in that says nothing needs both. The runner hands a
    planner the class map and the measured envelope only when its entry declares them, and refuses
    to drive one that needs the class map without it."""
    from offroadbench.navigation.drivers import DEFAULT_NEEDS, NEEDS, PlannerSpec
    from offroadbench.navigation.policies import POLICIES

    assert PLANNERS.get("straight").needs == frozenset()
    assert PLANNERS.get("astar").needs == PLANNERS.get("lattice").needs == DEFAULT_NEEDS == {"classes", "vehicle"}
    assert NEEDS == {"classes", "vehicle", "map"} and PlannerSpec(plan_straight).needs == DEFAULT_NEEDS
    assert POLICIES.get("reactive").needs == {"vehicle"} and POLICIES.get("mppi").needs == {"vehicle", "map"}
    assert PlannerChoice("straight").needs == frozenset() and planner_from_table({"name": "reactive"}).needs == {"vehicle"}
    with pytest.raises(ValueError, match="wheels"):
        PlannerSpec(plan_straight, needs=frozenset({"wheels"}))

    seen = {}

    def spy(name):
        def plan_spy(problem, cfg):
            seen[name] = (problem.classes, problem.vehicle)
            return problem.endpoints()
        return plan_spy

    needs = {"_test_none": frozenset(), "_test_vehicle": frozenset({"vehicle"}), "_test_default": DEFAULT_NEEDS}
    for name, need in needs.items():
        PLANNERS.add(name, PlannerSpec(spy(name), needs=need))
    try:
        classes = _open()
        mission = Mission.between(0, (2.0, 2.0), (3.0, 2.0))
        with World(FLAT) as world:
            for name in needs:
                run_mission(world, mission, planner=PlannerChoice(name), classes=classes,
                            rules=FailureRules(timeout_factor=1.0))
            with pytest.raises(InputError, match="planner '_test_default' needs the class map"):
                run_mission(world, mission, planner=PlannerChoice("_test_default"))
    finally:
        for name in needs:
            PLANNERS._entries.pop(name)
    assert seen["_test_none"] == (None, None)
    assert seen["_test_vehicle"][0] is None and isinstance(seen["_test_vehicle"][1], VehicleEnvelope)
    measured = seen["_test_default"][1]
    assert np.array_equal(seen["_test_default"][0], classes)
    assert measured == seen["_test_vehicle"][1] and measured != VehicleEnvelope(length_m=1.0)  # measured, not a default
    assert measured.length_m == pytest.approx(0.99, abs=0.02)  # the Husky's overall length (spec sheet: 0.99 m)

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
    grid = cost_grid(_problem(_open(), (1.0, 1.0), (2.0, 1.0)), AStarConfig(grid_m=0.25))
    cost = np.ones_like(grid.cost)
    cost[:, 10:14] = 3.0  # x in [2.5, 3.5) m minus half a pixel
    g = type(grid)(cost, grid.f, grid.step_m)
    c = g.segment_cost(np.array([1.5, 2.0]), np.array([4.5, 2.0]))
    assert c == pytest.approx(2.0 * 1.0 + 1.0 * 3.0, rel=0.03)


def test_astar_on_open_ground_is_the_straight_line():
    for planner in (plan_astar, plan_lattice):
        wp = planner(_problem(_open(), (1.0, 2.0), (10.0, 6.0)))
        assert np.array_equal(wp[0], [1.0, 2.0]) and np.array_equal(wp[-1], [10.0, 6.0])
        assert _length(wp) == pytest.approx(math.hypot(9.0, 4.0), rel=0.01)


def _clearance(points, classes):
    """Smallest distance from the (dense) path to a high pixel, metres."""
    from scipy.ndimage import distance_transform_edt

    d = distance_transform_edt(classes != HIGH) * CELL
    r = np.rint(points[:, 1] / CELL).astype(int)
    c = np.rint(points[:, 0] / CELL).astype(int)
    return float(d[r, c].min())


@pytest.mark.parametrize("planner", [plan_astar, plan_lattice])
def test_terrain_aware_planners_go_through_the_gap_with_half_a_width_of_clearance(planner):
    classes = _wall_classes()
    veh = VehicleEnvelope()
    wp = planner(_problem(classes, (2.0, 2.5), (10.0, 2.5)), _by_classes(planner))
    assert np.array_equal(wp[0], [2.0, 2.5]) and np.array_equal(wp[-1], [10.0, 2.5])
    dense = _dense(wp)
    assert _clearance(dense, classes) >= 0.5 * veh.width_m - CELL
    assert dense[:, 1].max() > 5.0 + 0.5 * veh.width_m  # over the wall's end (y = 5 m)
    assert 8.0 < _length(wp) < 2 * math.hypot(4.0, 3.5) + 2.0
    line = _dense(plan_straight(_problem(classes, (2.0, 2.5), (10.0, 2.5))))
    assert _clearance(line, classes) == 0.0  # the straight line crosses the wall


def test_a_wider_vehicle_keeps_further_from_high_cells():
    classes = _wall_classes()
    wide = VehicleEnvelope(width_m=1.4, length_m=1.4)
    wp = plan_astar(_problem(classes, (2.0, 2.5), (10.0, 2.5), vehicle=wide), CLASSES)
    assert _clearance(_dense(wp), classes) >= 0.7 - CELL


@pytest.mark.parametrize("planner", [plan_astar, plan_lattice])
def test_paths_stay_inside_the_mission_border(planner):
    """A wall that leaves a gap only in the border strip: the planners must not use it."""
    classes = np.full(FLAT.shape, LOW, dtype=np.uint8)
    classes[int(1.5 / CELL):, 118:123] = HIGH  # the wall reaches down to y = 1.5 m; the border is 2 m
    problem = _problem(classes, (3.0, 4.0), (9.0, 4.0), border_m=2.0)
    wp = planner(problem, _by_classes(planner))  # the gap is in the border strip: crossing the wall is the only way left
    assert np.all(problem.inside_border(_dense(wp)))
    classes[: int(6.5 / CELL)] = LOW
    classes[int(6.5 / CELL):, 118:123] = HIGH  # now a gap at y < 6.5 m, inside the border
    wp = planner(_problem(classes, (3.0, 4.0), (9.0, 4.0), border_m=2.0), _by_classes(planner))
    assert np.all(_problem(classes, (3.0, 4.0), (9.0, 4.0), border_m=2.0).inside_border(_dense(wp)))


def test_astar_goes_round_a_semi_patch_but_crosses_a_semi_band():
    classes = _open()
    classes[60:101, 100:141] = SEMI  # 2 m square on the line y = 4 m
    problem = _problem(classes, (2.0, 4.0), (10.0, 4.0))
    grid = cost_grid(problem, CLASSES)
    assert grid.f == 5
    assert np.nanmin(grid.cost) == pytest.approx(1.0) and grid.cost.max() == pytest.approx(1.0 + AStarConfig().semi_cost)

    def path_cost(points):
        return sum(grid.segment_cost(a, b) for a, b in zip(points[:-1], points[1:], strict=True))

    straight = plan_straight(problem)
    assert path_cost(straight) == pytest.approx(8.0 + 2.0 * 2.0, rel=0.05)
    wp = plan_astar(problem, CLASSES)
    d = _dense(wp)  # 1 cm steps
    in_semi = classes[np.rint(d[:, 1] / CELL).astype(int), np.rint(d[:, 0] / CELL).astype(int)] == SEMI
    assert in_semi.sum() * 0.01 < 0.8  # a corner clipped at most, not 2 m through it
    assert _length(wp) < 8.8 and path_cost(wp) < 0.8 * path_cost(straight)
    classes[:, 100:141] = SEMI  # now a band across the whole map: semi is dear, not forbidden
    wp = plan_astar(_problem(classes, (2.0, 4.0), (10.0, 4.0)), CLASSES)
    assert _length(wp) == pytest.approx(8.0, abs=0.1)


@pytest.mark.parametrize("planner", [plan_astar, plan_lattice])
def test_without_a_way_round_the_planners_cross_as_little_high_ground_as_they_can(planner, caplog):
    classes = _wall_classes(gap=False)  # 0.25 m thick, from edge to edge
    problem = _problem(classes, (2.0, 2.5), (10.0, 2.5))
    with caplog.at_level(logging.WARNING, logger="offroadbench.navigation.planners"):
        wp = planner(problem, _by_classes(planner))
    assert "no path" not in caplog.text  # no fallback to the straight line: a planned crossing
    d = _dense(wp)
    on_high = classes[np.rint(d[:, 1] / CELL).astype(int), np.rint(d[:, 0] / CELL).astype(int)] == HIGH
    assert 0 < on_high.sum() * 0.01 < 0.6  # across the wall, not along it


def test_lattice_leaves_along_the_heading_and_never_turns_tighter_than_its_radius():
    classes = _wall_classes()
    start, goal = (2.0, 2.5), (10.0, 2.5)  # the wall ahead forces two turns
    cfg = LatticeConfig(turn_radius_m=1.5, hazard="classes")
    wp = plan_lattice(_problem(classes, start, goal), cfg)
    heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
    first = wp[1] - wp[0]
    assert abs(math.atan2(first[1], first[0]) - heading) < 0.2
    seg = np.diff(wp[:-1], axis=0)  # the last piece to the exact goal is a straight stub
    ang = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    lens = np.hypot(seg[:, 0], seg[:, 1])
    kappa = np.abs(np.diff(ang)) / (0.5 * (lens[1:] + lens[:-1]))
    assert kappa.max() <= 1.0 / cfg.turn_radius_m * 1.05
    assert _clearance(_dense(wp), classes) >= 0.5 * VehicleEnvelope().width_m - CELL


# ---------------------------------------------------------------------------- tracking
def test_two_waypoints_use_the_line_tracker_unchanged():
    spec = load_vehicle("husky")
    cfg = ControllerConfig()
    wp = plan_straight(_problem(_open(), (1.0, 2.0), (9.0, 5.0)))
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
        astar, tel_a = run_mission(world, mission, planner=planner_from_table({"name": "astar"}),
                                   classes=_wall_classes(), rules=rules)
    assert straight.failure_reason == "stuck" and tel_s["x_m"].max() < 6.0
    assert astar.success
    assert astar.path_length_m > 9.0  # the detour
    assert tel_a["y_m"].max() > 5.3  # round the wall's end, which is at y = 5 m
    near_wall = np.abs(tel_a["x_m"] - 6.0) < 0.6
    assert np.all(tel_a["y_m"][near_wall] > 5.0)


# ---------------------------------------------------------------------------- footprint hazard
def _step_wall(height: float, gap: bool = True) -> Heightmap:
    """A 0.3 m thick wall of ``height`` along x = 6 m, from y = 0 to 5 m (to the top edge without the gap)."""
    z = np.zeros(FLAT.shape)
    x = np.arange(FLAT.cols) * CELL
    y = np.arange(FLAT.rows) * CELL
    z[(y <= (5.0 if gap else 8.0))[:, None] & (np.abs(x - 6.0) <= 0.15)[None, :]] = height
    return Heightmap(z, CELL)


def test_footprint_hazard_of_a_tilted_plane_and_of_a_step():
    veh = VehicleEnvelope()
    x = np.arange(FLAT.cols) * CELL
    plane = Heightmap(np.broadcast_to(0.2 * x, FLAT.shape).copy(), CELL)
    hz = footprint_hazard(plane, veh, 5)
    inner = (slice(4, -4), slice(4, -4))  # away from the edge padding
    assert np.allclose(hz["slope"][inner], 0.2 / veh.max_slope)
    assert np.allclose(hz["roughness"][inner], 0.0, atol=1e-9)
    # the wheel's path on a plane rises with it across the window (half a wheel radius each way,
    # rounded up to 2 pixels of 5 cm)
    assert np.allclose(hz["step"][inner], 0.2 * 4 * CELL / veh.max_step_m)
    row = 4  # y = 1 m, beside the wall
    kerb = footprint_hazard(_step_wall(0.12), veh, 5)
    cols = (np.arange(kerb["step"].shape[1]) * 5 + 2) * CELL  # planning-cell centres, m
    # the window holds the wheel's whole climb onto a step just under its limit
    assert kerb["step"][row, np.abs(cols - 6.0) < 0.2].max() == pytest.approx(0.12 / veh.max_step_m)
    assert kerb["hazard"].max() < 1.0
    far = np.abs(cols - 6.0) > 0.15 + 0.5 * veh.width_m + veh.wheel_radius_m + 0.25
    assert np.all(kerb["step"][row, far] == 0.0)
    wall = footprint_hazard(_step_wall(0.2), veh, 5)
    assert wall["hazard"][row, np.abs(cols - 6.0) < 0.2].min() > 1.0


def test_footprint_hazard_is_computed_once_per_map_vehicle_and_grid():
    """Every mission on a terrain plans on the same hazard: it is kept per (map, vehicle, grid),
    read-only, equal to a fresh computation, and recomputed for another vehicle, grid or map."""
    import gc

    from offroadbench.navigation import costmap

    hm = _step_wall(0.12)
    veh = VehicleEnvelope()
    first = footprint_hazard(hm, veh, 5)
    assert footprint_hazard(hm, veh, 5) is first
    fresh = costmap._footprint_hazard(hm, veh, 5)
    assert all(np.array_equal(first[k], fresh[k]) for k in fresh)
    assert not first["hazard"].flags.writeable
    wide = footprint_hazard(hm, dataclasses.replace(veh, width_m=1.2), 5)
    assert wide is not first and wide["step"].sum() > first["step"].sum()  # a wider reach sees the step sooner
    assert footprint_hazard(hm, veh, 4) is not first
    assert footprint_hazard(_step_wall(0.12), veh, 5) is not first  # another (equal) map object
    n = len(costmap._HAZARD_CACHE)
    del hm, first, wide
    gc.collect()
    assert len(costmap._HAZARD_CACHE) < n  # dropped with its map


@pytest.mark.parametrize("planner", [plan_astar, plan_lattice])
def test_footprint_planners_go_round_a_step_above_the_limit_and_over_one_below_it(planner):
    veh = VehicleEnvelope()
    start, goal = (2.0, 2.5), (10.0, 2.5)
    high = _step_wall(2.0 * veh.max_step_m)
    problem = PlanningProblem(hm=high, classes=_open(), start_xy=start, goal_xy=goal, border_m=1.0)
    wp = planner(problem)
    dense = _dense(wp)
    assert np.all(problem.inside_border(dense))
    assert dense[:, 1].max() > 5.0 + 0.5 * veh.width_m  # round the wall's end (y = 5 m)
    # half a width clear of every wall pixel
    from scipy.ndimage import distance_transform_edt

    d = distance_transform_edt(high.z == 0) * CELL
    assert d[np.rint(dense[:, 1] / CELL).astype(int), np.rint(dense[:, 0] / CELL).astype(int)].min() >= 0.5 * veh.width_m
    low = PlanningProblem(hm=_step_wall(0.4 * veh.max_step_m), classes=_open(), start_xy=start, goal_xy=goal,
                          border_m=1.0)
    assert _length(planner(low)) == pytest.approx(8.0, abs=0.05)  # a kerb it can climb: straight over it


def test_classes_and_footprint_grids_see_different_things():
    """The class grid sees the class map only; the footprint grid the heights only."""
    problem = _problem(_wall_classes(), (2.0, 2.5), (10.0, 2.5))
    assert np.isinf(cost_grid(problem, CLASSES).cost).any()
    assert np.all(cost_grid(problem, AStarConfig()).cost == 1.0)
    with pytest.raises(InputError, match="AStarConfig.hazard = 'slope' is not known; allowed: footprint, classes"):
        AStarConfig(hazard="slope")
