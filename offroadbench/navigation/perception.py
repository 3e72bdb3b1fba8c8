"""Planners that see less than the truth: a degraded copy of the map for planning.

By default a planner plans on the very heightmap the physics drives on: an oracle. A
:class:`PerceptionConfig` (keys of a study's ``[planner]`` table, beside the planner's own) gives
it a degraded map instead, while the physics keeps the true terrain:

* ``map_cell_m``: a coarser map. Heights are averaged over blocks of about ``map_cell_m`` (an
  elevation map of that resolution, e.g. 0.2-0.5 m cells for a rover's stereo map) and read back at
  the true grid's points by bilinear interpolation, so steps narrower than a cell are smoothed away.
* ``map_noise_m``: Gaussian height error of this standard deviation, one draw per map cell (per
  ``map_cell_m`` cell when coarsened, else per pixel), optionally smoothed to a correlation length
  ``map_noise_corr_m`` (a Gaussian filter, rescaled back to the same standard deviation) as stereo
  range errors are correlated over a patch rather than per pixel.
* ``sensing_radius_m``: the planner knows only what it has seen: the (degraded) map within this
  radius of every position the vehicle has had. Unseen ground is guessed as the smooth large-scale
  shape of what was seen (:func:`seen_map`): the optimistic free-space assumption of planners like
  D* Lite (Koenig & Likhachev 2002), unknown terrain assumed passable. The planner re-plans from the vehicle's position whenever it has moved
  ``replan_every_m`` since the last plan, on the map seen so far.

Determinism. The error field of a trial is drawn from a generator seeded by
:func:`perception_seed`: ``offroadbench.seeding.derive_seed`` of a stable hash of the mission (its
index and the exact bits of its start and goal, which are a pure function of the mission seed and
the terrain), on its own stream. So a trial's map error is the same in every run, order and worker
count, and a replay rebuilds it.

The map-error keys do not model localisation error, occlusion (everything within the radius is
seen) or policies (a policy observes the true height patch under them); the class map (the
``hazard = "classes"`` cost) is always the true closed class map. The ``mast`` sensor
(``sensor = "mast"``, offroadbench.navigation.sensor) models occlusion, range-dependent height noise
and localisation drift, for planners and policies alike; it replaces the map-error keys (which must
then be 0). ``limits = "sheet"`` (the default since issue 42) has the planners and policies plan with
the vehicle's published limits (offroadbench.navigation.sensor.sheet_envelope); ``"measured"`` with the
simulated vehicle's own. A trial without a perception config (``PlannerChoice.perception`` None: the
true map and pose, stored so by runs before issue 42 and by planners that need no vehicle) plans with
the measured limits, so a stored trial replays as it ran.
"""

from __future__ import annotations

import hashlib
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from offroadbench.config import check_choice, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

__all__ = [
    "LIMITS",
    "SENSORS",
    "PERCEPTION_STREAM",
    "PerceptionConfig",
    "Replanner",
    "degrade",
    "perception_seed",
    "seen_map",
    "split_perception",
]

#: the arms of ``sensor`` (offroadbench.navigation.sensor)
SENSORS = ("oracle", "mast")
#: where the planners' vehicle limits come from (``limits``)
LIMITS = ("measured", "sheet")

#: first spawn-key entry of the perception stream (terrains use 0, missions 1; offroadbench.seeding)
PERCEPTION_STREAM = 2


@dataclass(frozen=True, kw_only=True)
class PerceptionConfig:
    """How the planner's map differs from the true terrain (all zero: it is the true terrain)."""

    map_noise_m: float = 0.0
    """Standard deviation of the Gaussian height error of the planner's map, m."""
    map_noise_corr_m: float = 0.0
    """Correlation length of the height error (std of the Gaussian smoothing), m; 0 = one
    independent draw per map cell."""
    map_cell_m: float = 0.0
    """Cell size of the planner's map, m; 0 (or at most the terrain's cell) = the terrain's own grid."""
    sensing_radius_m: float = 0.0
    """The planner sees the map within this distance of the vehicle's positions so far, m; 0 = the
    whole map from the start."""
    replan_every_m: float = 1.0
    """With a sensing radius or the ``mast`` sensor: re-plan after the vehicle has moved this far
    since the last plan, m."""
    sensor: str = "oracle"
    """What the planner or policy knows: ``oracle`` (the map above and the true pose) or ``mast`` (a
    mast-mounted range sensor with occlusion, range noise and odometry drift,
    offroadbench.navigation.sensor; the map-error keys above must then be 0)."""
    sensor_range_m: float = 8.0
    """``mast``: range of the sensor, m."""
    mast_height_m: float = 0.75
    """``mast``: height of the sensor above the ground under the vehicle, m."""
    sensor_noise_per_range: float = 0.005
    """``mast``: standard deviation of a seen height per metre of range (m per m)."""
    scan_every_m: float = 0.25
    """``mast``: the sensor scans each time the vehicle has moved this far, m."""
    odometry_drift: float = 0.01
    """``mast``: odometry drift: the standard deviation of the per-trial distance scale error and of
    the heading error's random walk per square-root metre travelled (rad)."""
    limits: str = "sheet"
    """The vehicle limits the planners and policies plan with: ``sheet`` (the default: the maker's
    published grade and step limits where its vehicle.toml gives them,
    offroadbench.navigation.sensor.sheet_envelope) or ``measured`` (from the simulated vehicle's own
    failure thresholds). A planner that needs no vehicle (the straight line) ignores it."""

    def __post_init__(self) -> None:
        for name in ("map_noise_m", "map_noise_corr_m", "map_cell_m", "sensing_radius_m",
                     "sensor_noise_per_range", "odometry_drift"):
            check_range(self, name, getattr(self, name), lo=0.0)
        for name in ("replan_every_m", "sensor_range_m", "mast_height_m", "scan_every_m"):
            check_range(self, name, getattr(self, name), lo=0.0, lo_open=True)
        check_choice(self, "sensor", self.sensor, SENSORS)
        check_choice(self, "limits", self.limits, LIMITS)
        if self.sensor == "mast" and (self.map_noise_m > 0 or self.map_cell_m > 0 or self.sensing_radius_m > 0):
            raise InputError("PerceptionConfig: sensor = 'mast' builds its own map; map_noise_m, map_cell_m and "
                             f"sensing_radius_m must be 0 (got {self.map_noise_m}, {self.map_cell_m}, "
                             f"{self.sensing_radius_m})")

    @property
    def active(self) -> bool:
        """Whether the planner's map, pose or limits differ from the truth at all."""
        return (self.map_noise_m > 0 or self.map_cell_m > 0 or self.sensing_radius_m > 0
                or self.sensor != "oracle" or self.limits != "measured")

    @property
    def replanning(self) -> bool:
        """Whether the planner re-plans as it goes (a sensing radius or the mast sensor)."""
        return self.sensing_radius_m > 0 or self.sensor != "oracle"


_KEYS = tuple(f.name for f in fields(PerceptionConfig))


def split_perception(table: dict[str, Any], where: str = "[planner]") -> tuple[PerceptionConfig, dict[str, Any]]:
    """Take the :class:`PerceptionConfig` keys out of a ``[planner]`` table: (config, the rest)."""
    from offroadbench.config import from_dict

    mine = {k: v for k, v in table.items() if k in _KEYS}
    rest = {k: v for k, v in table.items() if k not in _KEYS}
    return from_dict(PerceptionConfig, mine, where=f"{where} (map)"), rest


def perception_seed(mission: Any) -> int:
    """The integer seed of a mission's map error: a stable hash of its index, start and goal."""
    from offroadbench.seeding import derive_seed

    data = struct.pack("<q4d", int(mission.index), *map(float, (*mission.start_xy_m, *mission.goal_xy_m)))
    root = int.from_bytes(hashlib.sha256(data).digest()[:8], "little") >> 1
    return derive_seed(root, PERCEPTION_STREAM)


def _block_factor(hm: Heightmap, cfg: PerceptionConfig) -> int:
    return max(1, round(cfg.map_cell_m / hm.cell_size_m)) if cfg.map_cell_m > 0 else 1


def _coarse_to_fine(coarse: np.ndarray, f: int, shape: tuple[int, int]) -> np.ndarray:
    """Bilinear read-back of block values (block centres at pixel (i + 1/2) f - 1/2) at every pixel."""
    if f == 1:
        return coarse[: shape[0], : shape[1]].copy()
    from scipy.ndimage import map_coordinates

    r = (np.arange(shape[0]) + 0.5) / f - 0.5
    c = (np.arange(shape[1]) + 0.5) / f - 0.5
    rr, cc = np.meshgrid(r, c, indexing="ij")
    return map_coordinates(coarse, [rr, cc], order=1, mode="nearest")


def _block_mean(z: np.ndarray, f: int) -> np.ndarray:
    rows, cols = z.shape
    pr, pc = -rows % f, -cols % f
    padded = np.pad(z, ((0, pr), (0, pc)), mode="edge")
    return padded.reshape(padded.shape[0] // f, f, padded.shape[1] // f, f).mean(axis=(1, 3))


def degrade(hm: Heightmap, cfg: PerceptionConfig, rng: np.random.Generator) -> Heightmap:
    """The planner's map of ``hm``: coarsened to ``map_cell_m`` and with height noise (see the module
    docstring); ``hm`` itself when neither is set."""
    f = _block_factor(hm, cfg)
    if f == 1 and cfg.map_noise_m == 0:
        return hm
    coarse = _block_mean(hm.z, f) if f > 1 else hm.z.copy()
    if cfg.map_noise_m > 0:
        noise = rng.standard_normal(coarse.shape)
        if cfg.map_noise_corr_m > 0:
            from scipy.ndimage import gaussian_filter

            noise = gaussian_filter(noise, sigma=cfg.map_noise_corr_m / (f * hm.cell_size_m), mode="wrap")
            sd = float(noise.std())
            noise = noise / sd if sd > 0 else noise
        coarse = coarse + cfg.map_noise_m * noise
    return Heightmap(_coarse_to_fine(coarse, f, hm.shape), hm.cell_size_m)


#: length scale of the smooth guess of unseen ground, m (std of the Gaussian of the normalised convolution)
UNSEEN_SMOOTHING_M = 1.0


#: whether seen_map may use the compiled Gaussian filter (tests switch it off to compare)
USE_COMPILED_SMOOTHING = True


def _gaussian_nearest(a: np.ndarray, sigma: float) -> np.ndarray:
    """``scipy.ndimage.gaussian_filter(a, sigma, mode="nearest")``: numba's compiled pass when
    installed (offroadbench.navigation.compiled.smooth, the same bits, ~10x faster), else scipy's."""
    if USE_COMPILED_SMOOTHING:
        try:
            from offroadbench.navigation.compiled import smooth
        except (ImportError, RuntimeError):
            pass
        else:
            return smooth.gaussian_nearest(a, sigma)
    from scipy.ndimage import gaussian_filter

    return gaussian_filter(a, sigma, mode="nearest")


def seen_map(hm: Heightmap, seen: np.ndarray, smoothing_m: float = UNSEEN_SMOOTHING_M) -> Heightmap:
    """``hm`` where ``seen`` (bool, its shape) is True; elsewhere a smooth guess from what was seen.

    The guess is the normalised convolution (Knutsson & Westin 1993) of the seen heights with a
    Gaussian of ``smoothing_m``, sum G (z seen) / sum G seen, extended outward from where that
    weight vanishes by the nearest value: the large-scale shape of the seen ground continued, with
    no obstacle narrower than ``smoothing_m`` invented in the unknown (extending the seen heights
    themselves would stretch a seen ridge across the whole unknown map).
    """
    if seen.all():
        return hm
    if not seen.any():
        return Heightmap(np.full(hm.shape, float(np.median(hm.z))), hm.cell_size_m)
    from scipy.ndimage import distance_transform_edt

    sigma = smoothing_m / hm.cell_size_m
    w = _gaussian_nearest(seen.astype(float), sigma)
    num = _gaussian_nearest(np.where(seen, hm.z, 0.0), sigma)
    ok = w > 1e-3
    guess = np.where(ok, num / np.where(ok, w, 1.0), 0.0)
    if not ok.all():
        idx = distance_transform_edt(~ok, return_distances=False, return_indices=True)
        guess = guess[idx[0], idx[1]]
    return Heightmap(np.where(seen, hm.z, guess), hm.cell_size_m)


class Replanner:
    """The plans of one trial on the planner's degraded, partly seen map.

    ``plan(problem) -> waypoints`` is the planner (e.g. ``lambda p:
    offroadbench.navigation.drivers.plan(choice, p)``); ``problem`` the true planning problem.

    ``waypoints`` is the current plan; :meth:`update` with the vehicle's position returns a new plan
    (from that position to the goal) when one is due, else None; ``trace`` is the start, every
    re-planning position and the current plan, the path the planner meant the vehicle to take.
    """

    def __init__(self, plan: Callable[[Any], np.ndarray], problem: Any, mission: Any, cfg: PerceptionConfig,
                 sensing: Any = None) -> None:
        self.plan_fn, self.problem, self.cfg = plan, problem, cfg
        self.sensing = sensing if sensing is not None and sensing.name != "oracle" else None
        self.map = degrade(problem.hm, cfg, np.random.default_rng(perception_seed(mission)))
        hm = problem.hm
        self._rows = np.arange(hm.rows)[:, None] * hm.cell_size_m
        self._cols = np.arange(hm.cols)[None, :] * hm.cell_size_m
        self.seen = np.zeros(hm.shape, dtype=bool) if cfg.sensing_radius_m > 0 else np.ones(hm.shape, dtype=bool)
        self.replans = 0
        self._trace: list[np.ndarray] = []
        start = np.asarray(problem.start_xy, dtype=float)
        self._last = start
        self.waypoints = self._plan(start)

    def _plan(self, xy: np.ndarray) -> np.ndarray:
        import dataclasses

        if self.sensing is not None:  # the sensor's map: unseen cells continue the seen ground
            z = self.sensing.z
            self.seen = ~np.isnan(z)
            known = seen_map(Heightmap(np.where(self.seen, z, 0.0), self.map.cell_size_m), self.seen)
        else:
            if self.cfg.sensing_radius_m > 0:
                r = self.cfg.sensing_radius_m
                self.seen |= (self._cols - xy[0]) ** 2 + (self._rows - xy[1]) ** 2 <= r * r
            known = seen_map(self.map, self.seen)
        start = (float(xy[0]), float(xy[1]))
        problem = dataclasses.replace(self.problem, hm=known, start_xy=start)
        self._trace.append(np.asarray(start))
        return self.plan_fn(problem)

    def update(self, xy: Any) -> np.ndarray | None:
        """A new plan from ``xy`` (map metres; the believed position under the ``mast`` sensor) if the
        vehicle moved ``replan_every_m`` since the last."""
        if not self.cfg.replanning:
            return None
        p = np.asarray(xy, dtype=float)[:2]
        if math.hypot(*(p - self._last)) < self.cfg.replan_every_m or not self.problem.inside_border(p)[0]:
            return None
        self._last = p
        self.replans += 1
        self.waypoints = self._plan(p)
        return self.waypoints

    @property
    def trace(self) -> np.ndarray:
        """(N, 2): the start, each re-planning position and the current plan after the last one."""
        return np.vstack([*self._trace[:-1], self.waypoints]) if self._trace else self.waypoints
