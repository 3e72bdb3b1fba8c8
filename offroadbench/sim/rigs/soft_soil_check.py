"""The soft-soil rows of the vehicle check (offroadbench.sim.rigs.vehicle_check): the climb limit
and the drawbar pull on a deformable soil (lunar regolith at lunar gravity).

A wheel without a motor (a rear-wheel-drive car's front wheels) is towed: it rolls at the slip where
its soil torque vanishes (Wong 2008, *Theory of Ground Vehicles*, 4th ed., ch. 2: a towed wheel's
motion resistance; here the Wong-Reece torque of Ishigami et al. 2007, Eq. 7, set to zero), and its
drawbar pull there, the negative of its motion resistance, is added to the driven wheels' pull.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from offroadbench.heightmap import Heightmap
from offroadbench.sim.config import SimConfig
from offroadbench.sim.engine import TrialWorld, open_world
from offroadbench.sim.trial.steering import drive_twist
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle
from offroadbench.sim.rigs.vehicle_measure import CheckResult, FLAT_CELL_M, abs_row, bisect_threshold, climbs_grade, ratio_row


#: soil and gravity of the soft-soil rows
SOFT_SOIL = "lunar-regolith"


SOFT_SOIL_GRAVITY_M_S2 = 1.62


def towed_pull_n(soil, radius_m: float, width_m: float, load_n: float) -> float:
    """Drawbar pull of a towed (undriven) wheel carrying ``load_n``, N (negative: its motion
    resistance): the Wong-Reece pull at the slip in [-0.5, 0.5] where the wheel's soil torque is zero
    (module docstring), each slip with the sinkage that carries the load."""
    from offroadbench.sim.tyre_laws.terramechanics import static_sinkage, wheel_forces

    def forces(slip: float):
        h = static_sinkage(soil, radius_m, width_m, load_n, slip)
        return wheel_forces(soil, radius_m, width_m, h, slip)

    # the torque rises with the slip: negative when skidding, positive when driving
    slip = _rising_root(lambda x: float(forces(x)[2]), -0.5, 0.5)
    return float(forces(slip)[1])


def _rising_root(f, lo: float, hi: float) -> float:
    """Where ``f`` (rising over [lo, hi]) crosses 0, to 1e-12 (Brent's method: ~10 calls of ``f``
    where a bisection to that width takes 40; each call here is a sinkage solve); ``lo`` where f is
    already >= 0 there, ``hi`` where it is still < 0 there."""
    from scipy.optimize import brentq

    if f(lo) >= 0.0:
        return lo
    if f(hi) < 0.0:
        return hi
    return float(brentq(f, lo, hi, xtol=1e-12))


def soil_climb_limit_deg(soil, radius_m: float, width_m: float, mass_kg: float, g: float, slip: float,
                         n_wheels: int = 4, n_driven: int | None = None) -> float:
    """Steepest grade on which ``n_wheels`` equally loaded wheels, ``n_driven`` of them (default all)
    driven at ``slip`` and the rest towed (:func:`towed_pull_n`), pull the vehicle's weight component,
    degrees (Wong-Reece drawbar pull at the sinkage carrying ``m g cos / n``)."""
    from offroadbench.sim.tyre_laws.terramechanics import static_sinkage, wheel_forces

    driven = n_wheels if n_driven is None else n_driven

    def margin(theta: float) -> float:
        load = mass_kg * g * math.cos(theta) / n_wheels
        h = static_sinkage(soil, radius_m, width_m, load, slip)
        pull = driven * float(wheel_forces(soil, radius_m, width_m, h, slip)[1])
        if driven < n_wheels:
            pull += (n_wheels - driven) * towed_pull_n(soil, radius_m, width_m, load)
        return pull - mass_kg * g * math.sin(theta)

    if margin(0.0) < 0.0:
        return 0.0
    return math.degrees(_rising_root(lambda theta: -margin(theta), 0.0, 0.5 * math.pi))  # the margin falls with the grade


def track_climb_limit_deg(soil, width_m: float, length_m: float, mass_kg: float, g: float, slip: float,
                          com_height_m: float = 0.0) -> float:
    """Steepest grade on which two belts (b x L each) at ``slip`` pull the vehicle's weight component,
    degrees: ``2 (F(i) - R_c) = m g sin(theta)`` with each belt carrying ``m g cos(theta) / 2``
    (offroadbench.sim.tyre_laws.track_patch). Load transfer: the weight's component along the grade,
    acting at the centre of mass ``com_height_m`` above the belts, moves the centre of pressure back by
    ``e = h tan(theta)``; a linear pressure keeps the whole belt on the ground while ``e <= L / 6`` and
    shortens the contact to ``3 (L / 2 - e)`` beyond (the front lifts; Wong 2008, ch. 2, eccentric
    load), and the thrust is the belt's over that contact."""
    from offroadbench.sim.tyre_laws.track_patch import compaction_resistance_n, track_sinkage_m, track_thrust_n

    def margin(theta: float) -> float:
        w = mass_kg * g * math.cos(theta) / 2.0
        e = com_height_m * math.tan(theta)
        contact = length_m if e <= length_m / 6.0 else max(1e-9, 3.0 * (length_m / 2.0 - e))
        pull = track_thrust_n(soil, width_m, contact, w, slip) - compaction_resistance_n(
            soil, width_m, track_sinkage_m(soil, width_m, length_m, w))
        return 2.0 * pull - mass_kg * g * math.sin(theta)

    if margin(0.0) < 0.0:
        return 0.0
    return math.degrees(_rising_root(lambda theta: -margin(theta), 0.0, 0.5 * math.pi))  # the margin falls with the grade


def tow_pull(world: TrialWorld, slip: float, seconds: float = 8.0) -> float:
    """Drawbar pull at ``slip``: a drag on the chassis fed back on the mean wheel slip, N. With undriven
    wheels the slip fed back is the driven wheels' ``1 - v / (omega r)`` from the chassis's forward
    speed ``v`` and their commanded tyre speed ``omega r`` (the engines' mean slip counts the towed
    wheels too)."""
    spec = world.spec
    kinematic = not all(spec.is_driven(w) for w in spec.wheel_joints)
    world.spawn(2.0, world.hm.height_m / 2.0, 0.0)
    rate = world.sim.physics_rate_hz
    weight = world.geometry.mass_kg * world.sim.gravity_m_s2
    drag, pulls = 0.0, []
    n = int(round(seconds * rate))
    for k in range(n):
        tyre_speed = min(0.3, 0.3 * k / rate)
        drive_twist(world, tyre_speed, 0.0)
        world.push_base(-drag, 0.0, 0.0)
        world.step()
        measured = world.wheel_slip()
        if kinematic and measured is not None:
            pos, quat, lin, _ = world.base_state()
            r = world.rotation_matrix(quat)
            forward = r[0] * lin[0] + r[3] * lin[1] + r[6] * lin[2]
            measured = 1.0 - forward / tyre_speed if tyre_speed > 0.0 else 0.0
        if measured is not None and k > rate:
            drag = drag + 0.5 * weight * (slip - measured) / rate  # integral feedback (a push if negative)
        if k >= n - 2 * rate:
            pulls.append(drag)
    return sum(pulls) / len(pulls)


def come_to_rest(world: TrialWorld, speed_m_s: float = 0.005, hold_s: float = 0.25, limit_s: float = 3.0) -> None:
    """Step a vehicle still moving after its spawn's settle until its vertical speed has stayed under
    ``speed_m_s`` for ``hold_s`` (at most ``limit_s``); a vehicle already still is left as it is. A sprung
    vehicle (the HUNTER's struts) landing on the soil in lunar gravity still bounced after the settle's
    0.5 s, and its sinkage read 0.006 m against 0.010 m at rest."""
    if abs(world.base_state()[2][2]) < speed_m_s:
        return
    still, need = 0, int(round(hold_s * world.sim.physics_rate_hz))
    for _ in range(int(round(limit_s * world.sim.physics_rate_hz))):
        world.step()
        still = still + 1 if abs(world.base_state()[2][2]) < speed_m_s else 0
        if still >= need:
            return


def _soft_setup(sim: SimConfig) -> tuple[float, Any, SimConfig, Heightmap]:
    """(gravity m/s^2, the soil's parameters, the rigs' settings, their flat 16 m world) of the soft-soil
    rows: ``SOFT_SOIL`` under the terramechanics tyres in ``SOFT_SOIL_GRAVITY_M_S2``."""
    from offroadbench.sim.tyre_laws.terramechanics import load_soil

    g = SOFT_SOIL_GRAVITY_M_S2
    soft = dataclasses.replace(sim, tyre_model="terramechanics", soil=SOFT_SOIL, gravity_m_s2=g,
                               settle_time_s=min(sim.settle_time_s, 0.5))
    return g, load_soil(SOFT_SOIL), soft, Heightmap.flat(161, 161, FLAT_CELL_M)


def soft_soil_checks(vehicle: VehicleSpec | str, sim: SimConfig = SimConfig()) -> list[CheckResult]:
    """The soft-soil rows (module docstring): ``SOFT_SOIL`` in ``SOFT_SOIL_GRAVITY_M_S2``."""
    from offroadbench.sim.tyre_laws.terramechanics import static_sinkage, wheel_forces

    spec = vehicle if isinstance(vehicle, VehicleSpec) else load_vehicle(vehicle)
    if spec.wheel_width_m is None:
        return []
    if spec.track_contact_length_m is not None:
        return _track_rows(spec, sim)
    g, soil, soft, flat = _soft_setup(sim)
    r, b = spec.wheel_radius_m, spec.wheel_width_m
    where = f"{SOFT_SOIL}, g = {g:g} m/s^2 (Bekker parameters from 1 g: not validated in reduced gravity)"
    with open_world(flat, spec, soft) as world:
        c = flat.width_m / 2.0
        world.spawn(c, c, 0.0)
        come_to_rest(world)
        mass = world.geometry.mass_kg
        n = len(spec.wheel_joints)
        n_driven = sum(spec.is_driven(w) for w in spec.wheel_joints)
        load = mass * g / n
        sink = world.wheel_penetration_m()
        expected_sink = static_sinkage(soil, r, b, load)
        grade = bisect_threshold(lambda a: climbs_grade(world, a), 0.0, 60.0, 0.5)
        pull = tow_pull(world, 0.2)
    h20 = static_sinkage(soil, r, b, load, 0.2)
    expected_pull = n_driven * float(wheel_forces(soil, r, b, h20, 0.2)[1])
    towed = ""
    if n_driven < n:
        expected_pull += (n - n_driven) * towed_pull_n(soil, r, b, load)
        towed = f" driven and {n - n_driven} towed"
    limit = soil_climb_limit_deg(soil, r, b, mass, g, 0.75, n, n_driven)
    mu = spec.wheel_friction * sim.terrain_friction
    return [
        ratio_row("soft soil: sinkage at rest", sink, expected_sink, "m", 0.85, 1.15,
                   f"{where}; Wong-Reece sinkage carrying {load:.1f} N per wheel"),
        abs_row("soft soil: steepest grade climbed from rest", grade, limit, "deg", 3.0,
                 f"{where}; quasi-static soil limit at slip 0.75; on rigid ground grip alone allows "
                 f"atan(mu) = {math.degrees(math.atan(mu)):.1f} deg (mu = {mu:g})"),
        CheckResult("soft soil: drawbar pull at 20 % slip", pull, expected_pull, "N",
                    bool(abs(pull - expected_pull) <= max(0.1 * abs(expected_pull), 0.01 * mass * g)),
                    "within 10 % or 1 % of the weight",
                    f"{where}; {n_driven}{towed} x a wheel's Wong-Reece pull at {load:.1f} N, weight {mass * g:.1f} N"),
    ]


def _track_rows(spec: VehicleSpec, sim: SimConfig) -> list[CheckResult]:
    """The soft-soil rows of a tracked vehicle with a track patch: its belts against the Bekker / Wong
    track relations (offroadbench.sim.tyre_laws.track_patch), each belt carrying half the weight. The
    belts' slip settles more slowly than a wheel's (their relaxation length is longer), so the tow rig
    runs 16 s."""
    from offroadbench.sim.tyre_laws.track_patch import drawbar_pull_n, track_sinkage_m

    g, soil, soft, flat = _soft_setup(sim)
    b, length = spec.wheel_width_m, spec.track_contact_length_m
    where = f"{SOFT_SOIL}, g = {g:g} m/s^2 (Bekker parameters from 1 g: not validated in reduced gravity); belts {length:g} x {b:g} m"
    with open_world(flat, spec, soft) as world:
        c = flat.width_m / 2.0
        world.spawn(c, c, 0.0)
        come_to_rest(world)
        mass = world.geometry.mass_kg
        sink = world.wheel_penetration_m()
        com_height = world.centre_of_mass_m()[2] - (flat.z_min_m - sink)  # above the belts' bottom
        grade = bisect_threshold(lambda a: climbs_grade(world, a), 0.0, 60.0, 0.5)
        pull = tow_pull(world, 0.2, seconds=16.0)
    w = mass * g / 2.0
    expected_pull = 2.0 * drawbar_pull_n(soil, b, length, w, 0.2)
    limit = track_climb_limit_deg(soil, b, length, mass, g, 0.75, com_height)
    mu = spec.wheel_friction * sim.terrain_friction
    return [
        ratio_row("soft soil: sinkage at rest", sink, track_sinkage_m(soil, b, length, w), "m", 0.85, 1.15,
                   f"{where}; Bekker sinkage of a belt carrying {w:.1f} N"),
        abs_row("soft soil: steepest grade climbed from rest", grade, limit, "deg", 3.0,
                 f"{where}; quasi-static belt limit at slip 0.75 with the load moved back (centre of mass "
                 f"{com_height:.3f} m above the belts); on rigid ground grip alone allows "
                 f"atan(mu) = {math.degrees(math.atan(mu)):.1f} deg (mu = {mu:g})"),
        CheckResult("soft soil: drawbar pull at 20 % slip", pull, expected_pull, "N",
                    bool(abs(pull - expected_pull) <= max(0.1 * abs(expected_pull), 0.01 * mass * g)),
                    "within 10 % or 1 % of the weight",
                    f"{where}; 2 x a belt's thrust less its compaction resistance, weight {mass * g:.1f} N"),
    ]
