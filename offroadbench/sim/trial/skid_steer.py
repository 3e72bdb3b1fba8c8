"""Skid-steer drive: body twist (v, omega) -> wheel angular velocity commands.

Differential-drive kinematics with an effective track: ``v_left = v - omega * B / 2`` and
``v_right = v + omega * B / 2`` with ``B = skid_track_factor * track``, because skid-steered
wheels slip sideways while turning and the vehicle turns slower than a differential drive of the
geometric track would (Clearpath's husky_control uses the same multiplier, 1.875).

Wheel speeds are saturated as Clearpath's husky_base does (``limitDifferentialSpeed``): if the
faster side would exceed the vehicle's top speed at the tyre (``max_speed_m_s``), both sides are
scaled by the same factor, so the commanded curvature ``omega / v`` is kept and only the pace
drops. A 2 rad/s turn in place of the Husky needs 2 x 1.875 x 0.571 / 2 = 1.07 m/s at the tyres
and is therefore driven at 1.87 rad/s.
"""

from __future__ import annotations

from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["wheel_speeds", "achievable_twist"]


def wheel_speeds(v_m_s: float, omega_rad_s: float, spec: VehicleSpec) -> tuple[float, float]:
    """(left, right) wheel angular velocities in rad/s for a forward speed and a yaw rate (CCW +)."""
    half = 0.5 * spec.skid_track_factor * spec.track_m
    left, right = v_m_s - omega_rad_s * half, v_m_s + omega_rad_s * half
    fastest = max(abs(left), abs(right))
    if fastest > spec.max_speed_m_s:
        scale = spec.max_speed_m_s / fastest
        left, right = left * scale, right * scale
    return left / spec.wheel_radius_m, right / spec.wheel_radius_m


def achievable_twist(v_m_s: float, omega_rad_s: float, spec: VehicleSpec) -> tuple[float, float]:
    """The (v, omega) the saturated wheel speeds of :func:`wheel_speeds` stand for: the command
    scaled down, curvature kept, when a side would exceed the top speed."""
    left, right = wheel_speeds(v_m_s, omega_rad_s, spec)
    r = spec.wheel_radius_m
    return 0.5 * r * (left + right), r * (right - left) / (spec.skid_track_factor * spec.track_m)
