"""The vehicle check's bounds for tracks and sprung wheels (offroadbench.sim.rigs.vehicle_check): pure
formulas, derived in their docstrings, and the suspension's figures read from a vehicle's URDF.

- :func:`track_step_bound_m`: the highest step a belt-driven track of equal road wheels climbs
  quasi-statically (``VehicleSpec.belt_drive``: the TALON);
- :func:`sprung_tip_angle_deg`: the tilt-table tip angle of a vehicle on vertical struts
  (``VehicleSpec.suspension_*``: the HUNTER 2.0), the body rolling on its springs.
"""

from __future__ import annotations

import math

from offroadbench.sim.engines.base import read_urdf, unsprung_kg
from offroadbench.sim.rigs.vehicle_measure import bisect_threshold
from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["sprung_tip_angle_deg", "suspension_of", "track_step_bound_m"]


def track_step_bound_m(wheel_radius_m: float, mu: float, lift_share: float, face_run_m: float,
                       torque_ratio: float = math.inf) -> float:
    """Highest step a belt-driven track of equal road wheels climbs quasi-statically, metres.

    The track's front is its front road wheel (no raised idler: ``vehicles/talon``), so a step face met
    below that wheel's centre is climbed by geometry, as by the front idler of a track whose front run
    rises to it: the contact's normal lifts the track (the approach-angle rule of tracked vehicles: a
    step up to the front idler's centre height). A higher face is met at the wheel's front, and only
    the belt's friction on the face lifts it (derived here, quasi-static, the hull rigid): the hull
    pivots on its rear road wheel, so the front must carry ``lift_share`` s of the weight W (the centre
    of mass's distance from the rear wheel over the wheelbase), and the rear wheel pushes the front
    into the face with at most its grip ``mu (1 - s) W``. A face inclined ``phi`` from the vertical
    (a step across a heightfield is a ramp ``face_run_m`` long: one cell) presses the wheel with
    ``N`` at ``phi`` above the horizontal; the belt, driven forward, rubs up the face with ``mu N``:

        lift  N (sin phi + mu cos phi) = s W,     push  N (cos phi - mu sin phi) <= mu (1 - s) W,

    that is ``tan(phi + atan mu) >= s / (mu (1 - s))``. The step is climbed while ``phi = atan(run / h)``
    is at least that angle, and while the belts' torque carries the front wheel's rub and the rear's
    push, ``(mu N + push) / W <= torque_ratio`` (the tracks' summed sprocket torque over ``r W``). A
    vertical face (``run`` 0) with ``s / (mu (1 - s)) > mu`` is climbed only to the wheel's centre,
    ``r``. With ``mu`` = 0.8, ``s`` = 1/2 and a 2 cm run: ``phi`` >= 12.7 deg, ``h`` <= 0.089 m.
    """

    def climbs(h: float) -> bool:
        if h <= wheel_radius_m:
            return True
        phi = math.atan2(face_run_m, h)
        n = lift_share / (math.sin(phi) + mu * math.cos(phi))  # N / W
        push = n * (math.cos(phi) - mu * math.sin(phi))
        return push <= mu * (1.0 - lift_share) and mu * n + max(0.0, push) <= torque_ratio

    return bisect_threshold(climbs, wheel_radius_m, 20.0 * wheel_radius_m, 1e-5)


def sprung_tip_angle_deg(mass_kg: float, unsprung_kg: float, com_height_m: float, wheel_radius_m: float,
                         track_m: float, stiffness_n_m: float, preload_n: float, droop_m: float, bump_m: float,
                         g: float = 9.81) -> float:
    """Tilt-table tip angle of a vehicle whose wheels ride vertical struts (VehicleSpec.suspension_*), deg.

    Derived here (quasi-static, in the roll plane, the struts at the wheel centres, ``unsprung_kg`` per
    wheel, two wheels a side seen as one): at the tip the uphill wheels carry nothing, so their struts
    hang at full extension ``q_u = max(-droop, -preload / k)``; the downhill struts carry the sprung mass
    and the hanging uphill wheels, ``F = (m_s + 2 m_u) g cos(theta + phi) / 2`` each (the load along the
    rolled body's z axis), so they compress to ``q_d = min(bump, (F - preload) / k)`` and the body rolls
    downhill by ``phi = atan((q_d - q_u) / track)``. The sprung centre of mass, ``d`` above the strut
    line, moves with the roll toward the downhill wheels; the vehicle tips when the whole centre of mass
    is over their contact line: ``tan(theta) = Y / Z`` (its distance from that line along the table and
    its height), solved by fixed-point iteration. Rigid struts (``k`` -> infinity) give the geometric
    ``atan((track / 2) / h)``.
    """
    n = 4.0
    m_s = mass_kg - n * unsprung_kg
    d = (mass_kg * com_height_m - n * unsprung_kg * wheel_radius_m) / m_s - wheel_radius_m
    q_u = max(-droop_m, -preload_n / stiffness_n_m)
    theta = math.atan2(track_m / 2.0, com_height_m)
    for _ in range(200):
        phi, q_d = 0.0, 0.0
        for _ in range(50):
            load = (m_s + 2.0 * unsprung_kg) * g * math.cos(theta + phi) / 2.0
            q_d = min(bump_m, (load - preload_n) / stiffness_n_m)
            phi = math.atan2(q_d - q_u, track_m)
        s, c = math.sin(phi), math.cos(phi)
        sprung_y = q_d * s + track_m / 2.0 * c - d * s
        sprung_z = wheel_radius_m - q_d * c + track_m / 2.0 * s + d * c
        uphill_y = q_d * s + track_m * c - q_u * s
        y = (m_s * sprung_y + 2.0 * unsprung_kg * uphill_y) / mass_kg
        z = (m_s * sprung_z + n * unsprung_kg * wheel_radius_m) / mass_kg
        theta = math.atan2(y, z)
    return math.degrees(theta)


def suspension_of(spec: VehicleSpec) -> tuple[float, float, float]:
    """(unsprung mass per wheel kg, droop m, bump m) of a sprung vehicle, from its URDF: the mean mass
    below each suspension joint, the joints' limits (the smallest travel of any)."""
    struts = [j for j in read_urdf(spec.urdf)[1] if j.name in spec.suspension_joints]
    return (unsprung_kg(spec.urdf, spec.suspension_joints), min(-j.limits[0] for j in struts),
            min(j.limits[1] for j in struts))
