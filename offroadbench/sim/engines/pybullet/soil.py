"""The ``terramechanics`` tyre model on PyBullet: the soil forces of
:class:`offroadbench.sim.tyre_laws.soil_wheels.SoilWheels` (the force law, shared with MuJoCo)
applied to the wheels before every physics step.

Bullet's wheel-terrain contact is switched off (a collision filter per wheel and terrain tile);
the chassis keeps its contact, so belly strikes stay real. Each step, before ``stepSimulation``,
:class:`SoilTyres` reads every wheel's link state of the last step (explicit, like
:class:`offroadbench.sim.engines.pybullet.tyres.CoulombTyres`), asks the force law for its force
and torque, and applies them at the wheel centre.
"""

from __future__ import annotations

from offroadbench.sim.engines.pybullet._pb import pb

from offroadbench.sim.tyre_laws.soil_wheels import SoilWheels, soil_setup

__all__ = ["SoilTyres", "make_soil_tyres"]


class SoilTyres:
    """The soil forces of ``core`` (one slot per link of ``wheels``, in that order) on a PyBullet body."""

    def __init__(self, cid: int, body: int, wheels: list[int], core: SoilWheels) -> None:
        self._cid = cid
        self._body = body
        self._wheels = list(wheels)
        self.core = core
        #: per wheel link in contact after the last apply: (sinkage m, slip in the direction of motion, penetration m)
        self.last: dict[int, tuple[float, float, float]] = {}

    def reset(self) -> None:
        """Forget the slip states (after the vehicle is teleported)."""
        self.core.reset()
        self.last = {}

    def apply(self) -> None:
        """Apply one step's soil forces and torques from the wheel states of the last step."""
        cid, body, core = self._cid, self._body, self.core
        states = pb.getLinkStates(body, self._wheels, computeLinkVelocity=1, computeForwardKinematics=1,
                                 physicsClientId=cid)
        core.begin()
        last = {}
        for i, (link, st) in enumerate(zip(self._wheels, states, strict=True)):
            qx, qy, qz, qw = st[5]
            # the wheel's axle: the link frame's y axis in the world
            axle = (2.0 * (qx * qy - qw * qz), 1.0 - 2.0 * (qx * qx + qz * qz), 2.0 * (qy * qz + qw * qx))
            out = core.wheel_force(i, st[4], axle, st[6], st[7])
            if out is None:
                continue
            force, torque = out
            pb.applyExternalForce(body, link, force, st[4], pb.WORLD_FRAME, physicsClientId=cid)
            pb.applyExternalTorque(body, link, torque, pb.WORLD_FRAME, physicsClientId=cid)
            last[link] = core.last[i]
        self.last = last


def make_soil_tyres(world, body: int, mass_kg: float) -> SoilTyres:
    """The soil tyres of a World's vehicle of ``mass_kg``: its soil and wheel, Bullet's wheel-terrain
    collisions off (for this vehicle body; the tables are built once per World and kept on it;
    offroadbench.sim.tyre_laws.soil_wheels.soil_setup)."""
    spec, sim, cid = world.spec, world.sim, world.client_id
    setup = getattr(world, "_soil_setup", None)
    if setup is None:  # once per World: the vehicle is reloaded for every mission, the soil is not
        setup = soil_setup(spec, sim.soil, mass_kg, len(world.wheel_joints), sim.gravity_m_s2, world.dt_s,
                           getattr(world, "soil_map", None))  # World.use_soil_map
        world._soil_setup = setup
    for terrain in world.terrain_bodies:
        for j in world.wheel_joints:
            pb.setCollisionFilterPair(terrain, body, -1, j, 0, physicsClientId=cid)
    return SoilTyres(cid, body, world.wheel_joints, setup.wheels(len(world.wheel_joints), world.hm, world.dt_s))
