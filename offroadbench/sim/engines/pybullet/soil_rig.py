"""The single-wheel soil rig on PyBullet (offroadbench.sim.rigs.soil_check describes the rig): a
carriage (x prismatic joint), a free vertical slide carrying the load (z prismatic joint) and the
wheel (revolute joint) of one multibody, the soil acting through the shared force law
(:class:`~offroadbench.sim.tyre_laws.soil_wheels.SoilWheels`, applied by
:class:`~offroadbench.sim.engines.pybullet.soil.SoilTyres`).
"""

from __future__ import annotations

from offroadbench.sim.engines.pybullet._pb import pb

from offroadbench.sim.engines.pybullet.soil import SoilTyres
from offroadbench.sim.tyre_laws.soil_wheels import SoilWheels

__all__ = ["run_rig"]


def _rig(cid: int, radius_m: float, load_kg: float) -> tuple[int, int, int]:
    """The rig body: fixed base, x carriage, z slide carrying ``load_kg``, wheel. (body, x, z joints)."""
    box = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.01, 0.01, 0.01], physicsClientId=cid)
    wheel = pb.createCollisionShape(pb.GEOM_SPHERE, radius=radius_m, physicsClientId=cid)
    body = pb.createMultiBody(
        baseMass=0.0, baseCollisionShapeIndex=-1, basePosition=[0.0, 0.0, radius_m + 0.002],
        linkMasses=[1.0, load_kg, 1e-3],
        linkCollisionShapeIndices=[box, box, wheel],
        linkVisualShapeIndices=[-1, -1, -1],
        linkPositions=[[0, 0, 0], [0, 0, 0], [0, 0, 0]],
        linkOrientations=[[0, 0, 0, 1]] * 3,
        linkInertialFramePositions=[[0, 0, 0]] * 3,
        linkInertialFrameOrientations=[[0, 0, 0, 1]] * 3,
        linkParentIndices=[0, 1, 2],
        linkJointTypes=[pb.JOINT_PRISMATIC, pb.JOINT_PRISMATIC, pb.JOINT_REVOLUTE],
        linkJointAxis=[[1, 0, 0], [0, 0, 1], [0, 1, 0]],
        physicsClientId=cid,
    )
    for link in (-1, 0, 1, 2):
        pb.setCollisionFilterGroupMask(body, link, 0, 0, physicsClientId=cid)  # nothing collides: the soil carries it
        pb.changeDynamics(body, link, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
    pb.changeDynamics(body, 2, localInertiaDiagonal=[0.01, 0.05, 0.01], physicsClientId=cid)
    pb.setJointMotorControl2(body, 1, pb.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)  # the slide is free
    return body, 0, 1


def run_rig(core: SoilWheels, *, radius_m: float, load_kg: float, gravity_m_s2: float, carriage_m_s: float,
            wheel_rad_s: float, dt_s: float, steps: int) -> tuple[float, float, float]:
    """Drive the rig for ``steps`` steps of ``dt_s``: the carriage at ``carriage_m_s``, the wheel at
    ``wheel_rad_s``; (sinkage m, drawbar pull N, driving torque N m), each the mean over the last
    quarter of the steps."""
    cid = pb.connect(pb.DIRECT)
    try:
        pb.setGravity(0, 0, -gravity_m_s2, physicsClientId=cid)
        pb.setPhysicsEngineParameter(fixedTimeStep=dt_s, numSubSteps=0, numSolverIterations=50, physicsClientId=cid)
        pb.resetSimulation(physicsClientId=cid)
        pb.setGravity(0, 0, -gravity_m_s2, physicsClientId=cid)
        body, jx, _jz = _rig(cid, radius_m, load_kg)
        pb.resetBasePositionAndOrientation(body, [0.5, 0.1, radius_m + 0.002], [0, 0, 0, 1], physicsClientId=cid)
        tyres = SoilTyres(cid, body, [2], core)
        pb.setJointMotorControl2(body, jx, pb.VELOCITY_CONTROL, targetVelocity=carriage_m_s, force=1e5,
                                 physicsClientId=cid)
        pb.setJointMotorControl2(body, 2, pb.VELOCITY_CONTROL, targetVelocity=wheel_rad_s, force=1e5,
                                 physicsClientId=cid)
        acc = []
        for k in range(steps):
            tyres.apply()
            pb.stepSimulation(physicsClientId=cid)
            if k >= 3 * steps // 4:
                sink = tyres.last[2][0] if 2 in tyres.last else 0.0
                pull = -pb.getJointState(body, jx, physicsClientId=cid)[3]
                torque = pb.getJointState(body, 2, physicsClientId=cid)[3]
                acc.append((sink, pull, torque))
    finally:
        pb.disconnect(physicsClientId=cid)
    return tuple(sum(c) / len(c) for c in zip(*acc, strict=True))
