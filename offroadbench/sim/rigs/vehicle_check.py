"""Vehicle check: does the simulated vehicle do what its own physics says it should?

Every row is judged against what the model's own figures predict (its grip ``mu`` = wheel x
terrain friction, its geometry as loaded, its motor torque), so a check fails when the model
disagrees with its physics, or when its physics makes it unfit to drive (a top-heavy vehicle that
rolls before it slides). The spec sheet's figures (``rated_*`` in vehicle.toml) stand beside the
rows they match, as information, with the reason for any difference: the sheet assumes its own
surface (the Husky's 45 deg climb needs mu >= 1; the model's tyres have 0.8).

:func:`check_vehicle` builds small flat and stepped worlds and measures, with the same World,
contact model and skid-steer drive the trials use:

- **yaw-rate tracking**, in place and at cruise speed, at headings 0, 22.5 and 45 deg (Bullet's
  friction directions sit on the world axes, so a heading-dependent contact shows here) for
  commands 0.25-2 rad/s (capped at the vehicle's yaw-rate limit). The expected value is the
  command after the drive's limits (:func:`offroadbench.sim.trial.steering.achievable`: skid-steer's
  wheel-speed saturation, or a steered vehicle's minimum turning radius, whose vehicle has no
  in-place rows); pass: 0.85-1.1x.
- **straight-line drift**: lateral offset after 10 m driven open loop at cruise speed on flat
  ground (expected 0; pass: under 2 % of the distance). A symmetric vehicle on a flat heightfield
  still drifts: at the check's 22.5 deg heading its wheels cross the triangles' diagonals at
  different moments left and right. Measured 2026-11-26 on PyBullet over husky, jackal, talon and
  hunter: 0.1-9.3 cm with the drive train on the wheel links, 4.8-15.9 cm with it geared
  (``SimConfig.drive_train_reaction``): the same order, and 1 % sat inside that scatter.
- **stopping distance** of the whole vehicle's centre of mass from top speed when the wheels are
  commanded to stop (stopped: under 1 cm/s for 0.5 s), against
  ``v^2 / (2 a)`` with ``a = min(max_accel, mu g, n tau / (r m_eff))``: the vehicle's rated
  deceleration, what the grip allows, or what the motors can do against the vehicle's mass plus
  the drive train's reflected mass ``m_eff = m + sum(I_spin) / r^2``; pass: 0.5-1.5x.
- **static tip angle** on a tilt table: the table (here: gravity, turned about the vehicle's long
  axis; the same thing for a rigid vehicle on flat ground) tilts slowly, with a grippy surface
  so the vehicle cannot slide, until the uphill wheels leave the ground. Expected: the
  geometric ``atan((track / 2) / h)`` with ``h`` the height of the whole vehicle's centre of mass
  above the ground, measured on the settled vehicle (a vehicle on sprung struts, ``suspension_*``:
  :func:`~offroadbench.sim.rigs.vehicle_bounds.sprung_tip_angle_deg`, its body rolling on its springs);
  pass: within 2 deg. The table jumps to 15 deg below that and the vehicle rests there 2 s before the
  slow ramp; the tip counts once the uphill wheels have stayed off the table for 0.25 s.
- **steepest slope climbed from rest** (gravity turned about the lateral axis): bisection on the
  grade at which the vehicle, started at rest, gains 1 m uphill. Expected: the quasi-static limit
  of :func:`climb_limit_deg` (load transfer to the rear axle, each axle limited by its grip or its
  motors' torque, and at most the pitch-over angle); pass: within 4 deg. The spec sheet's grade
  stands beside it.
- **side slope held** (gravity turned about the long axis, the vehicle's own friction, resting 2 s
  at the first angle as on the tilt table): the tilt at which the parked vehicle starts to slide or tip, against ``min(atan(mu), tip angle)``
  (within 2 deg); the spec sheet's side slope beside it.
- **static stability**: the tilt-table tip angle must exceed the slide angle ``atan(mu)``: at rest
  on a side slope the vehicle slides before it rolls over (a centre of mass raised 0.5 m on the
  Husky fails this row).
- **highest step climbed** at cruise speed from 1.5 m away (bisection on the height of a step
  across a 2 cm grid). Expected: the geometric bound of :func:`step_bound_m` (wheel radius, chassis nose, belly clearing the edge); pass: 0.6-1.05x.
  A rocker-bogie's middle and rear wheels push the front one up the face: about a wheel diameter
  (Bickler 1998); pass: 0.75-1.25x. A belt-driven track (``belt_drive``) is approached at a crawl,
  0.1 m/s, against the quasi-static climb of :func:`track_step_bound_m` (its front road wheel by
  geometry to its centre, above by the belt's friction on the face); pass: 0.6-1.05x. At cruise speed
  its kinetic energy adds to that (the TALON climbed 0.13 m on PyBullet, 0.11 m on MuJoCo at 1 m/s,
  0.09 and 0.08 m at 0.1 m/s), which a quasi-static bound does not hold
  (:func:`~offroadbench.sim.rigs.vehicle_bounds.track_step_bound_m`).

**Soft soil** (:func:`soft_soil_checks`, the ``terramechanics`` tyre model on lunar regolith in
lunar gravity, offroadbench.sim.tyre_laws.terramechanics):

- **sinkage at rest** against the Wong-Reece sinkage that carries a quarter of the weight; pass:
  within 15 %.
- **steepest grade climbed from rest** (as on rigid ground), against the quasi-static soil limit
  :func:`soil_climb_limit_deg` at slip 0.75 (the largest slip at which the test's 0.5 m/s wheel
  speed still gains its 1 m in 10 s); pass: within 3 deg; the note gives the rigid-ground figure.
- **drawbar pull at 20 % slip**: the vehicle drives on flat soil while a horizontal force on the
  chassis, fed back on the mean wheel slip, holds the slip at 0.2; the force is the vehicle's
  drawbar pull, against four times a wheel's Wong-Reece pull at a quarter of the weight; pass:
  within 10 % of the expected pull or 1 % of the weight.

A tracked vehicle with a track patch (``track_contact_length_m``) is checked against its belts'
Bekker / Wong relations instead (offroadbench.sim.tyre_laws.track_patch): a belt's sinkage under
half the weight, a climb limit with the load moved back by the grade
(:func:`~offroadbench.sim.rigs.soft_soil_check.track_climb_limit_deg`), and twice a belt's thrust
less its compaction resistance at 20 % slip (a 16 s tow: a belt's slip settles more slowly).

All measurements are in SI units; angles are reported in degrees. The soft-soil rows are in
:mod:`offroadbench.sim.rigs.soft_soil_check`, the row type and the measuring helpers in
:mod:`offroadbench.sim.rigs.vehicle_measure`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numpy as np

from offroadbench.heightmap import Heightmap
from offroadbench.progress import ProgressFn, report
from offroadbench.sim.config import SimConfig
from offroadbench.sim.engine import TrialWorld, engine_capabilities, open_world
from offroadbench.sim.trial.steering import achievable, drive_twist, min_turn_radius_m, reference_layout
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle
from offroadbench.sim.rigs.vehicle_measure import (CheckResult, FLAT_CELL_M, STEP_CELL_M, abs_row, bisect_threshold, climbs_grade,
                                                   com_height, left_load, mean_yaw_rate, ramp_tilt, ratio_row,
                                                   run_for, set_tilted_gravity)
from offroadbench.sim.rigs.vehicle_bounds import sprung_tip_angle_deg, suspension_of, track_step_bound_m
from offroadbench.sim.rigs.soft_soil_check import (SOFT_SOIL, SOFT_SOIL_GRAVITY_M_S2, soft_soil_checks,
                                                   soil_climb_limit_deg)

__all__ = ["CheckResult", "check_vehicle", "climb_limit_deg", "step_bound_m", "track_step_bound_m", "sprung_tip_angle_deg", "YAW_COMMANDS_RAD_S", "HEADINGS_DEG",
           "soft_soil_checks", "soil_climb_limit_deg", "SOFT_SOIL", "SOFT_SOIL_GRAVITY_M_S2"]


#: yaw-rate commands of the tracking checks, rad/s (capped at the vehicle's limit)
YAW_COMMANDS_RAD_S = (0.25, 0.5, 1.0, 2.0)
#: headings of the tracking checks, degrees from the world x axis
HEADINGS_DEG = (0.0, 22.5, 45.0)


# ---------------------------------------------------------------------------- the checks
def _yaw_tracking(world: TrialWorld, headings_deg, commands) -> list[CheckResult]:
    spec = world.spec
    cruise = min(1.0, spec.max_speed_m_s)
    layout = reference_layout(spec, world.geometry.wheel_centres_m)
    r_min = min_turn_radius_m(spec, layout)
    rows = []
    modes = (("in place", 0.0), (f"at {cruise:g} m/s", cruise)) if r_min == 0.0 else ((f"at {cruise:g} m/s", cruise),)
    for mode, v in modes:
        for h in headings_deg:
            for w in commands:
                w = min(w, spec.max_yaw_rate_rad_s)
                _, w_ach = achievable(v, w, spec, layout)
                got = mean_yaw_rate(world, v, w, math.radians(h))
                note = "" if math.isclose(w_ach, w, rel_tol=1e-9) else (
                    f"command {w:g} rad/s, wheel speeds saturated at {spec.max_speed_m_s:g} m/s" if r_min == 0.0 else
                    f"command {w:g} rad/s, limited by the minimum turning radius {r_min:.2f} m "
                    f"(steering limit {spec.max_steer_angle_deg:g} deg)")
                rows.append(ratio_row(f"yaw rate {mode}, heading {h:g} deg, command {w:g} rad/s",
                                       got, w_ach, "rad/s", 0.85, 1.1, note))
    return rows


def _drift(world: TrialWorld) -> CheckResult:
    spec = world.spec
    v = min(1.0, spec.max_speed_m_s)
    heading = math.radians(22.5)
    x0, y0 = 2.0, 2.0
    world.spawn(x0, y0, heading)
    drive_twist(world, v, 0.0)
    along = 0.0
    pos = world.base_state()[0]
    for _ in range(int(round(30.0 * world.sim.physics_rate_hz))):
        world.step()
        pos = world.base_state()[0]
        along = (pos[0] - x0) * math.cos(heading) + (pos[1] - y0) * math.sin(heading)
        if along >= 10.0:
            break
    lateral = -(pos[0] - x0) * math.sin(heading) + (pos[1] - y0) * math.cos(heading)
    return abs_row("straight-line drift over 10 m", abs(lateral), 0.0, "m", 0.2,
                    f"open loop at {v:g} m/s, heading 22.5 deg; {along:.1f} m driven")


def _stopping(world: TrialWorld) -> CheckResult:
    spec = world.spec
    v = spec.max_speed_m_s
    world.spawn(2.0, world.hm.height_m / 2.0, 0.0)
    drive_twist(world, v, 0.0)
    run_for(world, 2.0 + 3.0 * v / spec.max_accel_m_s2)
    speed = math.hypot(*world.base_state()[2][:2])
    # the whole vehicle's centre of mass (a suspended body swings on its rockers as the wheels stop)
    start = world.centre_of_mass_m()
    world.command_wheels(0.0, 0.0)
    still, settle = 0, int(round(0.5 * world.sim.physics_rate_hz))
    for _ in range(int(round(5.0 * world.sim.physics_rate_hz))):
        world.step()
        # stopped: under 1 cm/s for 0.5 s (a suspended body swings through 0 while it stops)
        still = still + 1 if math.hypot(*world.base_state()[2][:2]) < 0.01 else 0
        if still >= settle:
            break
    end = world.centre_of_mass_m()
    dist = math.hypot(end[0] - start[0], end[1] - start[1])
    mu = spec.wheel_friction * world.sim.terrain_friction
    n = sum(map(spec.is_driven, spec.wheel_joints))
    share = n / len(spec.wheel_joints)  # the driven (braking) wheels' share of the weight, about
    spin = sum(world.geometry.wheel_spin_inertia_kg_m2)
    m_eff = world.geometry.mass_kg + spin / spec.wheel_radius_m**2
    motors = n * spec.wheel_torque_limit_nm / (spec.wheel_radius_m * m_eff)
    decel = min(spec.max_accel_m_s2, share * mu * world.sim.gravity_m_s2, motors)
    expected = speed * speed / (2.0 * decel)
    return ratio_row("stopping distance from top speed", dist, expected, "m", 0.5, 1.5,
                      f"from {speed:.2f} m/s; v^2 / (2 a), a = min(max_accel, mu g, n tau / (r m_eff)) = "
                      f"{decel:.2f} m/s^2, m_eff = m + sum(I_spin) / r^2 = {m_eff:.1f} kg")


#: how long the vehicle rests on the tilt table at the ramp's first angle before the ramp starts, s
TILT_SETTLE_S = 2.0


def _tilt_and_settle(world: TrialWorld, start_deg: float) -> None:
    """Tilt the table to ``start_deg`` at once and let the vehicle come to rest there for
    :data:`TILT_SETTLE_S` before the slow ramp: a sprung vehicle rolls on its springs when the table
    jumps to the first angle and overshoots (a damping ratio of 0.3 overshoots by 37 %), which
    unloaded the uphill wheels of the HUNTER at once and read as a tip or a slide at the first angle."""
    set_tilted_gravity(world, math.radians(start_deg), "x")
    run_for(world, TILT_SETTLE_S)


#: how long the uphill wheels must stay off the tilt table to count as lifted, s (a sprung wheel hanging on
#: its droop stop chattered off the ground for single steps on PyBullet 4 deg before the tip)
TIP_LIFT_S = 0.25


def _tip_angle(spec: VehicleSpec, sim: SimConfig, hm: Heightmap) -> tuple[CheckResult, float, float]:
    grippy = dataclasses.replace(sim, terrain_friction=max(sim.terrain_friction, 5.0 / spec.wheel_friction))
    with open_world(hm, spec, grippy) as world:
        c = hm.width_m / 2.0
        world.spawn(c, c, 0.0)
        h = com_height(world)
        note = f"geometric atan((track/2) / h), centre of mass h = {h:.3f} m above ground"
        expected = math.degrees(math.atan2(spec.track_m / 2.0, h))
        if spec.suspension_joints:
            unsprung, droop, bump = suspension_of(spec)
            rigid = expected
            expected = sprung_tip_angle_deg(world.geometry.mass_kg, unsprung, h, spec.wheel_radius_m, spec.track_m,
                                            spec.suspension_stiffness_n_m, spec.suspension_preload_n, droop, bump,
                                            world.sim.gravity_m_s2)
            note = (f"sprung_tip_angle_deg: the body rolls on its springs toward the downhill wheels (rigid: "
                    f"{rigid:.1f} deg), centre of mass h = {h:.3f} m above ground")
        # downhill toward -y: the right side; the left (uphill) wheels unload at the tip angle and stay off
        start = expected - 15.0
        _tilt_and_settle(world, start)
        run, need = [0], int(round(TIP_LIFT_S * world.sim.physics_rate_hz))

        def lifted() -> bool:
            run[0] = run[0] + 1 if left_load(world) <= 0.0 else 0
            return run[0] >= need

        angle = ramp_tilt(world, 1.0, lifted, start_deg=start) - (need - 1) / world.sim.physics_rate_hz
    row = abs_row("static tip angle (tilt table)", angle, expected, "deg", 2.0,
                   f"{note}; grippy table so the vehicle cannot slide; tip: the uphill wheels off the table for "
                   f"{TIP_LIFT_S:g} s")
    return row, expected, h


def _side_slope(world: TrialWorld, tip_deg: float) -> CheckResult:
    spec = world.spec
    mu = spec.wheel_friction * world.sim.terrain_friction
    slide = math.degrees(math.atan(mu))
    expected = min(slide, tip_deg)
    c = world.hm.width_m / 2.0
    world.spawn(c, c, 0.0)
    start = max(0.0, min(20.0, expected - 10.0))
    _tilt_and_settle(world, start)
    y0 = world.base_state()[0][1]

    def moved() -> bool:
        return abs(world.base_state()[0][1] - y0) > 0.02 or left_load(world) <= 0.0

    angle = ramp_tilt(world, 1.0, moved, start_deg=start)
    set_tilted_gravity(world, 0.0, "x")
    note = f"slides at atan(mu) = {slide:.1f} deg (mu = {mu:g}) or tips at {tip_deg:.1f} deg"
    rated = spec.rated_side_slope_deg
    if rated is not None and rated > expected + 2.0:
        note += (f"; the sheet's {rated:g} deg needs mu >= {math.tan(math.radians(rated)):.2f}" if slide < tip_deg
                 else f"; the sheet's {rated:g} deg is past this model's tip angle")
    elif rated is not None:
        note += f"; the sheet's {rated:g} deg is within this model's limit"
    return dataclasses.replace(abs_row("side slope held, parked", angle, expected, "deg", 2.0, note), sheet=rated)


def _stability(tip_deg: float, mu: float) -> CheckResult:
    """A ground vehicle at rest on a side slope should slide before it rolls over: its geometric tip
    angle must exceed the grip angle atan(mu). A top-heavy model (centre of mass high over a narrow
    track) fails here."""
    slide = math.degrees(math.atan(mu))
    return CheckResult("static stability: tip angle over slide angle", tip_deg, slide, "deg", tip_deg > slide,
                       "tip angle above atan(mu)",
                       f"rolls over at {tip_deg:.1f} deg, slides at atan(mu) = {slide:.1f} deg (mu = {mu:g})")


def climb_limit_deg(mass_kg: float, com_height_m: float, half_wheelbase_m: float, wheels_per_axle: int,
                    wheel_radius_m: float, torque_nm: float, mu: float, g: float = 9.81,
                    driven: tuple[bool, bool] = (True, True)) -> float:
    """Steepest grade a rigid two-axle vehicle climbs at constant speed, degrees (quasi-static).

    On a grade ``theta`` the axle loads are ``m g (cos(theta) / 2 -+ sin(theta) h / (2 a))`` (front,
    rear; ``h`` the centre-of-mass height, ``a`` half the wheelbase, the centre of mass midway), and
    each axle pushes at most ``min(mu N_axle, n tau / r)``: its grip or its motors' torque. The
    grade is the largest ``theta`` at which the two together still match ``m g sin(theta)``, and at
    most the pitch-over angle ``atan(a / h)``, where the front axle's load reaches zero and the
    vehicle would turn over backwards about the rear axle. ``driven``: whether the (front, rear)
    axle has motors (a rear-wheel-drive car's front axle pushes nothing).
    """

    def margin(theta: float) -> float:
        c, s = math.cos(theta), math.sin(theta)
        shift = s * com_height_m / (2.0 * half_wheelbase_m)
        push = sum(min(mu * mass_kg * g * max(0.0, 0.5 * c + sign * shift),
                       wheels_per_axle * torque_nm / wheel_radius_m)
                   for sign, on in zip((-1.0, 1.0), driven, strict=True) if on)
        return push - mass_kg * g * s

    lo, hi = 0.0, 0.5 * math.pi
    if com_height_m > 0.0:
        hi = math.atan(half_wheelbase_m / com_height_m)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if margin(mid) >= 0.0 else (lo, mid)
    return math.degrees(lo)


def _climb(world: TrialWorld, com_height_m: float) -> CheckResult:
    """``com_height_m``: the centre of mass over the ground of the settled vehicle (a failed climb
    may leave the vehicle on its back)."""
    spec = world.spec
    grade = bisect_threshold(lambda a: climbs_grade(world, a), 0.0, 60.0, 0.5)
    mu = spec.wheel_friction * world.sim.terrain_friction
    half_base = 0.5 * world.geometry.wheelbase_m
    per_axle = len(spec.wheel_joints) // 2
    xs = [c[0] for c in world.geometry.wheel_centres_m]
    mid = 0.5 * (max(xs) + min(xs))
    driven = tuple(any(spec.is_driven(n) and (x > mid) == front for n, x in zip(spec.wheel_joints, xs, strict=True))
                   for front in (True, False))
    expected = climb_limit_deg(world.geometry.mass_kg, com_height_m, half_base, per_axle, spec.wheel_radius_m,
                               spec.wheel_torque_limit_nm, mu, world.sim.gravity_m_s2, driven)
    grip = math.degrees(math.atan(mu))
    note = (f"quasi-static limit with load transfer to the rear axle, per-axle grip (mu = {mu:g}) and motor "
            f"torque ({spec.wheel_torque_limit_nm:g} N m per wheel); grip alone: {grip:.1f} deg")
    rated = spec.rated_climb_grade_deg
    if rated is not None and rated > expected + 3.0:
        if expected >= grip - 0.1:
            note += (f"; the sheet's {rated:g} deg assumes more grip: it needs mu >= "
                     f"{math.tan(math.radians(rated)):.2f}")
        else:
            note += (f"; the sheet's {rated:g} deg is past this model's limit (load transfer unloads the front "
                     "tyres and the rear motors reach their torque limit)")
    elif rated is not None:
        note += f"; the sheet's {rated:g} deg is within this model's limit"
    return dataclasses.replace(abs_row("steepest grade climbed from rest", grade, expected, "deg", 4.0, note),
                               sheet=rated)


def _step_world(height_m: float, spec: VehicleSpec) -> Heightmap:
    length = 8.0
    width = max(2.0, 4.0 * spec.track_m)
    x = np.arange(int(round(length / STEP_CELL_M)) + 1) * STEP_CELL_M
    z = np.where(x >= 4.0, height_m, 0.0)
    return Heightmap(np.tile(z, (int(round(width / STEP_CELL_M)) + 1, 1)), STEP_CELL_M)


def _climbs_step(spec: VehicleSpec, sim: SimConfig, height_m: float, speed_m_s: float | None = None) -> bool:
    """Whether the vehicle, driven straight at ``speed_m_s`` (None: cruise, 1 m/s or its top speed)
    from 1.5 m before it, gets over a step of ``height_m`` (its body reaches 1.5 m past the edge)
    on its wheels: one turned past 90 deg (its body's up axis pointing below the horizon, on its
    side or roof) has not, and the attempt ends there."""
    hm = _step_world(height_m, spec)
    with open_world(hm, spec, sim) as world:
        world.spawn(2.5, hm.height_m / 2.0, 0.0)
        v = min(1.0, spec.max_speed_m_s) if speed_m_s is None else speed_m_s
        drive_twist(world, v, 0.0)
        # 10 s, or twice the time the 3 m to the finish take at cruise speed for a slower vehicle
        for _ in range(int(round(max(10.0, 6.0 / v) * sim.physics_rate_hz))):
            world.step()
            pos, (qx, qy, _, _), _, _ = world.base_state()
            if pos[0] > 5.5:
                return True
            if 1.0 - 2.0 * (qx * qx + qy * qy) < 0.0:  # the body's up axis, world z (quaternion xyzw)
                return False
    return False


def step_bound_m(wheel_radius_m: float, belly_m: float, wheelbase_m: float, overhang: bool) -> float:
    """Highest step a rigid 4-wheeler can climb by geometry alone, metres.

    A wheel rolls onto a step no higher than its radius. If the chassis reaches further forward
    than the front tyres, its nose strikes any step higher than the belly first. Otherwise the
    front wheels climb and tilt the chassis, and the belly crosses the edge: with the rear wheel on
    the ground and the front one on the step, the belly above the edge, ``d`` ahead of the rear
    axle, is ``belly + h d / L`` high; the edge gets closest to the rear axle when the rear wheel
    touches it, ``d = sqrt(2 r h - h^2)``. The bound is the highest ``h <= r`` the belly clears.
    """
    if overhang:
        return min(wheel_radius_m, belly_m)

    def clears(h: float) -> bool:
        d = math.sqrt(max(0.0, 2.0 * wheel_radius_m * h - h * h))
        return belly_m + h * d / wheelbase_m >= h

    return bisect_threshold(clears, 0.0, wheel_radius_m, 1e-4)


#: the approach speed of a belt-driven track's step row, m/s: its kinetic energy lifts the centre of
#: mass by v^2 / (2 g) = 0.5 mm, so the climb is the quasi-static one :func:`track_step_bound_m` bounds
TRACK_STEP_SPEED_M_S = 0.1


def _track_step(world_geometry, spec: VehicleSpec, sim: SimConfig) -> tuple[float, str]:
    """(expected step m, note) of a belt-driven track (:func:`track_step_bound_m`)."""
    xs = [c[0] for c in world_geometry.wheel_centres_m]
    rear, front = min(xs), max(xs)
    share = (0.0 - rear) / (front - rear)  # the centre of mass at the body frame's x (0)
    mu = spec.wheel_friction * sim.terrain_friction
    torque = len(spec.wheel_joints) * spec.wheel_torque_limit_nm / (spec.wheel_radius_m * world_geometry.mass_kg
                                                                      * sim.for_terrain().gravity_m_s2)
    expected = track_step_bound_m(spec.wheel_radius_m, mu, share, STEP_CELL_M, torque)
    why = (f"belt-driven track, approached at {TRACK_STEP_SPEED_M_S:g} m/s (quasi-static): the front road wheel "
           f"climbs by geometry to its centre, above it by the belt's friction (mu = {mu:g}) on the step's face "
           f"(one {STEP_CELL_M:g} m cell), the hull pivoting on its rear road wheel ({share:.2f} of the weight on "
           "the front)")
    return expected, why


def _step(spec: VehicleSpec, sim: SimConfig, belly_m: float, wheelbase_m: float, overhang: bool,
          geometry=None) -> CheckResult:
    lo, hi = 0.6, 1.05
    speed = None
    name = "highest step climbed at cruise speed"
    if spec.belt_drive and geometry is not None:
        expected, why = _track_step(geometry, spec, sim)
        speed = TRACK_STEP_SPEED_M_S
        name = f"highest step climbed at {speed:g} m/s"
    elif spec.steering == "rocker_bogie":
        # the middle and rear wheels push the front wheel up the step face: a rocker-bogie climbs about
        # a wheel diameter (Bickler 1998, "Roving over Mars"; Lindemann and Voorhees 2005); "about": 0.75-1.25x
        expected = 2.0 * spec.wheel_radius_m
        why = "the middle and rear wheels push the front one up the face: about a wheel diameter (Bickler 1998)"
        lo, hi = 0.75, 1.25
    else:
        expected = step_bound_m(spec.wheel_radius_m, belly_m, wheelbase_m, overhang)
        why = ("the chassis nose reaches past the tyres and strikes a step higher than the belly" if overhang
               else "the tilted belly must clear the step edge between the axles")
    top = 1.2 * max(spec.wheel_radius_m, expected)
    height = bisect_threshold(lambda h: _climbs_step(spec, sim, h, speed), 0.0, top, 0.01)
    kind = "geometric" if speed is None else "quasi-static"
    note = f"{kind} bound (wheel radius {spec.wheel_radius_m:g} m, belly {belly_m:.3f} m): {why}"
    if spec.rated_step_m is not None:
        note += f"; the sheet's {spec.rated_step_m:g} m is set beside it"
    return dataclasses.replace(ratio_row(name, height, expected, "m", lo, hi, note), sheet=spec.rated_step_m)


def check_vehicle(
    vehicle: VehicleSpec | str,
    sim: SimConfig = SimConfig(),
    *,
    headings_deg: Sequence[float] = HEADINGS_DEG,
    yaw_commands_rad_s: Sequence[float] = YAW_COMMANDS_RAD_S,
    progress: ProgressFn | None = None,
) -> list[CheckResult]:
    """Measure the vehicle on small test worlds; one :class:`CheckResult` per figure (module docstring)."""
    spec = vehicle if isinstance(vehicle, VehicleSpec) else load_vehicle(vehicle)
    quick = dataclasses.replace(sim, settle_time_s=min(sim.settle_time_s, 0.5))
    flat = Heightmap.flat(161, 161, FLAT_CELL_M)
    rows: list[CheckResult] = []
    total = 7
    tip_row, tip_deg, com_h = _tip_angle(spec, quick, flat)
    report(progress, 1, total)
    with open_world(flat, spec, quick) as world:
        rows += _yaw_tracking(world, headings_deg, yaw_commands_rad_s)
        report(progress, 2, total)
        rows.append(_drift(world))
        rows.append(_stopping(world))
        report(progress, 3, total)
        rows.append(tip_row)
        rows.append(_stability(tip_deg, spec.wheel_friction * quick.terrain_friction))
        rows.append(_side_slope(world, tip_deg))
        rows.append(_climb(world, com_h))
        report(progress, 4, total)
        geo = world.geometry
    report(progress, 5, total)
    rows.append(_step(spec, quick, geo.belly_m, geo.wheelbase_m, geo.overhang, geo))
    report(progress, 6, total)
    if "terramechanics" in engine_capabilities(sim.engine).tyre_models:  # the soft-soil rows need that tyre model
        rows += soft_soil_checks(spec, sim)
    report(progress, 7, total)
    return rows


