"""The single-wheel soil rig on PyBullet (offroadbench.sim.rigs.soil_check describes the rig): a
carriage (x prismatic joint), a free vertical slide carrying the load (z prismatic joint) and the
wheel (revolute joint) of one multibody on a flat heightmap, the soil acting through
:class:`~offroadbench.sim.engines.pybullet.soil.SoilTyres`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import pybullet as pb

from offroadbench.heightmap import Heightmap
from offroadbench.progress import ProgressFn, report
from offroadbench.sim.engines.pybullet.soil import SoilTyres
from offroadbench.sim.tyre_laws.terramechanics import SoilParams, build_tables

__all__ = ["rig_rows", "urdf_mass_kg"]


def urdf_mass_kg(urdf: str) -> float:
    """Total mass of a URDF's links as PyBullet loads them, kg."""
    cid = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(urdf, flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        mass = sum(pb.getDynamicsInfo(body, j, physicsClientId=cid)[0]
                   for j in range(-1, pb.getNumJoints(body, physicsClientId=cid)))
    finally:
        pb.disconnect(physicsClientId=cid)
    return mass


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


def rig_rows(soil: SoilParams, radius_m: float, width_m: float, load_n: float, *, gravity_m_s2: float,
             slips: Sequence[float], wheel_speed_m_s: float, physics_rate_hz: int, seconds: float,
             progress: ProgressFn | None = None) -> list[tuple[float, float, float]]:
    """(sinkage m, drawbar pull N, driving torque N m) at each slip, each the mean over the last
    quarter of ``seconds`` of driving (offroadbench.sim.rigs.soil_check.rig_curve)."""
    dt = 1.0 / physics_rate_hz
    load_kg = load_n / gravity_m_s2
    length_m = wheel_speed_m_s * seconds + 2.0
    hm = Heightmap.flat(5, math.ceil(length_m / 0.05) + 1, 0.05)
    k_series = load_kg / dt**2  # as SoilTyres' cap for a wheel's share of the mass
    tables = build_tables(soil, radius_m, width_m, k_series)
    rows = []
    cid = pb.connect(pb.DIRECT)
    try:
        pb.setGravity(0, 0, -gravity_m_s2, physicsClientId=cid)
        pb.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0, numSolverIterations=50, physicsClientId=cid)
        for i, s in enumerate(slips):
            pb.resetSimulation(physicsClientId=cid)
            pb.setGravity(0, 0, -gravity_m_s2, physicsClientId=cid)
            body, jx, _jz = _rig(cid, radius_m, load_kg)
            pb.resetBasePositionAndOrientation(body, [0.5, 0.1, radius_m + 0.002], [0, 0, 0, 1], physicsClientId=cid)
            tyres = SoilTyres(cid, body, [2], hm, tables, dt, load_kg, damping_n_s_m=0.5 * load_kg / dt,
                              relaxation_m=max(soil.shear_modulus_m, 0.02), lateral_relaxation_m=soil.lateral_shear_modulus_m)
            omega = wheel_speed_m_s / radius_m
            pb.setJointMotorControl2(body, jx, pb.VELOCITY_CONTROL, targetVelocity=wheel_speed_m_s * (1.0 - s),
                                     force=1e5, physicsClientId=cid)
            pb.setJointMotorControl2(body, 2, pb.VELOCITY_CONTROL, targetVelocity=omega, force=1e5, physicsClientId=cid)
            n = round(seconds * physics_rate_hz)
            acc = []
            for k in range(n):
                tyres.apply()
                pb.stepSimulation(physicsClientId=cid)
                if k >= 3 * n // 4:
                    sink = tyres.last[2][0] if 2 in tyres.last else 0.0
                    pull = -pb.getJointState(body, jx, physicsClientId=cid)[3]
                    torque = pb.getJointState(body, 2, physicsClientId=cid)[3]
                    acc.append((sink, pull, torque))
            rows.append(tuple(sum(c) / len(c) for c in zip(*acc)))
            report(progress, i + 1, len(slips))
    finally:
        pb.disconnect(physicsClientId=cid)
    return rows
