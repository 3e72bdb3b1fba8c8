"""A batch of worlds on MuJoCo Warp: one vehicle, each world on its own terrain, stepped together.

:class:`WarpBatch` puts the host model (offroadbench.sim.engines.mujoco_warp.model.BatchModel: K
height fields) on a Warp device (``[sim.mujoco_warp] device``) with ``geom_dataid`` batched per
world, so world w's terrain geom reads terrain ``terrain_of[w]``. A trial step of every world is
``substeps`` MuJoCo steps, each ``step1`` (its collision checked: :meth:`WarpBatch.step1`), the tyre kernel (offroadbench.sim.engines.mujoco_warp.
kernels.apply_tyres), ``step2`` and the contact read: the sequence of the MuJoCo engine's
``MuJoCoTyres._step_compiled`` with ``tyres_each_substep``. The host talks to the device once per
:meth:`advance` (the commands and any resets go down, the state comes back in :attr:`host`), not
per MuJoCo step.

Worlds reset individually (:meth:`reset`): MuJoCo Warp's ``reset_data`` with a mask, then the new
pose written into that world's ``qpos`` (velocities zero) and its tyre state forgotten, as the
MuJoCo engine's ``mj_resetData`` before every spawn.
"""

from __future__ import annotations


import numpy as np
import warp as wp

wp.config.log_level = wp.LOG_WARNING  # before Warp initialises: no banner, no line per kernel module loaded
import mujoco_warp as mjw  # noqa: E402

from offroadbench.errors import InputError
from offroadbench.sim.engines.mujoco_warp import kernels, soil_kernels
from offroadbench.sim.engines.mujoco_warp.model import BatchModel

__all__ = ["WarpBatch"]


class HostState:
    """The batch's state as last read to the host: every world's ``qpos`` and ``qvel`` (float64
    copies of the device's float32), its wheels' normal loads (N) and deepest wheel penetration (m)."""

    def __init__(self, nworld: int, nq: int, nv: int, nwheel: int) -> None:
        self.qpos = np.zeros((nworld, nq))
        self.qvel = np.zeros((nworld, nv))
        self.loads = np.zeros((nworld, nwheel))
        self.penetration = np.zeros(nworld)
        self.soil = np.zeros((nworld, nwheel, soil_kernels.NCOL))
        """``terramechanics``: each wheel's soil state (soil_kernels' columns) after the last step."""
        self.on = np.zeros((nworld, nwheel), dtype=np.int32)
        """``terramechanics``: 1 where the wheel was on the soil in the last step."""
        self.dropped = np.zeros(nworld, dtype=np.int32)
        """Terrain contacts taken out of the solver since the world's reset (WarpBatch.step1)."""


class WarpBatch:
    """``nworld`` worlds of ``model`` on Warp device ``device`` (``cpu`` or ``cuda[:n]``), world w on
    terrain ``terrain_of[w]`` (an index into ``model.terrains``)."""

    def __init__(self, model: BatchModel, terrain_of, device: str = "cpu", nconmax: int = 64,
                 njmax: int = 256, cuda_graph: bool = True) -> None:
        wp.init()
        self.model = model
        found = [str(d) for d in wp.get_devices()]
        if device not in found and not (device == "cuda" and any(d.startswith("cuda") for d in found)):
            raise InputError(f"[sim.mujoco_warp] device = {device!r}: Warp finds no such device here "
                             f"(available: {', '.join(found)})")
        self.device = wp.get_device(device)
        self.nworld = nworld = len(terrain_of)
        m = model.model
        lay = model.layout()
        self.nwheel = nwheel = len(lay["wheel_bodies"])
        self.n_left = lay["n_left"]
        self.substeps = model.substeps
        self.terrain_of = np.asarray(terrain_of, dtype=np.int32)
        with wp.ScopedDevice(self.device):
            self.m = mjw.put_model(m, batch_sizes={"geom_dataid": nworld})
            self.m.opt.run_collision_detection = False  # collision runs in self.step1, checked
            dataid = self.m.geom_dataid.numpy()
            dataid[:, lay["terrain_geom"]] = self.terrain_of
            self.m.geom_dataid.assign(dataid)
            self.d = mjw.make_data(m, nworld=nworld, nconmax=nconmax, njmax=njmax)
            self.state = wp.zeros((nworld, nwheel, kernels.NCOL), dtype=wp.float64)
            self.touch = wp.zeros((nworld, nwheel), dtype=wp.int32)
            self.held = wp.zeros((nworld, nwheel), dtype=wp.int32)
            self.pen = wp.zeros(nworld, dtype=wp.float64)
            self.push = wp.zeros(nworld, dtype=wp.vec3)
            self.wheel_body = wp.array(lay["wheel_bodies"], dtype=wp.int32)
            self.wheel_qvel = wp.array(lay["wheel_qvel"], dtype=wp.int32)
            self.wheel_axis = wp.array(np.asarray(lay["wheel_axes"], dtype=np.float64), dtype=wp.vec3d)
            self.consts = wp.array(np.array([lay["mu"], lay["dt"], lay["k"], lay["c"]]), dtype=wp.float64)
            self.geom_slot = wp.array(lay["geom_slot"], dtype=wp.int32)
            self.mask = wp.zeros(nworld, dtype=wp.int32)
            self.dropped = wp.zeros(nworld, dtype=wp.int32)
            self.soil = None
            if model.sim.tyre_model == "terramechanics":  # the soil law in place of the tyre law
                sl = model.soil_layout()
                self.soil = wp.zeros((nworld, nwheel, soil_kernels.NCOL), dtype=wp.float64)
                self.on = wp.zeros((nworld, nwheel), dtype=wp.int32)
                self.soil_consts = wp.array([float(sl["consts"][k]) for k in soil_kernels.CONSTS], dtype=wp.float64)
                self.soil_ints = wp.array(sl["ints"], dtype=wp.int32)
                self.soil_tables = wp.array(sl["tables"], dtype=wp.float64)
                self.heights = wp.array(sl["heights"], dtype=wp.float64)
                self.terrain_dev = wp.array(self.terrain_of, dtype=wp.int32)
                self.delta_max_m = sl["delta_max_m"]
        self.chassis = lay["chassis"]
        self.terrain_geom = lay["terrain_geom"]
        self.ctrl = np.zeros((nworld, m.nu))
        self.pushed = np.zeros((nworld, 3))
        self._resets: dict[int, np.ndarray] = {}
        self.host = HostState(nworld, m.nq, m.nv, nwheel)
        self._states: list | None = None
        """Every world's base state as lists (:meth:`base_state`), None until next asked for."""
        self.steps = 0
        self.cuda_graph = cuda_graph
        """On a CUDA device: run :meth:`trial_step` as one captured CUDA graph (:meth:`advance`)."""
        self._graph = None
        """MuJoCo steps taken by every world so far (a world-step count is this times nworld)."""

    # ------------------------------------------------------------------ host -> device
    def reset(self, world: int, qpos: np.ndarray, terrain: int) -> None:
        """Reset world ``world`` to rest at ``qpos`` on terrain ``terrain`` (before the next :meth:`advance`)."""
        self._resets[world] = np.asarray(qpos, dtype=float)
        self.terrain_of[world] = terrain
        self.host.qpos[world] = qpos
        self.host.qvel[world] = 0.0
        self.host.loads[world] = 0.0
        self.host.penetration[world] = 0.0
        self.host.soil[world] = 0.0
        self.host.on[world] = 0
        self.host.dropped[world] = 0
        self._states = None

    def _apply_resets(self) -> None:
        if not self._resets:
            return
        mask = np.zeros(self.nworld, dtype=np.int32)
        mask[list(self._resets)] = 1
        with wp.ScopedDevice(self.device):
            self.mask.assign(mask)
            dataid = self.m.geom_dataid.numpy()
            dataid[:, self.terrain_geom] = self.terrain_of
            self.m.geom_dataid.assign(dataid)
            mjw.reset_data(self.m, self.d, wp.array(mask.astype(bool), dtype=bool))
            self.dropped.assign(np.where(mask == 1, 0, self.dropped.numpy()).astype(np.int32))
            qpos = self.d.qpos.numpy()
            for w, q in self._resets.items():
                qpos[w] = q
            self.d.qpos.assign(qpos)
            wp.launch(kernels.reset_worlds, dim=(self.nworld, self.nwheel),
                      inputs=[self.mask, self.state, self.touch, self.held, self.pen])
            if self.soil is not None:
                self.terrain_dev.assign(self.terrain_of)
                wp.launch(soil_kernels.reset_soil, dim=(self.nworld, self.nwheel), inputs=[self.mask, self.soil, self.on])
        self._resets.clear()

    # ------------------------------------------------------------------ stepping
    def step1(self) -> None:
        """MuJoCo Warp's ``step1`` with its collision run first and checked: the kinematics, the
        collision, then every terrain contact that cannot be the height field's (its normal points
        down, or its witness point on the terrain lies above it) taken out of the constraint solver
        (kernels.drop_false_contacts; counted in :attr:`HostState.dropped`), then
        ``step1`` itself, which makes the constraint rows from these contacts (the model's
        ``opt.run_collision_detection`` is off: MuJoCo Warp's way for contacts set by its user).
        The kinematics is computed twice; the contacts and every bit downstream are ``step1``'s
        own when no contact is dropped."""
        m, d = self.m, self.d
        mjw.kinematics(m, d)
        mjw.collision(m, d)
        con = d.contact
        wp.launch(kernels.drop_false_contacts, dim=d.naconmax,
                  inputs=[d.nacon, con.worldid, con.geom, con.dist, con.pos, con.frame, con.type, self.terrain_geom,
                          d.geom_xpos, m.geom_dataid, m.hfield_adr, m.hfield_nrow, m.hfield_ncol, m.hfield_size,
                          m.hfield_data, self.dropped])
        mjw.step1(m, d)

    def trial_step(self) -> None:
        """One trial step of every world, kernel launches only (no host exchange, so a CUDA graph can
        hold it): ``substeps`` times :meth:`step1`, the tyre law (kernels.apply_tyres) or the soil law
        (soil_kernels.apply_soil), ``step2`` and, for the tyres, the contact sums (``clear_sums``,
        ``read_contacts``, ``release_untouched``): the MuJoCo engine's ``_step_compiled`` /
        ``step_trial_soil`` with ``tyres_each_substep``. Under ``terramechanics`` no contact is read
        (the soil carries the wheels)."""
        d, m = self.d, self.m
        con = d.contact
        dim = (self.nworld, self.nwheel)
        for _ in range(self.substeps):
            self.step1()
            if self.soil is not None:
                wp.launch(soil_kernels.apply_soil, dim=dim,
                          inputs=[d.qvel, d.xmat, d.xipos, d.xfrc_applied, self.chassis, self.wheel_body,
                                  self.wheel_qvel, self.wheel_axis, self.soil_consts, self.soil_ints,
                                  self.soil_tables, self.heights, self.terrain_dev, self.push, self.soil, self.on])
                mjw.step2(m, d)
                continue
            wp.launch(kernels.apply_tyres, dim=dim,
                      inputs=[d.qvel, d.xmat, d.xipos, d.xfrc_applied, self.chassis, self.wheel_body,
                              self.wheel_qvel, self.wheel_axis, self.consts, self.push, self.state,
                              self.touch, self.held])
            mjw.step2(m, d)
            wp.launch(kernels.clear_sums, dim=dim, inputs=[self.state, self.touch, self.pen])
            wp.launch(kernels.read_contacts, dim=d.naconmax,
                      inputs=[d.nacon, con.worldid, con.geom, con.dist, con.pos, con.frame, con.type, con.efc_address,
                              d.efc.force, self.terrain_geom, self.geom_slot, self.state, self.touch, self.pen])
            wp.launch(kernels.release_untouched, dim=dim, inputs=[self.touch, self.held])

    def advance(self, trial_steps: int) -> None:
        """Every world ``trial_steps`` trial steps ahead with the commands in :attr:`ctrl` and
        :attr:`pushed`, then the state read into :attr:`host`: one host exchange.

        On a CUDA device with ``cuda_graph`` (``[sim.mujoco_warp] cuda_graph``, the default) the
        trial step is captured once as a CUDA graph (Warp's ScopedCapture, as MuJoCo Warp's own
        benchmarks capture ``step``) and launched ``trial_steps`` times; elsewhere its launches are
        issued one by one. Both run the same kernels on the same arrays in the same order."""
        self._apply_resets()
        d = self.d
        with wp.ScopedDevice(self.device):
            d.ctrl.assign(self.ctrl.astype(np.float32))
            self.push.assign(self.pushed.astype(np.float32))
            if self.cuda_graph and self.device.is_cuda:
                if self._graph is None:
                    with wp.ScopedCapture(device=self.device) as capture:
                        self.trial_step()
                    self._graph = capture.graph
                for _ in range(trial_steps):
                    wp.capture_launch(self._graph)
            else:
                for _ in range(trial_steps):
                    self.trial_step()
            self.steps += trial_steps * self.substeps
            self._read_host()

    def _read_host(self) -> None:
        """The state after an advance into :attr:`host` (the device's float32 widened): poses and
        velocities, the dropped-contact counts, and the tyres' loads and penetration or the soil's
        state, its on-soil flags and the deepest sinkage (_soil_c's readers; the wheel loads stay zero)."""
        d, host = self.d, self.host
        self._states = None  # base_state's table, made again at its next call
        host.qpos[:] = d.qpos.numpy()
        host.qvel[:] = d.qvel.numpy()
        host.dropped[:] = self.dropped.numpy()
        if self.soil is None:
            host.loads[:] = self.state.numpy()[:, :, kernels.LOAD]
            host.penetration[:] = self.pen.numpy()
            return
        host.soil[:] = self.soil.numpy()
        host.on[:] = self.on.numpy()
        host.penetration[:] = soil_kernels.penetrations(host.soil, host.on)

    def base_state(self, w: int) -> tuple[tuple, tuple, tuple, tuple]:
        """World ``w``'s (centre-of-mass position, quaternion xyzw, linear velocity, angular
        velocity) in the world frame, from :attr:`host` (:func:`base_states`, computed for every
        world at once after an advance or a reset)."""
        if self._states is None:
            self._states = np.column_stack(base_states(self.host.qpos, self.host.qvel)).tolist()
        s = self._states[w]
        return (s[0], s[1], s[2]), (s[3], s[4], s[5], s[6]), (s[7], s[8], s[9]), (s[10], s[11], s[12])


def base_states(qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every world's base state from its free joint's rows (``qpos`` (n, nq), ``qvel`` (n, nv),
    float64): 13 columns, the centre-of-mass position (3), the quaternion x, y, z, w renormalised
    (float32 storage on the device; 4), the linear (3) and the angular velocity (3) in the world
    frame: MuJoCoWorld.base_state's arithmetic, element-wise, each operation the one a world's
    scalar code does in the same order (numpy's +, -, *, / and sqrt round as Python's floats do),
    so the same bits."""
    qw, x, y, z = qpos[:, 3], qpos[:, 4], qpos[:, 5], qpos[:, 6]
    n = np.sqrt(qw * qw + x * x + y * y + z * z)
    qw, x, y, z = qw / n, x / n, y / n, z / n
    r = rotation_matrix((x, y, z, qw))
    w0, w1, w2 = qvel[:, 3], qvel[:, 4], qvel[:, 5]
    return (qpos[:, 0], qpos[:, 1], qpos[:, 2], x, y, z, qw, qvel[:, 0], qvel[:, 1], qvel[:, 2],
            r[0] * w0 + r[1] * w1 + r[2] * w2, r[3] * w0 + r[4] * w1 + r[5] * w2, r[6] * w0 + r[7] * w1 + r[8] * w2)


def rotation_matrix(quat: tuple) -> tuple:
    """Row-major 3x3 rotation matrix (body -> world) of a unit quaternion (x, y, z, w): floats, or
    arrays of many quaternions' components (element-wise, the same operations)."""
    x, y, z, w = quat
    return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w),
            2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w),
            2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y))
