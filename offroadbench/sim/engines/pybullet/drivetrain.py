"""The drive train's reflected inertia on PyBullet, reacting on the chassis as through a gearbox.

A wheel's spin inertia ``I_spin`` (``VehicleSpec.wheel_spin_inertia_kg_m2``) is the tyre's own
``I_tyre`` plus the motor rotor's ``J_r`` seen through the gearbox, ``J_x = J_r N^2`` (N the gear
ratio). The rotor spins at ``N omega`` inside the chassis, so its angular momentum is
``J_r N omega = J_x omega / N``: spinning it up costs the motor ``J_x alpha`` of torque at the wheel,
but the chassis feels only ``1/N`` of it as reaction (stator and gear teeth pass the rest back and
forth inside the drive train). MuJoCo models exactly this with a joint's ``armature``: an inertia
on the joint's own coordinate that carries none of the bodies' momentum (the limit N -> infinity).

PyBullet has no armature. Putting ``J_x`` on the wheel link (``changeDynamics(localInertiaDiagonal)``,
``SimConfig.drive_train_reaction = "link"``, the model before 2026-11-26) makes all of
``I_spin alpha`` and the excess's gyroscopic torque in turns react on the chassis, and makes the
chassis drag ``J_x`` along whenever it pitches with the motors holding the wheels: at launch in
lunar gravity (1.62 m/s^2) the Husky's four motors at their 28 N m limit spinning up 1 kg m^2
wheels reared it up to 44-45 deg on flat rigid ground, where MuJoCo stays below 1 deg.

:func:`attach_flywheels` (``drive_train_reaction = "gear"``, the default) builds the armature out
of parts Bullet has: per wheel a flywheel of inertia ``J_x`` on a revolute joint of a body fixed
in the world (no collision shape, out of the way below the map), tied to the wheel's joint by a
``JOINT_GEAR`` constraint of ratio -1 (equal joint speeds). The constraint is solved with the
motors and contacts in Bullet's own solver (no explicit, lagged force): the motor now spins up
``I_tyre + J_x`` as before, but the torque that accelerates the flywheel reacts on the world, not
on the chassis, and the chassis' own rotation does not drive the flywheel. Measured
(benchmarks/RESULTS.md, 'Drive-train reaction'): on a free test body the chassis takes the tyre's
share of the motor torque to within 6 %; the Husky's launch pitch in lunar gravity falls from
45.0 deg to under 1 deg.

A tracked vehicle's belt (``VehicleSpec.belt_drive``, :func:`couple_belts`) is built the same way:
each side's road wheels tied by ``JOINT_GEAR`` constraints of ratio -1 (equal joint speeds), so the
side turns as one belt and the motors' summed torque reaches the ground through whichever wheels
bear on it.
"""

from __future__ import annotations

from offroadbench.sim.engines.pybullet._pb import pb

__all__ = ["Flywheels", "apply_springs", "attach_flywheels", "belt_motor_forces", "couple_belts"]

_FLYWHEEL_MASS_KG = 1.0
"""Mass of each flywheel link (on its axis: it carries no torque from gravity), kg."""
_GEAR_MAX_FORCE = 1e6
"""The gear constraint's impulse cap (N m), far above any wheel motor's torque."""


class Flywheels:
    """The flywheels of one loaded vehicle and their gear constraints (remove before the vehicle)."""

    def __init__(self, cid: int, bodies: list[int], constraints: list[int]) -> None:
        self._cid = cid
        self.bodies = bodies
        self.constraints = constraints

    def remove(self) -> None:
        """Remove the constraints and flywheel bodies from the world."""
        for c in self.constraints:
            pb.removeConstraint(c, physicsClientId=self._cid)
        for b in self.bodies:
            pb.removeBody(b, physicsClientId=self._cid)
        self.bodies, self.constraints = [], []


def attach_flywheels(cid: int, vehicle: int, wheels: list[int], excess_kg_m2: list[float],
                     anchor_m: tuple[float, float, float], driven: list[bool] | None = None) -> Flywheels:
    """One grounded flywheel of inertia ``excess_kg_m2[i]`` (kg m^2) geared 1:1 to each wheel joint
    ``wheels[i]`` of ``vehicle`` whose excess is positive; ``anchor_m`` is where the flywheels'
    fixed bases sit (world frame, m; anywhere out of the vehicle's way: they collide with nothing).

    ``driven[i]`` False marks a wheel without a motor (a car's towed front wheels): its flywheel is
    not a drive train but the numerical inertia the explicit tyre forces need (vehicles/hunter), so
    it is spared Bullet's default velocity damping (about ``I w (0.04 + 0.04 |w|)``), which no motor
    makes up there and which would brake the free wheel (README, "Known limitations")."""
    bodies, constraints = [], []
    driven = [True] * len(wheels) if driven is None else driven
    for joint, excess, motor in zip(wheels, excess_kg_m2, driven, strict=True):
        if excess <= 0.0:
            continue
        axis = tuple(pb.getJointInfo(vehicle, joint, physicsClientId=cid)[13])
        fly = pb.createMultiBody(
            baseMass=0.0, basePosition=list(anchor_m), linkMasses=[_FLYWHEEL_MASS_KG],
            linkCollisionShapeIndices=[-1], linkVisualShapeIndices=[-1], linkPositions=[[0.0, 0.0, 0.0]],
            linkOrientations=[[0.0, 0.0, 0.0, 1.0]], linkInertialFramePositions=[[0.0, 0.0, 0.0]],
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]], linkParentIndices=[0],
            linkJointTypes=[pb.JOINT_REVOLUTE], linkJointAxis=[list(axis)], physicsClientId=cid)
        pb.changeDynamics(fly, 0, localInertiaDiagonal=[excess, excess, excess], physicsClientId=cid)
        pb.setJointMotorControl2(fly, 0, pb.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)  # free
        if not motor:  # a separate call: with localInertiaDiagonal in the same one it stopped every vehicle
            pb.changeDynamics(fly, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
        gear = pb.createConstraint(vehicle, joint, fly, 0, pb.JOINT_GEAR, list(axis), [0.0, 0.0, 0.0],
                                   [0.0, 0.0, 0.0], physicsClientId=cid)
        # Bullet's gear row holds q_dot_a + ratio * q_dot_b = 0: ratio -1 gives equal joint speeds
        pb.changeConstraint(gear, gearRatio=-1.0, maxForce=_GEAR_MAX_FORCE, erp=0.0, physicsClientId=cid)
        bodies.append(fly)
        constraints.append(gear)
    return Flywheels(cid, bodies, constraints)


def couple_belts(cid: int, vehicle: int, sides: list[list[int]]) -> list[int]:
    """Tie each side's wheel joints (``sides``: lists of joint indices of ``vehicle``, the first the
    sprocket's) into one belt: a ``JOINT_GEAR`` constraint of ratio -1 (equal joint speeds) between the
    first wheel and each other. Returns the constraints (remove them before the vehicle).

    A track's belt wraps the sprocket and every road wheel of its side, so they turn at one speed (the
    belt's, over the wheels' common radius) and the sprocket's torque reaches the ground through the
    road wheels that bear on it, not in fixed shares: a side resting on one road wheel still pushes
    with the whole sprocket torque (up to that wheel's grip). Each wheel is geared to the first
    directly. The gears alone did not hold a side at one speed against Bullet's per-wheel velocity
    motors (a side stalled against a step turned its loaded wheels 18 % slower than its airborne ones:
    the solver's iterations do not settle motors and gears together), so the World also gives the
    wheels' motors the side's torque in proportion to their loads (World._share_belt_torque); then
    the wheels of a stalled side turn within 1 % of one speed. The constraints hold speeds, not angles
    (``erp`` 0, as the flywheels' gear): the road wheels' angles may drift apart, which changes
    nothing for spheres."""
    constraints = []
    for joints in sides:
        drive = joints[0]
        axis = tuple(pb.getJointInfo(vehicle, drive, physicsClientId=cid)[13])
        for wheel in joints[1:]:
            gear = pb.createConstraint(vehicle, drive, vehicle, wheel, pb.JOINT_GEAR, list(axis), [0.0, 0.0, 0.0],
                                       [0.0, 0.0, 0.0], physicsClientId=cid)
            pb.changeConstraint(gear, gearRatio=-1.0, maxForce=_GEAR_MAX_FORCE, erp=0.0, physicsClientId=cid)
            constraints.append(gear)
    return constraints


def belt_motor_forces(loads_n, side_sizes: tuple[int, int], wheel_torque_nm: float) -> list[float]:
    """Each wheel motor's torque limit on a belt (left wheels, then right), N m: the side's torque
    ``n wheel_torque_nm`` (its sprocket's) in proportion to the wheels' normal loads ``loads_n`` (N, the
    last step's), evenly when the side is in the air (World._share_belt_torque, couple_belts)."""
    forces, k = [], 0
    for n in side_sizes:
        total_nm, side = n * wheel_torque_nm, list(loads_n[k:k + n])
        load = sum(side)
        forces += [total_nm * w / load for w in side] if load > 0.0 else [total_nm / n] * n
        k += n
    return forces


def apply_springs(cid: int, vehicle: int, joints: list[int], stiffness_n_m: float, damping_n_s_m: float,
                  preload_n: float) -> None:
    """Each suspension joint's spring and damper (VehicleSpec.suspension_*) for the next step, from its
    present position ``q`` and speed (explicit): the wheel pushed down with ``preload + k q + c q_dot``
    (offroadbench.sim.engines.mujoco.mjcf builds the same spring as slide joints' stiffness, springref
    and damping); the travel is the URDF's joint limits, which Bullet holds."""
    states = pb.getJointStates(vehicle, joints, physicsClientId=cid)
    forces = [-(preload_n + stiffness_n_m * q + damping_n_s_m * v) for q, v, _, _ in states]
    pb.setJointMotorControlArray(vehicle, joints, pb.TORQUE_CONTROL, forces=forces, physicsClientId=cid)
