"""Path tracking on a straight start-goal line or a planned polyline: pure pursuit for steering, a
reference-tracking speed loop (a ruckig jerk-limited reference, followed with feedback) for speed.

Steering (pure pursuit, Coulter 1992): the goal point lies ``lookahead`` ahead of the vehicle's
projection on the line (clamped to the goal); with ``alpha`` the bearing of that point in the
vehicle frame and ``l`` its distance, the arc through it has curvature ``kappa = 2 sin(alpha) / l``
and the yaw-rate command is ``omega = v * kappa``.

Speed: a two-degree-of-freedom loop, a feedforward reference plus feedback on its tracking error
(the trajectory generator + feedforward + feedback structure of Astrom & Murray 2008, Feedback
Systems, Sec. 8.5 "A general controller structure"; anti-windup by conditional integration,
Astrom & Hagglund 2006, Advanced PID Control, ch. 3 "Integrator windup")::

                  +-------------------+  v_ref (feedforward)
      goal L ---->| ruckig reference  |-------------------------+
                  | own state p, v, a |                         |
                  +-------------------+                         v
                     |  p_ref     ^                       +-----------+      +-----------+
                     |            | re-plan only when     |    sum    |  u   |  wheels,  |
                     v            | |p_ref - p| > bound   | v_ref +   |----->|  vehicle, |---+
                  +------+        |                       | k_p e + I |      |  soil     |   |
                  |  -   |--------+---------------------->| sat [0,   |      +-----------+   |
                  +------+     e = p_ref - p              |   u_max]  |                      |
                     ^                                    +-----------+                      |
                     |          I += k_i e dt, unless u is held at a limit in e's direction   |
                     +-------------------- measured progress p along the path ----------------+

* The reference (progress ``p_ref``, speed ``v_ref``, acceleration ``a_ref``) is a 1-D ruckig
  trajectory to the goal at rest, within the cruise speed, the vehicle's acceleration and jerk. It
  starts once from the vehicle's measured progress and speed and then evolves from its *own* state
  each control period (ruckig's output fed back as its input), so slip does not pull it down.
* The wheel-speed command is ``u = v_ref + k_p e + I`` with the progress error ``e = p_ref - p``
  and ``I = k_i int e dt``, saturated to ``[0, u_max]`` (``u_max`` the vehicle's top speed at the
  tyre; under a steady slip ``s`` the wheels need ``v_ref / (1 - s)``, which the feedback supplies).
  The integral stops growing while ``u`` is held at a limit in the direction ``e`` pushes it.
* Re-plan: only when the vehicle is more than ``speed_lag_bound_m`` behind (or ahead of) the
  reference is the reference moved, to that bound from the measured progress; its speed and
  acceleration are kept. The command is therefore never reset to the measured speed: a vehicle that
  is held back keeps being commanded ``v_ref + k_p * bound + I`` (the wheels dig; the ``entrapped``
  rule judges that), and one that breaks free needs no new jerk-limited start.
* Traction control (``traction_slip_limit``, off by default) caps ``u`` at
  ``max(v, 0.1 v_cruise) / (1 - limit)`` of the measured speed ``v``, so the commanded slip stays
  near the limit (the slip-limiting idea of rover traction control, e.g. the slip compensation
  of Ishigami, Nagatani & Yoshida 2008; here only a cap, no slip estimator).
* Past the goal (``p >= L``) the command is 0.

Before 2026-11-26 the profile was re-planned every tick from the *measured* progress and speed, so
under a steady slip ``s`` the command settled near ``v + a dt``, i.e. ``a dt / s``: on flat lunar
regolith the Husky was commanded 0.6-0.7 m/s instead of 1 m/s (issue 28).
"""

from __future__ import annotations

import bisect
import math

import numpy as np
from ruckig import InputParameter, OutputParameter, Result, Ruckig

from offroadbench.errors import InputError
from offroadbench.sim.config import ControllerConfig
from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["pure_pursuit_omega", "SpeedProfile", "speed_loop", "LineTracker", "PathTracker", "make_tracker"]


#: ruckig's results of a trajectory going on or arrived (looked up once: a pybind11 enum's attribute
#: costs more than the whole membership test)
_RUNNING = (Result.Working, Result.Finished)


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
    return _pursuit(float(target_xy[0]) - float(pos_xy[0]), float(target_xy[1]) - float(pos_xy[1]), yaw_rad, v_m_s,
                    max_yaw_rate_rad_s)


def _pursuit(dx: float, dy: float, yaw_rad: float, v_m_s: float, max_yaw_rate_rad_s: float) -> float:
    """:func:`pure_pursuit_omega` from the target's offset (dx, dy) from the vehicle, m, in plain
    floats (each operation the one numpy's element-wise arithmetic does, so the same bits)."""
    dist = math.hypot(dx, dy)
    if dist < 1e-9:
        return 0.0
    alpha = math.atan2(dy, dx) - yaw_rad
    kappa = 2.0 * math.sin(alpha) / dist
    return max(-max_yaw_rate_rad_s, min(max_yaw_rate_rad_s, v_m_s * kappa))


class SpeedProfile:
    """A jerk-limited reference (progress, speed, acceleration) to the goal, and the wheel-speed
    command that follows it (module docstring: the block diagram, the re-plan and the anti-windup).

    Args:
        length_m: path length, m (the reference plans to rest there).
        dt_s: control period, s.
        v_max, a_max, j_max: the reference's speed (the cruise speed), acceleration and jerk limits.
        command_max_m_s: the largest wheel-speed command, m/s (the vehicle's top speed at the tyre);
            ``v_max`` if None.
        lag_bound_m: the re-plan bound on |reference - measured progress|, m.
        k_p_1_s, k_i_1_s2: feedback gains on the progress error, 1/s and 1/s^2.
        slip_limit: traction control: the command is held to ``max(v, v_creep) / (1 - slip_limit)``
            of the measured speed ``v`` (``v_creep`` = 10 % of ``v_max``); None: off.
    """

    def __init__(self, length_m: float, dt_s: float, v_max: float, a_max: float, j_max: float, *,
                 command_max_m_s: float | None = None, lag_bound_m: float = 0.5, k_p_1_s: float = 1.0,
                 k_i_1_s2: float = 0.25, slip_limit: float | None = None) -> None:
        self.length_m = float(length_m)
        self.dt_s = float(dt_s)
        self._otg = Ruckig(1, dt_s)
        self._inp = InputParameter(1)
        self._out = OutputParameter(1)
        self._inp.max_velocity = [v_max]
        self._inp.max_acceleration = [a_max]
        self._inp.max_jerk = [j_max]
        self._inp.target_position = [self.length_m]
        self._inp.target_velocity = [0.0]
        self._inp.target_acceleration = [0.0]
        self._inp.current_position = [0.0]
        self._inp.current_velocity = [0.0]
        self._inp.current_acceleration = [0.0]
        self._v_max = float(v_max)
        self._u_max = float(v_max if command_max_m_s is None else max(command_max_m_s, v_max))
        self._bound = float(lag_bound_m)
        self._k_p = float(k_p_1_s)
        self._k_i = float(k_i_1_s2)
        self._slip_limit = slip_limit
        self._started = False
        self.integral_m_s = 0.0
        """The integral term of the command, m/s (held in [0, command max])."""
        self.replans = 0
        """How often the reference was re-planned (the vehicle left the lag bound)."""

    @property
    def reference(self) -> tuple[float, float, float]:
        """(progress m, speed m/s, acceleration m/s^2) of the reference now."""
        return (float(self._inp.current_position[0]), float(self._inp.current_velocity[0]),
                float(self._inp.current_acceleration[0]))

    def _advance(self) -> None:
        """One control period of the reference, from its own state."""
        if self._inp.current_position[0] >= self.length_m and abs(self._inp.current_velocity[0]) < 1e-9:
            self._inp.current_position = [self.length_m]
            self._inp.current_acceleration = [0.0]
            return
        result = self._otg.update(self._inp, self._out)
        if result not in _RUNNING:
            p, v, a = self.reference
            raise RuntimeError(f"ruckig failed with {result} from reference progress {p:.3f} m, speed {v:.3f} m/s, "
                               f"acceleration {a:.3f} m/s^2")
        self._out.pass_to_input(self._inp)

    def command(self, progress_m: float, speed_m_s: float) -> float:
        """Wheel-speed command (m/s, >= 0) for the next period, from the measured progress along the
        path and the measured speed along it."""
        if progress_m >= self.length_m:
            self.integral_m_s = 0.0
            return 0.0
        if not self._started:  # the reference starts where the vehicle is, at its speed
            self._started = True
            self._inp.current_position = [min(float(progress_m), self.length_m)]
            self._inp.current_velocity = [max(0.0, min(self._v_max, float(speed_m_s)))]
        self._advance()
        p_ref, v_ref = self._inp.current_position[0], self._inp.current_velocity[0]  # as .reference gives them
        error = p_ref - progress_m
        if abs(error) > self._bound:
            # re-plan: the reference is moved to the bound from the measured progress; its speed and
            # acceleration are kept, so the command is not pulled down to the measured speed
            self.replans += 1
            p_ref = min(self.length_m, progress_m + math.copysign(self._bound, error))
            self._inp.current_position = [p_ref]
            error = p_ref - progress_m
        u_max = self._u_max
        if self._slip_limit is not None:
            u_max = min(u_max, max(speed_m_s, 0.1 * self._v_max) / (1.0 - self._slip_limit))
        unclipped = v_ref + self._k_p * error + self.integral_m_s
        u = max(0.0, min(u_max, unclipped))
        # anti-windup (conditional integration): the integral grows only while the command is not
        # held at a limit in the direction the error pushes it
        if (unclipped < u_max or error < 0.0) and (unclipped > 0.0 or error > 0.0):
            self.integral_m_s = max(0.0, min(u_max, self.integral_m_s + self._k_i * error * self.dt_s))
        return u


def speed_loop(length_m: float, spec: VehicleSpec, cfg: ControllerConfig) -> SpeedProfile:
    """The speed loop of a path of ``length_m`` for this vehicle and controller configuration."""
    return SpeedProfile(length_m, 1.0 / cfg.control_rate_hz, min(cfg.cruise_speed_m_s, spec.max_speed_m_s),
                        spec.max_accel_m_s2, spec.max_jerk_m_s3, command_max_m_s=spec.max_speed_m_s,
                        lag_bound_m=cfg.speed_lag_bound_m, k_p_1_s=cfg.speed_gain_1_s,
                        k_i_1_s2=cfg.speed_integral_gain_1_s2, slip_limit=cfg.traction_slip_limit or None)


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
        self.speed = speed_loop(self.length_m, spec, cfg)
        # the per-tick arithmetic in plain floats: the same operations as numpy's on the arrays above
        self._sx, self._sy = float(self.start[0]), float(self.start[1])
        self._ux, self._uy = float(self.unit[0]), float(self.unit[1])
        self._lookahead_m = float(cfg.lookahead_m)
        self._w_max = float(spec.max_yaw_rate_rad_s)

    def point_xy(self, s_m: float) -> tuple[float, float]:
        """The point ``s_m`` along the line, capped at the goal (not at the start), two floats: ``start
        + unit * min(s_m, length)`` element-wise."""
        m = min(s_m, self.length_m)
        return self._sx + self._ux * m, self._sy + self._uy * m

    def progress(self, pos_xy) -> float:
        """Distance along the line of the projection of ``pos_xy`` (x, y, ...), metres."""
        return (float(pos_xy[0]) - self._sx) * self._ux + (float(pos_xy[1]) - self._sy) * self._uy

    def command(self, pos_xy, yaw_rad: float, vel_xy) -> tuple[float, float, float]:
        """(v, omega, progress) for the measured position, yaw and horizontal velocity (each (x, y))."""
        px, py = float(pos_xy[0]), float(pos_xy[1])
        ux, uy = self._ux, self._uy
        s = (px - self._sx) * ux + (py - self._sy) * uy
        v = self.speed.command(s, float(vel_xy[0]) * ux + float(vel_xy[1]) * uy)
        m = min(max(s, 0.0) + self._lookahead_m, self.length_m)
        omega = _pursuit(self._sx + ux * m - px, self._sy + uy * m - py, yaw_rad, v, self._w_max)
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
        self.speed = speed_loop(self.length_m, spec, cfg)
        # the per-tick arithmetic on plain floats (element-wise, the same operations as on the arrays)
        self._pts = [tuple(p) for p in self.points.tolist()]
        self._units = [tuple(u) for u in self._unit.tolist()]
        self._lens = self._seg_len.tolist()
        self._cums = self._cum.tolist()
        self._goal_xy = self._pts[-1]

    def _project(self, pos_xy: np.ndarray) -> tuple[int, float]:
        """(segment index, arc length) of the nearest point within the search window."""
        pts, units, lens, cums = self._pts, self._units, self._lens, self._cums
        px, py = float(pos_xy[0]), float(pos_xy[1])
        last = len(lens) - 1
        best_d, best_k, best_s = math.inf, self._seg, 0.0
        k = first = self._seg
        reach = self._s + self._window_m
        while k <= last and (k == first or cums[k] <= reach):
            (ax, ay), (ux, uy) = pts[k], units[k]
            t = (px - ax) * ux + (py - ay) * uy  # _dot2
            t_c = t if (k == 0 and t < 0) or (k == last and t > 0) else min(max(t, 0.0), lens[k])
            d = math.hypot(px - (ax + t_c * ux), py - (ay + t_c * uy))  # to the foot
            if d < best_d:
                best_d, best_k, best_s = d, k, cums[k] + t_c
            k += 1
        return best_k, best_s

    def point_at(self, s_m: float) -> np.ndarray:
        """The path point at arc length ``s_m`` (clamped to the path)."""
        return np.array(self.point_xy(s_m))

    def point_xy(self, s_m: float) -> tuple[float, float]:
        """:meth:`point_at` as two floats (the same operations)."""
        s = min(max(s_m, 0.0), self.length_m)
        k = min(bisect.bisect_right(self._cums, s) - 1, len(self._lens) - 1)  # np.searchsorted(side="right")
        (ax, ay), (ux, uy), t = self._pts[k], self._units[k], s - self._cums[k]
        return ax + t * ux, ay + t * uy

    def progress(self, pos_xy: np.ndarray) -> float:
        """Arc length along the path of the projection of ``pos_xy``, metres."""
        self._seg, self._s = self._project(pos_xy)
        return self._s

    def command(self, pos_xy: np.ndarray, yaw_rad: float, vel_xy: np.ndarray) -> tuple[float, float, float]:
        """(v, omega, progress) for the measured position, yaw and horizontal velocity."""
        s = self.progress(pos_xy)
        px, py = float(pos_xy[0]), float(pos_xy[1])
        gx, gy = self._goal_xy
        to_goal = math.hypot(gx - px, gy - py)
        # the speed profile plans to the goal, not to the foot of the projection: a vehicle that
        # has run past the path's end (or cut a hairpin) away from the goal keeps driving back to it
        ux, uy = self._units[self._seg]
        v = self.speed.command(min(s, self.length_m - to_goal), float(vel_xy[0]) * ux + float(vel_xy[1]) * uy)
        tx, ty = self.point_xy(max(s, 0.0) + self.cfg.lookahead_m)
        dx, dy = tx - px, ty - py
        alpha = (math.atan2(dy, dx) - yaw_rad + math.pi) % (2.0 * math.pi) - math.pi
        w_max = self.spec.max_yaw_rate_rad_s
        if abs(alpha) > 0.5 * math.pi:  # behind: the tightest arc, curvature 2 / l, toward it
            omega = max(-w_max, min(w_max, math.copysign(2.0 * v / max(math.hypot(dx, dy), 1e-9), alpha)))
        else:
            omega = _pursuit(dx, dy, yaw_rad, v, w_max)  # pure_pursuit_omega
        return v, omega, s


def make_tracker(waypoints, spec: VehicleSpec, cfg: ControllerConfig) -> LineTracker | PathTracker:
    """LineTracker for two waypoints (the straight plan, exactly as before planners existed), else
    PathTracker."""
    pts = np.asarray(waypoints, dtype=float)
    if len(pts) == 2:
        return LineTracker(pts[0], pts[1], spec, cfg)
    return PathTracker(pts, spec, cfg)
