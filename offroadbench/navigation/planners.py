"""Path planners: a registry of functions ``plan(problem, cfg) -> (N, 2) waypoints``.

A planner receives a :class:`PlanningProblem` (the heightmap, the study's closed roughness-class
map, start, goal, the mission border and the vehicle's envelope) and its own frozen config, and
returns waypoints in map metres (x, y), the first exactly the start and the last exactly the goal.
The trial runner follows them with pure pursuit (offroadbench.navigation.trackers).

Registering a planner:

* in the same process, with the decorator::

      @register_planner("mine", config=MyConfig)
      def plan_mine(problem: PlanningProblem, cfg: MyConfig) -> np.ndarray: ...

* from an installed package, with an entry point in its ``pyproject.toml``::

      [project.entry-points."offroadbench.planners"]
      mine = "my_package:PLANNER"        # a PlannerSpec (or a plan function)

Then ``[planner] name = "mine"`` (plus the config's fields) in a study, ``drive --planner mine``
and ``TraverseEnv(planner="mine")`` use it. ``examples/offroadbench-example-planner`` is a
complete package.

Built-in planners (what each optimises and what it cannot see is in its docstring):

- ``straight``: the paper's start-goal line (Majhor & Bos 2023, Sec. 2.3).
- ``astar``: 8-connected A* on a hazard cost grid, string-pulled.
- ``lattice``: hybrid A* over arcs of bounded curvature (a state lattice in heading).

The cost grid (:func:`cost_grid`, shared by ``astar`` and ``lattice``). The map is coarsened to
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

import dataclasses
import heapq
import logging
import math
import weakref
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np

from offroadbench.analysis.roughness import HIGH, SEMI, border_mask, disk, gradient_map
from offroadbench.config import check_choice, check_int, check_range, from_dict
from offroadbench.errors import InputError, PluginError
from offroadbench.heightmap import Heightmap
from offroadbench.registry import Registry

__all__ = [
    "VehicleEnvelope",
    "PlanningProblem",
    "NoConfig",
    "PlannerSpec",
    "PLANNERS",
    "register_planner",
    "PlannerChoice",
    "planner_from_table",
    "plan",
    "entry_config",
    "CostConfig",
    "AStarConfig",
    "LatticeConfig",
    "CostGrid",
    "cost_grid",
    "footprint_hazard",
    "HAZARDS",
    "plan_straight",
    "plan_astar",
    "plan_lattice",
]

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------- the problem
@dataclass(frozen=True, kw_only=True)
class VehicleEnvelope:
    """What a planner knows of the vehicle: its footprint and limits (defaults: the Husky)."""

    length_m: float = 0.99
    """Overall length of the footprint, m (Clearpath Husky A200: 0.99 m)."""
    width_m: float = 0.67
    """Overall width of the footprint, m (Husky: 0.67 m)."""
    max_speed_m_s: float = 1.0
    """Top speed, m/s."""
    max_yaw_rate_rad_s: float = 2.0
    """Largest yaw rate command, rad/s."""
    max_slope: float = 0.8
    """Steepest climbable slope, rise/run (about the tyre friction coefficient on a slope)."""
    max_step_m: float = 0.13
    """Highest step the vehicle climbs, m (Husky: 0.13 m, the geometric bound of
    offroadbench.sim.check.step_bound_m: the chassis nose strikes a step higher than the belly)."""
    ground_clearance_m: float = 0.13
    """Height of the belly above flat ground, m (Husky: 0.13 m, the spec sheet's and the URDF's)."""
    wheel_radius_m: float = 0.1651
    """Wheel radius, m (Husky: 0.1651 m): a wheel rides on the terrain's envelope at this radius."""

    def __post_init__(self) -> None:
        for name in ("length_m", "width_m", "max_speed_m_s", "max_yaw_rate_rad_s", "max_slope", "max_step_m",
                     "ground_clearance_m", "wheel_radius_m"):
            check_range(self, name, getattr(self, name), lo=0, lo_open=True)

    @property
    def half_diagonal_m(self) -> float:
        return 0.5 * math.hypot(self.length_m, self.width_m)


@dataclass(frozen=True, eq=False)
class PlanningProblem:
    """One planning query: terrain, classes, the mission's ends, its border and the vehicle."""

    hm: Heightmap
    """The terrain."""
    classes: np.ndarray
    """The closed roughness-class map (uint8 LOW/SEMI/HIGH, the heightmap's shape), classified with
    the study's ``[roughness]`` config: the map the missions were drawn on."""
    start_xy: tuple[float, float]
    """Mission start, map metres."""
    goal_xy: tuple[float, float]
    """Mission goal, map metres."""
    border_m: float = 0.0
    """Missions keep this far from the map edge; planned paths must too."""
    vehicle: VehicleEnvelope = field(default_factory=VehicleEnvelope)
    """Footprint and limits of the vehicle that will drive the path."""

    def __post_init__(self) -> None:
        classes = np.asarray(self.classes)
        if classes.shape != self.hm.shape:
            raise InputError(f"class map shape {classes.shape} does not match the heightmap's {self.hm.shape}")
        object.__setattr__(self, "classes", classes)
        object.__setattr__(self, "start_xy", (float(self.start_xy[0]), float(self.start_xy[1])))
        object.__setattr__(self, "goal_xy", (float(self.goal_xy[0]), float(self.goal_xy[1])))

    @property
    def heading_rad(self) -> float:
        """Direction start -> goal: the vehicle is spawned facing it."""
        return math.atan2(self.goal_xy[1] - self.start_xy[1], self.goal_xy[0] - self.start_xy[0])

    def endpoints(self) -> np.ndarray:
        """``[start, goal]`` as a (2, 2) array: the straight plan."""
        return np.array([self.start_xy, self.goal_xy], dtype=float)

    def inside_border(self, xy: np.ndarray, tol_m: float = 1e-9) -> np.ndarray:
        """Which points (N, 2) lie inside the mission border."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        lo = self.border_m - tol_m
        x_hi = (self.hm.cols - 1) * self.hm.cell_size_m - self.border_m + tol_m
        y_hi = (self.hm.rows - 1) * self.hm.cell_size_m - self.border_m + tol_m
        return (p[:, 0] >= lo) & (p[:, 0] <= x_hi) & (p[:, 1] >= lo) & (p[:, 1] <= y_hi)


# ---------------------------------------------------------------------------- registry
@dataclass(frozen=True, kw_only=True)
class NoConfig:
    """A planner without settings."""


@dataclass(frozen=True)
class PlannerSpec:
    """A registry entry: the plan function, its config class and a one-line summary."""

    plan: Callable[[PlanningProblem, Any], np.ndarray]
    config: type = NoConfig
    summary: str = ""


def _as_spec(name: str, obj: object) -> PlannerSpec:
    """An entry point's object as a PlannerSpec: a PlannerSpec, or a plan function (whose
    ``config`` attribute, if any, is its config class)."""
    if isinstance(obj, PlannerSpec):
        return obj
    if callable(obj):
        doc = (getattr(obj, "__doc__", None) or "").strip().splitlines()
        return PlannerSpec(obj, getattr(obj, "config", NoConfig), doc[0] if doc else "")
    raise TypeError(f"planner {name!r}: expected a PlannerSpec or a function, got {type(obj).__name__}")


#: name -> PlannerSpec; installed packages add entries through the ``offroadbench.planners`` group
PLANNERS: Registry[PlannerSpec] = Registry("planner", entry_point_group="offroadbench.planners", adapt=_as_spec)


def register_planner(name: str, *, config: type = NoConfig, summary: str = ""):
    """Decorator: register ``fn(problem, cfg) -> waypoints`` as planner ``name`` with its config class."""

    def deco(fn):
        doc = (fn.__doc__ or "").strip().splitlines()
        PLANNERS.add(name, PlannerSpec(fn, config, summary or (doc[0] if doc else "")))
        return fn

    return deco


@dataclass(frozen=True)
class PlannerChoice:
    """What drives a trial: a planner (or a policy, see offroadbench.navigation.policies) by name,
    with its frozen config. A study's ``[planner]`` table."""

    name: str = "straight"
    config: Any = NoConfig()
    kind: str = "planner"
    """``planner`` (pure pursuit follows its path) or ``policy`` (closed loop on observations)."""

    @property
    def params(self) -> dict[str, Any]:
        """The config's fields as a plain dict (for tables and replays)."""
        return dataclasses.asdict(self.config) if dataclasses.is_dataclass(self.config) else {}


def planner_from_table(table: Mapping[str, Any], where: str = "[planner]") -> PlannerChoice:
    """A study's ``[planner]`` table: ``name`` (a planner or a policy; default ``straight``) and the
    fields of that entry's config. Unknown names and fields are InputErrors."""
    from offroadbench.navigation.policies import POLICIES

    data = dict(table)
    name = data.pop("name", "straight")
    if not isinstance(name, str):
        raise InputError(f"{where}: name must be a string, got {name!r}")
    if name in PLANNERS:
        spec, kind = PLANNERS.get(name), "planner"
    elif name in POLICIES:
        spec, kind = POLICIES.get(name), "policy"
    else:
        PLANNERS.get(name)  # the did-you-mean error
        raise AssertionError  # pragma: no cover
    try:
        cfg = from_dict(spec.config, data, where=f"{where} ({name})")
    except TypeError as exc:
        raise InputError(f"{where} ({name}): {exc}") from None
    return PlannerChoice(name, cfg, kind)


def entry_config(kind: str, name: str, cfg: Any, expected: type) -> Any:
    """``cfg`` for the registered ``kind`` (planner or policy) ``name`` whose config class is
    ``expected``: the default ``NoConfig()`` of a bare ``PlannerChoice(name)`` becomes
    ``expected()``; a config of another class is an InputError."""
    if isinstance(cfg, expected):
        return cfg
    if type(cfg) is NoConfig:
        return expected()
    raise InputError(f"{kind} {name!r} takes config class {expected.__name__}, got {type(cfg).__name__}")


def plan(choice: PlannerChoice | str, problem: PlanningProblem) -> np.ndarray:
    """Waypoints (N, 2) from a planner, checked: finite, at least two, from exactly the start to
    exactly the goal, on the map. A plug-in that breaks the contract raises PluginError (a RuntimeError)."""
    if isinstance(choice, str):
        choice = PlannerChoice(choice)
    if choice.kind != "planner":
        raise InputError(f"{choice.name!r} is a policy, not a planner")
    spec = PLANNERS.get(choice.name)
    wp = np.asarray(spec.plan(problem, entry_config("planner", choice.name, choice.config, spec.config)), dtype=float)
    bad = None
    if wp.ndim != 2 or wp.shape[1] != 2 or len(wp) < 2 or not np.all(np.isfinite(wp)):
        bad = f"returned an array of shape {wp.shape}; expected (N >= 2, 2) finite waypoints"
    elif not (np.array_equal(wp[0], problem.start_xy) and np.array_equal(wp[-1], problem.goal_xy)):
        bad = f"runs from {wp[0].tolist()} to {wp[-1].tolist()}, not from the start {problem.start_xy} to the goal {problem.goal_xy}"
    elif not np.all((wp >= 0) & (wp <= [problem.hm.width_m, problem.hm.height_m])):
        bad = "leaves the map"
    if bad:
        raise PluginError(f"planner {choice.name!r} {bad}")
    return wp


# ---------------------------------------------------------------------------- straight
@register_planner("straight", summary="the start-goal line (the paper's naive plan)")
def plan_straight(problem: PlanningProblem, cfg: NoConfig = NoConfig()) -> np.ndarray:
    """The start-goal line (Majhor & Bos 2023, Sec. 2.3): waypoints ``[start, goal]``.

    Optimises: length. Cannot see: anything of the terrain.
    """
    return problem.endpoints()


# ---------------------------------------------------------------------------- cost grid
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
    residual = np.empty(shape)
    rows = max(1, 2**22 // max(1, shape[1] * k.size))  # row blocks of ~32 MB of residuals
    for r0 in range(0, shape[0], rows):
        sl = slice(r0, r0 + rows)
        res = win[sl] - (a[sl, :, None, None] * xx + b[sl, :, None, None] * yy + c[sl, :, None, None])
        residual[sl] = np.abs(np.where(k, res, 0.0)).max(axis=(2, 3))
    return np.hypot(a, b), residual


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


def _no_path(name: str, problem: PlanningProblem, cfg: CostConfig) -> np.ndarray:
    (sx, sy), (gx, gy) = problem.start_xy, problem.goal_xy
    msg = f"{name}: no path from ({sx:.2f}, {sy:.2f}) to ({gx:.2f}, {gy:.2f}) m inside the mission border"
    if not cfg.fallback_to_straight:
        raise InputError(msg)
    log.warning("%s; following the straight line", msg)
    return problem.endpoints()


# ---------------------------------------------------------------------------- A*
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
    errors, anything the cell size blurs out.
    """
    for relaxed in (False, True):
        grid = cost_grid(problem, cfg, relaxed)
        cells = _astar(grid.cost, grid.cell_of(problem.start_xy), grid.cell_of(problem.goal_xy))
        if cells is not None:
            break
        log.debug("astar: no path clear of high cells; crossing them at high_cost")
    if cells is None:
        return _no_path("astar", problem, cfg)
    centres = np.array(cells, dtype=float)[:, ::-1] * grid.step_m + 0.5 * (grid.f - 1) * problem.hm.cell_size_m
    ends = problem.endpoints()
    points = np.vstack([ends[:1], centres[1:-1], ends[1:]])
    return _string_pull(points, grid, cfg.shortcut_tolerance)


# ---------------------------------------------------------------------------- hybrid A*
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
    for dr, dc, step in _MOVES:
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
    exact, so the path is near-optimal, not provably optimal.
    """
    for relaxed in (False, True):
        found = _lattice_search(problem, cfg, relaxed)
        if found is not None:
            return found
    return _no_path("lattice", problem, cfg)


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
