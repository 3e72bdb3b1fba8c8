"""Drive-train limits and rolling resistance as small pure functions, for the trial loop to call.

Neither is wired into the physics yet (``sim/world.py`` applies a constant torque limit, and
``sim/contact.py`` has no rolling resistance); these are the terms, with their sources, for the
loop that owns the contact and the motors to apply once per step:

* :func:`power_limited_torque`: a drive with a power limit P shared by n wheels gives each wheel
  at most ``min(tau_max, P / (n |omega|))``: the constant-torque region of an electric drive below
  its base speed, the constant-power region above it. For the Husky, the spec sheet's 400 W over 4
  wheels at the 1 m/s top speed (omega = 1 / 0.1651 = 6.06 rad/s) gives 16.5 N m per wheel; the
  vehicle's 28 N m (sized for the sheet's 45 deg climb) is reached below 3.6 rad/s (0.59 m/s).
* :func:`rolling_resistance_force`: the resistance of a rolling pneumatic tyre, ``C_rr N``
  opposing the rolling velocity (Wong 2008, Theory of Ground Vehicles, Ch. 1: C_rr about 0.015 on
  concrete, 0.04-0.08 on medium-hard soil, 0.2-0.3 in sand for car and tractor tyres). The sign
  is smoothed over ``v_eps`` so a parked wheel gets no chattering force (the tyre's bristle holds
  it). Applied at each wheel-terrain contact along the wheel's rolling direction (the wheel's
  forward axis projected on the contact plane), with the contact's normal force ``N``.

offroadbench.sim.engines.pybullet.tyres.CoulombTyres already has, per contact and per step, the normal force and
the slip velocity: the place to add the rolling-resistance force. world.command_wheels is the
place to pass :func:`power_limited_torque` of the current wheel speeds as the motors' forces.
"""

from __future__ import annotations

import math

__all__ = ["power_limited_torque", "rolling_resistance_force"]


def power_limited_torque(torque_limit_nm: float, power_w: float | None, n_wheels: int,
                         wheel_speed_rad_s: float) -> float:
    """The torque a wheel's motor may apply at ``wheel_speed_rad_s``: ``torque_limit_nm``, and at
    most ``power_w / (n_wheels |omega|)`` when a power limit is given (None: no power limit), N m."""
    if power_w is None:
        return float(torque_limit_nm)
    if power_w < 0 or n_wheels < 1:
        raise ValueError(f"power_w = {power_w!r} must be >= 0 and n_wheels = {n_wheels!r} >= 1")
    w = abs(float(wheel_speed_rad_s))
    if w == 0.0:
        return float(torque_limit_nm)
    return float(min(torque_limit_nm, power_w / (n_wheels * w)))


def rolling_resistance_force(normal_force_n: float, rolling_velocity_m_s: float, crr: float,
                             v_eps_m_s: float = 0.01) -> float:
    """The rolling-resistance force along the rolling direction, N: ``-C_rr N v / sqrt(v^2 + eps^2)``
    (its magnitude tends to ``C_rr N`` when rolling, to 0 at rest). A negative normal force (no
    contact) gives 0."""
    n = max(0.0, float(normal_force_n))
    v = float(rolling_velocity_m_s)
    return -crr * n * v / math.sqrt(v * v + v_eps_m_s * v_eps_m_s)
