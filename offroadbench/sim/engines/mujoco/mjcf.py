"""URDF -> MJCF: the MuJoCo model of one terrain (a height field) and one vehicle (see
offroadbench.sim.engines.mujoco.world for the choices: the chassis frame at its centre of mass, the
drive train's spin inertia as armature, the tyres' stiffness and damping as solref)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from offroadbench.errors import InputError
from offroadbench.io.export.mujoco import mujoco_hfield_size
from offroadbench.sim.engines.base import UrdfLink, read_urdf


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


class MjcfBuilder:
    """The model-building half of offroadbench.sim.engines.mujoco.world.MuJoCoWorld."""

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
        missing = [n for n in spec.wheel_joints + spec.steer_joints + spec.differential_joints + spec.suspension_joints
                   if n not in by_name]
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
                pos = tuple(p - o for p, o in zip(j.pos, offset, strict=True))
                el = ET.SubElement(parent_el, "body", name=j.child, pos=_fmt(pos), euler=_fmt(j.euler))
                if j.kind in ("continuous", "revolute"):
                    jel = ET.SubElement(el, "joint", name=j.name, type="hinge", axis=_fmt(j.axis), damping="0")
                    if j.name in wheel_names and spec.wheel_spin_inertia_kg_m2 is not None:
                        own = abs(j.axis[0]) * link.inertia[0] + abs(j.axis[1]) * link.inertia[1] + abs(j.axis[2]) * link.inertia[2]
                        jel.set("armature", repr(max(0.0, spec.wheel_spin_inertia_kg_m2 - own)))
                elif j.kind == "prismatic" and j.name in spec.suspension_joints:
                    self._suspension_joint(el, j)
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

    def idle_stages(self) -> int:
        """MuJoCo's disable bits (``mjtDisableBit``) of the stages that do nothing for this model: the
        same bits with them off, less work (benchmarks/RESULTS.md, branch ``perf3``):

        - ``island``: constraint islands (``mj_island``, the solver per island) for one vehicle, one
          kinematic tree, whose constrained dofs are always one island;
        - ``spring`` and ``damper``, without suspension struts: no joint has a stiffness or a damping
          (the wheels' damping is 0; the drive train is armature and velocity actuators), so
          ``mj_passive``'s forces and implicitfast's passive-damping derivative are zero; both off
          skip them."""
        import mujoco

        bits = mujoco.mjtDisableBit
        off = int(bits.mjDSBL_ISLAND)
        if not self.spec.suspension_joints:
            off |= int(bits.mjDSBL_SPRING) | int(bits.mjDSBL_DAMPER)
        return off

    def _articulate(self, root, act, links, by_name) -> None:
        """Steering servos after the wheel motors (position actuators, stiff against the steered
        link's inertia about the steering axis, limited to the spec's steering torque) and the
        rockers' differential as a joint equality (angles opposite: the body pitches by the mean of
        the rockers'), for steered and rocker-bogie vehicles; a tracked vehicle's belts
        (``belt_drive``) as joint equalities (each side's wheels at one angle)."""
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
        if spec.belt_drive:
            # each side's road wheels turn as one belt: each wheel's angle equals the side's first wheel's
            # (offroadbench.sim.engines.pybullet.drivetrain.couple_belts: the same model on PyBullet), as
            # stiff as MuJoCo keeps stable (a time constant of two steps)
            eq = ET.SubElement(root, "equality")
            for side in (spec.left_wheel_joints, spec.right_wheel_joints):
                for name in side[1:]:
                    ET.SubElement(eq, "joint", joint1=name, joint2=side[0], polycoef="0 1 0 0 0",
                                  solref=_fmt((2.0 * self._dt_mj, 1.0)))

    def _suspension_joint(self, el, joint) -> None:
        """A suspension strut (VehicleSpec.suspension_*): a slide joint whose spring pushes the wheel down
        with ``preload + k q`` (MuJoCo's passive spring ``-k (q - springref)`` with ``springref = -preload / k``)
        and whose damper adds ``c q_dot``, its travel the URDF's limits (the PyBullet world applies the same
        forces explicitly: offroadbench.sim.engines.pybullet.world.World._spring_forces)."""
        spec = self.spec
        if joint.limits is None:
            raise InputError(f"URDF {spec.urdf}: suspension joint {joint.name} needs a <limit> (its travel)")
        k = spec.suspension_stiffness_n_m
        ET.SubElement(el, "joint", name=joint.name, type="slide", axis=_fmt(joint.axis), stiffness=repr(k),
                      springref=repr(-spec.suspension_preload_n / k), damping=repr(spec.suspension_damping_n_s_m),
                      range=_fmt(joint.limits), limited="true")

    def _add_link(self, el, link: UrdfLink, shift, *, is_wheel: bool, coulomb: bool, share: float) -> None:
        spec, sim, tune = self.spec, self.sim, self.contact
        com = tuple(c - s for c, s in zip(link.com, shift, strict=True))
        if link.mass > 0:
            ET.SubElement(el, "inertial", pos=_fmt(com), mass=repr(link.mass), diaginertia=_fmt(link.inertia))
        for kind, size, pos, euler in link.shapes:
            g = ET.SubElement(el, "geom", type=kind, size=_fmt(size), pos=_fmt(tuple(p - s for p, s in zip(pos, shift, strict=True))),
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
