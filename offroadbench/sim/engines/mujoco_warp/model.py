"""The host half of the batched engine: one MuJoCo model of one vehicle holding K terrains.

:class:`BatchModel` is the MuJoCo engine's own world (offroadbench.sim.engines.mujoco.world.MuJoCoWorld:
the same URDF -> MJCF translation, contact tuning, servo gains and measured geometry) built on
an *envelope* of the batch's terrains, with one height field per terrain in its assets. The
terrains must share their grid (rows, columns, cell size); the envelope spans the lowest and the
highest height of them all, and every height field is written as ``(z - z_low) / (z_high - z_low)``
in float32 with that one size, so the one terrain geom (placed at ``z_low``) shows terrain k
wherever the geom's ``geom_dataid`` is k: MuJoCo Warp batches that field per world
(``put_model(m, batch_sizes={"geom_dataid": nworld})``).

The model stays a CPU MuJoCo model: its data is used only for kinematics at a spawn (where the
vehicle is put down clear of its own terrain, as MuJoCoWorld.spawn does) and by nothing else.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim.config import SimConfig
from offroadbench.sim.engines.mujoco.queries import hfield_ray_height, subtree_com
from offroadbench.sim.engines.mujoco.world import MuJoCoWorld
from offroadbench.sim.trial.vehicle import VehicleSpec
from offroadbench.sim.tyre_laws.coulomb import bristle_constants

__all__ = ["BatchModel", "envelope"]


def envelope(terrains: list[Heightmap]) -> Heightmap:
    """A Heightmap of the terrains' common grid whose heights span the lowest and highest of them
    all (the size every height field of the batch model is given); an InputError if the grids differ."""
    first = terrains[0]
    for hm in terrains[1:]:
        if (hm.rows, hm.cols, hm.cell_size_m) != (first.rows, first.cols, first.cell_size_m):
            raise InputError(f"engine 'mujoco_warp': one batch's terrains must share a grid; got {first.rows}x"
                             f"{first.cols} at {first.cell_size_m} m and {hm.rows}x{hm.cols} at {hm.cell_size_m} m")
    lo = min(hm.z_min_m for hm in terrains)
    hi = max(hm.z_max_m for hm in terrains)
    z = np.full((first.rows, first.cols), lo)
    z[0, 0] = hi if hi > lo else lo + 1.0
    return Heightmap(z=z, cell_size_m=first.cell_size_m)


class BatchModel(MuJoCoWorld):
    """The MuJoCo model of ``vehicle`` with one height field per terrain of ``terrains`` (same grid).

    ``hfield_ids[k]`` is terrain k's height field; :meth:`spawn_qpos` puts the vehicle down on
    one of them. The MuJoCo engine's own collision functions and tyre loops are built but never
    stepped here (MuJoCo Warp steps the model)."""

    def __init__(self, terrains: list[Heightmap], vehicle: VehicleSpec | str, sim: SimConfig) -> None:
        self.terrains = list(terrains)
        if not sim.mujoco.tyres_each_substep:
            raise InputError("engine 'mujoco_warp': [sim.mujoco] tyres_each_substep = false is not supported (the "
                             "device kernels apply the tyre and soil forces at every MuJoCo step); allowed: true")
        super().__init__(envelope(self.terrains), vehicle, sim)
        if self._articulated:
            raise InputError(f"engine 'mujoco_warp': vehicle {self.spec.name!r} has steering or suspension joints; "
                             "only vehicles whose wheels hang straight off the chassis are supported")
        self.hfield_ids = tuple(range(len(self.terrains)))

    def _mjcf(self) -> str:
        """The MuJoCo engine's MJCF with K - 1 more height fields of the same size."""
        root = ET.fromstring(super()._mjcf())
        asset = root.find("asset")
        first = asset.find("hfield")
        for k in range(1, len(self.terrains)):
            ET.SubElement(asset, "hfield", {**first.attrib, "name": f"terrain_{k}"})
        return ET.tostring(root, encoding="unicode")

    def _write_heights(self, block_rows: int = 64) -> None:
        """Each terrain's heights into its height field, normalised to the envelope (float32)."""
        m, env = self.model, self.hm
        lo, span = env.z_min_m, env.relief_m
        for k, hm in enumerate(self.terrains):
            adr, cols = int(m.hfield_adr[k]), hm.cols
            for r0 in range(0, hm.rows, block_rows):
                block = (hm.z[r0:r0 + block_rows] - lo) / span
                m.hfield_data[adr + r0 * cols:adr + r0 * cols + block.size] = block.astype(np.float32).ravel()

    def spawn_qpos(self, terrain: int, x_m: float, y_m: float, heading_rad: float, roll_rad: float = 0.0) -> np.ndarray:
        """The vehicle's joint positions at a spawn on terrain ``terrain``: at (x, y) facing
        ``heading_rad``, rolled by ``roll_rad``, its lowest point ``sim.spawn_clearance_m`` above
        the terrain within its reach: MuJoCoWorld.spawn's pose, before the settle."""
        self._place(self.terrains[terrain], x_m, y_m, heading_rad, roll_rad)
        return self.data.qpos.copy()

    def centre_of_mass_at(self, qpos) -> tuple[float, float, float]:
        """The whole vehicle's centre of mass at joint positions ``qpos``, m (host kinematics)."""
        self.data.qpos[:] = qpos
        return subtree_com(self.model, self.data, self._chassis)

    def ray_height(self, terrain: int, x_m: float, y_m: float) -> float:
        """Height of terrain ``terrain``'s collision surface at (x, y) by a vertical ray, m (NaN off the map)."""
        m = self.model
        return self._ray_height(m, terrain, x_m, y_m)

    def _ray_height(self, m, terrain: int, x_m: float, y_m: float) -> float:
        m.geom_dataid[self._terrain_geom] = self.hfield_ids[terrain]
        try:
            return hfield_ray_height(m, self.data, self._terrain_geom, x_m, y_m, self.terrains[terrain].z_max_m + 1.0,
                                     kinematics=True)
        finally:
            m.geom_dataid[self._terrain_geom] = self.hfield_ids[0]

    def layout(self) -> dict:
        """What the device kernels need of the model: wheel bodies, their spin dofs' qvel addresses
        and axes (chassis frame), the chassis body, the terrain geom, each geom's wheel slot, the
        number of left wheels, and the tyre constants (friction coefficient, bristle step s,
        stiffness N/m, damping N s/m) of the MuJoCo engine's CoulombBristles."""
        k, c = bristle_constants(self._mass_kg / len(self._wheel_bodies), self.dt_s)
        dt = self._dt_mj  # tyres_each_substep: the only setting this engine accepts (__init__)
        slot = [self._wheel_geom.get(g, -1) for g in range(self.model.ngeom)]
        return {"wheel_bodies": list(self._wheel_bodies), "wheel_qvel": list(self._wheel_qvel),
                "wheel_axes": [list(a) for a in self._wheel_axis], "chassis": self._chassis,
                "terrain_geom": self._terrain_geom, "geom_slot": slot, "n_left": self._n_left,
                "mu": self.spec.wheel_friction * self.sim.terrain_friction, "dt": dt, "k": k, "c": c}

    def soil_layout(self) -> dict:
        """What the soil kernels (offroadbench.sim.engines.mujoco_warp.soil_kernels) need under the
        ``terramechanics`` tyre model: the float64 constants (``soil_kernels.CONSTS``, the MuJoCo
        engine's own SoilWheels built for this vehicle, soil and step), the grid and table sizes,
        the soil tables (sinkage, F_z, F_x, T, F_y one after the other, float64), each terrain's
        heights (row-major, float64, one row per terrain), and the tables' top penetration, m."""
        from offroadbench.sim.tyre_laws.soil_wheels import MAX_LATERAL_SLIP, RESISTANCE_FADE_M_S
        from offroadbench.sim.tyre_laws.terramechanics import LAMBDA_SCALE

        soil = self._soil
        if self.spec.track_contact_length_m:
            raise InputError(f"engine 'mujoco_warp': vehicle {self.spec.name!r} is tracked; its belts' soil law "
                             "(belt segments) is not on the device: use engine 'mujoco'")
        t = soil.tables
        hm = self.terrains[0]
        consts = {"radius_m": soil._r, "dt_s": soil._dt, "damping_n_s_m": soil._c, "relaxation_m": soil._sx,
                  "lateral_relaxation_m": soil._sy, "cell_m": hm.cell_size_m, "delta_max_m": t.delta_max_m,
                  "k_series_n_m": t.k_series_n_m, "lambda_scale": LAMBDA_SCALE, "max_lateral_slip": MAX_LATERAL_SLIP,
                  "fade_m_s": RESISTANCE_FADE_M_S}
        tables = np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in (t.sinkage, t.fz, t.fx, t.torque, t.fy)])
        heights = np.stack([np.asarray(h.z, dtype=np.float64).ravel() for h in self.terrains])
        return {"consts": consts, "ints": [hm.rows, hm.cols, t.n_delta, t.n_slip, t.n_lat], "tables": tables,
                "heights": heights, "delta_max_m": float(t.delta_max_m)}
