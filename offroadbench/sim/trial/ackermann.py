"""Pure pursuit in its bicycle-model form, for car-like (``ackermann``) vehicles.

Coulter (1992, *Implementation of the Pure Pursuit Path Tracking Algorithm*, CMU-RI-TR-92-01,
eq. 1-3): the arc from the rear axle through the look-ahead point at distance ``l`` and bearing
``alpha`` has curvature ``kappa = 2 sin(alpha) / l``; a bicycle of wheelbase ``L`` drives it with
the steering angle ``delta = atan(L kappa)``. The angle is limited to the vehicle's largest
steering angle and changes by at most ``max_steer_rate / control rate`` per control tick (the
steering servo's speed); a look-ahead point behind the vehicle (|alpha| > 90 deg) gets full lock
toward it. The yaw rate handed to the drive is the bicycle's ``v tan(delta) / L``, which
offroadbench.sim.trial.steering turns back into the two front wheels' Ackermann angles.

The path, the progress along it and the speed profile are those of the wrapped tracker
(offroadbench.sim.trial.controller's LineTracker or PathTracker); only the steering differs.
"""

from __future__ import annotations

import math

import numpy as np

from offroadbench.sim.config import ControllerConfig
from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["bicycle_steer_rad", "BicycleTracker"]


def bicycle_steer_rad(alpha_rad: float, lookahead_dist_m: float, wheelbase_m: float, max_steer_rad: float) -> float:
    """Steering angle (rad, left +) of the bicycle-model pure pursuit (Coulter 1992, eq. 1-3):
    ``atan(2 L sin(alpha) / l)``, limited to +-``max_steer_rad``; full lock toward a point behind."""
    alpha = (alpha_rad + math.pi) % (2.0 * math.pi) - math.pi
    if abs(alpha) > 0.5 * math.pi or lookahead_dist_m <= 1e-9:
        return math.copysign(max_steer_rad, alpha) if alpha else 0.0
    delta = math.atan(2.0 * wheelbase_m * math.sin(alpha) / lookahead_dist_m)
    return max(-max_steer_rad, min(max_steer_rad, delta))


class BicycleTracker:
    """Wraps a LineTracker / PathTracker: same progress and speed, bicycle-model steering.

    ``max_steer_rad`` is the bicycle's largest angle (the turn at which the inner wheel reaches the
    vehicle's steering limit). ``command`` returns (v, omega, progress) like the wrapped tracker, with ``omega = v tan(delta) / L``;
    ``steer_rad`` is the last steering angle (rate-limited)."""

    def __init__(self, base, spec: VehicleSpec, cfg: ControllerConfig, wheelbase_m: float,
                 max_steer_rad: float) -> None:
        self.base = base
        self.spec = spec
        self.cfg = cfg
        self.length_m = base.length_m
        self.wheelbase_m = float(wheelbase_m)
        self.max_steer_rad = float(max_steer_rad)
        self.max_step_rad = math.radians(spec.max_steer_rate_deg_s) / cfg.control_rate_hz
        self.steer_rad = 0.0

    def progress(self, pos_xy: np.ndarray) -> float:
        return self.base.progress(pos_xy)

    def command(self, pos_xy: np.ndarray, yaw_rad: float, vel_xy: np.ndarray) -> tuple[float, float, float]:
        """(v, omega, progress) for the measured position (of the base), yaw and horizontal velocity."""
        v, _, s = self.base.command(pos_xy, yaw_rad, vel_xy)
        # the look-ahead point: the path's point_at (clamped to the path), or on a line capped at the goal
        tx, ty = self.base.point_xy(max(s, 0.0) + self.cfg.lookahead_m)
        dx, dy = tx - float(pos_xy[0]), ty - float(pos_xy[1])
        alpha = math.atan2(dy, dx) - yaw_rad
        want = bicycle_steer_rad(alpha, math.hypot(dx, dy), self.wheelbase_m, self.max_steer_rad)
        step = self.max_step_rad
        self.steer_rad = max(self.steer_rad - step, min(self.steer_rad + step, want))
        return v, v * math.tan(self.steer_rad) / self.wheelbase_m, s
