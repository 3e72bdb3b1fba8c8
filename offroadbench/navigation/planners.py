"""Path planners: a registry of pure functions ``(heightmap, classes, start_xy, goal_xy, cfg) -> (N, 2)``.

Every planner returns waypoints in map metres (x, y), the first exactly ``start_xy`` and the last
exactly ``goal_xy``; the trial runner follows them with pure pursuit
(``ControllerConfig.planner``). ``classes`` is the roughness-class map of Majhor & Bos 2023, Eq. (3)-(4)
(uint8 LOW/SEMI/HIGH, the heightmap's shape), usually the closed map the missions are drawn on.

- ``straight``: the paper's naive plan (Sec. 2.3): the start-goal line, two waypoints.
- ``astar``: terrain-aware. The map is coarsened to cells of about ``cfg.grid_m``; a coarse cell
  is forbidden if any of its pixels is ``high`` (the paper's non-traversable class), and otherwise
  costs, per metre,

      c = 1 + gradient_weight * mean Moore gradient (Eq. 3, rise/run) + semi_cost * (semi fraction)
            + clearance_cost * [within clearance_m of a high pixel]

  Costs are then averaged over the vehicle's footprint (a ``footprint_m`` square), so the path does
  not weave between rough patches smaller than the vehicle, and the forbidden cells are put back.
  8-connected A* (octile heuristic, admissible since c >= 1) finds the cheapest cell path, whose
  step cost is the step length times the mean cost of its two cells. The path is then shortened
  by string pulling: a run of waypoints is replaced by one straight segment when the segment
  crosses no forbidden cell and costs at most ``1 + shortcut_tolerance`` times the run
  (costs integrated along the segment at a quarter-cell spacing). If no path avoids the high
  cells, ``astar`` returns the straight line and logs a warning (or raises, see
  ``PlannerConfig.fallback_to_straight``).
"""

from __future__ import annotations

import functools
import heapq
import logging
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from offroadbench.analysis.roughness import HIGH, SEMI, RoughnessConfig, classify_terrain, disk, gradient_map
from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

__all__ = [
    "PlannerConfig",
    "Planner",
    "PLANNERS",
    "get_planner",
    "plan_path",
    "planning_classes",
    "plan_straight",
    "plan_astar",
    "path_cost_grid",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class PlannerConfig:
    """Settings of the terrain-aware planners (``straight`` ignores them)."""

    grid_m: float = 0.25
    """Size of the planning cells, m (rounded to a whole number of map cells)."""
    gradient_weight: float = 2.0
    """Extra cost per metre per unit of mean Moore gradient (rise/run) of a cell."""
    semi_cost: float = 2.0
    """Extra cost per metre of an all-semi cell (times the fraction of semi pixels in the cell)."""
    clearance_m: float = 0.6
    """Cells within this distance of a high pixel pay ``clearance_cost``: about half the Husky's
    diagonal (0.99 x 0.67 m), so that the corners of a vehicle on the path stay clear."""
    clearance_cost: float = 4.0
    """Extra cost per metre of a cell within ``clearance_m`` of a high pixel."""
    footprint_m: float = 1.0
    """Side of the square over which cell costs are averaged, m (the Husky is 0.99 x 0.67 m)."""
    shortcut_tolerance: float = 0.1
    """String pulling may raise the cost of a stretch of path by at most this fraction. Not 0,
    because every turn costs the skid-steered vehicle more than the cost grid says (it turns at
    only ~0.2-0.4 rad/s, measured), so fewer, straighter legs track better."""
    fallback_to_straight: bool = True
    """With no path around the high cells: True returns the straight line (logged), False raises."""

    def __post_init__(self) -> None:
        check_range(self, "grid_m", self.grid_m, lo=0, lo_open=True)
        for name in ("gradient_weight", "semi_cost", "clearance_m", "clearance_cost", "footprint_m",
                     "shortcut_tolerance"):
            check_range(self, name, getattr(self, name), lo=0)


PlannerFn = Callable[[Heightmap, "np.ndarray | None", tuple, tuple, PlannerConfig], np.ndarray]


@dataclass(frozen=True)
class Planner:
    """A registry entry: the function and whether it reads the class map."""

    fn: PlannerFn
    needs_classes: bool
    summary: str


def _endpoints(start_xy, goal_xy) -> np.ndarray:
    return np.array([[float(start_xy[0]), float(start_xy[1])], [float(goal_xy[0]), float(goal_xy[1])]])


def plan_straight(hm: Heightmap, classes, start_xy, goal_xy, cfg: PlannerConfig = PlannerConfig()) -> np.ndarray:
    """The start-goal line (Majhor & Bos 2023, Sec. 2.3): waypoints ``[start, goal]``."""
    return _endpoints(start_xy, goal_xy)


# ------------------------------------------------------------------------------ A*
def _factor(hm: Heightmap, cfg: PlannerConfig) -> int:
    return max(1, int(round(cfg.grid_m / hm.cell_size_m)))


def _blocks(a: np.ndarray, f: int, reduce) -> np.ndarray:
    """Reduce ``f x f`` blocks of ``a`` (edge-padded to whole blocks)."""
    rows, cols = a.shape
    pr, pc = -rows % f, -cols % f
    p = np.pad(a, ((0, pr), (0, pc)), mode="edge")
    return reduce(p.reshape(p.shape[0] // f, f, p.shape[1] // f, f), axis=(1, 3))


def path_cost_grid(hm: Heightmap, classes: np.ndarray, cfg: PlannerConfig = PlannerConfig()) -> tuple[np.ndarray, int]:
    """(cost per metre of each planning cell, inf = forbidden; cells per planning cell ``f``).

    Planning cell (R, C) covers map cells ``[R f, R f + f) x [C f, C f + f)``.
    """
    from scipy.ndimage import binary_dilation, uniform_filter

    classes = np.asarray(classes)
    if classes.shape != hm.shape:
        raise InputError(f"class map shape {classes.shape} does not match the heightmap's {hm.shape}")
    f = _factor(hm, cfg)
    high = classes == HIGH
    cost = 1.0 + cfg.gradient_weight * _blocks(gradient_map(hm), f, np.mean)
    cost += cfg.semi_cost * _blocks((classes == SEMI).astype(float), f, np.mean)
    radius_px = cfg.clearance_m / hm.cell_size_m
    if radius_px >= 1 and high.any():
        near = binary_dilation(high, structure=disk(radius_px))
        cost += cfg.clearance_cost * _blocks(near, f, np.any)
    size = int(round(cfg.footprint_m / (f * hm.cell_size_m)))
    if size > 1:
        cost = uniform_filter(cost, size=size, mode="nearest")
    cost[_blocks(high, f, np.any)] = np.inf
    return cost, f


def _cell_of(xy, f: int, hm: Heightmap, shape) -> tuple[int, int]:
    r = min(max(int(round(xy[1] / hm.cell_size_m)), 0), hm.rows - 1) // f
    c = min(max(int(round(xy[0] / hm.cell_size_m)), 0), hm.cols - 1) // f
    return min(r, shape[0] - 1), min(c, shape[1] - 1)


_MOVES = tuple((dr, dc, math.hypot(dr, dc)) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc)


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
        for dr, dc, step in _MOVES:
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


def _segment_cost(cost: np.ndarray, step_m: float, a: np.ndarray, b: np.ndarray) -> float:
    """Cost of the straight segment a -> b (metres), integrated over the planning cells it crosses."""
    length = float(np.hypot(*(b - a)))
    if length == 0.0:
        return 0.0
    n = max(1, int(math.ceil(length / (0.25 * step_m))))
    t = (np.arange(n) + 0.5) / n
    pts = a[None, :] + t[:, None] * (b - a)[None, :]
    idx = np.clip(np.floor(pts / step_m).astype(int), 0, [cost.shape[1] - 1, cost.shape[0] - 1])
    return float(cost[idx[:, 1], idx[:, 0]].mean() * length)


def _string_pull(points: np.ndarray, cost: np.ndarray, step_m: float, tol: float) -> np.ndarray:
    """Greedy shortcutting: from each kept waypoint, jump to the farthest one the rule allows."""
    seg = [_segment_cost(cost, step_m, points[k], points[k + 1]) for k in range(len(points) - 1)]
    keep = [0]
    i = 0
    while i < len(points) - 1:
        j = i + 1
        run = seg[i]
        while j + 1 < len(points):
            run_next = run + seg[j]
            direct = _segment_cost(cost, step_m, points[i], points[j + 1])
            if not math.isfinite(direct) or direct > (1.0 + tol) * run_next:
                break
            j += 1
            run = run_next
        keep.append(j)
        i = j
    return points[keep]


def plan_astar(hm: Heightmap, classes, start_xy, goal_xy, cfg: PlannerConfig = PlannerConfig()) -> np.ndarray:
    """Terrain-aware waypoints: A* on the cost grid of :func:`path_cost_grid`, then string pulling."""
    cost, f = path_cost_grid(hm, classes, cfg)
    step_m = f * hm.cell_size_m
    s_cell = _cell_of(start_xy, f, hm, cost.shape)
    g_cell = _cell_of(goal_xy, f, hm, cost.shape)
    cost = cost.copy()
    for cell in (s_cell, g_cell):  # the mission's own ends are always usable
        if not math.isfinite(cost[cell]):
            cost[cell] = 1.0 + cfg.semi_cost + cfg.clearance_cost
    cells = _astar(cost, s_cell, g_cell)
    if cells is None:
        msg = (f"astar: no path from ({start_xy[0]:.2f}, {start_xy[1]:.2f}) to ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) m "
               "avoids the high-roughness cells")
        if not cfg.fallback_to_straight:
            raise InputError(msg)
        log.warning("%s; following the straight line", msg)
        return _endpoints(start_xy, goal_xy)
    centres = (np.array(cells, dtype=float)[:, ::-1] + 0.5) * step_m  # (x, y) of each cell's centre
    ends = _endpoints(start_xy, goal_xy)
    points = np.vstack([ends[:1], centres[1:-1], ends[1:]])
    return _string_pull(points, cost, step_m, cfg.shortcut_tolerance)


# ------------------------------------------------------------------------------ registry
PLANNERS: dict[str, Planner] = {
    "straight": Planner(plan_straight, False, "the start-goal line (the paper's naive plan)"),
    "astar": Planner(plan_astar, True, "8-connected A* on a roughness cost grid, high cells forbidden, string-pulled"),
}


def get_planner(name: str) -> Planner:
    try:
        return PLANNERS[name]
    except KeyError:
        raise InputError(f"unknown planner {name!r}; known planners: {', '.join(sorted(PLANNERS))}") from None


@functools.lru_cache(maxsize=2)
def planning_classes(hm: Heightmap, cfg: RoughnessConfig = RoughnessConfig()) -> np.ndarray:
    """The closed class map the missions are drawn on (read-only), cached per Heightmap object.

    Heightmaps are immutable, so the cache (keyed on the object and the config) never goes stale.
    """
    return classify_terrain(hm, cfg).closed


def plan_path(name: str, hm: Heightmap, start_xy, goal_xy, cfg: PlannerConfig = PlannerConfig(),
              classes: np.ndarray | None = None) -> np.ndarray:
    """Waypoints (N, 2) from the planner ``name``; ``classes`` defaults to :func:`planning_classes`."""
    planner = get_planner(name)
    if planner.needs_classes and classes is None:
        classes = planning_classes(hm)
    return planner.fn(hm, classes, start_xy, goal_xy, cfg)
