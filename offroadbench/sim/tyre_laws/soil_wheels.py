"""The ``terramechanics`` tyre model's per-wheel contact, engine-neutral: soft-soil wheel forces from a
wheel's pose and velocities, every physics step.

An engine's adapter (offroadbench.sim.engines.pybullet.soil for PyBullet,
offroadbench.sim.engines.mujoco.world for MuJoCo) switches its own wheel-terrain contact off, reads each
wheel's centre, axle and velocities, asks :meth:`SoilWheels.wheel_force` for the force and torque,
and applies them at the wheel centre; the chassis keeps the engine's contact, so belly strikes stay
real. The force law, with the states of the last step (explicit, like the ``coulomb`` model's
:class:`~offroadbench.sim.tyre_laws.coulomb.CoulombBristles`):

1. **Ground under the wheel.** The terrain surface is the heightmap's bilinear patch (heights and
   slopes from the four samples around a point; an engine's two triangles per cell differ from it
   by the cell's twist, millimetres on rough maps). Its plane is taken under the wheel centre, the
   wheel's lowest rim point towards that plane is found (the rim is a circle about the axle, so a
   rolled wheel touches with the rim's lowest point, not the centre's foot), and the plane is taken
   again under that point.
2. **Penetration** ``delta`` of the rim into that plane (along its normal): the soil sinkage plus
   the series spring (offroadbench.sim.tyre_laws.terramechanics, "Tables").
3. **Slip.** In the plane, with ``e_f = axle x n`` the rolling direction: the wheel centre's speed
   ``V`` along it, ``U = r omega`` of the wheel's spin about its axle, and the lateral speed
   ``V_y``. The longitudinal and lateral slips are the states of a first-order relaxation (the
   tyre's relaxation length, Pacejka's transient slip) whose steady states are Wong's slip
   ``s = (U - V) / max(|U|, |V|)`` and the lateral slip ratio ``lambda = |V_y| / max(|U|, |V|)``.
   At rest they become springs of the slip displacement, so a parked wheel holds on a slope
   without creeping; while driving they follow the slip within a relaxation length. The length is
   the soil's K, lengthened where needed so that the slip spring stays inside the explicit step's
   stability bound (``k dt^2 / m < 1/4`` for a wheel's share of the mass; :func:`soil_setup`).
4. **Forces** from the tables (mirrored for reverse motion): normal load ``F_z`` along the normal
   (plus a damping term on the penetration rate, the soil being plastic), drawbar pull ``F_x``
   along ``e_f``, lateral force ``F_y`` against the lateral slip, all at the wheel centre, and the
   resistance torque ``T`` about the axle against the spin. The compaction resistance (the drawbar
   pull at zero slip, negative) is faded in over the first ``v0`` of the wheel's travel speed, so a
   wheel at rest (or spinning in place) is not pushed backwards.

Per-step arithmetic is scalar Python ``math`` (no numpy), in a fixed order (the same bits on every
x86-64 CPU; README, "Reproducibility").
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim.tyre_laws.terramechanics import MAX_SINKAGE_FRACTION, SoilTables, build_tables, load_soil
from offroadbench.sim.tyre_laws.track_patch import (SegmentTable, TrackPatch, compaction_resistance_n, segment_table,
                                                    shear_development)

__all__ = ["MAX_LATERAL_SLIP", "RESISTANCE_FADE_M_S", "SoilSetup", "SoilWheels", "belt_segment", "soil_setup"]

#: speed over which the compaction resistance fades in, m/s
RESISTANCE_FADE_M_S = 0.05
#: largest lateral slip ratio the state may reach (the force is saturated long before)
MAX_LATERAL_SLIP = 50.0


@dataclass(frozen=True, eq=False)
class SoilSetup:
    """What the soil contact of one vehicle needs, built once per world (:func:`soil_setup`)."""

    tables: SoilTables
    """The wheel's force tables on the soil."""
    share_kg: float
    """One wheel's share of the vehicle's mass, kg."""
    relaxation_m: float
    """Longitudinal slip relaxation length, m."""
    lateral_relaxation_m: float
    """Lateral slip relaxation length, m."""
    soil_map: object = None
    """A soil map (offroadbench.terrain.soil_map.SoilMap) whose index 0 is this setup's soil, or None."""
    map_soils: tuple = ()
    """For a soil map, (tables, relaxation m, lateral relaxation m) of each of its soils, index 0 first."""
    damping_mass_kg: float | None = None
    """The mass the penetration damping is sized for, kg: None, the wheel's share (``share_kg``); on
    a sprung vehicle its unsprung mass (:func:`soil_setup`)."""

    def wheels(self, n_wheels: int, hm: Heightmap, dt_s: float, step_dt_s: float | None = None) -> SoilWheels:
        """The per-wheel contact for ``n_wheels`` wheels on ``hm``, integrated at ``step_dt_s``
        (default ``dt_s``, the trial's step the setup was built for); penetration damping
        ``0.5 m / dt`` for the wheel's moving mass ``m`` (:attr:`damping_mass_kg`; as the Coulomb
        bristle's)."""
        m = self.share_kg if self.damping_mass_kg is None else self.damping_mass_kg
        return SoilWheels(n_wheels, hm, self.tables, dt_s if step_dt_s is None else step_dt_s, self.share_kg,
                          damping_n_s_m=0.5 * m / dt_s, relaxation_m=self.relaxation_m,
                          lateral_relaxation_m=self.lateral_relaxation_m, soil_map=self.soil_map,
                          map_soils=self.map_soils)


def _static_penetration(tables: SoilTables, load_n: float) -> float:
    """Penetration at which the tables carry ``load_n`` at zero slip, m (bisection)."""
    lo, hi = 0.0, tables.delta_max_m
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if tables.lookup(mid, 0.0)[1] < load_n:
            lo = mid
        else:
            hi = mid
    return hi


def soil_setup(spec, soil_name: str, mass_kg: float, n_wheels: int, gravity_m_s2: float, dt_s: float,
               soil_map=None) -> SoilSetup:
    """The soil contact's tables and constants for a vehicle of ``mass_kg`` on ``n_wheels`` wheels
    at the trial step ``dt_s`` (any engine).

    The series spring is the vehicle's tyre stiffness capped at ``m / dt^2`` for a wheel's share
    ``m`` of the mass (the explicit step's stability); the slip relaxation lengths are the soil's K
    and K_y, lengthened so that the slip spring ``(dF/ds) / length`` at the static load stays below
    ``0.25 m / dt^2``. With a ``soil_map`` (offroadbench.terrain.soil_map.SoilMap) every soil of the
    map gets its own tables and lengths, the same way; ``soil_name`` is then ignored for the map's
    default, its index 0.

    The penetration damping (:meth:`SoilSetup.wheels`) is sized for the mass that moves with the
    wheel: its share of the vehicle on a rigid one, but on a sprung vehicle (``suspension_joints``)
    the unsprung mass below a strut (offroadbench.sim.engines.base.unsprung_kg), which moves alone
    once its strut leaves the droop stop. Sized on the share, the HUNTER's (16.25 kg against its
    wheels' 3.5-4.5 kg: ``c dt / m`` = 2.3 on a rear wheel at 60 Hz, above the explicit step's bound
    of 2) made the wheels that left their stops chatter on lunar regolith (vertical speed
    0.08-0.11 m/s RMS) and the car rest on that diagonal pair (31-32 N against 20-21 N), which read
    -6.8 N of drawbar pull against -5.2 N in vehicle check (-5.8 N with this damping; MuJoCo, at
    120 Hz, did not chatter).
    """
    if soil_map is not None:
        parts = [_one_soil(spec, name, mass_kg, n_wheels, gravity_m_s2, dt_s) for name in soil_map.soils]
        first = parts[0]
        setup = dataclasses.replace(first, soil_map=soil_map,
                                    map_soils=tuple((p.tables, p.relaxation_m, p.lateral_relaxation_m) for p in parts))
    else:
        setup = _one_soil(spec, soil_name, mass_kg, n_wheels, gravity_m_s2, dt_s)
    if getattr(spec, "suspension_joints", ()):
        from offroadbench.sim.engines.base import unsprung_kg

        unsprung = unsprung_kg(spec.urdf, spec.suspension_joints)
        setup = dataclasses.replace(setup, damping_mass_kg=min(setup.share_kg, unsprung))
    return setup


def _one_soil(spec, soil_name: str, mass_kg: float, n_wheels: int, gravity_m_s2: float, dt_s: float) -> SoilSetup:
    """:func:`soil_setup` for one soil everywhere."""
    if spec.wheel_width_m is None:
        raise InputError(f"vehicle {spec.name!r} has no wheel_width_m; the terramechanics tyre model needs it")
    soil = load_soil(soil_name)
    share = mass_kg / n_wheels
    dt = dt_s
    k_cap = share / dt**2
    k_series = min(spec.tyre_stiffness_n_m or k_cap, k_cap)
    if getattr(spec, "track_contact_length_m", None) is not None:
        return _belt_setup(spec, soil, share, n_wheels, gravity_m_s2, dt, k_series)
    tables = build_tables(soil, spec.wheel_radius_m, spec.wheel_width_m, k_series)
    k_stab = 0.25 * share / dt**2
    delta = _static_penetration(tables, share * gravity_m_s2)
    ds = 2.0 / (tables.n_slip - 1)
    slope_x = max(abs(tables.lookup(delta, -1.0 + (j + 1) * ds)[2] - tables.lookup(delta, -1.0 + j * ds)[2]) / ds
                  for j in range(tables.n_slip - 1))
    slope_y = tables.lateral(delta, 0.0, 0.01) / 0.01
    return SoilSetup(tables=tables, share_kg=share, relaxation_m=max(soil.shear_modulus_m, slope_x / k_stab),
                     lateral_relaxation_m=max(soil.lateral_shear_modulus_m, slope_y / k_stab))


def belt_segment(table: SegmentTable, delta: float, s_m: float, lam: float, direction: float, fade: float,
                  radius_m: float) -> tuple[float, float, float, float, float]:
    """(sinkage m, normal N, pull along the rolling direction N, resistance torque N m, side force
    magnitude N) of a belt segment at penetration ``delta``, signed slip ``s_m`` (in the direction of
    motion) and lateral slip ratio ``lam`` (offroadbench.sim.tyre_laws.track_patch); the compaction
    resistance fades in over the first ``RESISTANCE_FADE_M_S`` of speed, as a wheel's."""
    soil, patch = table.soil, table.patch
    sink, f_n = table.lookup(delta)
    strength = patch.width_m * patch.segment_length_m * soil.cohesion_pa + f_n * math.tan(
        math.radians(soil.friction_angle_deg))
    thrust = math.copysign(strength * shear_development(s_m * patch.contact_length_m / soil.shear_modulus_m), s_m)
    resistance = compaction_resistance_n(soil, patch.width_m, sink) / patch.segments
    f_x = direction * (thrust - (1.0 - fade) * resistance)
    torque = direction * radius_m * thrust
    f_y = strength * shear_development(lam * patch.contact_length_m / soil.lateral_shear_modulus_m)
    return sink, f_n, f_x, torque, f_y


def _belt_setup(spec, soil, share: float, n_wheels: int, gravity_m_s2: float, dt: float, k_series: float) -> SoilSetup:
    """:func:`soil_setup` for a tracked vehicle's belts: each road wheel a segment of its side's belt
    (``n_wheels / 2`` a side), its table capped at the wheels' sinkage cap; the relaxation lengths as a
    wheel's, from the segment's thrust and side-force slopes at the static load."""
    patch = TrackPatch(contact_length_m=spec.track_contact_length_m, width_m=spec.wheel_width_m,
                       segments=max(1, n_wheels // 2))
    table = segment_table(soil, patch, spec.wheel_radius_m, k_series, MAX_SINKAGE_FRACTION * spec.wheel_radius_m)
    k_stab = 0.25 * share / dt**2
    strength = patch.width_m * patch.segment_length_m * soil.cohesion_pa + share * gravity_m_s2 * math.tan(
        math.radians(soil.friction_angle_deg))
    # the steepest slope of the thrust against slip is at slip 0: strength x d g(iL/K) / di = strength L / (2 K)
    slope_x = strength * patch.contact_length_m / (2.0 * soil.shear_modulus_m)
    slope_y = strength * patch.contact_length_m / (2.0 * soil.lateral_shear_modulus_m)
    return SoilSetup(tables=table, share_kg=share, relaxation_m=max(soil.shear_modulus_m, slope_x / k_stab),
                     lateral_relaxation_m=max(soil.lateral_shear_modulus_m, slope_y / k_stab))


class SoilWheels:
    """Wong-Reece soil forces on ``n_wheels`` wheels (module docstring). ``share_kg`` is one wheel's
    share of the vehicle's mass; ``damping_n_s_m`` damps the penetration rate; ``dt_s`` is the step
    the slip states are integrated at. With a ``soil_map`` (offroadbench.terrain.soil_map.SoilMap),
    each wheel takes, every step, the tables and relaxation lengths (``map_soils``, by the map's
    index) of the soil at the map sample nearest its contact point (the rim's lowest point)."""

    def __init__(self, n_wheels: int, hm: Heightmap, tables: SoilTables, dt_s: float, share_kg: float,
                 damping_n_s_m: float, relaxation_m: float, lateral_relaxation_m: float, soil_map=None,
                 map_soils: tuple = ()) -> None:
        self.n = n_wheels
        self._z = hm.z
        self._cell = hm.cell_size_m
        self._rows, self._cols = hm.rows, hm.cols
        self.tables = tables
        self._r = tables.radius_m
        self._dt = dt_s
        self._share = share_kg
        self._c = damping_n_s_m
        self._sx = relaxation_m
        self._sy = lateral_relaxation_m
        self._state: list[list[float] | None] = [None] * n_wheels
        #: per wheel in contact in the last step: (sinkage m, slip in the direction of motion, penetration m)
        self.last: dict[int, tuple[float, float, float]] = {}
        self._map = soil_map
        if soil_map is not None and len(map_soils) != len(soil_map.soils):
            raise InputError(f"soil map of {len(soil_map.soils)} soils given tables for {len(map_soils)}")
        self._soils = tuple(map_soils) if soil_map is not None else ((tables, relaxation_m, lateral_relaxation_m),)
        #: per wheel in contact in the last step: the index of its soil (0 without a soil map)
        self.last_soil: dict[int, int] = {}

    def reset(self) -> None:
        """Forget the slip states (after the vehicle is teleported)."""
        self._state = [None] * self.n
        self.last = {}
        self.last_soil = {}

    def begin(self) -> None:
        """Start a step: forget the last step's contacts (:attr:`last`)."""
        self.last = {}
        self.last_soil = {}

    def outside_model(self) -> bool:
        """True when a wheel in contact in the last step bottomed out: its penetration passed the
        tables' top (:meth:`~offroadbench.sim.tyre_laws.terramechanics.SoilTables.outside`), where the
        soil's sinkage cap is reached and the series spring alone carries it."""
        return any(self._soils[self.last_soil.get(i, 0)][0].outside(v[2]) for i, v in self.last.items())

    # ---------------------------------------------------------------- geometry
    def _surface(self, x: float, y: float):
        """(height, dz/dx, dz/dy) of the bilinear surface at (x, y), or None off the map."""
        u, v = x / self._cell, y / self._cell
        if not (0.0 <= u <= self._cols - 1 and 0.0 <= v <= self._rows - 1):
            return None
        c0 = min(int(u), self._cols - 2)
        r0 = min(int(v), self._rows - 2)
        fx, fy = u - c0, v - r0
        z = self._z
        z00, z01 = z.item(r0, c0), z.item(r0, c0 + 1)
        z10, z11 = z.item(r0 + 1, c0), z.item(r0 + 1, c0 + 1)
        h = (z00 * (1.0 - fx) + z01 * fx) * (1.0 - fy) + (z10 * (1.0 - fx) + z11 * fx) * fy
        gx = ((z01 - z00) * (1.0 - fy) + (z11 - z10) * fy) / self._cell
        gy = ((z10 - z00) * (1.0 - fx) + (z11 - z01) * fx) / self._cell
        return h, gx, gy

    def _contact(self, cx: float, cy: float, cz: float, ax: float, ay: float, az: float):
        """(penetration, normal, rim point) of the wheel against the surface, or None (off the map)."""
        qx, qy = cx, cy
        for _ in range(2):
            surf = self._surface(qx, qy)
            if surf is None:
                return None
            h, gx, gy = surf
            ex, ey = qx, qy  # the plane below passes through (ex, ey, h)
            norm = math.sqrt(gx * gx + gy * gy + 1.0)
            nx, ny, nz = -gx / norm, -gy / norm, 1.0 / norm
            na = nx * ax + ny * ay + nz * az
            px, py, pz = nx - na * ax, ny - na * ay, nz - na * az  # normal's part in the wheel plane
            pn = math.sqrt(px * px + py * py + pz * pz)
            if pn < 1e-6:  # wheel lying flat on the ground: no rolling contact
                return None
            rx, ry, rz = cx - self._r * px / pn, cy - self._r * py / pn, cz - self._r * pz / pn
            qx, qy = rx, ry
        # distance of the rim point below the plane
        depth = -((rx - ex) * nx + (ry - ey) * ny + (rz - h) * nz)
        return depth, (nx, ny, nz), (rx, ry, rz)

    # ---------------------------------------------------------------- forces
    def wheel_force(self, i: int, centre: tuple, axle: tuple, lin: tuple, ang: tuple):
        """(force x, y, z N; torque x, y, z N m), world frame, on wheel ``i`` whose centre is at
        ``centre`` with unit axle ``axle``, linear velocity ``lin`` and angular velocity ``ang``
        (world frame), both acting at the wheel centre; None where the wheel does not touch the
        soil. Updates the wheel's slip state and :attr:`last`."""
        cx, cy, cz = centre
        ax, ay, az = axle
        hit = self._contact(cx, cy, cz, ax, ay, az)
        if hit is None or hit[0] <= 0.0:
            self._state[i] = None
            return None
        delta, (nx, ny, nz), rim = hit
        k = 0 if self._map is None else self._map.soil_index_at(rim[0], rim[1])
        tables, sx, sy = self._soils[k]
        vx, vy, vz = lin
        wx, wy, wz = ang
        # rolling direction e_f = axle x n, lateral e_l = n x e_f
        fx_, fy_, fz_ = ay * nz - az * ny, az * nx - ax * nz, ax * ny - ay * nx
        fn = math.sqrt(fx_ * fx_ + fy_ * fy_ + fz_ * fz_)
        fx_, fy_, fz_ = fx_ / fn, fy_ / fn, fz_ / fn
        lx, ly, lz = ny * fz_ - nz * fy_, nz * fx_ - nx * fz_, nx * fy_ - ny * fx_
        v_f = vx * fx_ + vy * fy_ + vz * fz_
        v_l = vx * lx + vy * ly + vz * lz
        v_n = vx * nx + vy * ny + vz * nz
        u_roll = self._r * (wx * ax + wy * ay + wz * az)
        vref = max(abs(u_roll), abs(v_f))
        dt = self._dt
        state = self._state[i]
        if state is None:
            state = [0.0, 0.0]
        # implicit relaxation of the slip displacements (module docstring, 3)
        ux = (state[0] + dt * (u_roll - v_f)) / (1.0 + dt * vref / sx)
        ux = min(sx, max(-sx, ux))
        uy = (state[1] - dt * v_l) / (1.0 + dt * vref / sy)
        uy = min(MAX_LATERAL_SLIP * sy, max(-MAX_LATERAL_SLIP * sy, uy))
        self._state[i] = [ux, uy]
        slip = ux / sx
        lam = abs(uy) / sy
        direction = 1.0 if (u_roll if abs(u_roll) >= abs(v_f) else v_f) >= 0.0 else -1.0
        s_m = direction * slip
        fade = 1.0 - min(1.0, abs(v_f) / RESISTANCE_FADE_M_S)
        if isinstance(tables, SegmentTable):  # a track's belt segment (offroadbench.sim.tyre_laws.track_patch)
            sink, f_n, f_x, torque, f_y = belt_segment(tables, delta, s_m, lam, direction, fade, self._r)
        else:
            sink, f_n, f_x, torque = tables.lookup(delta, s_m)
            _, _, f_x0, torque0 = tables.lookup(delta, 0.0)
            f_x = direction * (f_x - fade * f_x0)
            torque = direction * (torque - fade * torque0)
            f_y = tables.lateral(delta, s_m, lam)
        if uy < 0.0:
            f_y = -f_y
        f_n = max(0.0, f_n - self._c * v_n)
        self.last[i] = (sink, s_m, delta)
        self.last_soil[i] = k
        return ([f_n * nx + f_x * fx_ + f_y * lx, f_n * ny + f_x * fy_ + f_y * ly, f_n * nz + f_x * fz_ + f_y * lz],
                [-torque * ax, -torque * ay, -torque * az])
