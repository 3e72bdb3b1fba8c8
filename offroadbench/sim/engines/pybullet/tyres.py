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
(offroadbench.sim.engines.pybullet.soil, offroadbench.sim.tyre_laws.terramechanics).
"""

from __future__ import annotations

from offroadbench.sim.engines.pybullet._pb import pb

from offroadbench.sim.tyre_laws.coulomb import CoulombBristles

__all__ = ["CoulombTyres"]


class CoulombTyres:
    """Coulomb tyre forces against the slip, applied before each PyBullet step (``coulomb`` model).

    ``mu`` is the tyre-terrain friction coefficient (the vehicle's wheel friction times the
    terrain's, as Bullet would combine them); ``stiffness_n_m`` and ``damping_n_s_m`` are the
    bristle's tangential stiffness and damping per contact; ``dt_s`` is the physics step. The
    force law is :class:`CoulombBristles`'.
    """

    def __init__(self, cid: int, body: int, terrain: frozenset[int], wheels: list[int], mu: float, dt_s: float,
                 stiffness_n_m: float, damping_n_s_m: float) -> None:
        self._cid = cid
        self._body = body
        self._terrain = terrain
        self._wheels = sorted(wheels)
        #: wheel link -> its slot in the bristles (fixed at construction)
        self._slot = {link: i for i, link in enumerate(self._wheels)}
        self.bristles = CoulombBristles(len(self._wheels), mu, dt_s, stiffness_n_m, damping_n_s_m)

    def reset(self) -> None:
        """Forget the bristle deflections (after the vehicle is teleported)."""
        self.bristles.reset()

    def apply(self) -> None:
        """Apply one step's friction forces from the contacts of the last step.

        Plain Python floats throughout (no numpy: a scalar numpy op costs more than the arithmetic,
        and its SIMD dispatch could differ between CPUs); the arithmetic, its order and so its
        results are those of the first implementation, bit for bit.
        """
        cid, body = self._cid, self._body
        contacts = pb.getContactPoints(bodyA=body, physicsClientId=cid)
        terrain, slot, core = self._terrain, self._slot, self.bristles
        core.clear()
        acc, touch = core.acc, core.touch
        # a sphere on a heightfield touches several triangles: sum each wheel's normal forces and
        # apply its friction at their force-weighted point, along their force-weighted normal
        any_touch = False
        for c in contacts:
            fn = c[9]
            if fn > 0.0 and c[2] in terrain:
                i = slot.get(c[3])
                if i is None:
                    continue
                touch[i] = any_touch = True
                p, n = c[5], c[7]
                b = 7 * i
                acc[b] += fn
                acc[b + 1] += fn * p[0]
                acc[b + 2] += fn * p[1]
                acc[b + 3] += fn * p[2]
                acc[b + 4] += fn * n[0]
                acc[b + 5] += fn * n[1]
                acc[b + 6] += fn * n[2]
        core.release_untouched()
        if not any_touch:
            return
        states = pb.getLinkStates(body, self._wheels, computeLinkVelocity=1, physicsClientId=cid)
        wheels = self._wheels
        for i in range(core.n):
            if touch[i]:
                st = states[i]
                fx, fy, fz, px, py, pz = core.wheel_force(i, st[0], st[6], st[7])
                pb.applyExternalForce(body, wheels[i], (fx, fy, fz), (px, py, pz), pb.WORLD_FRAME,
                                      physicsClientId=cid)
