"""Skid-steer drive: body twist (v, omega) -> wheel angular velocity commands.

Differential-drive kinematics with an effective track: ``v_left = v - omega * B / 2`` and
``v_right = v + omega * B / 2`` with ``B = skid_track_factor * track``, because skid-steered
wheels slip sideways while turning and the vehicle turns slower than a differential drive of the
geometric track would (Clearpath's husky_control uses the same multiplier, 1.875).
"""

from __future__ import annotations

from offroadbench.sim.vehicle import VehicleSpec

__all__ = ["wheel_speeds"]


def wheel_speeds(v_m_s: float, omega_rad_s: float, spec: VehicleSpec) -> tuple[float, float]:
    """(left, right) wheel angular velocities in rad/s for a forward speed and a yaw rate (CCW +)."""
    half = 0.5 * spec.skid_track_factor * spec.track_m
    return (v_m_s - omega_rad_s * half) / spec.wheel_radius_m, (v_m_s + omega_rad_s * half) / spec.wheel_radius_m
