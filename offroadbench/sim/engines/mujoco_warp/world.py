"""One world of a MuJoCo Warp batch seen as a TrialWorld (offroadbench.sim.engine), and the engine
``mujoco_warp``'s own TrialWorld (a batch of one).

:class:`WorldView` is world w of a :class:`~offroadbench.sim.engines.mujoco_warp.batch.WarpBatch`.
Its :meth:`~WorldView.step` only counts: the physics of the counted steps runs when the trial next
reads the state or sets a command (:meth:`WorldView.sync`, given by whoever owns the batch: the
lock-step scheduler of offroadbench.sim.engines.mujoco_warp.runner, which advances the whole batch
once every world waits, or :class:`WarpWorld`, which advances its batch of one). The trial runner
(offroadbench.sim.trial.runner.drive_mission) reads the state at its telemetry and control ticks
only, so the batch is advanced, and read to the host, once per trial tick.

Not supported here (each an InputError naming it): pushing the chassis (``push_base``) and
turning gravity (``set_gravity``) inside a lock-step batch; a soil map (``use_soil_map``: the
``terramechanics`` soil kernels hold one soil's tables, as the MuJoCo engine's compiled loop,
which falls back to its Python loop for a map); vehicles with articulated wheels or tracks.
"""

from __future__ import annotations

from typing import Callable

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim.config import SimConfig
from offroadbench.sim.engines.base import settle
from offroadbench.sim.engines.mujoco_warp import soil_kernels
from offroadbench.sim.engines.mujoco_warp.batch import WarpBatch, rotation_matrix
from offroadbench.sim.engines.mujoco_warp.model import BatchModel
from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["WarpWorld", "WorldView"]


class WorldView:
    """World ``world`` of ``batch``, on terrain ``terrain`` of its model; ``sync(view)`` runs the
    view's counted steps (and returns once its state is current)."""

    def __init__(self, batch: WarpBatch, world: int, terrain: int, sync: Callable[[WorldView], None]) -> None:
        model = batch.model
        self.batch, self.world, self.terrain = batch, world, terrain
        self.hm: Heightmap = model.terrains[terrain]
        self.sim: SimConfig = model.sim
        self.spec: VehicleSpec = model.spec
        self.dt_s = model.dt_s
        self.geometry = model.geometry
        self.pending = 0
        """Trial steps counted by :meth:`step` and not yet run."""
        self._sync = sync

    def sync(self) -> None:
        """Run the counted steps, if any."""
        if self.pending:
            self._sync(self)

    def close(self) -> None:
        """Nothing to free (the batch owns the device data)."""

    def __enter__(self) -> WorldView:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def spawn(self, x_m: float, y_m: float, heading_rad: float, roll_rad: float = 0.0) -> None:
        """Reset the world, put the vehicle at rest above (x, y) facing ``heading_rad`` and let it settle
        with braked wheels for ``sim.settle_time_s`` (counted steps; MuJoCoWorld.spawn's pose)."""
        self.sync()
        qpos = self.batch.model.spawn_qpos(self.terrain, x_m, y_m, heading_rad, roll_rad)
        self.batch.reset(self.world, qpos, self.terrain)
        settle(self)

    def command_wheels(self, left_rad_s: float, right_rad_s: float) -> None:
        """Velocity targets of the left and right wheels, rad/s (torque-limited by the actuators)."""
        self.sync()
        b = self.batch
        b.ctrl[self.world, :b.n_left] = left_rad_s
        b.ctrl[self.world, b.n_left:b.nwheel] = right_rad_s

    def command_wheel_speeds(self, speeds_rad_s) -> None:
        """One velocity target per wheel (``spec.wheel_joints`` order), rad/s."""
        self.sync()
        self.batch.ctrl[self.world, :self.batch.nwheel] = speeds_rad_s

    def step(self) -> None:
        """Count one trial step (run at the next :meth:`sync`)."""
        self.pending += 1

    def advance(self, n: int) -> None:
        """Count ``n`` trial steps (TrialWorld.step n times; the trial runner's steps between ticks)."""
        self.pending += n

    def base_state(self) -> tuple[tuple, tuple, tuple, tuple]:
        """(centre-of-mass position, quaternion xyzw, linear velocity, angular velocity), world frame."""
        self.sync()
        return self.batch.base_state(self.world)

    def rotation_matrix(self, quat: tuple) -> tuple:
        """Row-major 3x3 rotation matrix (body -> world) of a unit quaternion (x, y, z, w)."""
        return rotation_matrix(quat)

    def wheel_penetration_m(self) -> float:
        """Deepest penetration of any wheel into the terrain in the last MuJoCo step (0 if none), m;
        under the ``terramechanics`` tyre model, the deepest soil sinkage."""
        self.sync()
        return float(self.batch.host.penetration[self.world])

    def wheel_slip(self) -> float | None:
        """Mean longitudinal slip of the wheels on the soil in the last MuJoCo step (1: spinning in
        place), or None under the ``coulomb`` tyre model or with no wheel on the soil."""
        if self.batch.soil is None:
            return None
        self.sync()
        host = self.batch.host
        return soil_kernels.slip(host.soil[self.world], host.on[self.world])

    def wheel_outside_model(self) -> bool | None:
        """True when a wheel on the soil bottomed out in the last MuJoCo step (outside the soil
        model), None under the ``coulomb`` tyre model."""
        if self.batch.soil is None:
            return None
        self.sync()
        host = self.batch.host
        return soil_kernels.outside(host.soil[self.world], host.on[self.world], self.batch.delta_max_m)

    def dropped_contacts(self) -> int:
        """Terrain contacts the batch took out of the solver in this world since its spawn (settling
        included; kernels.drop_false_contacts, summed over the MuJoCo steps: HostState.dropped), as
        of the last state read: not synced, so the steps counted since then (a trial's last steps
        to its timeout, never read) are not run for it, and a batch advances as it would without."""
        return int(self.batch.host.dropped[self.world])

    def use_soil_map(self, soil_map) -> None:
        """Not supported: the soil kernels hold one soil's tables."""
        raise InputError("engine 'mujoco_warp' cannot read a soil map (its soil kernels hold one soil's tables); "
                         "use engine 'mujoco'")

    def wheel_loads_n(self) -> tuple[float, ...]:
        """Each wheel's summed normal force from the terrain in the last MuJoCo step, N (left, then
        right); zero under the ``terramechanics`` tyre model (no wheel contact is read, as on the
        MuJoCo engine)."""
        self.sync()
        return tuple(self.batch.host.loads[self.world].tolist())

    def centre_of_mass_m(self) -> tuple[float, float, float]:
        """The whole vehicle's centre of mass in the world, m (host kinematics of the world's pose)."""
        self.sync()
        return self.batch.model.centre_of_mass_at(self.batch.host.qpos[self.world])

    def push_base(self, fx: float, fy: float, fz: float) -> None:
        """An external force on the chassis at its centre of mass during the next step, N (world frame)."""
        raise InputError("engine 'mujoco_warp': push_base is supported only on a world of its own (WarpWorld)")

    def set_gravity(self, gx: float, gy: float, gz: float) -> None:
        """Not supported: the batch's gravity is its model's."""
        raise InputError("engine 'mujoco_warp' cannot turn gravity (set_gravity); use engine 'mujoco'")

    def ray_height(self, x_m: float, y_m: float) -> float:
        """Height of the terrain's collision surface at (x, y) by a vertical ray, m (NaN off the map)."""
        return self.batch.model.ray_height(self.terrain, x_m, y_m)


class WarpWorld(WorldView):
    """The engine ``mujoco_warp`` as a TrialWorld: one terrain, one vehicle, a batch of one world on
    the device of ``[sim.mujoco_warp]``; its counted steps run when the state is read."""

    def __init__(self, hm: Heightmap, vehicle: VehicleSpec | str = "husky", sim: SimConfig = SimConfig()) -> None:
        cfg = sim.mujoco_warp
        model = BatchModel([hm], vehicle, sim)
        batch = WarpBatch(model, [0], device=cfg.device, nconmax=cfg.nconmax, njmax=cfg.njmax,
                      cuda_graph=cfg.cuda_graph)
        super().__init__(batch, 0, 0, WarpWorld._advance)
        self._push = False

    @staticmethod
    def _advance(view: WorldView) -> None:
        n, view.pending = view.pending, 0
        if view._push:  # the pushed force acts during the next step only
            view.batch.advance(1)
            view.batch.pushed[0] = 0.0
            view._push = False
            n -= 1
        if n:
            view.batch.advance(n)

    def push_base(self, fx: float, fy: float, fz: float) -> None:
        """An external force on the chassis at its centre of mass during the next step, N (world frame)."""
        self.sync()
        self.batch.pushed[0] = (fx, fy, fz)
        self._push = True

    def close(self) -> None:
        """Drop the device data."""
        self.batch = None
