"""Single-wheel test rig: one wheel on a soil, driven at controlled slip and load in the physics engine.

The rig is the soil-bin test of terramechanics laboratories (Wong & Reece 1967; Ishigami et al. 2007,
Sec. 4): a carriage moves along x at a set speed, a free vertical slide carries the load, and the
wheel below it spins at a set angular velocity, so the slip is ``s = 1 - v / (r omega)``. Here the
carriage and slide are prismatic joints and the wheel a revolute joint of one PyBullet multibody;
the soil acts on the wheel through the ``terramechanics`` tyre model
(:class:`offroadbench.sim.soil_contact.SoilTyres`) on a flat heightmap. Once steady, the rig reads:

* sinkage: the soil sinkage the tyre model reports (the series spring's part excluded);
* drawbar pull: the force the carriage's motor holds back (the soil's forward push on the wheel);
* driving torque: the torque the wheel's motor applies (the soil's resistance torque).

:func:`model_curve` gives the same quantities from the Wong-Reece integrals directly (the sinkage at
which ``F_z`` carries the load, then ``F_x`` and ``T`` there), without the engine, the tables or
the relaxation, so the rig tests the whole per-step path.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from offroadbench.heightmap import Heightmap
from offroadbench.progress import ProgressFn, report
from offroadbench.sim.soil_contact import SoilTyres
from offroadbench.sim.terramechanics import (
    SoilParams,
    build_tables,
    static_sinkage,
    wheel_forces,
)

__all__ = ["SLIPS", "SoilCheck", "model_curve", "rig_curve", "wheel_load_n"]

#: slips of the check
SLIPS = tuple(round(0.1 * i, 1) for i in range(10))


@dataclass(frozen=True)
class SoilCheck:
    """Sinkage, drawbar pull and torque against slip for one wheel, load and soil."""

    soil: str
    radius_m: float
    width_m: float
    load_n: float
    slip: np.ndarray
    sinkage_m: np.ndarray
    drawbar_pull_n: np.ndarray
    torque_nm: np.ndarray


def model_curve(soil: SoilParams, radius_m: float, width_m: float, load_n: float,
                slips: Sequence[float] = SLIPS) -> SoilCheck:
    """The Wong-Reece integrals at the sinkage that carries ``load_n`` at each slip."""
    out = []
    for s in slips:
        h = static_sinkage(soil, radius_m, width_m, load_n, s)
        _, fx, t = wheel_forces(soil, radius_m, width_m, h, s)
        out.append((h, float(fx), float(t)))
    h, fx, t = (np.array(c) for c in zip(*out))
    return SoilCheck(soil.name, radius_m, width_m, load_n, np.asarray(slips, dtype=float), h, fx, t)


def wheel_load_n(spec, gravity_m_s2: float) -> float:
    """One wheel's share of the vehicle's weight, N (the URDF's masses, equal shares)."""
    cid = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(spec.urdf, flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        mass = sum(pb.getDynamicsInfo(body, j, physicsClientId=cid)[0]
                   for j in range(-1, pb.getNumJoints(body, physicsClientId=cid)))
    finally:
        pb.disconnect(physicsClientId=cid)
    return mass * gravity_m_s2 / len(spec.wheel_joints)


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


def rig_curve(soil: SoilParams, radius_m: float, width_m: float, load_n: float, *, gravity_m_s2: float = 9.81,
              slips: Sequence[float] = SLIPS, wheel_speed_m_s: float = 0.6, physics_rate_hz: int = 60,
              seconds: float = 4.0, progress: ProgressFn | None = None) -> SoilCheck:
    """Drive the rig at each slip for ``seconds`` and average the last quarter (module docstring).

    ``wheel_speed_m_s`` is ``r omega``; the carriage moves at ``(1 - s)`` of it, which must stay above
    the tyre model's resistance fade speed (0.05 m/s) for the steady-state Wong-Reece forces to apply.
    """
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
    h, fx, t = (np.array(c) for c in zip(*rows))
    return SoilCheck(soil.name, radius_m, width_m, load_n, np.asarray(slips, dtype=float), h, fx, t)
