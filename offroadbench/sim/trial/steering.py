"""Steering kinds: how a body twist (v, omega) becomes joint commands, and which tracker drives.

One function per question, chosen by ``VehicleSpec.steering``:

- :func:`drive_twist` commands a world's joints for a forward speed ``v`` (m/s) and a yaw rate
  ``omega`` (rad/s, CCW +). ``skid``: the two sides' wheel speeds of
  offroadbench.sim.trial.skid_steer (wheeled skid-steer, and tracks as rows of road wheels).
  ``ackermann`` and ``rocker_bogie``: every wheel rolls along the velocity its centre has in a
  rigid-body turn about the instantaneous centre (:func:`steered_commands`), so a steered wheel is
  turned to ``atan2(omega x_i, v - omega y_i)`` and driven at ``hypot(v - omega y_i, omega x_i) / r``,
  an unsteered one at ``(v - omega y_i) / r``; ``(x_i, y_i)`` is the wheel centre relative to the
  reference point (the middle of the unsteered wheels' axle line: the rear axle of a car, whose
  wheels then roll without side slip). For two front wheels this is the Ackermann condition
  ``cot(delta_outer) - cot(delta_inner) = track / wheelbase`` (Gillespie 1992, *Fundamentals of
  Vehicle Dynamics*, eq. 6-1 in its small-angle form ``delta = L / R``; here exact).
- :func:`achievable` gives the (v, omega) the vehicle can follow: skid-steer as skid_steer's; a
  steered vehicle's yaw rate is limited by its largest steering angle (a minimum turning radius).
- :func:`make_vehicle_tracker` picks the path tracker: bicycle-model pure pursuit for ``ackermann``
  (offroadbench.sim.trial.ackermann), the yaw-rate pure pursuit of
  offroadbench.sim.trial.controller for the others (a rocker-bogie with corner steering follows
  any arc, turning in place included).
"""

from __future__ import annotations

import math

import numpy as np

from offroadbench.sim.config import ControllerConfig
from offroadbench.sim.trial import skid_steer
from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["drive_twist", "twist_driver", "steered_commands", "achievable", "min_turn_radius_m", "reference_layout",
           "make_vehicle_tracker"]


def reference_layout(spec: VehicleSpec, wheel_centres_m) -> tuple[tuple[float, float], ...]:
    """Each wheel's (x, y) relative to the steering reference point, m, body frame, in
    ``spec.wheel_joints`` order: ``wheel_centres_m`` (offroadbench.sim.engine.VehicleGeometry's)
    shifted so that x = 0 is the mean x of the unsteered wheels and y = 0 the middle of the track."""
    centres = [(float(c[0]), float(c[1])) for c in wheel_centres_m]
    steered = set(spec.steered_wheel_joints)
    fixed = [c for name, c in zip(spec.wheel_joints, centres, strict=True) if name not in steered] or centres
    x0 = sum(c[0] for c in fixed) / len(fixed)
    y0 = 0.5 * (max(c[1] for c in centres) + min(c[1] for c in centres))
    return tuple((x - x0, y - y0) for x, y in centres)


def _rigid_turn(v_m_s: float, omega_rad_s: float, spec: VehicleSpec,
                layout: tuple[tuple[float, float], ...]) -> tuple[list[float], list[float]]:
    """(tyre speeds m/s in ``spec.wheel_joints`` order, steering angles rad) of the rigid-body turn,
    the angles limited to the largest steering angle, the speeds not yet limited."""
    steer_of = {w: i for i, w in enumerate(spec.steered_wheel_joints)}
    limit = math.radians(spec.max_steer_angle_deg)
    speeds = [0.0] * len(layout)
    angles = [0.0] * len(spec.steer_joints)
    for k, (name, (x, y)) in enumerate(zip(spec.wheel_joints, layout, strict=True)):
        vx, vy = v_m_s - omega_rad_s * y, omega_rad_s * x
        i = steer_of.get(name)
        if i is None:
            speeds[k] = vx
            continue
        if abs(vx) < 1e-12 and abs(vy) < 1e-12:
            continue
        a, sp = math.atan2(vy, vx), math.hypot(vx, vy)
        if a > 0.5 * math.pi:  # drive backwards rather than steer past 90 deg
            a, sp = a - math.pi, -sp
        elif a < -0.5 * math.pi:
            a, sp = a + math.pi, -sp
        angles[i] = max(-limit, min(limit, a))
        speeds[k] = sp
    return speeds, angles


def _speed_scale(speeds: list[float], spec: VehicleSpec) -> float:
    fastest = max(abs(s) for s in speeds)
    return spec.max_speed_m_s / fastest if fastest > spec.max_speed_m_s else 1.0


def steered_commands(v_m_s: float, omega_rad_s: float, spec: VehicleSpec,
                     layout: tuple[tuple[float, float], ...]) -> tuple[list[float], list[float]]:
    """(wheel speeds rad/s in ``spec.wheel_joints`` order, steering angles rad in ``spec.steer_joints``
    order) for a rigid-body turn (module docstring); steering angles limited to the largest, and all
    wheel speeds scaled together if the fastest tyre would exceed the top speed (the curvature is kept)."""
    speeds, angles = _rigid_turn(v_m_s, _turn_limited(v_m_s, omega_rad_s, spec, layout), spec, layout)
    scale = _speed_scale(speeds, spec)
    return [s * scale / spec.wheel_radius_m for s in speeds], angles


def _turn_limited(v_m_s: float, omega_rad_s: float, spec: VehicleSpec, layout) -> float:
    """The yaw rate limited to ``|v| / R_min`` (:func:`min_turn_radius_m`): a car's driven wheels
    must not be told the speeds of a tighter turn than its steering makes (they would skid-steer it)."""
    r_min = min_turn_radius_m(spec, layout)
    if r_min <= 0.0:
        return omega_rad_s
    cap = abs(v_m_s) / r_min
    return max(-cap, min(cap, omega_rad_s))


def min_turn_radius_m(spec: VehicleSpec, layout) -> float:
    """Smallest turning radius of the reference point, m: 0 for skid steering and for a vehicle whose
    steered wheels reach the angle of a turn in place, else ``x / tan(max steering angle)`` of the
    steered wheel farthest from the reference axle (the wheelbase of a car: Gillespie 1992, eq. 6-1)."""
    if spec.steering == "skid":
        return 0.0
    steered = set(spec.steered_wheel_joints)
    limit = math.radians(spec.max_steer_angle_deg)
    pts = [p for name, p in zip(spec.wheel_joints, layout, strict=True) if name in steered]
    if all(math.atan2(abs(x), abs(y)) <= limit + 1e-9 for x, y in pts):
        return 0.0  # every steered wheel can point along a circle about the reference point
    reach = max(abs(x) for x, _ in pts)
    # the inner wheel reaches the limit first: R - |y| = reach / tan(limit)
    return reach / math.tan(limit) + max(abs(y) for _, y in pts)


def achievable(v_m_s: float, omega_rad_s: float, spec: VehicleSpec, layout=None) -> tuple[float, float]:
    """The (v, omega) a command stands for after the drive's limits: skid-steer's wheel-speed
    saturation, or a steered vehicle's minimum turning radius (|omega| <= |v| / R_min) and top speed."""
    if spec.steering == "skid":
        return skid_steer.achievable_twist(v_m_s, omega_rad_s, spec)
    omega_rad_s = _turn_limited(v_m_s, omega_rad_s, spec, layout)
    scale = _speed_scale(_rigid_turn(v_m_s, omega_rad_s, spec, layout)[0], spec)
    return v_m_s * scale, omega_rad_s * scale


def drive_twist(world, v_m_s: float, omega_rad_s: float) -> None:
    """Command ``world``'s joints for the body twist (v, omega) (module docstring)."""
    twist_driver(world)(v_m_s, omega_rad_s)


def twist_driver(world):
    """:func:`drive_twist` for ``world`` as a function of (v, omega), with what depends only on the
    vehicle (its wheel layout, the minimum turning radius, the steering limit) worked out once: the
    trial loop calls it at every control tick. The same floating-point operations, in the same order,
    as :func:`skid_steer.wheel_speeds` and :func:`steered_commands`."""
    spec = world.spec
    v_max, radius = spec.max_speed_m_s, spec.wheel_radius_m
    if spec.steering == "skid":
        half = 0.5 * spec.skid_track_factor * spec.track_m
        command_wheels = world.command_wheels

        def drive_skid(v_m_s: float, omega_rad_s: float) -> None:
            left, right = v_m_s - omega_rad_s * half, v_m_s + omega_rad_s * half
            fastest = max(abs(left), abs(right))
            if fastest > v_max:
                scale = v_max / fastest
                left, right = left * scale, right * scale
            command_wheels(left / radius, right / radius)
        return drive_skid

    layout = reference_layout(spec, world.geometry.wheel_centres_m)
    r_min = min_turn_radius_m(spec, layout)
    limit = math.radians(spec.max_steer_angle_deg)
    steer_of = {w: i for i, w in enumerate(spec.steered_wheel_joints)}
    # per wheel: (its index among the steered wheels or None, x, y), as _rigid_turn walks them
    wheels = tuple((steer_of.get(name), x, y) for name, (x, y) in zip(spec.wheel_joints, layout, strict=True))
    n_steer = len(spec.steer_joints)
    half_pi = 0.5 * math.pi
    command_steering, command_wheel_speeds = world.command_steering, world.command_wheel_speeds

    def drive_steered(v_m_s: float, omega_rad_s: float) -> None:
        if not r_min <= 0.0:  # _turn_limited (its test, NaN included)
            cap = abs(v_m_s) / r_min
            omega_rad_s = max(-cap, min(cap, omega_rad_s))
        speeds, angles = [], [0.0] * n_steer  # _rigid_turn
        for i, x, y in wheels:
            vx, vy = v_m_s - omega_rad_s * y, omega_rad_s * x
            if i is None:
                speeds.append(vx)
                continue
            if abs(vx) < 1e-12 and abs(vy) < 1e-12:
                speeds.append(0.0)
                continue
            a, sp = math.atan2(vy, vx), math.hypot(vx, vy)
            if a > half_pi:
                a, sp = a - math.pi, -sp
            elif a < -half_pi:
                a, sp = a + math.pi, -sp
            angles[i] = max(-limit, min(limit, a))
            speeds.append(sp)
        fastest = max(abs(s) for s in speeds)  # _speed_scale
        scale = v_max / fastest if fastest > v_max else 1.0
        command_steering(angles)
        command_wheel_speeds([s * scale / radius for s in speeds])
    return drive_steered


def make_vehicle_tracker(waypoints, spec: VehicleSpec, cfg: ControllerConfig, world=None):
    """The path tracker for the vehicle's steering kind (module docstring)."""
    from offroadbench.sim.trial.controller import make_tracker

    base = make_tracker(np.asarray(waypoints, dtype=float), spec, cfg)
    if spec.steering != "ackermann":
        return base
    from offroadbench.sim.trial.ackermann import BicycleTracker

    layout = reference_layout(spec, world.geometry.wheel_centres_m)
    wheelbase = max(abs(x) for x, _ in layout)
    # the bicycle's largest angle: the one whose turn puts the inner wheel at its steering limit
    return BicycleTracker(base, spec, cfg, wheelbase_m=wheelbase,
                          max_steer_rad=math.atan(wheelbase / min_turn_radius_m(spec, layout)))
