"""``astar``: 8-connected A* on the planning cost grid (offroadbench.navigation.costmap), string-pulled."""

from __future__ import annotations

import heapq
import logging
import math
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_range
from offroadbench.navigation.costmap import MOVES, CostConfig, CostGrid, cost_grid, no_path
from offroadbench.navigation.drivers import register_planner
from offroadbench.navigation.problem import PlannerRefusal, PlanningProblem

__all__ = ["AStarConfig", "plan_astar"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class AStarConfig(CostConfig):
    """Settings of ``astar``."""

    shortcut_tolerance: float = 0.1
    """String pulling may raise the cost of a stretch of path by at most this fraction. Not 0:
    every turn costs a skid-steered vehicle more than the cost grid says, so fewer, straighter
    legs track better."""

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range(self, "shortcut_tolerance", self.shortcut_tolerance, lo=0)


def _astar(cost: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> list[tuple[int, int]] | None:
    """Cheapest 8-connected cell path (step cost = length x mean of the two cells' costs), or None."""
    rows, cols = cost.shape
    c = cost.ravel().tolist()
    s = start[0] * cols + start[1]
    g = goal[0] * cols + goal[1]
    gr, gc = goal
    best = {s: 0.0}
    parent = {s: -1}
    heap = [(0.0, 0.0, s)]
    sqrt2m2 = math.sqrt(2.0) - 2.0
    closed = set()
    while heap:
        _, d, n = heapq.heappop(heap)
        if n in closed:
            continue
        if n == g:
            path = []
            while n != -1:
                path.append(divmod(n, cols))
                n = parent[n]
            return path[::-1]
        closed.add(n)
        r, col = divmod(n, cols)
        cn = c[n]
        for dr, dc, step in MOVES:
            rr, cc = r + dr, col + dc
            if not (0 <= rr < rows and 0 <= cc < cols):
                continue
            m = rr * cols + cc
            cm = c[m]
            if cm == math.inf or m in closed:
                continue
            nd = d + step * 0.5 * (cn + cm)
            if nd < best.get(m, math.inf):
                best[m] = nd
                parent[m] = n
                ar, ac = abs(gr - rr), abs(gc - cc)
                h = ar + ac + sqrt2m2 * min(ar, ac)  # octile distance, cost >= 1 per cell
                heapq.heappush(heap, (nd + h, nd, m))
    return None


def _string_pull(points: np.ndarray, grid: CostGrid, tol: float) -> np.ndarray:
    """Greedy shortcutting: from each kept waypoint, jump to the farthest one the rule allows."""
    seg = [grid.segment_cost(points[k], points[k + 1]) for k in range(len(points) - 1)]
    keep = [0]
    i = 0
    while i < len(points) - 1:
        j = i + 1
        run = seg[i]
        while j + 1 < len(points):
            run_next = run + seg[j]
            direct = grid.segment_cost(points[i], points[j + 1])
            if not math.isfinite(direct) or direct > (1.0 + tol) * run_next:
                break
            j += 1
            run = run_next
        keep.append(j)
        i = j
    return points[keep]


@register_planner("astar", config=AStarConfig,
                  summary="8-connected A* on the hazard cost grid (the vehicle's slope, clearance and step limits), string-pulled")
def plan_astar(problem: PlanningProblem, cfg: AStarConfig = AStarConfig()) -> np.ndarray:
    """A* on the cost grid (see the module docstring), then string pulling.

    Optimises: the integral of the cost grid along the path (length, weighted by the footprint
    hazard, or by roughness and nearness to high cells with ``hazard = "classes"``). Cannot see:
    the vehicle's heading and turning (the path may start sideways or turn on the spot; the
    footprint hazard is the worst over every heading), wheel slip and momentum, the tracker's own
    errors, anything the cell size blurs out. A vehicle that cannot turn in place (an Ackermann car:
    ``VehicleEnvelope.min_turn_radius_m`` > 0) is refused.
    """
    if problem.vehicle is not None and problem.vehicle.min_turn_radius_m > 0.0:
        raise PlannerRefusal(f"planner 'astar' plans paths that may turn on the spot; this vehicle turns no tighter than "
                         f"{problem.vehicle.min_turn_radius_m:.2f} m: use planner 'lattice' (arcs of bounded curvature)")
    for relaxed in (False, True):
        grid = cost_grid(problem, cfg, relaxed)
        cells = _astar(grid.cost, grid.cell_of(problem.start_xy), grid.cell_of(problem.goal_xy))
        if cells is not None:
            break
        log.debug("astar: no path clear of high cells; crossing them at high_cost")
    if cells is None:
        return no_path("astar", problem, cfg)
    centres = np.array(cells, dtype=float)[:, ::-1] * grid.step_m + 0.5 * (grid.f - 1) * problem.hm.cell_size_m
    ends = problem.endpoints()
    points = np.vstack([ends[:1], centres[1:-1], ends[1:]])
    return _string_pull(points, grid, cfg.shortcut_tolerance)
