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
  installed, else in Python (``[sim.mujoco] tyre_loop``, MuJoCoConfig); so do the
  ``terramechanics`` soil forces (``_soil_c``). Vehicles with articulated wheels keep the Python
  loops (the kernels take a wheel's velocity from the chassis' rigid motion and its spin). With
  the compiled loops a whole trial step is one compiled call (``_tyres_c.step_trial``,
  ``_soil_step_c.step_trial_soil``: MuJoCo's ``mj_step1`` / ``mj_step2`` called through their C
  addresses, no Python between them; the same bits).
- **Terrain collision**: ``[sim.mujoco] hfield_collision`` (offroadbench.sim.engines.mujoco._hfield_c):
  the sphere wheels' height-field contacts in closed form and the chassis box's early-out, installed in
  MuJoCo's collision table only during this world's own MuJoCo calls (``closed_form``, the default);
  the box's early-out alone (``exact``: MuJoCo's own contacts to the bit); or MuJoCo's own (``mujoco``).
- **Contact**: the tyres' vertical stiffness and damping (``tyre_stiffness_n_m``,
  ``tyre_damping_n_s_m``) as the wheels' ``solref = (time constant, damping ratio)``: the tyre's
  ``sqrt(m / k)`` and ``c / (2 sqrt(k m))`` for a wheel's share ``m`` of the mass, the time
  constant raised to two steps (MuJoCo's stable minimum; at 60 Hz the tyre is so softer than
  PyBullet's). MuJoCo's direct form ``(-k / m, -c / m)`` was tried: a sphere on a height field
  gets several contacts (the field is a union of prisms; counted after every trial step, the
  hfield's contacts with a wheel's geoms over the wheels with at least one: 2.66 a touching wheel
  for the Husky, median 2, 6 in 15 % of the wheel-steps, on 12 missions of 15 m on paper-d2.3 and
  paper-d2.45 cut to 601^2 cells; the Jackal 2.13; ``tests/sim/test_mujoco_contact_count.py``),
  each as stiff, and at 60 Hz the vehicle bounced off the ground. The chassis contact is MuJoCo's
  default, with the chassis' friction.
- **Reset**: ``mj_resetData`` before every spawn clears every piece of state, so results do not
  depend on the missions run before (bit-identical in any mission order).

Only the engine packages under offroadbench.sim.engines (this one, ``pybullet``, ``mujoco_warp``) import a
physics engine.
The model is built in ``mjcf.py`` (URDF -> MJCF), the tyre forces applied in ``tyres.py``, and the
vehicle indexed, measured and placed at a spawn in ``body.py``: the parts of :class:`MuJoCoWorld`.
"""

from __future__ import annotations

import functools
import logging
import math
import time

import mujoco
import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.sim.config import SimConfig
from offroadbench.sim.tyre_laws.coulomb import CoulombBristles, bristle_constants
from offroadbench.sim.tyre_laws.soil_wheels import soil_setup
from offroadbench.sim.engines.base import max_height_near, settle
from offroadbench.sim.engines.mujoco.settings import MUJOCO_CONTACT, ContactTuning
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle
from offroadbench.sim.engines.mujoco.kernels import compiled_loop, hfield_functions, soil_step, whole_step
from offroadbench.sim.engines.mujoco.mjcf import MjcfBuilder
from offroadbench.sim.engines.mujoco.queries import hfield_ray_height, subtree_com
from offroadbench.sim.engines.mujoco.tyres import MuJoCoTyres
from offroadbench.sim.engines.mujoco.body import VehicleBody

__all__ = ["MuJoCoWorld", "ContactTuning", "MUJOCO_CONTACT"]

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------- the world
class MuJoCoWorld(MuJoCoTyres, MjcfBuilder, VehicleBody):
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
        if type(self) is MuJoCoWorld:  # this engine's own steps (a subclass, the Warp batch's host model, keeps them)
            self.model.opt.disableflags |= self.idle_stages()
        self.data = mujoco.MjData(self.model)
        self._index()
        self._hfield = hfield_functions(contact.hfield_collision, self.model, self.data)
        log.info("MuJoCo world %dx%d built in %.2f s", hm.rows, hm.cols, time.perf_counter() - t0)
        self._mass_kg = self.geometry_mass()  # summed once
        self._tyres = None
        self._fast = None  # the compiled tyre loop's (module, float state, int state), if used
        self._step_arrays = None  # (qvel, xmat, xipos, xfrc_applied) views, for the compiled loop
        self._fast_step = None  # (mjModel, mjData addresses, MuJoCo's step functions, StepLayout tuple, table entries)
        self._step_call = None  # the compiled whole trial step with its arguments bound, for a step without a push
        self._steps_call = None  # the same for n trial steps in one call (its last two arguments: substeps, True)
        tc = None
        if sim.tyre_model == "coulomb":
            # the bristle of the PyBullet world (stiffness and damping from the trial's step, so the
            # tyre is the same whatever the engine's step), integrated at MuJoCo's step
            k, c = bristle_constants(self._mass_kg / len(self._wheel_bodies), self.dt_s)
            bristle = (len(self._wheel_bodies), self.spec.wheel_friction * sim.terrain_friction,
                       self._dt_mj if contact.tyres_each_substep else self.dt_s, k, c)
            self._tyres = CoulombBristles(*bristle)
            tc = self._loop_kernels(contact.tyre_loop, "_tyres_c")
        if tc is not None:
            slot = [self._wheel_geom.get(g, -1) for g in range(self.model.ngeom)]
            f, ist = tc.new_state(*bristle, self._wheel_bodies, self._wheel_qvel, self._wheel_axis, self._terrain_geom,
                                  self._chassis, slot)
            d = self.data
            tc.check_types(d.qvel, d.xmat, d.xipos, d.xfrc_applied, d.contact, d.efc_force)
            self._fast = (tc, f, ist)
            self._fast_step = whole_step(self.model, d, self._hfield)
            self._step_arrays = (d.qvel, d.xmat, d.xipos, d.xfrc_applied)  # views of fixed buffers: fetched once
            if self._fast_step is not None:  # the whole step's call with every argument bound (they never change)
                self._step_call = functools.partial(tc.STEP, *self._fast_step, *self._step_arrays, f, ist,
                                                    self.substeps, contact.tyres_each_substep)
                if contact.tyres_each_substep:  # every MuJoCo step alike: n trial steps are n * substeps of them
                    self._steps_call = functools.partial(tc.STEP, *self._fast_step, *self._step_arrays, f, ist)
        self._soil = None
        self._fast_soil = None  # the compiled soil loop's (module, float state, int state, tables), if used
        self._fast_soil_step = None  # (_soil_step_c.STEP, mjModel and mjData addresses, step functions, entries)
        if sim.tyre_model == "terramechanics":
            # the soil of the PyBullet world (tables and constants from the trial's step, the force
            # law offroadbench.sim.tyre_laws.soil_wheels), integrated at MuJoCo's step
            n = len(self._wheel_bodies)
            setup = soil_setup(self.spec, sim.soil, self._mass_kg, n, sim.gravity_m_s2, self.dt_s)
            self._soil = setup.wheels(n, hm, self.dt_s, self._dt_mj if contact.tyres_each_substep else self.dt_s)
            # the compiled loop holds wheel tables: a track's belt segments run in the Python loop
            sc = None if self.spec.track_contact_length_m else self._loop_kernels(contact.tyre_loop, "_soil_c")
            if sc is not None:
                f, ist, tab = sc.new_state(self._soil, hm, self._wheel_bodies, self._wheel_qvel, self._wheel_axis,
                                           self._chassis)
                d = self.data
                sc.check_types(d.qvel, d.xmat, d.xipos, d.xfrc_applied)
                self._fast_soil = (sc, f, ist, tab)
                self._fast_soil_step = soil_step(self.model, d, self._hfield)  # the whole step in one call
                self._step_arrays = (d.qvel, d.xmat, d.xipos, d.xfrc_applied)
        self._forces = self._tyres is not None or self._soil is not None  # tyre forces written each step
        self._loads = [0.0] * len(self._wheel_bodies)
        self._penetration = 0.0
        self._xfrc = [0.0] * (6 * self.model.nbody)  # xfrc_applied, row-major, written once per step
        self._xfrc_zero = [0.0] * (6 * self.model.nbody)
        self._base_force = None  # push_base's force for the next step
        self._last_rotation = None  # (quaternion, rotation matrix) of the last base_state
        self._z_max_m = hm.z_max_m  # the map's top, for every spawn (a scan of the whole map)
        self.geometry = self._measure_geometry()

    def _loop_kernels(self, choice: str, kernels: str):
        """The compiled loop's module (``_tyres_c`` or ``_soil_c``) for ``[sim.mujoco] tyre_loop =
        choice``, or None for the Python loop: also for a vehicle whose wheels move with more than the
        chassis (steering, rockers, bogies): the kernels take each wheel's velocity from the chassis'
        rigid motion and its spin, the Python loop from MuJoCo (``mj_objectVelocity``)."""
        module = compiled_loop(choice, kernels)
        if module is not None and self._articulated:
            log.info("vehicle %r has articulated wheels: the Python tyre loop", self.spec.name)
            return None
        return module

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Drop the model and data (MuJoCo frees them with the objects). Safe to call twice."""
        self.data = None
        self._fast_step = self._fast_soil_step = self._step_arrays = None  # the data's addresses and views
        self._step_call = self._steps_call = None

    def __enter__(self) -> MuJoCoWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _write_heights(self, block_rows: int = 64) -> None:
        """The map's heights into the model's height field, normalised to its relief (float32), in
        blocks of ``block_rows`` rows (elementwise, so the same bits as at once, without a float64
        copy of the whole map: offroadbench.memory.MUJOCO_BYTES_PER_CELL)."""
        hm = self.hm
        relief, z_min = hm.relief_m, hm.z_min_m
        out = self.model.hfield_data
        cols = hm.cols
        for r0 in range(0, hm.rows, block_rows):
            z = hm.z[r0:r0 + block_rows]
            block = (z - z_min) / relief if relief > 0 else np.zeros_like(z)
            out[r0 * cols:r0 * cols + block.size] = block.astype(np.float32).ravel()

    # ------------------------------------------------------------------ vehicle state
    def spawn(self, x_m: float, y_m: float, heading_rad: float, roll_rad: float = 0.0) -> None:
        """Reset all state (``mj_resetData``), put the vehicle at rest just above the terrain at (x, y),
        and let it settle for ``sim.settle_time_s`` with its wheels braked."""
        self._place(self.hm, x_m, y_m, heading_rad, roll_rad)
        self._forward()
        self._loads = [0.0] * len(self._loads)
        self._penetration = 0.0
        if self._tyres is not None:
            self._tyres.reset()
            self._tyres.clear()
        if self._fast is not None:
            self._fast[0].reset_state(self._fast[1], self._fast[2], len(self._loads))
        if self._soil is not None:
            self._soil.reset()
        if self._fast_soil is not None:
            self._fast_soil[0].reset_state(self._fast_soil[1], self._fast_soil[2], len(self._loads))
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

    def _forward(self) -> None:
        """``mj_forward`` with this world's height-field collision functions."""
        hf = self._hfield
        if hf is None:
            mujoco.mj_forward(self.model, self.data)
            return
        hf.install()
        try:
            mujoco.mj_forward(self.model, self.data)
        finally:
            hf.restore()

    def step(self) -> None:
        """One trial step of ``dt_s``: ``substeps`` times ``mj_step1``, the tyre forces into
        ``xfrc_applied``, ``mj_step2``, then the contacts; with this world's height-field collision
        functions in MuJoCo's table during those calls only (``[sim.mujoco] hfield_collision``)."""
        if self._step_call is not None and self._base_force is None:  # the compiled whole step, as _step_compiled calls it
            self._step_call()
            return
        hf = self._hfield
        whole = (self._fast_step if self._fast is not None else
                 self._fast_soil_step if self._fast_soil is not None else None)
        if hf is None or whole is not None:  # none, or the compiled step installs them itself
            self._advance()
            return
        hf.install()
        try:
            self._advance()
        finally:
            hf.restore()

    def _advance(self) -> None:
        """:meth:`step`'s MuJoCo calls and force loops."""
        if self._fast is not None:
            self._step_compiled()
            return
        if self._fast_soil is not None:
            self._step_soil_compiled()
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

    def base_state(self) -> tuple[tuple, tuple, tuple, tuple]:
        """(centre-of-mass position, quaternion xyzw, linear velocity, angular velocity), world frame."""
        q = self.data.qpos.tolist()
        v = self.data.qvel.tolist()
        w, x, y, z = q[3:7]
        quat = (x, y, z, w)
        r = self._rotation(quat)
        self._last_rotation = (quat, r)  # the caller's body frame (runner.body_frame) asks for it again
        wb = v[3:6]
        ang = (r[0] * wb[0] + r[1] * wb[1] + r[2] * wb[2],
               r[3] * wb[0] + r[4] * wb[1] + r[5] * wb[2],
               r[6] * wb[0] + r[7] * wb[1] + r[8] * wb[2])
        return (q[0], q[1], q[2]), quat, (v[0], v[1], v[2]), ang

    def rotation_matrix(self, quat: tuple) -> tuple:
        """Row-major 3x3 rotation matrix (body -> world) of a unit quaternion (x, y, z, w)."""
        last = self._last_rotation
        if last is not None and quat is last[0]:  # the quaternion base_state returned last: its matrix
            return last[1]
        return self._rotation(quat)

    @staticmethod
    def _rotation(quat: tuple) -> tuple:
        """:meth:`rotation_matrix`, computed."""
        x, y, z, w = quat
        return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w),
                2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w),
                2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y))

    def wheel_penetration_m(self) -> float:
        """Deepest penetration of any wheel into the terrain in the last step (0 if none), m; with the
        ``terramechanics`` tyre model, the deepest soil sinkage."""
        if self._fast is not None:
            return self._fast[0].penetration(self._fast[1], len(self._loads))
        if self._fast_soil is not None:
            return self._fast_soil[0].penetration(self._fast_soil[1], self._fast_soil[2], len(self._loads))
        if self._soil is not None:
            return max((v[0] for v in self._soil.last.values()), default=0.0)
        return self._penetration

    def use_soil_map(self, soil_map) -> None:
        """Each wheel's soil from ``soil_map`` (offroadbench.terrain.soil_map.SoilMap), read at its contact
        every step: the Python soil loop (the compiled loop holds one soil's tables)."""
        if self._soil is None:
            return
        n = len(self._wheel_bodies)
        setup = soil_setup(self.spec, self.sim.soil, self._mass_kg, n, self.sim.gravity_m_s2, self.dt_s, soil_map)
        self._soil = setup.wheels(n, self.hm, self.dt_s, self._dt_mj if self.contact.tyres_each_substep else self.dt_s)
        self._fast_soil = None

    def wheel_outside_model(self) -> bool | None:
        """True when a wheel on the soil bottomed out in the last step (outside the soil model), None
        without the ``terramechanics`` tyre model."""
        if self._fast_soil is not None:
            return self._fast_soil[0].outside(self._fast_soil[1], self._fast_soil[2], len(self._loads))
        return None if self._soil is None else self._soil.outside_model()

    def wheel_slip(self) -> float | None:
        """Mean longitudinal slip of the wheels on the soil in the last step (1: spinning in place),
        or None without the ``terramechanics`` tyre model or with no wheel on the soil."""
        if self._fast_soil is not None:
            return self._fast_soil[0].slip(self._fast_soil[1], self._fast_soil[2], len(self._loads))
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
        return subtree_com(self.model, self.data, self._chassis)

    def push_base(self, fx: float, fy: float, fz: float) -> None:
        """An external force on the chassis at its centre of mass during the next step, N (world frame)."""
        self._base_force = (fx, fy, fz)

    def set_gravity(self, gx: float, gy: float, gz: float) -> None:
        """Gravity vector, m/s^2."""
        self.model.opt.gravity[:] = (gx, gy, gz)

    def ray_height(self, x_m: float, y_m: float) -> float:
        """Height of the terrain's collision surface at (x, y) by a vertical ray, m (NaN off the map)."""
        return hfield_ray_height(self.model, self.data, self._terrain_geom, x_m, y_m, self.hm.z_max_m + 1.0)

