"""The ``terramechanics`` tyre model: soft-soil wheel forces applied to the wheels every physics step.

Bullet's wheel-terrain contact is switched off (a collision filter per wheel and terrain tile);
the chassis keeps its contact, so belly strikes stay real. Each step, before ``stepSimulation``,
:class:`SoilTyres` does for every wheel, with the states of the last step (explicit, like
:class:`offroadbench.sim.engines.pybullet.tyres.CoulombTyres`):

1. **Ground under the wheel.** The terrain surface is the heightmap's bilinear patch (heights and
   slopes from the four samples around a point; Bullet's two triangles per cell differ from it by
   the cell's twist, millimetres on rough maps). Its plane is taken under the wheel centre, the
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
   stability bound (``k dt^2 / m < 1/4`` for a wheel's share of the mass).
4. **Forces** from the tables (mirrored for reverse motion): normal load ``F_z`` along the normal
   (plus a damping term on the penetration rate, the soil being plastic), drawbar pull ``F_x``
   along ``e_f``, lateral force ``F_y`` against the lateral slip, all at the wheel centre, and the
   resistance torque ``T`` about the axle against the spin. The compaction resistance (the drawbar
   pull at zero slip, negative) is faded in over the first ``v0`` of the wheel's travel speed, so a
   wheel at rest (or spinning in place) is not pushed backwards.

Per-step arithmetic is scalar Python ``math`` (no numpy), in a fixed order.
"""

from __future__ import annotations

import math

import pybullet as pb

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim.tyre_laws.terramechanics import SoilTables, build_tables, load_soil

__all__ = ["SoilTyres", "make_soil_tyres"]

#: speed over which the compaction resistance fades in, m/s
RESISTANCE_FADE_M_S = 0.05
#: largest lateral slip ratio the state may reach (the force is saturated long before)
MAX_LATERAL_SLIP = 50.0


class SoilTyres:
    """Wong-Reece soil forces on the wheels (module docstring). ``share_kg`` is one wheel's share of
    the vehicle's mass; ``damping_n_s_m`` damps the penetration rate."""

    def __init__(self, cid: int, body: int, wheels: list[int], hm: Heightmap, tables: SoilTables, dt_s: float,
                 share_kg: float, damping_n_s_m: float, relaxation_m: float, lateral_relaxation_m: float) -> None:
        self._cid = cid
        self._body = body
        self._wheels = list(wheels)
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
        self._state: dict[int, list[float]] = {}
        #: per wheel in contact after the last apply: (sinkage m, slip in the direction of motion, penetration m)
        self.last: dict[int, tuple[float, float, float]] = {}

    def reset(self) -> None:
        """Forget the slip states (after the vehicle is teleported)."""
        self._state.clear()
        self.last.clear()

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
    def apply(self) -> None:
        """Apply one step's soil forces and torques from the wheel states of the last step."""
        cid, body = self._cid, self._body
        states = pb.getLinkStates(body, self._wheels, computeLinkVelocity=1, computeForwardKinematics=1,
                                 physicsClientId=cid)
        tables = self.tables
        self.last = {}
        for link, st in zip(self._wheels, states):
            cx, cy, cz = st[4]
            qx, qy, qz, qw = st[5]
            # the wheel's axle: the link frame's y axis in the world
            ax, ay, az = 2.0 * (qx * qy - qw * qz), 1.0 - 2.0 * (qx * qx + qz * qz), 2.0 * (qy * qz + qw * qx)
            hit = self._contact(cx, cy, cz, ax, ay, az)
            if hit is None or hit[0] <= 0.0:
                self._state.pop(link, None)
                continue
            delta, (nx, ny, nz), _ = hit
            vx, vy, vz = st[6]
            wx, wy, wz = st[7]
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
            state = self._state.get(link)
            if state is None:
                state = [0.0, 0.0]
            # implicit relaxation of the slip displacements (module docstring, 3)
            ux = (state[0] + dt * (u_roll - v_f)) / (1.0 + dt * vref / self._sx)
            ux = min(self._sx, max(-self._sx, ux))
            uy = (state[1] - dt * v_l) / (1.0 + dt * vref / self._sy)
            uy = min(MAX_LATERAL_SLIP * self._sy, max(-MAX_LATERAL_SLIP * self._sy, uy))
            self._state[link] = [ux, uy]
            slip = ux / self._sx
            lam = abs(uy) / self._sy
            direction = 1.0 if (u_roll if abs(u_roll) >= abs(v_f) else v_f) >= 0.0 else -1.0
            s_m = direction * slip
            sink, f_n, f_x, torque = tables.lookup(delta, s_m)
            _, _, f_x0, torque0 = tables.lookup(delta, 0.0)
            fade = 1.0 - min(1.0, abs(v_f) / RESISTANCE_FADE_M_S)
            f_x = direction * (f_x - fade * f_x0)
            torque = direction * (torque - fade * torque0)
            f_y = tables.lateral(delta, s_m, lam)
            if uy < 0.0:
                f_y = -f_y
            f_n = max(0.0, f_n - self._c * v_n)
            force = [f_n * nx + f_x * fx_ + f_y * lx, f_n * ny + f_x * fy_ + f_y * ly, f_n * nz + f_x * fz_ + f_y * lz]
            pb.applyExternalForce(body, link, force, [cx, cy, cz], pb.WORLD_FRAME, physicsClientId=cid)
            pb.applyExternalTorque(body, link, [-torque * ax, -torque * ay, -torque * az], pb.WORLD_FRAME,
                                   physicsClientId=cid)
            self.last[link] = (sink, s_m, delta)


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


def make_soil_tyres(world, body: int) -> SoilTyres:
    """The soil tyres of a World's vehicle: its soil and wheel, Bullet's wheel-terrain collisions off
    (for this vehicle body; the tables are built once per World and kept on it).

    The series spring is the vehicle's tyre stiffness capped at ``m / dt^2`` for a wheel's share
    ``m`` of the mass (the explicit step's stability), the penetration damping ``0.5 m / dt`` (as
    the Coulomb bristle's); the slip relaxation lengths are the soil's K and K_y, lengthened so that
    the slip spring ``(dF/ds) / length`` at the static load stays below ``0.25 m / dt^2``.
    """
    spec, sim, cid = world.spec, world.sim, world.client_id
    dt = world.dt_s
    setup = getattr(world, "_soil_setup", None)
    if setup is None:  # once per World: the vehicle is reloaded for every mission, the soil is not
        if spec.wheel_width_m is None:
            raise InputError(f"vehicle {spec.name!r} has no wheel_width_m; the terramechanics tyre model needs it")
        soil = load_soil(sim.soil)
        n_links = pb.getNumJoints(body, physicsClientId=cid)
        mass = sum(pb.getDynamicsInfo(body, link, physicsClientId=cid)[0] for link in range(-1, n_links))
        share = mass / len(world.wheel_joints)
        k_cap = share / dt**2
        k_series = min(spec.tyre_stiffness_n_m or k_cap, k_cap)
        tables = build_tables(soil, spec.wheel_radius_m, spec.wheel_width_m, k_series)
        k_stab = 0.25 * share / dt**2
        delta = _static_penetration(tables, share * sim.gravity_m_s2)
        ds = 2.0 / (tables.n_slip - 1)
        slope_x = max(abs(tables.lookup(delta, -1.0 + (j + 1) * ds)[2] - tables.lookup(delta, -1.0 + j * ds)[2]) / ds
                      for j in range(tables.n_slip - 1))
        slope_y = tables.lateral(delta, 0.0, 0.01) / 0.01
        setup = (tables, share, max(soil.shear_modulus_m, slope_x / k_stab),
                 max(soil.lateral_shear_modulus_m, slope_y / k_stab))
        world._soil_setup = setup
    tables, share, relax_x, relax_y = setup
    for terrain in world.terrain_bodies:
        for j in world.wheel_joints:
            pb.setCollisionFilterPair(terrain, body, -1, j, 0, physicsClientId=cid)
    return SoilTyres(cid, body, world.wheel_joints, world.hm, tables, dt, share, damping_n_s_m=0.5 * share / dt,
                     relaxation_m=relax_x, lateral_relaxation_m=relax_y)
