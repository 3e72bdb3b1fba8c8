"""Path tracking on a straight start-goal line or a planned polyline: pure pursuit for steering,
ruckig for speed.

Steering (pure pursuit, Coulter 1992): the goal point lies ``lookahead`` ahead of the vehicle's
projection on the line (clamped to the goal); with ``alpha`` the bearing of that point in the
vehicle frame and ``l`` its distance, the arc through it has curvature ``kappa = 2 sin(alpha) / l``
and the yaw-rate command is ``omega = v * kappa``.

Speed: every control tick, a one-dimensional ruckig problem runs from the *measured* progress
along the line and the *measured* speed along it (with the previous commanded acceleration, so
the command stays jerk-limited) to the goal at rest. The command is ruckig's velocity one tick
ahead, clipped to [0, max speed] (a vehicle measured slightly over the limit would otherwise be
commanded a small overshoot by the jerk-limited brake profile). Starting from the measurement each tick makes the profile react to slip and bumps; a
vehicle that stalls is commanded to re-accelerate within the jerk limit.
"""

from __future__ import annotations

import math

import numpy as np
from ruckig import InputParameter, OutputParameter, Result, Ruckig

from offroadbench.errors import InputError
from offroadbench.sim.config import ControllerConfig
from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["pure_pursuit_omega", "SpeedProfile", "LineTracker", "PathTracker", "make_tracker"]


def _dot2(x: float, y: float, unit) -> float:
    """``x * unit[0] + y * unit[1]`` in plain Python floats.

    Not ``np.dot``: numpy hands a dot product to BLAS, whose kernel (and so the last bit of the
    result, e.g. through a fused multiply-add) depends on the CPU; the control loop must compute
    the same bits on every x86-64 machine (README, "Reproducibility").
    """
    return float(x) * float(unit[0]) + float(y) * float(unit[1])


def pure_pursuit_omega(
    pos_xy: np.ndarray, yaw_rad: float, target_xy: np.ndarray, v_m_s: float, max_yaw_rate_rad_s: float
) -> float:
    """Yaw-rate command (rad/s, CCW +) to follow the arc to ``target_xy`` at speed ``v_m_s``."""
    d = np.asarray(target_xy, dtype=float) - np.asarray(pos_xy, dtype=float)
    dist = math.hypot(d[0], d[1])
    if dist < 1e-9:
        return 0.0
    alpha = math.atan2(d[1], d[0]) - yaw_rad
    kappa = 2.0 * math.sin(alpha) / dist
    return max(-max_yaw_rate_rad_s, min(max_yaw_rate_rad_s, v_m_s * kappa))


class SpeedProfile:
    """Jerk-limited speed along a path of given length, re-planned from measurements each tick."""

    def __init__(self, length_m: float, dt_s: float, v_max: float, a_max: float, j_max: float) -> None:
        self.length_m = float(length_m)
        self._otg = Ruckig(1, dt_s)
        self._inp = InputParameter(1)
        self._out = OutputParameter(1)
        self._inp.max_velocity = [v_max]
        self._inp.max_acceleration = [a_max]
        self._inp.max_jerk = [j_max]
        self._inp.target_position = [self.length_m]
        self._inp.target_velocity = [0.0]
        self._inp.target_acceleration = [0.0]
        self._v_max = v_max
        self._a_max = a_max
        self._accel = 0.0

    def command(self, progress_m: float, speed_m_s: float) -> float:
        """Speed command (m/s, >= 0) for the next tick, from measured progress and speed."""
        if progress_m >= self.length_m:
            self._accel = 0.0
            return 0.0
        self._inp.current_position = [progress_m]
        self._inp.current_velocity = [max(-self._v_max, min(self._v_max, speed_m_s))]
        self._inp.current_acceleration = [self._accel]
        result = self._otg.update(self._inp, self._out)
        if result not in (Result.Working, Result.Finished):
            raise RuntimeError(f"ruckig failed with {result} at progress {progress_m:.3f} m, speed {speed_m_s:.3f} m/s")
        self._accel = max(-self._a_max, min(self._a_max, self._out.new_acceleration[0]))
        return max(0.0, min(self._v_max, self._out.new_velocity[0]))


class LineTracker:
    """Follows the straight line from ``start`` to ``goal``: returns (v, omega) commands."""

    def __init__(self, start_xy, goal_xy, spec: VehicleSpec, cfg: ControllerConfig) -> None:
        self.start = np.asarray(start_xy, dtype=float)
        self.goal = np.asarray(goal_xy, dtype=float)
        delta = self.goal - self.start
        self.length_m = float(math.hypot(delta[0], delta[1]))
        self.unit = delta / self.length_m
        self.cfg = cfg
        self.spec = spec
        self.speed = SpeedProfile(
            self.length_m,
            1.0 / cfg.control_rate_hz,
            min(cfg.cruise_speed_m_s, spec.max_speed_m_s),
            spec.max_accel_m_s2,
            spec.max_jerk_m_s3,
        )

    def progress(self, pos_xy: np.ndarray) -> float:
        """Distance along the line of the projection of ``pos_xy``, metres."""
        return _dot2(pos_xy[0] - self.start[0], pos_xy[1] - self.start[1], self.unit)

    def command(self, pos_xy: np.ndarray, yaw_rad: float, vel_xy: np.ndarray) -> tuple[float, float, float]:
        """(v, omega, progress) for the measured position, yaw and horizontal velocity."""
        s = self.progress(pos_xy)
        v = self.speed.command(s, _dot2(vel_xy[0], vel_xy[1], self.unit))
        target = self.start + self.unit * min(max(s, 0.0) + self.cfg.lookahead_m, self.length_m)
        omega = pure_pursuit_omega(pos_xy, yaw_rad, target, v, self.spec.max_yaw_rate_rad_s)
        return v, omega, s


class PathTracker:
    """Follows a polyline of waypoints (N >= 2, metres) the way LineTracker follows a line.

    Progress is the arc length of the vehicle's projection on the path. The projection is searched
    on the segments from the current one to those starting within ``lookahead + 2 m`` of arc ahead
    of the last progress (so a path that comes back near itself is not short-cut); before the
    first segment and past the last, the projection runs on along their lines, as LineTracker's
    does. The pure-pursuit point lies ``lookahead``
    further along the path, and the speed profile runs over the whole path length. A planned path
    may leave the start in another direction than the mission heading the vehicle is spawned with:
    while the pure-pursuit point is behind the vehicle (|bearing| > 90 deg, where the arc's
    curvature ``2 sin(alpha) / l`` shrinks to 0), the bearing is taken as +-90 deg: the vehicle
    drives the tightest pure-pursuit arc (curvature 2 / l) round toward it. (Turning on the spot
    is no remedy: the skid-steered vehicle barely turns in place on rough ground.) The speed profile
    runs on ``min(progress, length - distance to the goal)``, so a vehicle that overshoots the end
    of the path, or stands off a hairpin, is not told it has arrived while it is still away from the
    goal.
    """

    def __init__(self, waypoints, spec: VehicleSpec, cfg: ControllerConfig) -> None:
        pts = np.asarray(waypoints, dtype=float)
        seg = np.diff(pts, axis=0)
        seg_len = np.array([math.hypot(dx, dy) for dx, dy in seg.tolist()])
        keep = np.concatenate([[True], seg_len > 1e-9])  # drop repeated waypoints
        self.points = pts[keep]
        if len(self.points) < 2:
            raise InputError(f"a path needs two distinct waypoints, got {len(pts)} point(s) with {len(self.points)} distinct")
        seg = np.diff(self.points, axis=0)
        self._seg_len = np.array([math.hypot(dx, dy) for dx, dy in seg.tolist()])
        self._unit = seg / self._seg_len[:, None]
        self._cum = np.concatenate([[0.0], np.cumsum(self._seg_len)])
        self.length_m = float(self._cum[-1])
        self.cfg = cfg
        self.spec = spec
        self._seg = 0
        self._s = 0.0
        self._window_m = cfg.lookahead_m + 2.0
        self.speed = SpeedProfile(
            self.length_m,
            1.0 / cfg.control_rate_hz,
            min(cfg.cruise_speed_m_s, spec.max_speed_m_s),
            spec.max_accel_m_s2,
            spec.max_jerk_m_s3,
        )

    def _project(self, pos_xy: np.ndarray) -> tuple[int, float]:
        """(segment index, arc length) of the nearest point within the search window."""
        last = len(self._seg_len) - 1
        best = (math.inf, self._seg, 0.0)
        k = self._seg
        while k <= last and (k == self._seg or self._cum[k] <= self._s + self._window_m):
            t = _dot2(pos_xy[0] - self.points[k][0], pos_xy[1] - self.points[k][1], self._unit[k])
            t_c = t if (k == 0 and t < 0) or (k == last and t > 0) else min(max(t, 0.0), self._seg_len[k])
            foot = self.points[k] + t_c * self._unit[k]
            d = math.hypot(pos_xy[0] - foot[0], pos_xy[1] - foot[1])
            if d < best[0]:
                best = (d, k, float(self._cum[k] + t_c))
            k += 1
        return best[1], best[2]

    def point_at(self, s_m: float) -> np.ndarray:
        """The path point at arc length ``s_m`` (clamped to the path)."""
        s = min(max(s_m, 0.0), self.length_m)
        k = min(int(np.searchsorted(self._cum, s, side="right")) - 1, len(self._seg_len) - 1)
        return self.points[k] + (s - self._cum[k]) * self._unit[k]

    def progress(self, pos_xy: np.ndarray) -> float:
        """Arc length along the path of the projection of ``pos_xy``, metres."""
        self._seg, self._s = self._project(np.asarray(pos_xy, dtype=float))
        return self._s

    def command(self, pos_xy: np.ndarray, yaw_rad: float, vel_xy: np.ndarray) -> tuple[float, float, float]:
        """(v, omega, progress) for the measured position, yaw and horizontal velocity."""
        s = self.progress(pos_xy)
        p = np.asarray(pos_xy, dtype=float)
        to_goal = math.hypot(self.points[-1][0] - p[0], self.points[-1][1] - p[1])
        # the speed profile plans to the goal, not to the foot of the projection: a vehicle that
        # has run past the path's end (or cut a hairpin) away from the goal keeps driving back to it
        v = self.speed.command(min(s, self.length_m - to_goal), _dot2(vel_xy[0], vel_xy[1], self._unit[self._seg]))
        target = self.point_at(max(s, 0.0) + self.cfg.lookahead_m)
        d = target - np.asarray(pos_xy, dtype=float)
        alpha = (math.atan2(d[1], d[0]) - yaw_rad + math.pi) % (2.0 * math.pi) - math.pi
        if abs(alpha) > 0.5 * math.pi:  # behind: the tightest arc, curvature 2 / l, toward it
            w_max = self.spec.max_yaw_rate_rad_s
            omega = max(-w_max, min(w_max, math.copysign(2.0 * v / max(math.hypot(d[0], d[1]), 1e-9), alpha)))
        else:
            omega = pure_pursuit_omega(pos_xy, yaw_rad, target, v, self.spec.max_yaw_rate_rad_s)
        return v, omega, s


def make_tracker(waypoints, spec: VehicleSpec, cfg: ControllerConfig) -> LineTracker | PathTracker:
    """LineTracker for two waypoints (the straight plan, exactly as before planners existed), else
    PathTracker."""
    pts = np.asarray(waypoints, dtype=float)
    if len(pts) == 2:
        return LineTracker(pts[0], pts[1], spec, cfg)
    return PathTracker(pts, spec, cfg)
