"""A MuJoCo world holding one terrain and one vehicle: the engine ``mujoco`` (SimConfig.engine).

It implements offroadbench.sim.engine.TrialWorld as offroadbench.sim.engines.pybullet.world.World does for
PyBullet, from the same inputs, so a trial, its telemetry and its failure rules are the same code:

- **Terrain**: one ``hfield`` from the Heightmap, placed as offroadbench.io.export.mujoco places
  it (sample (r, c) at (c cell, r cell, z[r, c]); row r at y = r cell, no flip), its elevations
  written into the compiled model (float32, normalised to the map's relief).
- **Vehicle**: the same URDF (links' inertials, box / sphere / cylinder collision shapes, joints)
  and ``vehicle.toml``. The chassis body's frame is put at its centre of mass, so the free joint's
  position and linear velocity are those of the centre of mass, which is what PyBullet's base
  state reports. The wheels' drive-train spin inertia (``wheel_spin_inertia_kg_m2``) is the
  joints' ``armature`` (the URDF's own spin inertia plus armature = the spec's figure).
- **Motors**: velocity actuators (``kv`` a stiff servo, the implicit-fast integrator keeps it
  stable) limited to the spec's wheel torque: PyBullet's VELOCITY_CONTROL motors.
- **Tyres**: under ``tyre_model = "coulomb"`` the wheels' contacts are frictionless (``condim``
  1) and the project's tyre model (offroadbench.sim.tyre_laws.coulomb.CoulombBristles, the very code the
  PyBullet world uses) applies the friction as forces: each trial step starts with ``mj_step1``
  (kinematics, collisions), the tyre forces from the last step's contacts and the current
  velocities into ``xfrc_applied``, then ``mj_step2``, at each of the trial step's MuJoCo steps
  (``ContactTuning.min_rate_hz``). Under ``bullet`` the wheels keep MuJoCo's friction. The
  contact reading and the forces run compiled (offroadbench.sim.engines.mujoco._tyres_c, numba:
  the same forces to the last bit, about a tenth of the Python loop's cost) when numba is
  installed, else in Python (``[sim.mujoco] tyre_loop``, MuJoCoConfig).
- **Contact**: the tyres' vertical stiffness and damping (``tyre_stiffness_n_m``,
  ``tyre_damping_n_s_m``) as the wheels' ``solref = (time constant, damping ratio)``: the tyre's
  ``sqrt(m / k)`` and ``c / (2 sqrt(k m))`` for a wheel's share ``m`` of the mass, the time
  constant raised to two steps (MuJoCo's stable minimum; at 60 Hz the tyre is so softer than
  PyBullet's). MuJoCo's direct form ``(-k / m, -c / m)`` was tried: a sphere on a height field
  gets 4-5 contacts (the field is a union of prisms), each as stiff, and at 60 Hz the vehicle
  bounced off the ground. The chassis contact is MuJoCo's default, with the chassis' friction.
- **Reset**: ``mj_resetData`` before every spawn clears every piece of state, so results do not
  depend on the missions run before (bit-identical in any mission order).

Only this module (and offroadbench.sim.engines.pybullet.world / contact for PyBullet) imports a physics engine.
"""

from __future__ import annotations

import logging
import math
import time
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export.mujoco import mujoco_hfield_size
from offroadbench.sim.config import SimConfig
from offroadbench.sim.tyre_laws.coulomb import CoulombBristles, bristle_constants
from offroadbench.sim.tyre_laws.soil_wheels import soil_setup
from offroadbench.sim.engine import VehicleGeometry
from offroadbench.sim.engines.base import UrdfLink, max_height_near, read_urdf, settle, spawn_height_m
from offroadbench.sim.engines.mujoco.settings import MUJOCO_CONTACT, ContactTuning
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle

__all__ = ["MuJoCoWorld", "ContactTuning", "MUJOCO_CONTACT"]

log = logging.getLogger(__name__)


def _compiled_loop(choice: str):
    """offroadbench.sim.engines.mujoco._tyres_c for ``[sim.mujoco] tyre_loop = choice``, or None for the
    Python loop (``auto`` without numba)."""
    if choice == "python":
        return None
    try:
        from offroadbench.sim.engines.mujoco import _tyres_c
    except ImportError:
        if choice == "compiled":
            raise InputError("MuJoCoConfig.tyre_loop = 'compiled' needs numba: pip install 'offroadbench[fast]'") from None
        return None
    except RuntimeError as exc:  # numba installed but unable to compile or cache (e.g. no writable cache folder)
        if choice == "compiled":
            raise InputError(f"MuJoCoConfig.tyre_loop = 'compiled': numba cannot build the loop ({exc})") from None
        log.warning("the compiled tyre loop is unavailable (%s); using the Python loop", exc)
        return None
    return _tyres_c



def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


# ---------------------------------------------------------------------------- the world
class MuJoCoWorld:
    """One terrain and one vehicle in MuJoCo (offroadbench.sim.engine.TrialWorld). Use as a
    context manager."""

    def __init__(self, hm: Heightmap, vehicle: VehicleSpec | str = "husky", sim: SimConfig = SimConfig(),
                 contact: ContactTuning | None = None) -> None:
        self.hm = hm
        self.sim = sim = sim.for_terrain()  # Earth's gravity where nothing names one
        self.spec = vehicle if isinstance(vehicle, VehicleSpec) else load_vehicle(vehicle)
        self.dt_s = 1.0 / sim.physics_rate_hz
        self.contact = contact = sim.mujoco if contact is None else contact  # [sim.mujoco], unless given
        self.substeps = max(1, math.ceil(contact.min_rate_hz / sim.physics_rate_hz))
        self._dt_mj = self.dt_s / self.substeps
        t0 = time.perf_counter()
        xml = self._mjcf()
        try:
            self.model = mujoco.MjModel.from_xml_string(xml)
        except ValueError as exc:
            raise InputError(f"vehicle {self.spec.name!r}: MuJoCo cannot compile its model ({exc})") from None
        self._write_heights()
        self.data = mujoco.MjData(self.model)
        self._index()
        log.info("MuJoCo world %dx%d built in %.2f s", hm.rows, hm.cols, time.perf_counter() - t0)
        self._mass_kg = self.geometry_mass()  # summed once
        self._tyres = None
        self._fast = None  # the compiled tyre loop's (module, float state, int state), if used
        tc = None
        if sim.tyre_model == "coulomb":
            # the bristle of the PyBullet world (stiffness and damping from the trial's step, so the
            # tyre is the same whatever the engine's step), integrated at MuJoCo's step
            k, c = bristle_constants(self._mass_kg / len(self._wheel_bodies), self.dt_s)
            bristle = (len(self._wheel_bodies), self.spec.wheel_friction * sim.terrain_friction,
                       self._dt_mj if contact.tyres_each_substep else self.dt_s, k, c)
            self._tyres = CoulombBristles(*bristle)
            tc = _compiled_loop(contact.tyre_loop)
        if tc is not None:
            slot = [self._wheel_geom.get(g, -1) for g in range(self.model.ngeom)]
            f, ist = tc.new_state(*bristle, self._wheel_bodies, self._wheel_qvel, self._wheel_axis, self._terrain_geom,
                                  self._chassis, slot)
            d = self.data
            tc.check_types(d.qvel, d.xmat, d.xipos, d.xfrc_applied, d.contact, d.efc_force)
            self._fast = (tc, f, ist)
        self._soil = None
        if sim.tyre_model == "terramechanics":
            # the soil of the PyBullet world (tables and constants from the trial's step, the force
            # law offroadbench.sim.tyre_laws.soil_wheels), integrated at MuJoCo's step
            n = len(self._wheel_bodies)
            setup = soil_setup(self.spec, sim.soil, self._mass_kg, n, sim.gravity_m_s2, self.dt_s)
            self._soil = setup.wheels(n, hm, self.dt_s, self._dt_mj if contact.tyres_each_substep else self.dt_s)
        self._forces = self._tyres is not None or self._soil is not None  # tyre forces written each step
        self._loads = [0.0] * len(self._wheel_bodies)
        self._penetration = 0.0
        self._xfrc = [0.0] * (6 * self.model.nbody)  # xfrc_applied, row-major, written once per step
        self._xfrc_zero = [0.0] * (6 * self.model.nbody)
        self._base_force = None  # push_base's force for the next step
        self.geometry = self._measure_geometry()

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Drop the model and data (MuJoCo frees them with the objects). Safe to call twice."""
        self.data = None

    def __enter__(self) -> MuJoCoWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ building
    def _mjcf(self) -> str:
        spec, sim, hm = self.spec, self.sim, self.hm
        links, joints = read_urdf(spec.urdf)
        children = {j.parent: [] for j in joints}
        for j in joints:
            children[j.parent].append(j)
        child_links = {j.child for j in joints}
        roots = [name for name in links if name not in child_links]
        if len(roots) != 1:
            raise InputError(f"URDF {spec.urdf}: expected one root link, found {roots}")
        by_name = {j.name: j for j in joints}
        missing = [n for n in spec.wheel_joints + spec.steer_joints + spec.differential_joints if n not in by_name]
        if missing:
            raise InputError(f"vehicle {spec.name!r}: URDF {spec.urdf} has no joint(s) {', '.join(missing)}")
        coulomb = sim.tyre_model == "coulomb"
        self._wheels_collide = sim.tyre_model != "terramechanics"  # the soil carries the wheels
        total_mass = sum(link.mass for link in links.values())
        share = total_mass / len(spec.wheel_joints)
        tune = self.contact

        root = ET.Element("mujoco", model=f"offroadbench-{spec.name}")
        ET.SubElement(root, "compiler", angle="radian", eulerseq="XYZ", inertiafromgeom="false", autolimits="true")
        option = ET.SubElement(root, "option", timestep=repr(self._dt_mj), ccd_iterations=str(tune.ccd_iterations), gravity=_fmt((0, 0, -sim.gravity_m_s2)),
                      integrator="implicitfast", cone=tune.cone, iterations=str(sim.solver_iterations))
        if not tune.refsafe:
            ET.SubElement(option, "flag", refsafe="disable")
        size = ET.SubElement(root, "size")
        size.set("memory", f"{max(16, 4 * len(spec.wheel_joints))}M")
        asset = ET.SubElement(root, "asset")
        rx, ry, ez, base = mujoco_hfield_size(hm)
        ET.SubElement(asset, "hfield", name="terrain", nrow=str(hm.rows), ncol=str(hm.cols), size=_fmt((rx, ry, ez, base)))
        world = ET.SubElement(root, "worldbody")
        ET.SubElement(world, "geom", name="terrain", type="hfield", hfield="terrain", pos=_fmt((rx, ry, hm.z_min_m)),
                      friction=_fmt((sim.terrain_friction, 0.005, 0.0001)), group="0")

        base_link = links[roots[0]]
        shift = base_link.com  # the chassis body's frame sits at its centre of mass
        body = ET.SubElement(world, "body", name="chassis", pos=_fmt((0, 0, hm.z_max_m + 10.0)))
        ET.SubElement(body, "freejoint", name="root")
        self._add_link(body, base_link, shift, is_wheel=False, coulomb=coulomb, share=share)
        wheel_names = set(spec.wheel_joints)

        def add_children(parent_el, link_name, offset):
            for j in children.get(link_name, []):
                link = links[j.child]
                pos = tuple(p - o for p, o in zip(j.pos, offset))
                el = ET.SubElement(parent_el, "body", name=j.child, pos=_fmt(pos), euler=_fmt(j.euler))
                if j.kind in ("continuous", "revolute"):
                    jel = ET.SubElement(el, "joint", name=j.name, type="hinge", axis=_fmt(j.axis), damping="0")
                    if j.name in wheel_names and spec.wheel_spin_inertia_kg_m2 is not None:
                        own = abs(j.axis[0]) * link.inertia[0] + abs(j.axis[1]) * link.inertia[1] + abs(j.axis[2]) * link.inertia[2]
                        jel.set("armature", repr(max(0.0, spec.wheel_spin_inertia_kg_m2 - own)))
                elif j.kind != "fixed":
                    raise InputError(f"URDF {spec.urdf}: joint {j.name} of type {j.kind!r} is not supported")
                self._add_link(el, link, (0.0, 0.0, 0.0), is_wheel=j.name in wheel_names, coulomb=coulomb, share=share)
                add_children(el, j.child, (0.0, 0.0, 0.0))

        add_children(body, roots[0], shift)
        act = ET.SubElement(root, "actuator")
        for name in spec.wheel_joints:
            spin = spec.wheel_spin_inertia_kg_m2 or links[by_name[name].child].inertia[1]
            # an undriven wheel keeps its (idle) actuator slot with no gain: it rolls freely
            gain = tune.servo_gain * spin / self._dt_mj if spec.is_driven(name) else 0.0
            ET.SubElement(act, "velocity", name=f"motor_{name}", joint=name, kv=repr(gain),
                          forcerange=_fmt((-spec.wheel_torque_limit_nm, spec.wheel_torque_limit_nm)))
        self._articulate(root, act, links, by_name)
        if any(j.kind != "fixed" and j.name not in wheel_names for j in joints):
            # links on steering or suspension joints are not all parent and child: keep MuJoCo from
            # colliding the vehicle with itself (PyBullet loads URDFs without self-collision)
            for g in root.iter("geom"):
                if g.get("name") != "terrain" and g.get("contype") != "0":
                    g.set("contype", "2")
                    g.set("conaffinity", "1")
        return ET.tostring(root, encoding="unicode")

    def _articulate(self, root, act, links, by_name) -> None:
        """Steering servos after the wheel motors (position actuators, stiff against the steered
        link's inertia about the steering axis, limited to the spec's steering torque) and the
        rockers' differential as a joint equality (angles opposite: the body pitches by the mean of
        the rockers'), for steered and rocker-bogie vehicles."""
        spec = self.spec
        for name in spec.steer_joints:
            link = links[by_name[name].child]
            wheel = next(j for j in by_name.values() if j.parent == link.name)
            inertia = link.inertia[2] + links[wheel.child].inertia[2] + links[wheel.child].mass * sum(
                p * p for p in wheel.pos[:2])
            kp = self.contact.servo_gain * max(inertia, 1e-6) / self._dt_mj**2
            ET.SubElement(act, "position", name=f"steer_{name}", joint=name, kp=repr(kp),
                          kv=repr(2.0 * math.sqrt(kp * max(inertia, 1e-6))),
                          forcerange=_fmt((-spec.steer_torque_limit_nm, spec.steer_torque_limit_nm)))
        if spec.differential_joints:
            left, right = spec.differential_joints
            eq = ET.SubElement(root, "equality")
            ET.SubElement(eq, "joint", joint1=left, joint2=right, polycoef="0 -1 0 0 0")

    def _add_link(self, el, link: UrdfLink, shift, *, is_wheel: bool, coulomb: bool, share: float) -> None:
        spec, sim, tune = self.spec, self.sim, self.contact
        com = tuple(c - s for c, s in zip(link.com, shift))
        if link.mass > 0:
            ET.SubElement(el, "inertial", pos=_fmt(com), mass=repr(link.mass), diaginertia=_fmt(link.inertia))
        for kind, size, pos, euler in link.shapes:
            g = ET.SubElement(el, "geom", type=kind, size=_fmt(size), pos=_fmt(tuple(p - s for p, s in zip(pos, shift))),
                              euler=_fmt(euler), group="1", priority="1",
                              solimp=_fmt(tune.solimp if is_wheel else tune.chassis_solimp))
            if is_wheel:
                g.set("name", f"wheel_{link.name}")
                if not self._wheels_collide:
                    g.set("contype", "0")
                    g.set("conaffinity", "0")
                g.set("margin", repr(tune.wheel_margin_m))
                g.set("gap", repr(tune.wheel_gap_m))
                g.set("solref", _fmt(tune.wheel_solref or self._tyre_solref(share)))
                if coulomb:
                    g.set("condim", "1")
                else:
                    g.set("condim", "3")
                    g.set("friction", _fmt((spec.wheel_friction * sim.terrain_friction, 0.005, 0.0001)))
            else:
                g.set("condim", str(tune.chassis_condim))
                g.set("solref", _fmt(tune.chassis_solref))
                g.set("friction", _fmt((spec.chassis_friction * sim.terrain_friction, 0.005, 0.0001)))

    def _tyre_solref(self, share: float) -> tuple[float, float]:
        """The wheels' solref (time constant, damping ratio) from the spec's tyre: the tyre's own
        time constant sqrt(m / k) and damping ratio c / (2 sqrt(k m)) for a wheel's share m of the
        mass, the time constant raised to MuJoCo's stable minimum of two steps."""
        spec = self.spec
        if spec.tyre_stiffness_n_m is None:
            return (max(0.02, 2.0 * self._dt_mj), 1.0)
        k, c = spec.tyre_stiffness_n_m, spec.tyre_damping_n_s_m
        floor = 2.0 * self._dt_mj if self.contact.refsafe else 0.0
        return (max(math.sqrt(share / k), floor), c / (2.0 * math.sqrt(k * share)))

    def _write_heights(self) -> None:
        hm = self.hm
        relief = hm.relief_m
        data = (hm.z - hm.z_min_m) / relief if relief > 0 else np.zeros_like(hm.z)
        self.model.hfield_data[:] = data.astype(np.float32).ravel()

    def _index(self) -> None:
        m = self.model
        obj = mujoco.mjtObj
        self._terrain_geom = mujoco.mj_name2id(m, obj.mjOBJ_GEOM, "terrain")
        self._chassis = mujoco.mj_name2id(m, obj.mjOBJ_BODY, "chassis")
        joints = [mujoco.mj_name2id(m, obj.mjOBJ_JOINT, n) for n in self.spec.wheel_joints]
        self._wheel_jnt = joints
        self._wheel_bodies = [int(m.jnt_bodyid[j]) for j in joints]
        self._wheel_qvel = [int(m.jnt_dofadr[j]) for j in joints]
        self._wheel_qpos = [int(m.jnt_qposadr[j]) for j in joints]
        self._wheel_axis = [tuple(float(a) for a in m.jnt_axis[j]) for j in joints]
        self._wheel_geom = {}
        for i, b in enumerate(self._wheel_bodies):
            for g in range(m.ngeom):
                if m.geom_bodyid[g] == b:
                    self._wheel_geom[g] = i
        self._n_left = len(self.spec.left_wheel_joints)
        # a wheel on a steering or suspension joint does not move with the chassis alone
        self._articulated = m.njnt > 1 + len(self._wheel_bodies)  # joints beyond the free joint and the wheels

    def geometry_mass(self) -> float:
        """Total mass of the vehicle's bodies, kg."""
        m = self.model
        return float(sum(m.body_mass[b] for b in range(1, m.nbody)))

    def _measure_geometry(self) -> VehicleGeometry:
        """The vehicle as loaded, in the air at heading 0 (offroadbench.sim.engine.VehicleGeometry)."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        mujoco.mj_kinematics(m, d)
        base = d.xipos[self._chassis].tolist()
        lo, hi = [math.inf] * 3, [-math.inf] * 3
        chassis_lo_z, chassis_front = math.inf, -math.inf
        wheel_lo_z, wheel_front = math.inf, -math.inf
        for g in range(m.ngeom):
            if g == self._terrain_geom:
                continue
            glo, ghi = self._geom_box(g)
            lo = [min(a, b) for a, b in zip(lo, glo)]
            hi = [max(a, b) for a, b in zip(hi, ghi)]
            if g in self._wheel_geom:
                wheel_lo_z, wheel_front = min(wheel_lo_z, glo[2]), max(wheel_front, ghi[0])
            elif m.geom_bodyid[g] == self._chassis:
                chassis_lo_z, chassis_front = min(chassis_lo_z, glo[2]), max(chassis_front, ghi[0])
        centres = [d.xipos[b].tolist() for b in self._wheel_bodies]
        spins = []
        for b, j, axis in zip(self._wheel_bodies, self._wheel_qvel, self._wheel_axis):
            own = sum(abs(a) * i for a, i in zip(axis, m.body_inertia[b].tolist()))
            spins.append(own + float(m.dof_armature[j]))
        return VehicleGeometry(
            mass_kg=self._mass_kg,
            wheel_spin_inertia_kg_m2=tuple(spins),
            wheel_centres_m=tuple((c[0] - base[0], c[1] - base[1], c[2] - base[2]) for c in centres),
            length_m=hi[0] - lo[0],
            width_m=hi[1] - lo[1],
            belly_m=chassis_lo_z - wheel_lo_z,
            overhang=chassis_front > wheel_front + 1e-3,
        )

    def _geom_box(self, g: int) -> tuple[list[float], list[float]]:
        """World-axis bounding box of vehicle geom ``g`` in the current kinematics, m."""
        m, d = self.model, self.data
        c = d.geom_xpos[g].tolist()
        r = d.geom_xmat[g].tolist()
        kind = m.geom_type[g]
        size = m.geom_size[g].tolist()
        if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            ext = [size[0]] * 3
        elif kind == mujoco.mjtGeom.mjGEOM_BOX:
            ext = [abs(r[3 * k]) * size[0] + abs(r[3 * k + 1]) * size[1] + abs(r[3 * k + 2]) * size[2] for k in range(3)]
        else:  # cylinder: radius across, half-length along its z axis
            ext = [size[0] * math.sqrt(max(0.0, 1.0 - r[3 * k + 2] ** 2)) + size[1] * abs(r[3 * k + 2]) for k in range(3)]
        return [c[k] - ext[k] for k in range(3)], [c[k] + ext[k] for k in range(3)]

    # ------------------------------------------------------------------ vehicle state
    def spawn(self, x_m: float, y_m: float, heading_rad: float, roll_rad: float = 0.0) -> None:
        """Reset all state (``mj_resetData``), put the vehicle at rest just above the terrain at (x, y),
        and let it settle for ``sim.settle_time_s`` with its wheels braked."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        cr, sr = math.cos(0.5 * roll_rad), math.sin(0.5 * roll_rad)
        ch, sh = math.cos(0.5 * heading_rad), math.sin(0.5 * heading_rad)
        quat = (ch * cr, ch * sr, sh * sr, sh * cr)  # w x y z of yaw(heading) * roll
        d.qpos[0:3] = (x_m, y_m, self.hm.z_max_m + 10.0)
        d.qpos[3:7] = quat
        mujoco.mj_kinematics(m, d)
        lows, reach = [], 0.0
        base = d.xipos[self._chassis].tolist()
        for g in range(m.ngeom):
            if g != self._terrain_geom:
                glo, ghi = self._geom_box(g)
                lows.append(glo[2])
                if m.geom_bodyid[g] == self._chassis:
                    reach = max(reach, 0.5 * math.hypot(ghi[0] - glo[0], ghi[1] - glo[1]))
        bottom = base[2] - min(lows)
        d.qpos[2] = spawn_height_m(self.hm, x_m, y_m, reach, self.spec.wheel_radius_m, bottom,
                                   self.sim.spawn_clearance_m)
        mujoco.mj_forward(m, d)
        self._loads = [0.0] * len(self._loads)
        self._penetration = 0.0
        if self._tyres is not None:
            self._tyres.reset()
            self._tyres.clear()
        if self._fast is not None:
            self._fast[0].reset_state(self._fast[1], self._fast[2], len(self._loads))
        if self._soil is not None:
            self._soil.reset()
        settle(self)

    def max_height_near(self, x_m: float, y_m: float, radius_m: float) -> float:
        """Highest terrain sample in the square of half-side ``radius_m`` around (x, y), metres
        (offroadbench.sim.engines.base.max_height_near)."""
        return max_height_near(self.hm, x_m, y_m, radius_m)

    def command_wheels(self, left_rad_s: float, right_rad_s: float) -> None:
        """Velocity targets of the left and right wheels, rad/s (torque-limited by the actuators)."""
        n = self._n_left
        ctrl = self.data.ctrl
        for i in range(len(self._wheel_bodies)):
            ctrl[i] = left_rad_s if i < n else right_rad_s

    def command_wheel_speeds(self, speeds_rad_s) -> None:
        """One velocity target per wheel (``spec.wheel_joints`` order), rad/s."""
        self.data.ctrl[: len(self._wheel_bodies)] = speeds_rad_s

    def command_steering(self, angles_rad) -> None:
        """Steering-joint targets, rad (``spec.steer_joints`` order; servos after the wheel motors)."""
        n = len(self._wheel_bodies)
        self.data.ctrl[n : n + len(angles_rad)] = angles_rad

    def step(self) -> None:
        """One trial step of ``dt_s``: ``substeps`` times ``mj_step1``, the tyre forces into
        ``xfrc_applied``, ``mj_step2``, then the contacts."""
        if self._fast is not None:
            self._step_compiled()
            return
        m, d = self.model, self.data
        each = self.contact.tyres_each_substep
        last = self.substeps - 1
        pushed = self._base_force
        if pushed is not None and not self._forces:
            d.xfrc_applied[self._chassis, 0:3] = pushed
        for k in range(self.substeps):
            if each or k == 0:
                mujoco.mj_step1(m, d)
                if self._forces:
                    self._apply_tyres()
                mujoco.mj_step2(m, d)
            else:
                mujoco.mj_step(m, d)  # the tyre forces of this trial step held in xfrc_applied
            if each or k == last:
                self._read_contacts()
        if pushed is not None:
            self._base_force = None
            if not self._forces:
                d.xfrc_applied[self._chassis] = 0.0

    def _step_compiled(self) -> None:
        """:meth:`step` with the compiled tyre loop (offroadbench.sim.engines.mujoco._tyres_c): the same
        sequence, the contacts read and the forces applied outside the interpreter."""
        m, d = self.model, self.data
        tc, f, ist = self._fast
        each = self.contact.tyres_each_substep
        last = self.substeps - 1
        pushed = self._base_force
        push = 14 * len(self._loads) + tc.F_PUSH_X
        if pushed is not None:
            f[push:push + 3] = pushed
            f[push + 3] = 1.0
        qvel, xmat, xipos, xfrc = d.qvel, d.xmat, d.xipos, d.xfrc_applied
        step1, step2, apply, read = mujoco.mj_step1, mujoco.mj_step2, tc.APPLY, tc.READ
        for k in range(self.substeps):
            if each or k == 0:
                step1(m, d)
                apply(qvel, xmat, xipos, xfrc, f, ist)
                step2(m, d)
            else:
                mujoco.mj_step(m, d)  # the tyre forces of this trial step held in xfrc_applied
            if each or k == last:
                con = d.contact
                read(con.geom, con.dist, con.pos, con.frame, con.efc_address, d.efc_force, f, ist)
        if pushed is not None:
            self._base_force = None
            f[push + 3] = 0.0

    def _apply_tyres(self) -> None:
        """The tyre forces (``coulomb``: of the wheels touched in the last step; ``terramechanics``:
        of every wheel on the soil), as forces and torques about each wheel's centre of mass in
        ``xfrc_applied`` (one write of all rows)."""
        d, core = self.data, self._tyres
        xfrc = self._xfrc
        xfrc[:] = self._xfrc_zero
        if self._base_force is not None:
            k = 6 * self._chassis
            xfrc[k:k + 3] = self._base_force
        if self._soil is not None:
            self._soil_forces(xfrc)
        elif any(core.touch):
            touch = core.touch
            qvel = d.qvel.tolist()
            r = d.xmat[self._chassis].tolist()
            xipos = d.xipos.tolist()
            v0, v1, v2 = qvel[0:3]
            wb0, wb1, wb2 = qvel[3:6]
            w0 = r[0] * wb0 + r[1] * wb1 + r[2] * wb2
            w1 = r[3] * wb0 + r[4] * wb1 + r[5] * wb2
            w2 = r[6] * wb0 + r[7] * wb1 + r[8] * wb2
            c0 = xipos[self._chassis]
            for i, b in enumerate(self._wheel_bodies):
                if not touch[i]:
                    continue
                c = xipos[b]
                if self._articulated:  # the wheel body's own velocity (steering, rockers, bogies)
                    vel = np.zeros(6)
                    mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)
                    fx, fy, fz, px, py, pz = core.wheel_force(i, c, tuple(vel[3:].tolist()), tuple(vel[:3].tolist()))
                    ox, oy, oz = px - c[0], py - c[1], pz - c[2]
                    k = 6 * b
                    xfrc[k:k + 6] = (fx, fy, fz, oy * fz - oz * fy, oz * fx - ox * fz, ox * fy - oy * fx)
                    continue
                rx, ry, rz = c[0] - c0[0], c[1] - c0[1], c[2] - c0[2]
                lin = (v0 + w1 * rz - w2 * ry, v1 + w2 * rx - w0 * rz, v2 + w0 * ry - w1 * rx)
                a0, a1, a2 = self._axis_world(i, r)
                s = qvel[self._wheel_qvel[i]]
                fx, fy, fz, px, py, pz = core.wheel_force(i, c, lin, (w0 + a0 * s, w1 + a1 * s, w2 + a2 * s))
                ox, oy, oz = px - c[0], py - c[1], pz - c[2]
                k = 6 * b
                xfrc[k:k + 6] = (fx, fy, fz, oy * fz - oz * fy, oz * fx - ox * fz, ox * fy - oy * fx)
        d.xfrc_applied.flat[:] = xfrc

    def _soil_forces(self, xfrc: list) -> None:
        """The soil's force and torque on each wheel (offroadbench.sim.tyre_laws.soil_wheels) into
        ``xfrc`` rows, from the wheels' poses and velocities now. The force acts at the wheel's centre
        of mass, taken as its centre (both shipped vehicles' wheels have it on the axle)."""
        d, soil = self.data, self._soil
        qvel = d.qvel.tolist()
        r = d.xmat[self._chassis].tolist()
        xipos = d.xipos.tolist()
        v0, v1, v2 = qvel[0:3]
        wb0, wb1, wb2 = qvel[3:6]
        w0 = r[0] * wb0 + r[1] * wb1 + r[2] * wb2
        w1 = r[3] * wb0 + r[4] * wb1 + r[5] * wb2
        w2 = r[6] * wb0 + r[7] * wb1 + r[8] * wb2
        c0 = xipos[self._chassis]
        soil.begin()
        for i, b in enumerate(self._wheel_bodies):
            c = xipos[b]
            if self._articulated:  # the wheel body's own velocity and axle (steering, rockers, bogies)
                vel = np.zeros(6)
                mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)
                axis = tuple(d.xaxis[self._wheel_jnt[i]].tolist())
                out = soil.wheel_force(i, c, axis, tuple(vel[3:].tolist()), tuple(vel[:3].tolist()))
                if out is not None:
                    k = 6 * b
                    xfrc[k:k + 6] = (*out[0], *out[1])
                continue
            rx, ry, rz = c[0] - c0[0], c[1] - c0[1], c[2] - c0[2]
            lin = (v0 + w1 * rz - w2 * ry, v1 + w2 * rx - w0 * rz, v2 + w0 * ry - w1 * rx)
            a0, a1, a2 = self._axis_world(i, r)
            s = qvel[self._wheel_qvel[i]]
            out = soil.wheel_force(i, c, (a0, a1, a2), lin, (w0 + a0 * s, w1 + a1 * s, w2 + a2 * s))
            if out is not None:
                k = 6 * b
                xfrc[k:k + 6] = (*out[0], *out[1])

    def _axis_world(self, i: int, r: list) -> tuple[float, float, float]:
        a = self._wheel_axis[i]  # in the chassis frame (the wheels hang straight off it)
        return (r[0] * a[0] + r[1] * a[1] + r[2] * a[2],
                r[3] * a[0] + r[4] * a[1] + r[5] * a[2],
                r[6] * a[0] + r[7] * a[1] + r[8] * a[2])

    def _read_contacts(self) -> None:
        """Each wheel's terrain contacts of the step just taken: normal loads, penetration, and the
        tyre model's sums (normal force, force-weighted point and normal)."""
        d = self.data
        n = d.ncon
        loads = self._loads
        for i in range(len(loads)):
            loads[i] = 0.0
        self._penetration = 0.0
        core = self._tyres
        if core is not None:
            core.clear()
        if n == 0:
            if core is not None:
                core.release_untouched()
            return
        con = d.contact
        geoms = con.geom[:n].tolist()
        dists = con.dist[:n].tolist()
        pos = con.pos[:n].tolist()
        frames = con.frame[:n].tolist()
        adr = con.efc_address[:n].tolist()
        efc = d.efc_force
        terrain, wheel_geom = self._terrain_geom, self._wheel_geom
        coulomb = core is not None
        acc = core.acc if coulomb else None
        touch = core.touch if coulomb else None
        force = np.zeros(6)
        deepest = 0.0
        for k in range(n):
            g1, g2 = geoms[k]
            if g1 == terrain:
                slot, sign = wheel_geom.get(g2), 1.0
            elif g2 == terrain:
                slot, sign = wheel_geom.get(g1), -1.0
            else:
                continue
            if slot is None:
                continue
            if -dists[k] > deepest:
                deepest = -dists[k]
            if adr[k] < 0:
                continue
            if coulomb:
                fn = float(efc[adr[k]])
            else:
                mujoco.mj_contactForce(self.model, d, k, force)
                fn = float(force[0])
            if fn <= 0.0:
                continue
            loads[slot] += fn
            if coulomb:
                p, f = pos[k], frames[k]
                b = 7 * slot
                touch[slot] = True
                acc[b] += fn
                acc[b + 1] += fn * p[0]
                acc[b + 2] += fn * p[1]
                acc[b + 3] += fn * p[2]
                acc[b + 4] += fn * sign * f[0]
                acc[b + 5] += fn * sign * f[1]
                acc[b + 6] += fn * sign * f[2]
        self._penetration = deepest
        if coulomb:
            core.release_untouched()

    def base_state(self) -> tuple[tuple, tuple, tuple, tuple]:
        """(centre-of-mass position, quaternion xyzw, linear velocity, angular velocity), world frame."""
        q = self.data.qpos.tolist()
        v = self.data.qvel.tolist()
        w, x, y, z = q[3:7]
        r = self.rotation_matrix((x, y, z, w))
        wb = v[3:6]
        ang = (r[0] * wb[0] + r[1] * wb[1] + r[2] * wb[2],
               r[3] * wb[0] + r[4] * wb[1] + r[5] * wb[2],
               r[6] * wb[0] + r[7] * wb[1] + r[8] * wb[2])
        return (q[0], q[1], q[2]), (x, y, z, w), (v[0], v[1], v[2]), ang

    def rotation_matrix(self, quat: tuple) -> tuple:
        """Row-major 3x3 rotation matrix (body -> world) of a unit quaternion (x, y, z, w)."""
        x, y, z, w = quat
        return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w),
                2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w),
                2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y))

    def wheel_penetration_m(self) -> float:
        """Deepest penetration of any wheel into the terrain in the last step (0 if none), m; with the
        ``terramechanics`` tyre model, the deepest soil sinkage."""
        if self._fast is not None:
            return self._fast[0].penetration(self._fast[1], len(self._loads))
        if self._soil is not None:
            return max((v[0] for v in self._soil.last.values()), default=0.0)
        return self._penetration

    def wheel_slip(self) -> float | None:
        """Mean longitudinal slip of the wheels on the soil in the last step (1: spinning in place),
        or None without the ``terramechanics`` tyre model or with no wheel on the soil."""
        if self._soil is None or not self._soil.last:
            return None
        slips = [v[1] for v in self._soil.last.values()]
        return sum(slips) / len(slips)

    def wheel_loads_n(self) -> tuple[float, ...]:
        """Each wheel's summed normal force from the terrain in the last step, N (left, then right)."""
        if self._fast is not None:
            return self._fast[0].loads(self._fast[1], len(self._loads))
        return tuple(self._loads)

    def centre_of_mass_m(self) -> tuple[float, float, float]:
        """The whole vehicle's centre of mass in the world, m."""
        m, d = self.model, self.data
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        return tuple(d.subtree_com[self._chassis].tolist())

    def push_base(self, fx: float, fy: float, fz: float) -> None:
        """An external force on the chassis at its centre of mass during the next step, N (world frame)."""
        self._base_force = (fx, fy, fz)

    def set_gravity(self, gx: float, gy: float, gz: float) -> None:
        """Gravity vector, m/s^2."""
        self.model.opt.gravity[:] = (gx, gy, gz)

    def ray_height(self, x_m: float, y_m: float) -> float:
        """Height of the terrain's collision surface at (x, y) by a vertical ray, m (NaN off the map)."""
        top = self.hm.z_max_m + 1.0
        dist = mujoco.mj_rayHfield(self.model, self.data, self._terrain_geom, np.array([x_m, y_m, top]),
                                   np.array([0.0, 0.0, -1.0]))
        return float("nan") if dist < 0 else top - dist

