"""The cost maps of the ``mppi`` policy (offroadbench.navigation.policies.mppi): the local window
of the perceived map a rollout is scored on (slope, step and wheel-envelope terms over the vehicle's
footprint), and the cost-to-go to the goal over the whole map."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope


@dataclass(frozen=True)
class CostWindow:
    """The per-cell cost features of a window of the map (rows ``r0..``, cols ``c0..``)."""

    r0: int
    c0: int
    cell_m: float
    static: np.ndarray
    """Belly hazard per cell, read at the vehicle's centre (unknown_hazard near unknown cells, inf
    off the map)."""
    step: np.ndarray
    """Step hazard per cell, read under each wheel track (likewise)."""
    rough: np.ndarray
    """Roughness per cell (height std under the footprint / ground clearance)."""
    gx: np.ndarray
    """Slope of the footprint plane along x per cell, rise/run (0 near unknown cells)."""
    gy: np.ndarray
    """Along y, likewise."""

    def index(self, x: np.ndarray, y: np.ndarray, ox: float = 0.0, oy: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Flat window indices (nearest cell) of points ``(ox + x, oy + y)``, map metres, and whether
        each lies in the window (one outside reads the window's edge cell)."""
        rows, cols = self.static.shape
        inv = 1.0 / self.cell_m
        c = np.rint(x * np.float32(inv) + np.float32(ox * inv - self.c0)).astype(np.int32)
        r = np.rint(y * np.float32(inv) + np.float32(oy * inv - self.r0)).astype(np.int32)
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        np.clip(c, 0, cols - 1, out=c)
        np.clip(r, 0, rows - 1, out=r)
        r *= cols
        r += c
        return r, inside


def _footprint(veh: VehicleEnvelope, cell_m: float) -> dict[str, int]:
    """Filter half-widths in cells (at least 1)."""
    def n(m: float) -> int:
        return max(1, int(round(m / cell_m)))

    return {"plane": n(veh.half_diagonal_m), "wheel": n(0.5 * veh.wheel_radius_m), "width": n(0.5 * veh.width_m)}


def _wheel_envelope(z: np.ndarray, cell_m: float, radius_m: float) -> np.ndarray:
    """The height of a wheel's lowest point as it rolls over ``z``: the grey dilation of the heights
    by a ball of the wheel's radius (as offroadbench.navigation.costmap.footprint_hazard)."""
    from scipy.ndimage import grey_dilation

    n = max(1, int(radius_m / cell_m))
    yy, xx = np.mgrid[-n : n + 1, -n : n + 1] * cell_m
    d2 = xx * xx + yy * yy
    inside = d2 <= radius_m**2
    ball = np.where(inside, np.sqrt(np.maximum(radius_m**2 - d2, 0.0)), 0.0)
    return grey_dilation(z, footprint=inside, structure=ball)


def cost_window(z: np.ndarray, cell_m: float, centre_xy, half_m: float, veh: VehicleEnvelope,
                unknown_hazard: float) -> CostWindow:
    """The cost features of the square of half-side ``half_m`` round ``centre_xy`` of the elevation
    map ``z`` (NaN = unknown; cells off the map have an infinite hazard); see the module docstring."""
    from scipy.ndimage import maximum_filter, minimum_filter, uniform_filter

    rows, cols = z.shape
    n = _footprint(veh, cell_m)
    pad = n["plane"] + n["wheel"] + n["width"] + int(veh.wheel_radius_m / cell_m) + 1
    cx, cy = int(round(centre_xy[0] / cell_m)), int(round(centre_xy[1] / cell_m))
    h = int(math.ceil(half_m / cell_m))
    r0, c0 = cy - h - pad, cx - h - pad  # the block: the window and a margin the filters read
    size = 2 * (h + pad) + 1
    block = np.full((size, size), np.nan)
    rs, cs = slice(max(r0, 0), min(r0 + size, rows)), slice(max(c0, 0), min(c0 + size, cols))
    on_map = np.zeros((size, size), dtype=bool)
    if rs.start < rs.stop and cs.start < cs.stop:
        block[rs.start - r0 : rs.stop - r0, cs.start - c0 : cs.stop - c0] = z[rs, cs]
        on_map[rs.start - r0 : rs.stop - r0, cs.start - c0 : cs.stop - c0] = True
    unknown = np.isnan(block)
    zb = np.where(unknown, np.nanmean(block) if not unknown.all() else 0.0, block)
    p = n["plane"]
    gx = np.zeros_like(zb)
    gy = np.zeros_like(zb)
    gx[:, p:-p] = (zb[:, 2 * p:] - zb[:, : -2 * p]) / (2 * p * cell_m)
    gy[p:-p, :] = (zb[2 * p:, :] - zb[: -2 * p, :]) / (2 * p * cell_m)
    env = _wheel_envelope(zb, cell_m, veh.wheel_radius_m)
    w = 2 * n["wheel"] + 1
    step = (maximum_filter(env, size=w) - minimum_filter(env, size=w)) / veh.max_step_m
    fp = 2 * n["width"] + 1
    mean = uniform_filter(zb, size=fp)
    var = np.maximum(uniform_filter(zb * zb, size=fp) - mean * mean, 0.0)
    belly = (maximum_filter(zb, size=fp) - mean) / veh.ground_clearance_m
    rough = np.sqrt(var) / veh.ground_clearance_m
    near_unknown = maximum_filter(unknown, size=2 * p + 1) if unknown.any() else unknown
    static = np.where(near_unknown, unknown_hazard, belly)
    step = np.where(near_unknown, unknown_hazard, step)
    static[~on_map] = np.inf
    step[~on_map] = np.inf
    gx[near_unknown] = 0.0
    gy[near_unknown] = 0.0
    rough[near_unknown] = 0.0
    sl = (slice(pad, size - pad), slice(pad, size - pad))
    f32 = [a[sl].astype(np.float32) for a in (static, step, rough, gx, gy)]
    return CostWindow(r0 + pad, c0 + pad, cell_m, *f32)


@dataclass(frozen=True)
class CostToGo:
    """Cost from each planning cell to the goal (cost-metres), on a grid of ``f x f`` map cells."""

    value: np.ndarray
    """(rows, cols) float32; cells no path reaches hold the largest finite value plus 10."""
    forbidden: np.ndarray
    """(rows, cols) float32: 1 where the strict cost grid forbids the cell (a hazard at or past one
    of the vehicle's limits over its footprint, or outside the mission border), else 0."""
    f: int
    cell_m: float

    def forbidden_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """1 where points (map metres, float32) fall in a forbidden cell (the cell each falls in)."""
        rows, cols = self.forbidden.shape
        inv = 1.0 / (self.f * self.cell_m)
        c = np.clip(np.floor(x * np.float32(inv) + np.float32(0.5 / self.f)).astype(np.int32), 0, cols - 1)
        r = np.clip(np.floor(y * np.float32(inv) + np.float32(0.5 / self.f)).astype(np.int32), 0, rows - 1)
        return self.forbidden.ravel()[r * cols + c]

    def at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bilinear cost-to-go at points (map metres; cell (R, C)'s centre is map pixel ``C f + (f - 1) / 2``)."""
        from scipy.ndimage import map_coordinates

        half = (self.f - 1) / 2.0
        u = (x / self.cell_m - half) / self.f
        v = (y / self.cell_m - half) / self.f
        return map_coordinates(self.value, [v, u], order=1, mode="nearest")


def cost_to_go(problem: PlanningProblem, grid_m: float) -> CostToGo:
    """Dijkstra from the goal over the footprint-hazard cost grid of ``problem`` (the one ``astar``
    plans on, offroadbench.navigation.costmap; relaxed when the strict grid has no path from the
    start): each 8-connected move costs its length times the mean cost per metre of its two cells."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    from offroadbench.navigation.costmap import CostConfig, cost_grid

    cfg = CostConfig(grid_m=grid_m)
    forbidden = None
    for relaxed in (False, True):
        grid = cost_grid(problem, cfg, relaxed=relaxed)
        if forbidden is None:
            forbidden = (~np.isfinite(grid.cost)).astype(np.float32)
        c = grid.cost
        rows, cols = c.shape
        ids = np.arange(rows * cols).reshape(rows, cols)
        src, dst, w = [], [], []
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            a = (slice(0, rows - dr), slice(max(-dc, 0), cols - max(dc, 0)))
            b = (slice(dr, rows), slice(max(dc, 0), cols + min(dc, 0)))
            ca, cb = c[a], c[b]
            ok = np.isfinite(ca) & np.isfinite(cb)
            src.append(ids[a][ok])
            dst.append(ids[b][ok])
            w.append(math.hypot(dr, dc) * grid.step_m * 0.5 * (ca[ok] + cb[ok]))
        n = rows * cols
        graph = coo_matrix((np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)).tocsr()
        goal = grid.cell_of(problem.goal_xy)
        dist = dijkstra(graph, directed=False, indices=goal[0] * cols + goal[1]).reshape(rows, cols)
        if math.isfinite(dist[grid.cell_of(problem.start_xy)]):
            break
    finite = np.isfinite(dist)
    top = float(dist[finite].max()) if finite.any() else 0.0
    return CostToGo(np.where(finite, dist, top + 10.0).astype(np.float32), forbidden, grid.f, problem.hm.cell_size_m)
