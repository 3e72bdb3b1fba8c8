"""What a planner or policy knows during a trial: the truth (the ``oracle`` arm) or a mast sensor.

``[planner] sensor`` (offroadbench.navigation.perception.PerceptionConfig) picks the arm:

* ``oracle``: the planner's map is the true terrain (or its degraded copy, the map-error keys), the
  vehicle knows exactly where it is. What every study did before the sensor model.
* ``mast``: :class:`MastSensor`. A range sensor on a mast ``mast_height_m`` above the ground under
  the vehicle scans all round (a spinning lidar) every ``scan_every_m`` the vehicle moves. A cell is
  seen when the straight line from the sensor to it clears the terrain: the classic radial-sweep
  viewshed (Franklin & Ray 1994, "Higher isn't necessarily better: visibility algorithms and
  experiments", Advances in GIS Research): along each of ``ceil(2 pi R / cell)`` azimuths, samples every cell out to
  the range ``R = sensor_range_m`` are visible when the tangent of their elevation angle from the
  sensor is at least the largest of the samples before them. Crater floors behind a rim, the far
  sides of ridges and ground beyond the range stay **unknown** (NaN), never guessed flat. A seen
  height carries Gaussian noise of standard deviation ``sensor_noise_per_range * range`` (the height
  error of a beam's angular error grows with range), drawn afresh at every scan; a cell keeps the
  mean of the samples that fell in it at its latest scan.
* **Localisation drift** (``odometry_drift``, mast only): the vehicle's believed pose is odometry, the
  true displacement between control ticks scaled by ``1 + e_s`` (``e_s`` ~ N(0, odometry_drift^2), one
  draw per trial: a wheel-radius error) and turned by a heading error ``psi`` that random-walks with
  the distance travelled, ``psi(d + dd) = psi(d) + odometry_drift sqrt(dd) n`` (rad, ``dd`` in metres).
  The position error after ``d`` metres is then of standard deviation about ``odometry_drift (d +
  d^1.5 / sqrt(3))``: 0.28 m after 10 m and 1.2 m after 30 m at the default 0.01, the few per cent
  of the distance of wheel odometry on rough ground. A scan is written into the map where the vehicle
  believes it saw it, ``q = b + R(psi) (p - t)`` (``t`` the true and ``b`` the believed position), so
  the map and the pose drift together, as a real map built from odometry does.

What a driver does with unknown cells is its own choice: MPPI gives them a fixed hazard
(offroadbench.navigation.policies.mppi); the cost-grid planners, which need finite heights, plan on
the smooth continuation of the seen ground (offroadbench.navigation.perception.seen_map), re-planning
from the believed position every ``replan_every_m``; a policy's height patch reads NaN there.

``limits = "sheet"`` has the planners plan with the vehicle's published limits (:func:`sheet_envelope`)
instead of those measured in the simulator.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.perception import LIMITS, SENSORS, perception_seed

__all__ = ["SENSORS", "LIMITS", "Oracle", "MastSensor", "make_sensing", "sheet_envelope", "viewshed"]



class Oracle:
    """The truth: the pose is the true pose, the map the given heights (the true terrain, or the
    map-error keys' degraded copy for planners)."""

    name = "oracle"

    def __init__(self, z_m: np.ndarray) -> None:
        self.z = z_m
        self.pose = (math.nan, math.nan, math.nan)
        self.trail: list[tuple[float, float]] = []

    def update(self, pos, yaw: float) -> tuple[float, float, float]:
        """The believed (x, y, yaw) at the true position ``pos`` (x, y[, z]) and heading: the truth."""
        self.pose = (float(pos[0]), float(pos[1]), float(yaw))
        return self.pose

    @property
    def seen(self) -> np.ndarray:
        return ~np.isnan(self.z)


def viewshed(hm: Heightmap, xy, sensor_z_m: float, range_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The radial-sweep viewshed of a sensor at ``(xy, sensor_z_m)`` over ``hm`` (module docstring).

    Returns the sample points' x, y (map metres), true heights and ranges, each (A, R) with A
    azimuths and R radial samples, and flattened to the visible samples only (on the map and not
    hidden by nearer terrain): four 1-D arrays.
    """
    return _Sweep(hm, range_m).run(xy, sensor_z_m)


#: whether the viewshed may use the compiled sweep (tests switch it off to compare)
USE_COMPILED_SWEEP = True


def _compiled_sweep():
    """offroadbench.navigation.compiled.sweep, or None (numba missing or unable to compile: the numpy sweep)."""
    if not USE_COMPILED_SWEEP:
        return None
    try:
        from offroadbench.navigation.compiled import sweep
    except (ImportError, RuntimeError):
        return None
    return sweep


class _Sweep:
    """The viewshed of one map and range with its work arrays kept from scan to scan: numba's sweep
    ray by ray (offroadbench.navigation.compiled.sweep) where installed, else numpy's, which writes its
    (A, R) samples into the same arrays each scan (``out=``; allocating some ten 1.3 MB arrays a
    scan cost thousands of page faults a scan). Both leave the visible samples in :attr:`seen`
    (views returned). One per sensor: not shared between threads."""

    def __init__(self, hm: Heightmap, range_m: float) -> None:
        self.hm = hm
        self.r, self.ray_x, self.ray_y = _rays(hm.cell_size_m, range_m)
        shape = self.ray_x.shape
        self.coords = np.empty((2,) + shape)  # (row, col): map_coordinates' coordinates, written in place
        self.x, self.y, self.z, self.tan, self.horizon = (np.empty(shape) for _ in range(5))
        self.on, self.valid, self.flag = (np.empty(shape, dtype=bool) for _ in range(3))
        self.rr = np.ascontiguousarray(np.broadcast_to(self.r, shape))
        size = self.rr.size
        self.seen = tuple(np.empty(size) for _ in range(4))  # the visible samples' x, y, z, range
        self.cells = (np.empty(size, dtype=np.int64), np.empty(size, dtype=np.int64))
        self.sums = self.counts = self.touched = None  # the compiled scan's per-cell work arrays (map-sized)

    def run(self, xy, sensor_z_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:func:`viewshed` of the sensor at ``(xy, sensor_z_m)``: the visible samples' x, y, true
        height (m) and range (m), four new 1-D arrays."""
        return tuple(a.copy() for a in self.visible(xy, sensor_z_m))

    def scratch(self, n: int) -> tuple[np.ndarray, ...]:
        """Work arrays of ``n`` elements that :meth:`visible`'s results do not use (their contents
        are the last sweep's leftovers): four float64, two int64, two bool."""
        return (*(a.reshape(-1)[:n] for a in (self.tan, self.horizon, *self.coords)),
                *(a[:n] for a in self.cells), *(a.reshape(-1)[:n] for a in (self.on, self.valid)))

    def visible(self, xy, sensor_z_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`run`, but views of this sweep's own arrays, overwritten by the next call."""
        compiled = _compiled_sweep()
        if compiled is not None:  # the same numbers ray by ray (offroadbench.navigation.compiled.sweep)
            n = compiled.sweep(self.hm.z, self.hm.cell_size_m, float(xy[0]), float(xy[1]), float(sensor_z_m),
                               self.r[0], self.ray_x, self.ray_y, *self.seen)
            return tuple(a[:n] for a in self.seen)
        from scipy.ndimage import map_coordinates

        hm, cell = self.hm, self.hm.cell_size_m
        x, y, z, tan, on, valid, flag = self.x, self.y, self.z, self.tan, self.on, self.valid, self.flag
        row, col = self.coords
        np.add(xy[0], self.ray_x, out=x)
        np.add(xy[1], self.ray_y, out=y)
        np.divide(x, cell, out=col)
        np.divide(y, cell, out=row)
        np.greater_equal(col, 0, out=on)
        on &= np.less_equal(col, hm.cols - 1, out=flag)
        on &= np.greater_equal(row, 0, out=flag)
        on &= np.less_equal(row, hm.rows - 1, out=flag)
        np.logical_and.accumulate(on, axis=1, out=valid)  # on the map from the sensor out: the samples that count
        map_coordinates(hm.z, self.coords, output=z, order=1, mode="nearest")
        np.subtract(z, sensor_z_m, out=tan)
        tan /= self.r
        # a sample is seen when its tangent is at least the largest before it on its ray; the samples
        # after a ray's first off-map one are not valid, so neither their tangents nor the off-map
        # ones (which blocked the ray beyond) enter any valid sample's horizon: no np.where needed
        horizon = np.maximum.accumulate(tan, axis=1, out=self.horizon)[:, :-1]
        horizon -= 1e-12
        flag[:, 0] = True  # nothing before the first sample: its horizon is -inf
        np.greater_equal(tan[:, 1:], horizon, out=flag[:, 1:])
        flag &= valid
        idx = np.flatnonzero(flag)
        # mode clip: the indices are in range; with the default (raise) numpy would buffer the output
        return tuple(a.take(idx, out=b[:idx.size], mode="clip") for a, b in zip((x, y, z, self.rr), self.seen, strict=True))


@functools.lru_cache(maxsize=8)
def _rays(cell_m: float, range_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The viewshed's sample offsets from the sensor, the same for every scan of a map: the ranges
    ``r`` (1, R) and ``r cos(phi)``, ``r sin(phi)`` (A, R), m (read-only)."""
    n_r = max(1, int(range_m / cell_m))
    n_a = max(8, int(math.ceil(2.0 * math.pi * range_m / cell_m)))
    r = (np.arange(1, n_r + 1) * cell_m)[None, :]
    phi = (np.arange(n_a) * (2.0 * math.pi / n_a))[:, None]
    out = (r, r * np.cos(phi), r * np.sin(phi))
    for a in out:
        a.setflags(write=False)
    return out


class MastSensor:
    """A mast-mounted range sensor and odometry (module docstring): ``update`` at every control tick
    with the true pose; ``pose`` is the believed pose, ``z`` the map built so far (NaN unknown; a new
    array after every scan), ``trail`` the believed positions at the ticks."""

    name = "mast"

    def __init__(self, hm: Heightmap, cfg: Any, rng: np.random.Generator, start_xy, heading_rad: float) -> None:
        self.hm, self.cfg, self.rng = hm, cfg, rng
        self.z = np.full(hm.shape, np.nan)
        self.scale_error = float(cfg.odometry_drift * rng.standard_normal())
        self.heading_error = 0.0
        self._true = np.asarray(start_xy, dtype=float)[:2].copy()
        self._belief = self._true.copy()
        self.pose = (float(self._belief[0]), float(self._belief[1]), float(heading_rad))
        self.trail = []
        self.scans = 0
        self._scanned_at = self._true.copy()
        self._sweep = _Sweep(hm, cfg.sensor_range_m)
        self._scan(self._true)

    def _scan(self, true_xy: np.ndarray) -> None:
        cfg, hm = self.cfg, self.hm
        ground = hm.height_at(*np.clip(true_xy, 0.0, [hm.width_m, hm.height_m]))
        sweep = self._sweep
        x, y, z, r = sweep.visible(true_xy, float(ground) + cfg.mast_height_m)
        compiled = _compiled_sweep()
        if compiled is not None:  # the arithmetic below, sample by sample (offroadbench.navigation.compiled.sweep)
            noise = self.rng.standard_normal(z.size, out=sweep.scratch(z.size)[0])
            new = self.z.copy().ravel()
            if sweep.sums is None:
                sweep.sums, sweep.counts = np.zeros(new.size), np.zeros(new.size, dtype=np.int64)
                sweep.touched = np.empty(new.size, dtype=np.int64)
            compiled.deposit(x, y, z, r, noise, float(cfg.sensor_noise_per_range), float(true_xy[0]), float(true_xy[1]),
                             float(self._belief[0]), float(self._belief[1]), math.cos(self.heading_error),
                             math.sin(self.heading_error), hm.cell_size_m, new, hm.rows, hm.cols, sweep.sums,
                             sweep.counts, sweep.touched)
            self.z = new.reshape(hm.shape)
            self.scans += 1
            self._scanned_at = true_xy.copy()
            return
        # the arithmetic of z + k r N(0, 1), q = b + R(psi) (p - t) and the cells' indices, term by
        # term in the order written before (tests/navigation/test_mast_floats.py), into work arrays
        noise, dx, dy, t, col, row, ok, flag = sweep.scratch(z.size)
        self.rng.standard_normal(z.size, out=noise)
        np.multiply(cfg.sensor_noise_per_range, r, out=t)
        t *= noise
        z += t  # the seen heights: z + (k r) n
        c, s = math.cos(self.heading_error), math.sin(self.heading_error)
        np.subtract(x, true_xy[0], out=dx)
        np.subtract(y, true_xy[1], out=dy)
        qx, qy = x, y  # the sample positions are not needed any more
        np.multiply(c, dx, out=qx)
        qx += self._belief[0]
        qx -= np.multiply(s, dy, out=t)  # b0 + c dx - s dy
        np.multiply(s, dx, out=qy)
        qy += self._belief[1]
        qy += np.multiply(c, dy, out=t)  # b1 + s dx + c dy
        qx /= hm.cell_size_m
        qy /= hm.cell_size_m
        np.copyto(col, np.rint(qx, out=qx), casting="unsafe")
        np.copyto(row, np.rint(qy, out=qy), casting="unsafe")
        np.greater_equal(col, 0, out=ok)
        ok &= np.less(col, hm.cols, out=flag)
        ok &= np.greater_equal(row, 0, out=flag)
        ok &= np.less(row, hm.rows, out=flag)
        row *= hm.cols
        row += col
        flat, z = (row, z) if ok.all() else (row[ok], z[ok])
        new = self.z.copy().ravel()
        if flat.size:  # the sums and counts over the cells from the first hit on, not the whole map
            lo = int(flat.min())
            flat -= lo
            sums = np.bincount(flat, weights=z)
            counts = np.bincount(flat)
            hit = counts > 0
            new[lo:lo + len(counts)][hit] = sums[hit] / counts[hit]
        self.z = new.reshape(hm.shape)
        self.scans += 1
        self._scanned_at = true_xy.copy()

    def update(self, pos, yaw: float) -> tuple[float, float, float]:
        """Odometry from the true position ``pos`` (x, y[, z]) and heading, and a scan when due:
        the believed (x, y, yaw)."""
        p = np.asarray(pos, dtype=float)[:2]
        d = p - self._true
        dist = math.hypot(*d)
        if dist > 0.0:
            c, s = math.cos(self.heading_error), math.sin(self.heading_error)
            k = 1.0 + self.scale_error
            self._belief = self._belief + k * np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])
            self.heading_error += self.cfg.odometry_drift * math.sqrt(dist) * float(self.rng.standard_normal())
            self._true = p.copy()
        if math.hypot(*(p - self._scanned_at)) >= self.cfg.scan_every_m:
            self._scan(p)
        self.pose = (float(self._belief[0]), float(self._belief[1]), float(yaw) + self.heading_error)
        self.trail.append((self.pose[0], self.pose[1]))
        return self.pose

    @property
    def seen(self) -> np.ndarray:
        """Which map cells have been seen (bool, the map's shape)."""
        return ~np.isnan(self.z)


def make_sensing(hm: Heightmap, cfg: Any, mission: Any, planner_map: Heightmap | None = None):
    """The sensing of one trial: :class:`Oracle` on ``planner_map`` (default ``hm``) unless ``cfg``
    (a PerceptionConfig or None) names the ``mast`` sensor; its stream is the mission's perception
    stream (offroadbench.navigation.perception.perception_seed)."""
    if cfg is None or cfg.sensor == "oracle":
        return Oracle((planner_map or hm).z)
    rng = np.random.default_rng(perception_seed(mission))
    return MastSensor(hm, cfg, rng, mission.start_xy_m, mission.heading_rad)


def sheet_envelope(envelope: Any, spec: Any) -> Any:
    """``envelope`` (a VehicleEnvelope) with the limits the maker publishes (a VehicleSpec's
    ``rated_*`` fields) where it gives them: ``max_slope = tan(min(rated climb grade, rated side
    slope))`` (the cost grids judge slope whatever the heading) and ``max_step_m = rated_step_m``;
    the rest as measured. Unchanged for a vehicle without a spec sheet."""
    grades = [g for g in (spec.rated_climb_grade_deg, spec.rated_side_slope_deg) if g is not None]
    changes: dict[str, float] = {}
    if grades:
        changes["max_slope"] = math.tan(math.radians(min(grades)))
    if spec.rated_step_m is not None:
        changes["max_step_m"] = float(spec.rated_step_m)
    return replace(envelope, **changes) if changes else envelope


@dataclass(frozen=True, eq=False)
class Belief:
    """What the sensor left at the end of a trial (for plots): the believed path and what was seen."""

    trail_xy: np.ndarray
    """Believed positions at the control ticks, (N, 2) map metres."""
    seen: np.ndarray
    """Which map cells the sensor's map holds at the end (bool, the map's shape; in the believed frame)."""
