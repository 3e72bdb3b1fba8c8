"""The vehicle half of offroadbench.sim.engines.mujoco.world.MuJoCoWorld's compiled model: its
indices (the terrain geom, the chassis, the wheels' joints, bodies, geoms and axes, the struts), its
mass, its measured geometry (offroadbench.sim.engine.VehicleGeometry) and its placement at a spawn
(clear of the terrain, from its geoms' world-axis bounding boxes)."""

from __future__ import annotations

import math

import mujoco

from offroadbench.heightmap import Heightmap
from offroadbench.sim.engine import VehicleGeometry
from offroadbench.sim.engines.base import spawn_height_m, suspension_rest_m

__all__ = ["VehicleBody"]


class VehicleBody:
    """The vehicle half of offroadbench.sim.engines.mujoco.world.MuJoCoWorld: indices, mass, geometry, placement."""

    def _index(self) -> None:
        """The compiled model's ids and addresses of the terrain geom, the chassis, the wheels (joints,
        bodies, velocity and position addresses, axes, geoms) and the struts, and whether a wheel moves
        with more than the chassis (``_articulated``)."""
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
        self._strut_qpos = [int(m.jnt_qposadr[mujoco.mj_name2id(m, obj.mjOBJ_JOINT, n)]) for n in self.spec.suspension_joints]
        self._spring_rest_m = suspension_rest_m(self.spec, self.sim.gravity_m_s2)
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
            lo = [min(a, b) for a, b in zip(lo, glo, strict=True)]
            hi = [max(a, b) for a, b in zip(hi, ghi, strict=True)]
            if g in self._wheel_geom:
                wheel_lo_z, wheel_front = min(wheel_lo_z, glo[2]), max(wheel_front, ghi[0])
            elif m.geom_bodyid[g] == self._chassis:
                chassis_lo_z, chassis_front = min(chassis_lo_z, glo[2]), max(chassis_front, ghi[0])
        centres = [d.xipos[b].tolist() for b in self._wheel_bodies]
        spins = []
        for b, j, axis in zip(self._wheel_bodies, self._wheel_qvel, self._wheel_axis, strict=True):
            own = sum(abs(a) * i for a, i in zip(axis, m.body_inertia[b].tolist(), strict=True))
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

    def _place(self, hm: Heightmap, x_m: float, y_m: float, heading_rad: float, roll_rad: float) -> None:
        """Reset all state (``mj_resetData``) and set the vehicle's joint positions at a spawn on ``hm``:
        at (x, y) facing ``heading_rad``, rolled by ``roll_rad``, its lowest point
        ``sim.spawn_clearance_m`` above the terrain within its reach, its struts at rest."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        cr, sr = math.cos(0.5 * roll_rad), math.sin(0.5 * roll_rad)
        ch, sh = math.cos(0.5 * heading_rad), math.sin(0.5 * heading_rad)
        d.qpos[0:3] = (x_m, y_m, (self._z_max_m if hm is self.hm else hm.z_max_m) + 10.0)
        d.qpos[3:7] = (ch * cr, ch * sr, sh * sr, sh * cr)  # w x y z of yaw(heading) * roll
        for adr in self._strut_qpos:  # a sprung vehicle's struts at rest in this gravity
            d.qpos[adr] = self._spring_rest_m
        mujoco.mj_kinematics(m, d)
        lows, reach = [], 0.0
        base = d.xipos[self._chassis].tolist()
        for g in range(m.ngeom):
            if g != self._terrain_geom:
                glo, ghi = self._geom_box(g)
                lows.append(glo[2])
                if m.geom_bodyid[g] == self._chassis:
                    reach = max(reach, 0.5 * math.hypot(ghi[0] - glo[0], ghi[1] - glo[1]))
        d.qpos[2] = spawn_height_m(hm, x_m, y_m, reach, self.spec.wheel_radius_m, base[2] - min(lows),
                                   self.sim.spawn_clearance_m)
