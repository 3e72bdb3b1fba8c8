"""The planning cost grid of the terrain-aware planners (``astar``, ``lattice``): cost per metre
of each planning cell, from the vehicle's footprint hazard or the paper's roughness classes.

The map is coarsened to
cells of about ``grid_m``; cells with a pixel outside the mission border are always forbidden.
``CostConfig.hazard`` picks what the other cells cost:

* ``footprint`` (the default): what stops the vehicle, from its own footprint and limits
  (:func:`footprint_hazard`, after GESTALT, Goldberg, Maimone & Matthies 2002). Each cell's hazard
  ``H`` is the largest of slope / max slope, plane-fit residual / ground clearance and wheel step /
  step limit over a vehicle-sized patch; ``H >= 1`` (at or past a limit) is forbidden, and every
  other cell costs ``1 + hazard_weight * H^2`` per metre. The class map is not used. On 20 m
  paper-d2.45 maps at D_high 2.6-2.95, each of 16 straight-line ``stuck`` stops had ``H >= 1``
  within 0.6 m ahead (wheel steps 0.14-0.36 m against the 0.13 m limit, plane-fit residuals
  0.13-0.48 m against the 0.13 m clearance, slopes under 0.13 rise/run against 0.8), while 89 %
  of the ground the successful drives crossed had ``H < 1``; the class map called 6 of those 16
  stops low or semi.
* ``classes``: the paper's roughness classes (Majhor & Bos 2023, Eq. 3-4). A cell is forbidden if
  any of its pixels lies within half the vehicle's width of a ``high`` pixel, so the vehicle's
  sides stay clear of it. Every other cell costs, per metre,

      c = 1 + gradient_weight * (mean Moore gradient, Eq. 3) / vehicle max slope
            + semi_cost * (semi fraction) + clearance_cost * [within half the vehicle's diagonal of high]

Either cost is averaged over a square as long as the vehicle (so a path does not weave between
rough patches smaller than the vehicle). The forbidden cells round the start and goal (other than
the border's) are opened, so a mission that starts next to a rough patch can leave it. When no
path avoids the forbidden cells, the search is repeated on a relaxed grid where they cost
``high_cost`` more per metre instead (the border stays forbidden).
"""

from __future__ import annotations

import logging
import math
import weakref
from dataclasses import dataclass

import numpy as np

from offroadbench.analysis.roughness import HIGH, SEMI, border_mask, disk, gradient_map
from offroadbench.config import check_choice, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope

__all__ = ["HAZARDS", "CostConfig", "CostGrid", "cost_grid", "footprint_hazard", "no_path", "MOVES"]

log = logging.getLogger(__name__)


#: the kinds of cost grid (CostConfig.hazard)
HAZARDS = ("footprint", "classes")


@dataclass(frozen=True, kw_only=True)
class CostConfig:
    """The cost grid of the terrain-aware planners (see the module docstring)."""

    grid_m: float = 0.25
    """Size of the planning cells, m (rounded to a whole number of map cells)."""
    hazard: str = "footprint"
    """What the cost grid costs: ``footprint`` (the vehicle's own limits: slope, roughness and step
    over a vehicle-sized patch, :func:`footprint_hazard`; ``hazard_weight`` applies) or ``classes``
    (the paper's roughness classes and the mean gradient; ``gradient_weight``, ``semi_cost`` and
    ``clearance_cost`` apply)."""
    hazard_weight: float = 4.0
    """``footprint``: extra cost per metre of a cell whose hazard is 1 (at one of the vehicle's
    limits); the extra cost grows as the square of the hazard, so mild terrain costs little."""
    gradient_weight: float = 2.0
    """Extra cost per metre at a mean Moore gradient equal to the vehicle's max slope."""
    semi_cost: float = 2.0
    """Extra cost per metre of an all-semi cell (times the fraction of semi pixels in the cell)."""
    clearance_cost: float = 4.0
    """Extra cost per metre of a cell within half the vehicle's diagonal of a high pixel."""
    high_cost: float = 20.0
    """When no path keeps clear of the high cells, the search is repeated with those cells allowed at
    this extra cost per metre (the border stays forbidden), so the path crosses as little of them as
    it can. Rough terrains (D_high 2.7 and above) often have no clear path at all."""
    fallback_to_straight: bool = True
    """With no path even so (the border cuts start from goal): True returns the straight line
    (logged), False raises."""

    def __post_init__(self) -> None:
        check_range(self, "grid_m", self.grid_m, lo=0, lo_open=True)
        check_choice(self, "hazard", self.hazard, HAZARDS)
        for name in ("hazard_weight", "gradient_weight", "semi_cost", "clearance_cost", "high_cost"):
            check_range(self, name, getattr(self, name), lo=0)


@dataclass(frozen=True)
class CostGrid:
    """Cost per metre of each planning cell (inf = forbidden); cell (R, C) covers map pixels
    ``[R f, R f + f) x [C f, C f + f)``, ``step_m = f * cell size``."""

    cost: np.ndarray
    f: int
    step_m: float

    def cell_of(self, xy) -> tuple[int, int]:
        r = min(max(int(xy[1] / self.step_m + 0.5 / self.f), 0), self.cost.shape[0] - 1)
        c = min(max(int(xy[0] / self.step_m + 0.5 / self.f), 0), self.cost.shape[1] - 1)
        return r, c

    def at(self, pts: np.ndarray) -> np.ndarray:
        """Cost at points (N, 2) in metres (the planning cell each falls in; pixel centres at k * cell)."""
        idx = np.floor(np.asarray(pts) / self.step_m + 0.5 / self.f).astype(int)
        idx = np.clip(idx, 0, [self.cost.shape[1] - 1, self.cost.shape[0] - 1])
        return self.cost[idx[:, 1], idx[:, 0]]

    def segment_cost(self, a: np.ndarray, b: np.ndarray) -> float:
        """Cost of the straight segment a -> b, integrated at a quarter-cell spacing."""
        length = float(math.hypot(b[0] - a[0], b[1] - a[1]))
        if length == 0.0:
            return 0.0
        n = max(1, int(math.ceil(length / (0.25 * self.step_m))))
        t = (np.arange(n + 1)) / n
        pts = a[None, :] + t[:, None] * (b - a)[None, :]
        c = self.at(pts)
        return float(np.mean(0.5 * (c[1:] + c[:-1])) * length)


def _blocks(a: np.ndarray, f: int, reduce) -> np.ndarray:
    """Reduce ``f x f`` blocks of ``a`` (edge-padded to whole blocks)."""
    rows, cols = a.shape
    p = np.pad(a, ((0, -rows % f), (0, -cols % f)), mode="edge")
    return reduce(p.reshape(p.shape[0] // f, f, p.shape[1] // f, f), axis=(1, 3))


def _patch_planes(z: np.ndarray, cell_m: float, radius_m: float, f: int, shape: tuple[int, int]):
    """Least-squares planes over a disk of ``radius_m`` round the centre pixel of each ``f x f``
    planning cell: (gradient magnitude, rise/run; largest absolute residual, m), each of ``shape``."""
    from numpy.lib.stride_tricks import sliding_window_view

    k = disk(max(radius_m / cell_m, 1.0))
    n = k.shape[0] // 2
    yy, xx = np.mgrid[-n : n + 1, -n : n + 1] * cell_m
    w = k.astype(float)
    zp = np.pad(z, ((n, n + f), (n, n + f)), mode="edge")
    c0 = f // 2
    win = sliding_window_view(zp, k.shape)[c0 :: f, c0 :: f][: shape[0], : shape[1]]
    # on a centred, symmetric disk the plane's three normal equations decouple
    a = np.einsum("rcij,ij->rc", win, w * xx) / float((w * xx * xx).sum())
    b = np.einsum("rcij,ij->rc", win, w * yy) / float((w * yy * yy).sum())
    c = np.einsum("rcij,ij->rc", win, w) / float(w.sum())
    compiled = _compiled_planes()
    if compiled is not None:  # the same numbers, 10-20x faster (offroadbench.navigation.compiled.planes)
        return np.hypot(a, b), compiled.plane_residuals(zp, k, xx, yy, a, b, c, f, c0)
    residual = np.empty(shape)
    rows = max(1, 2**22 // max(1, shape[1] * k.size))  # row blocks of ~32 MB of residuals
    for r0 in range(0, shape[0], rows):
        sl = slice(r0, r0 + rows)
        res = win[sl] - (a[sl, :, None, None] * xx + b[sl, :, None, None] * yy + c[sl, :, None, None])
        residual[sl] = np.abs(np.where(k, res, 0.0)).max(axis=(2, 3))
    return np.hypot(a, b), residual


#: whether _patch_planes may use the compiled residual pass (tests switch it off to compare)
USE_COMPILED_PLANES = True


def _compiled_planes():
    """offroadbench.navigation.compiled.planes, or None (numba missing or unable to compile: the numpy pass)."""
    if not USE_COMPILED_PLANES:
        return None
    try:
        from offroadbench.navigation.compiled import planes
    except (ImportError, RuntimeError):
        return None
    return planes


#: footprint hazards per terrain: a study plans every mission of a terrain on the same map, and the
#: hazard depends only on the map (immutable), the vehicle and the grid (~1 s on a 1009^2 map)
_HAZARD_CACHE: "weakref.WeakKeyDictionary[Heightmap, dict]" = weakref.WeakKeyDictionary()


def footprint_hazard(hm: Heightmap, vehicle: VehicleEnvelope, f: int) -> dict[str, np.ndarray]:
    """:func:`_footprint_hazard`, computed once per (map, vehicle, grid) while the map lives; the
    arrays are read-only."""
    per_map = _HAZARD_CACHE.setdefault(hm, {})
    key = (vehicle, f)
    if key not in per_map:
        out = _footprint_hazard(hm, vehicle, f)
        for a in out.values():
            a.setflags(write=False)
        per_map[key] = out
    return per_map[key]


def _footprint_hazard(hm: Heightmap, vehicle: VehicleEnvelope, f: int) -> dict[str, np.ndarray]:
    """How close each planning cell (``f x f`` map cells) comes to one of the vehicle's limits, by
    the terrain under a vehicle-sized patch round it; 1 = at the limit. Keys:

    * ``slope``: gradient of the least-squares plane over a disk of the vehicle's half diagonal
      (every heading of the footprint) / ``max_slope``;
    * ``roughness``: the largest distance of the terrain from that plane / ``ground_clearance_m``
      (a bump under the belly, or a hole a wheel drops into);
    * ``step``: the largest rise of the wheel's path within a disk of half a wheel radius (rounded
      up to whole pixels), anywhere within half the vehicle's width of the cell / ``max_step_m``.
      A wheel rides on the terrain's envelope at its radius (the grey dilation of the heights by a
      ball), so spikes narrower than a wheel count as the arc the wheel rolls over, not as cliffs.
      A step ``h`` lifts the wheel over ``sqrt(2 r h - h^2)`` (0.16 m for the Husky at its limit),
      which the window (0.2 m across on 5 cm pixels) holds whole. A plane's own rise across the
      window counts too: on 5 cm pixels a slope steeper than 0.65 reads as a step at the limit;
    * ``hazard``: the largest of the three, per cell; ``step`` is the largest over the cell's pixels.

    From GESTALT (Goldberg, Maimone & Matthies 2002, "Stereo vision and rover navigation software
    for planetary exploration", IEEE Aerospace Conf.) we take the scheme: every grid cell is
    judged by a least-squares plane through a rover-sized patch of terrain round it, with a tilt
    hazard from the plane's slope and a roughness hazard from the terrain's distance to the plane,
    each scaled by the rover's own limit, and a step hazard beside them. The wheel envelope in
    the step hazard, the limits (this vehicle's clearance and step bound) and the cost
    ``1 + w H^2`` are ours.
    """
    from scipy.ndimage import grey_dilation, maximum_filter, minimum_filter

    cell = hm.cell_size_m
    shape = (-(-hm.rows // f), -(-hm.cols // f))
    gradient, residual = _patch_planes(hm.z, cell, vehicle.half_diagonal_m, f, shape)
    n = max(1, int(vehicle.wheel_radius_m / cell))
    yy, xx = np.mgrid[-n : n + 1, -n : n + 1] * cell
    d2 = xx * xx + yy * yy
    inside = d2 <= vehicle.wheel_radius_m**2
    ball = np.where(inside, np.sqrt(np.maximum(vehicle.wheel_radius_m**2 - d2, 0.0)), 0.0)
    envelope = grey_dilation(hm.z, footprint=inside, structure=ball)
    near = disk(max(math.ceil(0.5 * vehicle.wheel_radius_m / cell), 1))
    rise = maximum_filter(envelope, footprint=near) - minimum_filter(envelope, footprint=near)
    step = maximum_filter(rise, footprint=disk(max(0.5 * vehicle.width_m / cell, 1.0)))
    out = {
        "slope": gradient / vehicle.max_slope,
        "roughness": residual / vehicle.ground_clearance_m,
        "step": _blocks(step, f, np.max) / vehicle.max_step_m,
    }
    out["hazard"] = np.maximum(np.maximum(out["slope"], out["roughness"]), out["step"])
    return out


def _class_cost(problem: PlanningProblem, cfg: CostConfig, f: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``classes`` grid: (cost per metre, cells on a high pixel, cells within half a width of one)."""
    from scipy.ndimage import binary_dilation

    hm, classes, veh = problem.hm, problem.classes, problem.vehicle
    cell = hm.cell_size_m
    high = classes == HIGH
    cost = 1.0 + cfg.gradient_weight * _blocks(gradient_map(hm), f, np.mean) / veh.max_slope
    cost += cfg.semi_cost * _blocks((classes == SEMI).astype(float), f, np.mean)
    if high.any():
        near = binary_dilation(high, structure=disk(max(veh.half_diagonal_m / cell, 1.0)))
        cost += cfg.clearance_cost * _blocks(near, f, np.any)
        blocked = binary_dilation(high, structure=disk(max(0.5 * veh.width_m / cell, 1.0)))
    else:
        blocked = high
    return cost, _blocks(high, f, np.any), _blocks(blocked, f, np.any)


def cost_grid(problem: PlanningProblem, cfg: CostConfig = CostConfig(), relaxed: bool = False) -> CostGrid:
    """The planning cost grid of ``problem`` (see the module docstring). ``relaxed``: hazardous
    cells (or cells near or on high pixels) cost ``high_cost`` more per metre instead of being
    forbidden."""
    from scipy.ndimage import uniform_filter

    hm, veh = problem.hm, problem.vehicle
    cell = hm.cell_size_m
    f = max(1, int(round(cfg.grid_m / cell)))
    if cfg.hazard == "footprint":
        hz = footprint_hazard(hm, veh, f)["hazard"]
        cost = 1.0 + cfg.hazard_weight * np.minimum(hz, 1.0) ** 2
        hard, soft = np.zeros(hz.shape, dtype=bool), hz >= 1.0
    else:
        cost, hard, soft = _class_cost(problem, cfg, f)
    size = int(round(veh.length_m / (f * cell)))
    if size > 1:
        cost = uniform_filter(cost, size=size, mode="nearest")
    outside_cells = _blocks(~border_mask(hm.shape, problem.border_m, cell), f, np.any)
    hard = hard | outside_cells
    soft = soft & ~hard
    # open the soft cells round the start and the goal, so the vehicle can leave them
    grid = CostGrid(cost, f, f * cell)
    reach = 0.5 * veh.width_m + 2 * grid.step_m
    rr, cc = np.mgrid[0 : cost.shape[0], 0 : cost.shape[1]]
    for xy in (problem.start_xy, problem.goal_xy):
        soft &= np.hypot(cc * grid.step_m - xy[0], rr * grid.step_m - xy[1]) > reach
    if relaxed:
        cost[hard & ~outside_cells] += cfg.high_cost
        cost[soft] += cfg.high_cost
        cost[outside_cells] = np.inf
    else:
        cost[hard | soft] = np.inf
    for xy in (problem.start_xy, problem.goal_xy):  # the mission's own ends are always usable
        rc = grid.cell_of(xy)
        if not math.isfinite(cost[rc]):
            cost[rc] = 1.0 + cfg.semi_cost + cfg.clearance_cost + cfg.gradient_weight + cfg.hazard_weight
    return grid


def no_path(name: str, problem: PlanningProblem, cfg: CostConfig) -> np.ndarray:
    """What a cost-grid planner returns when no path exists: the straight line (logged) with
    ``cfg.fallback_to_straight``, else an InputError."""
    (sx, sy), (gx, gy) = problem.start_xy, problem.goal_xy
    msg = f"{name}: no path from ({sx:.2f}, {sy:.2f}) to ({gx:.2f}, {gy:.2f}) m inside the mission border"
    if not cfg.fallback_to_straight:
        raise InputError(msg)
    log.warning("%s; following the straight line", msg)
    return problem.endpoints()


#: the 8-connected moves on the cost grid: (d row, d col, length in cells)
MOVES = tuple((dr, dc, math.hypot(dr, dc)) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc)
