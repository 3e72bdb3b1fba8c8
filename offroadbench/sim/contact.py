"""Tyre-terrain contact: how the wheels of a skid-steer vehicle push on the ground.

Why the contact needs care
--------------------------
A skid-steer vehicle turns by driving its two sides at different speeds; every tyre then slips,
sideways and along its rolling direction at once, and the ground's friction force on it points
against that slip (Coulomb: magnitude ``mu * N``, direction ``-slip / |slip|``). Summed over the
four tyres these forces give the yaw moment that turns the vehicle.

Bullet's multibody solver does not do that. It resolves a contact's friction along two tangent
directions fixed on the world axes and clips the friction impulse to the Coulomb limit along the
*impulse*, not the slip. For a light wheel (spin inertia 0.035 kg m^2, i.e. about 1.3 kg at the
tyre) the rolling-direction impulse needed to spin the wheel up is tiny, so the clipped force
ends up mostly sideways; the achieved turn rate then depends on the heading and repeats every
90 deg (a 2 rad/s turn in place gave 0.41 rad/s at headings along the world axes and 1.79 rad/s
at 45 deg; shared/DESIGN.md, "PyBullet facts measured later").

Two remedies, chosen with :attr:`offroadbench.sim.config.SimConfig.tyre_model`:

``bullet``
    Keep Bullet's friction, but give each wheel the spin inertia its drive train really has
    (``VehicleSpec.wheel_spin_inertia_kg_m2``: the tyre's own plus the reflected motor
    inertia, rotor inertia times the gear ratio squared). Applied with
    ``changeDynamics(localInertiaDiagonal=...)`` after loading. The heavier wheel makes the
    rolling-direction impulse comparable to the lateral one, so the clipped force points close
    to the slip at every heading. Limits: it is still Bullet's world-axis friction pyramid, so a
    small heading dependence remains; the extra spin inertia slows wheel spin-up (as a real
    gearbox does) and adds a gyroscopic roll torque in turns (``I_spin * omega_wheel * yaw rate``,
    about 6 N m at 6 rad/s wheel speed and 1 rad/s yaw rate: small against the vehicle's
    ``m g (track/2)`` of about 160 N m).

``coulomb``
    Bullet's wheel friction is switched off (lateral friction 0 on the wheel links) and the
    friction is applied by :class:`CoulombTyres` as external forces, once per physics step, at
    each wheel-terrain contact point. The force opposes the contact's slip velocity (the
    velocity of the wheel's material point at the contact, tangential part) with magnitude
    ``min(mu * N, |k d + c s|)``: a stiff bristle of stiffness ``k`` and damping ``c`` that
    stretches by the integrated slip ``d`` while the tyre sticks and saturates at the Coulomb
    limit when it slides (a Dahl-type stick-slip model, Dahl 1968). The bristle keeps a parked
    vehicle from creeping on a slope, which a pure velocity-regularised Coulomb law would let it
    do. ``N`` is the normal force Bullet reported for the contact in the previous step. The force
    direction follows the slip exactly, so the result is heading-independent by construction.
    Limits: the forces are explicit (one step behind the normal force and the velocities), so
    ``k`` and ``c`` must stay below the stability bound of the 60 Hz step for a wheel's share of
    the mass (``k dt^2 / m < 1``, ``c dt / m < 2``); there is no load sensitivity, rolling
    resistance or soil sinkage; it costs a contact query and a link-state query per step.

Both models keep Bullet's normal contact (with the vehicle's tyre stiffness and damping) and the
velocity-controlled, torque-limited wheel motors.

A third model, ``terramechanics``, puts the wheels on soft soil: Bullet's wheel-terrain contact is
switched off and Wong-Reece soil forces replace both the normal contact and the friction
(offroadbench.sim.soil_contact, offroadbench.sim.terramechanics).
"""

from __future__ import annotations

import math

import pybullet as pb

__all__ = ["CoulombTyres"]


class CoulombTyres:
    """Coulomb tyre forces against the slip, applied before each physics step (``coulomb`` model).

    ``mu`` is the tyre-terrain friction coefficient (the vehicle's wheel friction times the
    terrain's, as Bullet would combine them); ``stiffness_n_m`` and ``damping_n_s_m`` are the
    bristle's tangential stiffness and damping per contact; ``dt_s`` is the physics step.
    """

    def __init__(self, cid: int, body: int, terrain: frozenset[int], wheels: list[int], mu: float, dt_s: float,
                 stiffness_n_m: float, damping_n_s_m: float) -> None:
        self._cid = cid
        self._body = body
        self._terrain = terrain
        self._wheel_set = frozenset(wheels)
        self._mu = mu
        self._dt = dt_s
        self._k = stiffness_n_m
        self._c = damping_n_s_m
        self._bristle: dict[int, list[float]] = {}

    def reset(self) -> None:
        """Forget the bristle deflections (after the vehicle is teleported)."""
        self._bristle.clear()

    def apply(self) -> None:
        """Apply one step's friction forces from the contacts of the last step."""
        cid, body = self._cid, self._body
        contacts = pb.getContactPoints(bodyA=body, physicsClientId=cid)
        terrain = self._terrain
        # a sphere on a heightfield touches several triangles: sum each wheel's normal forces and
        # apply its friction at their force-weighted point, along their force-weighted normal
        by_wheel: dict[int, list[float]] = {}
        for c in contacts:
            fn = c[9]
            if fn > 0.0 and c[3] in self._wheel_set and c[2] in terrain:
                acc = by_wheel.setdefault(c[3], [0.0] * 7)
                p, n = c[5], c[7]
                acc[0] += fn
                acc[1] += fn * p[0]
                acc[2] += fn * p[1]
                acc[3] += fn * p[2]
                acc[4] += fn * n[0]
                acc[5] += fn * n[1]
                acc[6] += fn * n[2]
        if not by_wheel:
            self._bristle.clear()
            return
        links = sorted(by_wheel)
        states = pb.getLinkStates(body, links, computeLinkVelocity=1, physicsClientId=cid)
        for link, st in zip(links, states):
            fn, spx, spy, spz, snx, sny, snz = by_wheel[link]
            px, py, pz = spx / fn, spy / fn, spz / fn
            norm = math.sqrt(snx * snx + sny * sny + snz * snz)
            nx, ny, nz = snx / norm, sny / norm, snz / norm  # on the terrain, pointing at the wheel
            cx, cy, cz = st[0]
            vx, vy, vz = st[6]
            wx, wy, wz = st[7]
            rx, ry, rz = px - cx, py - cy, pz - cz
            # velocity of the wheel's material point at the contact: v + w x r
            ux = vx + wy * rz - wz * ry
            uy = vy + wz * rx - wx * rz
            uz = vz + wx * ry - wy * rx
            un = ux * nx + uy * ny + uz * nz
            sx, sy, sz = ux - un * nx, uy - un * ny, uz - un * nz  # tangential slip
            d = self._bristle.get(link)
            if d is None:
                d = [0.0, 0.0, 0.0]
            else:  # keep the stored deflection in the current tangent plane
                dn = d[0] * nx + d[1] * ny + d[2] * nz
                d = [d[0] - dn * nx, d[1] - dn * ny, d[2] - dn * nz]
            dt = self._dt
            d = [d[0] + sx * dt, d[1] + sy * dt, d[2] + sz * dt]
            k, cdamp = self._k, self._c
            fx, fy, fz = -(k * d[0] + cdamp * sx), -(k * d[1] + cdamp * sy), -(k * d[2] + cdamp * sz)
            f = math.sqrt(fx * fx + fy * fy + fz * fz)
            limit = self._mu * fn
            if f > limit:  # sliding: the Coulomb limit, and the bristle at its stretched length
                s = limit / f
                fx, fy, fz = fx * s, fy * s, fz * s
                d = [-fx / k, -fy / k, -fz / k]
            self._bristle[link] = d
            pb.applyExternalForce(body, link, [fx, fy, fz], [px, py, pz], pb.WORLD_FRAME, physicsClientId=cid)
        for link in list(self._bristle):
            if link not in by_wheel:
                del self._bristle[link]
