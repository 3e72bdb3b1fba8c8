"""``lattice``: hybrid A* over arcs of bounded curvature (after Dolgov et al. 2010) on the planning
cost grid (offroadbench.navigation.costmap)."""

from __future__ import annotations

import dataclasses
import heapq
import math
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.navigation.costmap import MOVES, CostConfig, CostGrid, cost_grid, no_path
from offroadbench.navigation.drivers import register_planner
from offroadbench.navigation.problem import PlanningProblem

__all__ = ["LatticeConfig", "plan_lattice"]


@dataclass(frozen=True, kw_only=True)
class LatticeConfig(CostConfig):
    """Settings of ``lattice``."""

    turn_radius_m: float = 1.5
    """Smallest turning radius of the arcs, m. A skid-steer can turn on the spot, but turning in
    place on rough ground is slow and slips; pure pursuit with a 1.5 m lookahead follows arcs of
    this radius cleanly."""
    step_m: float = 0.75
    """Arc length of one motion primitive, m."""
    headings: int = 16
    """Heading bins of the search's closed set."""
    turn_weight: float = 0.5
    """Extra cost per radian turned (metres of straight driving a radian of turning is worth)."""
    goal_tolerance_m: float = 0.5
    """The search ends within this distance of the goal; a last straight piece reaches it exactly."""
    max_expansions: int = 60000
    """Search budget (expanded states) before falling back (``fallback_to_straight``)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in ("turn_radius_m", "step_m", "goal_tolerance_m"):
            check_range(self, name, getattr(self, name), lo=0, lo_open=True)
        check_range(self, "turn_weight", self.turn_weight, lo=0)
        check_int(self, "headings", self.headings, lo=4, hi=360)
        check_int(self, "max_expansions", self.max_expansions, lo=1)


def _cost_to_go(grid: CostGrid, goal: tuple[int, int]) -> np.ndarray:
    """Cheapest 8-connected cost from every cell to the goal cell (Dijkstra), metres x cost."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    rows, cols = grid.cost.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    c = grid.cost
    src, dst, w = [], [], []
    for dr, dc, step in MOVES:
        here = (slice(max(0, -dr), rows - max(0, dr)), slice(max(0, -dc), cols - max(0, dc)))
        there = (slice(max(0, dr), rows + min(0, dr)), slice(max(0, dc), cols + min(0, dc)))
        a, ib, ca, cb = idx[here], idx[there], c[here], c[there]
        wt = step * grid.step_m * 0.5 * (ca + cb)
        ok = np.isfinite(wt)
        src.append(a[ok])
        dst.append(ib[ok])
        w.append(wt[ok])
    graph = coo_matrix((np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(rows * cols,) * 2)
    # distances *to* the goal = distances from it on the transposed graph
    d = dijkstra(graph.T.tocsr(), indices=goal[0] * cols + goal[1])
    return d.reshape(rows, cols)


@register_planner("lattice", config=LatticeConfig,
                  summary="hybrid A* over arcs of bounded curvature from the vehicle's heading, on the hazard cost grid")
def plan_lattice(problem: PlanningProblem, cfg: LatticeConfig = LatticeConfig()) -> np.ndarray:
    """Hybrid A* (after Dolgov et al. 2010): a search over poses (x, y, heading) whose moves are
    arcs of length ``step_m`` and curvature 0 or +-1/``turn_radius_m``, starting along the
    mission heading the vehicle is spawned with. A pose is pruned if an arc sample falls in a
    forbidden cell; the closed set is (planning cell, heading bin). The heuristic is the 2-D
    cost-to-go (Dijkstra on the cost grid, turning ignored), so the search follows the cheap
    corridor. The result is the sampled arcs (every ~quarter cell) plus a last straight piece
    to the exact goal.

    Optimises: the integral of the cost grid along a path the vehicle can follow without turning
    tighter than ``turn_radius_m``, plus ``turn_weight`` per radian turned. Cannot see: the
    footprint's heading (the hazard is the worst over every heading), wheel slip and momentum,
    the tracker's own errors; its heuristic (8-connected cell steps, turning ignored) is not
    exact, so the path is near-optimal, not provably optimal. The arcs are never tighter than the
    vehicle's own smallest turning radius (``VehicleEnvelope.min_turn_radius_m``, an Ackermann car's).
    """
    if problem.vehicle is not None and problem.vehicle.min_turn_radius_m > cfg.turn_radius_m:
        cfg = dataclasses.replace(cfg, turn_radius_m=problem.vehicle.min_turn_radius_m)
    for relaxed in (False, True):
        found = _lattice_search(problem, cfg, relaxed)
        if found is not None:
            return found
    return no_path("lattice", problem, cfg)


def _lattice_search(problem: PlanningProblem, cfg: LatticeConfig, relaxed: bool) -> np.ndarray | None:
    """One hybrid A* search on the strict or the relaxed cost grid; None if it finds no path."""
    grid = cost_grid(problem, cfg, relaxed)
    sx, sy = problem.start_xy
    gx, gy = problem.goal_xy
    goal_cell = grid.cell_of(problem.goal_xy)
    h2d = _cost_to_go(grid, goal_cell)
    if not math.isfinite(h2d[grid.cell_of(problem.start_xy)]):
        return None
    nb = cfg.headings
    kappas = (0.0, 1.0 / cfg.turn_radius_m, -1.0 / cfg.turn_radius_m)
    n_sub = max(2, int(math.ceil(cfg.step_m / (0.25 * grid.step_m))))
    s = np.arange(1, n_sub + 1) / n_sub * cfg.step_m
    W, H = problem.hm.width_m, problem.hm.height_m

    def arc(x, y, th, k):
        if k == 0.0:
            return x + s * math.cos(th), y + s * math.sin(th), th + 0.0 * s
        ths = th + k * s
        return x + (np.sin(ths) - math.sin(th)) / k, y - (np.cos(ths) - math.cos(th)) / k, ths

    def h(x, y):
        r, c = grid.cell_of((x, y))
        return max(float(h2d[r, c]), math.hypot(gx - x, gy - y))

    def key(x, y, th):
        r, c = grid.cell_of((x, y))
        return r, c, int(round((th % (2 * math.pi)) / (2 * math.pi) * nb)) % nb

    th0 = problem.heading_rad
    nodes = [(sx, sy, th0, -1, None)]  # x, y, heading, parent, samples of the arc from the parent
    heap = [(h(sx, sy), 0.0, 0)]
    closed = set()
    found = None
    expansions = 0
    while heap and expansions < cfg.max_expansions:
        _, g, i = heapq.heappop(heap)
        x, y, th, _, _ = nodes[i]
        k0 = key(x, y, th)
        if k0 in closed:
            continue
        closed.add(k0)
        expansions += 1
        if math.hypot(gx - x, gy - y) <= cfg.goal_tolerance_m:
            found = i
            break
        for k in kappas:
            xs, ys, ths = arc(x, y, th, k)
            if xs.min() < 0 or ys.min() < 0 or xs.max() > W or ys.max() > H:
                continue
            pts = np.column_stack([xs, ys])
            c = grid.at(pts)
            if not np.all(np.isfinite(c)):
                continue
            g2 = g + float(c.mean()) * cfg.step_m + cfg.turn_weight * abs(k) * cfg.step_m
            nx, ny, nth = float(xs[-1]), float(ys[-1]), float(ths[-1])
            if key(nx, ny, nth) in closed:
                continue
            nodes.append((nx, ny, nth, i, pts))
            heapq.heappush(heap, (g2 + h(nx, ny), g2, len(nodes) - 1))
    if found is None:
        return None
    pieces = []
    i = found
    while nodes[i][3] != -1:
        pieces.append(nodes[i][4])
        i = nodes[i][3]
    samples = np.vstack(pieces[::-1]) if pieces else np.empty((0, 2))
    # about two samples per primitive; drop those that would repeat an end point
    samples = samples[n_sub // 2 - 1 :: max(1, n_sub // 2)]
    ends = problem.endpoints()
    far = (np.hypot(*(samples - ends[0]).T) > 1e-6) & (np.hypot(*(samples - ends[1]).T) > 1e-6)
    return np.vstack([ends[:1], samples[far], ends[1:]])
