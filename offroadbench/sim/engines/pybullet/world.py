"""A PyBullet DIRECT world holding one terrain (a few heightfield tiles) and one vehicle.

The terrain is built once per World and reused for all its missions; the vehicle is removed and
loaded anew before each mission (:meth:`World.spawn`), so a mission's result does not depend on
what ran before it, to the last bit. Facts this relies on (measured, shared/DESIGN.md):

- Resetting the vehicle's pose, velocities and joints is not enough for that: Bullet keeps
  per-body state across steps that those resets leave alone (the vehicle's contact manifolds,
  whose cached points and impulses warm-start the solver, and the multibody's own solver data).
  With a reset vehicle, 3 of 6 missions on a 32 m paper map run after others in one World
  differed in their last digits from the same missions in a fresh World (and then chaotically),
  also with a physics step taken in the air between missions. A vehicle removed and loaded again
  (about 4 ms, against a second or more per mission) gave every mission the bits of a fresh World,
  in any order (``tests/test_portable.py``).

- The terrain (its heightfield tiles, built empty and then filled in place, and the facts that
  build relies on) is ``terrain.py``'s.
- URDFs load with URDF_USE_INERTIA_FROM_FILE, else PyBullet recomputes the inertias.
- Under the ``coulomb`` tyre model Bullet's friction cone is off (``enableConeFriction = 0``,
  SimConfig.cone_friction): the wheels' Bullet friction is 0 there, so the cone's solver rows for
  their contacts were wasted work (1.08-1.12x per trial on the paper missions, no outcome changed;
  benchmarks/RESULTS.md, 'Issue 25').

This package (this module, ``terrain.py``, ``measure.py``, ``drivetrain.py``, ``tyres.py`` and the
terramechanics adapter ``soil.py``) is the only code that calls pybullet for a trial: :class:`World`
implements offroadbench.sim.engine.TrialWorld, the engine boundary, for PyBullet; the vehicle's
geometry is measured once, at load (``measure.py``).
"""

from __future__ import annotations

import logging
import math
import time

from offroadbench.sim.engines.pybullet._pb import pb

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim.config import SimConfig
from offroadbench.sim.engines.pybullet.drivetrain import apply_springs, attach_flywheels, belt_motor_forces, couple_belts
from offroadbench.sim.engines.pybullet.tyres import CoulombTyres
from offroadbench.sim.tyre_laws.coulomb import bristle_constants
from offroadbench.sim.engine import VehicleGeometry
from offroadbench.sim.engines.base import max_height_near, settle, spawn_height_m, suspension_rest_m
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle
from offroadbench.sim.engines.pybullet.measure import bottom_offset_m, centre_of_mass_m, measure_geometry
from offroadbench.sim.engines.pybullet.terrain import build_terrain, heightfield_ray_height

__all__ = ["World"]

log = logging.getLogger(__name__)


class World:
    """One terrain and one vehicle in a private PyBullet DIRECT client. Use as a context manager.

    The PyBullet implementation of offroadbench.sim.engine.TrialWorld (engine ``pybullet``)."""

    def __init__(self, hm: Heightmap, vehicle: VehicleSpec | str = "husky", sim: SimConfig = SimConfig()) -> None:
        self.hm = hm
        self.sim = sim.for_terrain()  # Earth's gravity and the default soil where nothing names them
        self.spec = vehicle if isinstance(vehicle, VehicleSpec) else load_vehicle(vehicle)
        self.dt_s = 1.0 / sim.physics_rate_hz
        self._mass_kg: float | None = None  # the vehicle's summed link masses, kg (at its first load)
        self._flywheels = None  # the loaded vehicle's drive-train flywheels (drivetrain.attach_flywheels)
        self._belts: list[int] = []  # the loaded vehicle's belt constraints (drivetrain.couple_belts)
        self._belt_targets = [0.0] * len(self.spec.wheel_joints)  # a belt vehicle's wheel speed commands, rad/s
        self._cid = pb.connect(pb.DIRECT)
        if self._cid < 0:  # pragma: no cover - only when the physics server cannot start
            raise RuntimeError("could not start a PyBullet DIRECT client")
        try:
            self._configure_engine()
            t0 = time.perf_counter()
            self.terrain_bodies = self._build_terrain()
            self._terrain_set = frozenset(self.terrain_bodies)
            log.info("heightfield %dx%d built in %.2f s (%d tiles)", hm.rows, hm.cols, time.perf_counter() - t0,
                     len(self.terrain_bodies))
            self._spring_rest_m = suspension_rest_m(self.spec, self.sim.gravity_m_s2)
            self.vehicle_id = self._load_vehicle()
            self.geometry = self._measure_geometry()
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Disconnect the client (frees the heightfield). Safe to call twice."""
        if self._cid >= 0:
            pb.disconnect(physicsClientId=self._cid)
            self._cid = -1

    def __enter__(self) -> "World":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def client_id(self) -> int:
        """The PyBullet client (for tests that inspect the engine; the package never uses it
        outside this module)."""
        return self._cid

    # ------------------------------------------------------------------ building
    def _configure_engine(self) -> None:
        pb.setGravity(0, 0, -self.sim.gravity_m_s2, physicsClientId=self._cid)
        pb.setPhysicsEngineParameter(
            fixedTimeStep=self.dt_s,
            numSubSteps=0,
            numSolverIterations=self.sim.solver_iterations,
            deterministicOverlappingPairs=1,
            enableConeFriction=int(self.cone_friction),
            physicsClientId=self._cid,
        )

    @property
    def cone_friction(self) -> bool:
        """Whether Bullet's friction cone is on (SimConfig.cone_friction; default: off under the
        ``coulomb`` tyre model, whose wheels have no Bullet friction)."""
        if self.sim.cone_friction is not None:
            return self.sim.cone_friction
        return self.sim.tyre_model != "coulomb"

    def _build_terrain(self) -> tuple[int, ...]:
        """One static body per heightfield tile, all with the map's height range (terrain.build_terrain)."""
        return build_terrain(self._cid, self.hm, self.sim)

    def _load_vehicle(self) -> int:
        spec = self.spec
        body = pb.loadURDF(
            spec.urdf,
            basePosition=[0, 0, self.hm.z_max_m + 10.0],
            flags=pb.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=self._cid,
        )
        names = {
            pb.getJointInfo(body, j, physicsClientId=self._cid)[1].decode(): j
            for j in range(pb.getNumJoints(body, physicsClientId=self._cid))
        }
        missing = [n for n in spec.wheel_joints if n not in names]
        if missing:
            raise InputError(f"vehicle {spec.name!r}: URDF {spec.urdf} has no joint(s) {', '.join(missing)}")
        extra = [n for n in spec.steer_joints + spec.differential_joints + spec.suspension_joints if n not in names]
        if extra:
            raise InputError(f"vehicle {spec.name!r}: URDF {spec.urdf} has no joint(s) {', '.join(extra)}")
        self.steer_joints = [names[n] for n in spec.steer_joints]
        self.suspension_joints = [names[n] for n in spec.suspension_joints]
        self.left_joints = [names[n] for n in spec.left_wheel_joints]
        self.right_joints = [names[n] for n in spec.right_wheel_joints]
        self.wheel_joints = self.left_joints + self.right_joints
        # motor torque per wheel: the spec's limit, 0 on an undriven wheel (it rolls freely)
        self._wheel_forces = [spec.wheel_torque_limit_nm if spec.is_driven(n) else 0.0 for n in spec.wheel_joints]
        cid = self._cid
        pb.changeDynamics(body, -1, lateralFriction=spec.chassis_friction, physicsClientId=cid)
        tyre = {}
        if spec.tyre_stiffness_n_m is not None:
            tyre = {"contactStiffness": spec.tyre_stiffness_n_m, "contactDamping": spec.tyre_damping_n_s_m}
        coulomb = self.sim.tyre_model in ("coulomb", "terramechanics")
        gear = self.sim.drive_train == "gear"
        excess = []  # per wheel, the drive train's inertia beyond the tyre's own, kg m^2
        for j in self.wheel_joints:
            pb.changeDynamics(body, j, lateralFriction=0.0 if coulomb else spec.wheel_friction, **tyre,
                              physicsClientId=cid)
            ixx, iyy, izz = pb.getDynamicsInfo(body, j, physicsClientId=cid)[2]
            spin = iyy if spec.wheel_spin_inertia_kg_m2 is None else spec.wheel_spin_inertia_kg_m2
            excess.append(max(0.0, spin - iyy) if gear else 0.0)
            if not gear and spec.wheel_spin_inertia_kg_m2 is not None:  # all of it on the wheel link
                pb.changeDynamics(body, j, localInertiaDiagonal=[ixx, spin, izz], physicsClientId=cid)
        self._excess_kg_m2 = tuple(excess)
        self._flywheels = attach_flywheels(cid, body, self.wheel_joints, excess,
                                           (0.0, 0.0, self.hm.z_min_m - 50.0),
                                           [spec.is_driven(n) for n in spec.wheel_joints])
        self._articulate(body, names)
        if spec.belt_drive:
            self._belts = couple_belts(cid, body, [self.left_joints, self.right_joints])
        if self._mass_kg is None:  # summed once: every load of the vehicle has the same links
            n_links = pb.getNumJoints(body, physicsClientId=cid)
            self._mass_kg = sum(pb.getDynamicsInfo(body, link, physicsClientId=cid)[0] for link in range(-1, n_links))
        self._tyres = None
        if self.sim.tyre_model == "terramechanics":
            from offroadbench.sim.engines.pybullet.soil import make_soil_tyres

            self._tyres = make_soil_tyres(self, body, self._mass_kg)
        elif coulomb:
            share = self._mass_kg / len(self.wheel_joints)  # kg carried by one wheel on flat ground
            k, c = bristle_constants(share, self.dt_s)
            self._tyres = CoulombTyres(cid, body, self._terrain_set, self.wheel_joints,
                                       spec.wheel_friction * self.sim.terrain_friction, self.dt_s,
                                       stiffness_n_m=k, damping_n_s_m=c)
        return body

    def _articulate(self, body: int, names: dict[str, int]) -> None:
        """Joints other than the wheels (steered and rocker-bogie vehicles): every other revolute joint
        passive (its default motor off), the steering joints held at 0 by their servos, and the
        rockers' differential as a gear constraint (rocker angles opposite: the body pitches by the
        mean of the two rockers')."""
        cid, spec = self._cid, self.spec
        driven = set(self.wheel_joints) | set(self.steer_joints)
        for j in names.values():
            if j not in driven and pb.getJointInfo(body, j, physicsClientId=cid)[2] == pb.JOINT_REVOLUTE:
                pb.setJointMotorControl2(body, j, pb.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
        for j in self.suspension_joints:  # their springs act through step(): the default motor off
            pb.setJointMotorControl2(body, j, pb.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
        if self.steer_joints:
            self.command_steering([0.0] * len(self.steer_joints), body)
        if spec.differential_joints:
            left, right = (names[n] for n in spec.differential_joints)
            gear = pb.createConstraint(body, left, body, right, pb.JOINT_GEAR, [0, 1, 0], [0, 0, 0], [0, 0, 0],
                                       physicsClientId=cid)
            pb.changeConstraint(gear, gearRatio=1.0, maxForce=1e4, erp=0.2, physicsClientId=cid)

    def command_steering(self, angles_rad, body: int | None = None) -> None:
        """Steering-joint targets, rad (``spec.steer_joints`` order): position servos limited to the
        spec's steering torque and rate."""
        spec = self.spec
        for j, a in zip(self.steer_joints, angles_rad, strict=True):
            pb.setJointMotorControl2(self.vehicle_id if body is None else body, j, pb.POSITION_CONTROL,
                                     targetPosition=a, force=spec.steer_torque_limit_nm,
                                     maxVelocity=math.radians(spec.max_steer_rate_deg_s), physicsClientId=self._cid)

    def command_wheel_speeds(self, speeds_rad_s) -> None:
        """One velocity command per wheel (``spec.wheel_joints`` order), rad/s, torque-limited."""
        if self.spec.belt_drive:
            self._belt_targets = list(speeds_rad_s)
        pb.setJointMotorControlArray(self.vehicle_id, self.wheel_joints, pb.VELOCITY_CONTROL,
                                     targetVelocities=list(speeds_rad_s),
                                     forces=self._wheel_forces,
                                     physicsClientId=self._cid)

    def _measure_geometry(self) -> VehicleGeometry:
        """The vehicle as loaded (offroadbench.sim.engine.VehicleGeometry): in the air at
        (0, 0, z_max + 10 m), heading 0, wheels at joint angle 0 (measure.measure_geometry)."""
        return measure_geometry(self._cid, self.vehicle_id, self.wheel_joints, self._excess_kg_m2, self._mass_kg,
                                self.hm.z_max_m + 10.0)

    # ------------------------------------------------------------------ vehicle state
    def spawn(self, x_m: float, y_m: float, heading_rad: float, roll_rad: float = 0.0) -> None:
        """Put the vehicle at rest above (x, y) facing ``heading_rad``, clear of the terrain, then
        let it settle for ``sim.settle_time_s`` with its wheels braked.

        The vehicle is a newly loaded body (a new ``vehicle_id``; see the module docstring), so
        what ran before does not matter.
        """
        cid = self._cid
        self._flywheels.remove()  # their gear constraints hold the old vehicle's joints
        for c in self._belts:  # as do the belts'
            pb.removeConstraint(c, physicsClientId=cid)
        self._belts = []
        pb.removeBody(self.vehicle_id, physicsClientId=cid)
        self.vehicle_id = body = self._load_vehicle()
        orn = pb.getQuaternionFromEuler([roll_rad, 0.0, heading_rad])
        pb.resetBasePositionAndOrientation(body, [x_m, y_m, self.hm.z_max_m + 10.0], orn, physicsClientId=cid)
        pb.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
        for j in self.wheel_joints:
            pb.resetJointState(body, j, 0.0, 0.0, physicsClientId=cid)
        for j in self.suspension_joints:  # the struts at rest in this gravity
            pb.resetJointState(body, j, self._spring_rest_m, 0.0, physicsClientId=cid)
        aabb_lo, aabb_hi = pb.getAABB(body, -1, physicsClientId=cid)
        reach = 0.5 * math.hypot(aabb_hi[0] - aabb_lo[0], aabb_hi[1] - aabb_lo[1])
        z = spawn_height_m(self.hm, x_m, y_m, reach, self.spec.wheel_radius_m, bottom_offset_m(cid, body),
                           self.sim.spawn_clearance_m)
        pb.resetBasePositionAndOrientation(body, [x_m, y_m, z], orn, physicsClientId=cid)
        if self._tyres is not None:
            self._tyres.reset()
        settle(self)

    def max_height_near(self, x_m: float, y_m: float, radius_m: float) -> float:
        """Highest terrain sample in the square of half-side ``radius_m`` around (x, y), metres
        (offroadbench.sim.engines.base.max_height_near)."""
        return max_height_near(self.hm, x_m, y_m, radius_m)

    def command_wheels(self, left_rad_s: float, right_rad_s: float) -> None:
        """Velocity commands for the left and right wheels, torque-limited by the vehicle spec."""
        n_l, n_r = len(self.left_joints), len(self.right_joints)
        if self.spec.belt_drive:
            self._belt_targets = [left_rad_s] * n_l + [right_rad_s] * n_r  # step() shares the sides' torque
        pb.setJointMotorControlArray(
            self.vehicle_id,
            self.wheel_joints,
            pb.VELOCITY_CONTROL,
            targetVelocities=[left_rad_s] * n_l + [right_rad_s] * n_r,
            forces=self._wheel_forces,
            physicsClientId=self._cid,
        )

    def step(self) -> None:
        """One physics step (with the suspension's spring and damper forces and the Coulomb tyre forces
        first, if the vehicle has them and that model is on)."""
        if self.suspension_joints:
            self._spring_forces()
        if self._belts:
            self._share_belt_torque()
        if self._tyres is not None:
            self._tyres.apply()
        pb.stepSimulation(physicsClientId=self._cid)

    def _share_belt_torque(self) -> None:
        """The belts' side torque shared by their wheels' loads of the last step (drivetrain.belt_motor_forces);
        on soft soil, where Bullet's wheel contacts are off, evenly by the wheels in the soil."""
        if self.sim.tyre_model == "terramechanics":
            loads = tuple(1.0 if j in self._tyres.last else 0.0 for j in self.wheel_joints)
        else:
            loads = self.wheel_loads_n()
        forces = belt_motor_forces(loads, (len(self.left_joints), len(self.right_joints)),
                                   self.spec.wheel_torque_limit_nm)
        pb.setJointMotorControlArray(self.vehicle_id, self.wheel_joints, pb.VELOCITY_CONTROL,
                                     targetVelocities=self._belt_targets, forces=forces, physicsClientId=self._cid)

    def _spring_forces(self) -> None:
        """The suspension's spring and damper forces for the next step (drivetrain.apply_springs)."""
        spec = self.spec
        apply_springs(self._cid, self.vehicle_id, self.suspension_joints, spec.suspension_stiffness_n_m,
                      spec.suspension_damping_n_s_m, spec.suspension_preload_n)

    def base_state(self) -> tuple[tuple, tuple, tuple, tuple]:
        """(position, quaternion xyzw, linear velocity, angular velocity), world frame."""
        pos, orn = pb.getBasePositionAndOrientation(self.vehicle_id, physicsClientId=self._cid)
        lin, ang = pb.getBaseVelocity(self.vehicle_id, physicsClientId=self._cid)
        return pos, orn, lin, ang

    def rotation_matrix(self, quat: tuple) -> tuple:
        """Row-major 3x3 rotation matrix (body -> world) of a quaternion (x, y, z, w)."""
        return pb.getMatrixFromQuaternion(quat, physicsClientId=self._cid)

    def terrain_contacts(self) -> list[tuple]:
        """The vehicle's contact points with the terrain (any tile) from the last step, as
        ``pybullet.getContactPoints`` gives them (vehicle as body A)."""
        terrain = self._terrain_set
        return [c for c in pb.getContactPoints(bodyA=self.vehicle_id, physicsClientId=self._cid) if c[2] in terrain]

    def wheel_loads_n(self) -> tuple[float, ...]:
        """Each wheel's summed normal force from the terrain in the last step, N (left wheels, then right)."""
        loads = dict.fromkeys(self.wheel_joints, 0.0)
        for c in self.terrain_contacts():
            if c[3] in loads:
                loads[c[3]] += c[9]
        return tuple(loads[j] for j in self.wheel_joints)

    def centre_of_mass_m(self) -> tuple[float, float, float]:
        """The whole vehicle's centre of mass in the world, m (mass-weighted link centres)."""
        return centre_of_mass_m(self._cid, self.vehicle_id)

    def push_base(self, fx: float, fy: float, fz: float) -> None:
        """An external force on the chassis at its centre of mass during the next step, N (world frame)."""
        pos = pb.getBasePositionAndOrientation(self.vehicle_id, physicsClientId=self._cid)[0]
        pb.applyExternalForce(self.vehicle_id, -1, [fx, fy, fz], pos, pb.WORLD_FRAME, physicsClientId=self._cid)

    def set_gravity(self, gx: float, gy: float, gz: float) -> None:
        """Gravity vector, m/s^2."""
        pb.setGravity(gx, gy, gz, physicsClientId=self._cid)

    def wheel_penetration_m(self) -> float:
        """Deepest penetration of any wheel into the terrain in the last step (0 if none), metres;
        with the ``terramechanics`` tyre model, the deepest soil sinkage."""
        if self.sim.tyre_model == "terramechanics":
            return max((v[0] for v in self._tyres.last.values()), default=0.0)
        worst = 0.0
        wheels = self.wheel_joints
        for c in self.terrain_contacts():
            if c[3] in wheels and -c[8] > worst:
                worst = -c[8]
        return worst

    def wheel_outside_model(self) -> bool | None:
        """True when a wheel on the soil bottomed out in the last step (outside the soil model); None without soil."""
        return self._tyres.core.outside_model() if self.sim.tyre_model == "terramechanics" else None

    def use_soil_map(self, soil_map) -> None:
        """From the next spawn, each wheel's soil from ``soil_map`` (offroadbench.terrain.soil_map.SoilMap)."""
        self.soil_map, self._soil_setup = soil_map, None

    def wheel_slip(self) -> float | None:
        """Mean longitudinal slip of the wheels on the soil in the last step (1: spinning in place),
        or None without the ``terramechanics`` tyre model or with no wheel on the ground."""
        if self.sim.tyre_model != "terramechanics" or not self._tyres.last:
            return None
        slips = [v[1] for v in self._tyres.last.values()]
        return sum(slips) / len(slips)

    def ray_height(self, x_m: float, y_m: float) -> float:
        """Height of the terrain collision surface at (x, y) by a vertical ray, metres (NaN off the map;
        terrain.heightfield_ray_height)."""
        return heightfield_ray_height(self._cid, self.hm, self._terrain_set, x_m, y_m)
