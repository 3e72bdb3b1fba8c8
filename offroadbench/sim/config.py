"""Frozen settings of a traversal trial: physics, controller and failure rules.

Each loads from a TOML table with :func:`offroadbench.config.from_dict`, so a study file can
carry ``[sim]``, ``[controller]`` and ``[rules]`` tables.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from offroadbench.config import check_choice, check_int, check_range
from offroadbench.errors import InputError
from offroadbench.navigation.rules import FailureRules  # noqa: F401  (re-exported: a study's [rules] table)
from offroadbench.sim.engine import ENGINES, TYRE_MODELS, engine_capabilities
from offroadbench.sim.engines.mujoco.settings import MuJoCoConfig
from offroadbench.sim.engines.mujoco_warp.settings import MuJoCoWarpConfig

__all__ = ["SimConfig", "ControllerConfig", "FailureRules", "TYRE_MODELS", "EARTH_GRAVITY_M_S2", "tile_spans"]

#: gravity of a trial whose study and terrain name none, m/s^2
EARTH_GRAVITY_M_S2 = 9.81
#: smallest tiled heightfield side, cells (smaller tiles only add bodies and seams)
MIN_TILE_CELLS = 16


@dataclass(frozen=True, kw_only=True)
class SimConfig:
    """Physics and recording settings."""

    physics_rate_hz: int = 60
    """Bullet steps per simulated second. 60 Hz is the fastest rate that passes the physics
    sanity tests with sphere wheels (benchmarks/RESULTS.md, 'Traversal trials')."""
    telemetry_rate_hz: int = 20
    """Telemetry samples per second; the paper records at 20 Hz (Sec. 2.4)."""
    solver_iterations: int = 50
    """Bullet solver iterations per step: 10 let a parked vehicle creep under Bullet's friction, 100
    buy nothing over 50. 30 gave the same outcomes and vehicle-check rows but no measurable speed-up
    of a study (Bullet's solver mostly stops on its residual before either cap;
    benchmarks/RESULTS.md, 'Solver iterations')."""
    settle_time_s: float = 1.0
    """Time the vehicle rests with braked wheels after spawning, before the clock starts, s."""
    spawn_clearance_m: float = 0.02
    """Gap between the lowest point of the vehicle and the highest terrain under it at spawn, m."""
    gravity_m_s2: float | None = None
    """Magnitude of gravity, m/s^2. None: the terrain's body (its recipe's ``[body]``,
    offroadbench.bodies), else Earth's 9.81 (:meth:`for_terrain`)."""
    terrain_friction: float = 1.0
    """Friction coefficient of the terrain; Bullet multiplies it with the vehicle's."""
    heightfield_tile_cells: int = 256
    """Largest side of one terrain heightfield, in map cells. The map is split into near-equal tiles
    of at most this many cells, each its own Bullet heightfield; neighbouring tiles share their edge
    samples, so the surface is the same, but a wheel on a seam touches two shapes. Bullet's build
    of a heightfield holds a temporary render mesh of all its triangles (~0.7 GB for one 1009^2
    map); tiles cap that at one tile's share (offroadbench.sim.engines.pybullet.world). ``0`` builds one heightfield
    for the whole map (the build before 2026-11-23; results differ from tiled ones only through
    the seams' contacts)."""
    tyre_model: str = "coulomb"
    """Tyre-terrain friction (offroadbench.sim.engines.pybullet.tyres): ``bullet`` (Bullet's contact friction on
    the wheels, with the vehicle's wheel spin inertia) or ``coulomb`` (Bullet's wheel friction
    off; Coulomb forces against each contact's slip velocity, applied every step) or
    ``terramechanics`` (Bullet's wheel-terrain contact off; Wong-Reece soft-soil forces on each wheel
    every step, offroadbench.sim.engines.pybullet.soil, on the soil ``soil``)."""
    soil: str | None = None
    """Soil of the ``terramechanics`` tyre model: a soil name (``soils/*.toml``) or TOML path. None:
    the terrain's (its recipe's ``[soil] name``), else offroadbench.sim.tyre_laws.terramechanics.DEFAULT_SOIL."""
    cone_friction: bool | None = None
    """PyBullet's friction cone (``enableConeFriction``) for the contacts Bullet's solver owns:
    ``None`` (default) switches it off under the ``coulomb`` tyre model, where the wheels' Bullet
    friction is 0 and the cone's rows for their contacts are wasted solver work (about 17 % of
    the solver's time; the chassis' contacts then get Bullet's friction pyramid), and keeps it on
    under the other tyre models. ``True`` / ``False`` force it (benchmarks/RESULTS.md, 'Cone friction')."""
    drive_train_reaction: str | None = None
    """What the chassis feels of the wheels' drive-train spin inertia on PyBullet
    (offroadbench.sim.engines.pybullet.drivetrain): ``gear`` only the tyre's own inertia and the
    ground's torque react on the chassis, as through a gearbox and as MuJoCo's joint armature
    models it (the drive train's inertia sits on a grounded flywheel geared to the wheel); ``link``
    the whole ``wheel_spin_inertia_kg_m2`` sits on the wheel link and reacts in full (the model
    before 2026-11-26: it reared the Husky up 45 deg at launch in lunar gravity). None (default):
    ``gear``, except under the ``bullet`` tyre model, whose heading-independent turning needs the
    heavy wheel link in Bullet's own friction solve (offroadbench.sim.engines.pybullet.tyres: with
    ``gear`` a turn in place reaches 0.62 of its command at heading 0). MuJoCo's armature is always
    ``gear``."""
    engine: str = "pybullet"
    """Physics engine (offroadbench.sim.engine.ENGINES): ``pybullet`` (the paper's set-up, the
    default) or ``mujoco`` (offroadbench.sim.engines.mujoco.world; ``pip install 'offroadbench[mujoco]'``).
    Both run the same trial, tyre model, telemetry and failure rules."""
    mujoco: MuJoCoConfig = MuJoCoConfig()
    """The MuJoCo engine's own settings (the ``[sim.mujoco]`` table; the other engines ignore it)."""
    mujoco_warp: MuJoCoWarpConfig = MuJoCoWarpConfig()
    """The batched MuJoCo Warp engine's own settings (the ``[sim.mujoco_warp]`` table: device, worlds
    per batch, contact buffers; the other engines ignore it). Its model is ``[sim.mujoco]``'s."""

    def __post_init__(self) -> None:
        check_int(self, "physics_rate_hz", self.physics_rate_hz, lo=30, hi=2000)
        check_int(self, "telemetry_rate_hz", self.telemetry_rate_hz, lo=1, hi=self.physics_rate_hz)
        if self.physics_rate_hz % self.telemetry_rate_hz:
            raise InputError(
                f"SimConfig.telemetry_rate_hz = {self.telemetry_rate_hz} must divide "
                f"physics_rate_hz = {self.physics_rate_hz}"
            )
        check_int(self, "solver_iterations", self.solver_iterations, lo=1, hi=1000)
        check_int(self, "heightfield_tile_cells", self.heightfield_tile_cells, lo=0)
        if 0 < self.heightfield_tile_cells < MIN_TILE_CELLS:
            raise InputError(
                f"SimConfig.heightfield_tile_cells = {self.heightfield_tile_cells}: allowed 0 (one heightfield) "
                f"or {MIN_TILE_CELLS} or more cells"
            )
        check_range(self, "settle_time_s", self.settle_time_s, lo=0)
        check_range(self, "spawn_clearance_m", self.spawn_clearance_m, lo=0)
        if self.gravity_m_s2 is not None:
            check_range(self, "gravity_m_s2", self.gravity_m_s2, lo=0)
        if self.soil is not None and (not isinstance(self.soil, str) or not self.soil):
            raise InputError(f"SimConfig.soil = {self.soil!r}; must be a soil name or a .toml path")
        check_range(self, "terrain_friction", self.terrain_friction, lo=0, lo_open=True)
        check_choice(self, "tyre_model", self.tyre_model, TYRE_MODELS)
        check_choice(self, "engine", self.engine, ENGINES.names())
        if self.drive_train_reaction is not None:
            check_choice(self, "drive_train_reaction", self.drive_train_reaction, ("gear", "link"))
        if self.drive_train_reaction == "link" and self.engine != "pybullet":
            raise InputError(f"SimConfig.drive_train_reaction = 'link' is a PyBullet model; engine {self.engine!r} "
                             "always uses 'gear' (its joint armature)")
        models = engine_capabilities(self.engine).tyre_models  # the engine's own declaration
        if self.tyre_model not in models:
            raise InputError(f"SimConfig.tyre_model = {self.tyre_model!r} is not implemented on engine "
                             f"{self.engine!r}; allowed there: {', '.join(models)}")
        if self.cone_friction is not None and not isinstance(self.cone_friction, bool):
            raise InputError(f"SimConfig.cone_friction = {self.cone_friction!r}: allowed true, false or unset")

    @property
    def drive_train(self) -> str:
        """The drive-train reaction model in force (:attr:`drive_train_reaction` resolved)."""
        if self.drive_train_reaction is not None:
            return self.drive_train_reaction
        return "link" if self.tyre_model == "bullet" else "gear"

    def for_terrain(self, gravity_m_s2: float | None = None, soil: str | None = None) -> SimConfig:
        """This config with the terrain's gravity and soil where it leaves them open (None), and
        Earth's gravity and the default soil where the terrain names none either."""
        from offroadbench.sim.tyre_laws.terramechanics import DEFAULT_SOIL

        g = self.gravity_m_s2 if self.gravity_m_s2 is not None else gravity_m_s2
        return dataclasses.replace(self, gravity_m_s2=EARTH_GRAVITY_M_S2 if g is None else float(g),
                                   soil=self.soil or soil or DEFAULT_SOIL)


@dataclass(frozen=True, kw_only=True)
class ControllerConfig:
    """Pure pursuit on the planned path (the study's ``[planner]``; default the start-goal line), with
    a speed loop following a jerk-limited (ruckig) reference (offroadbench.sim.trial.controller)."""

    lookahead_m: float = 1.5
    """Pure-pursuit lookahead distance along the path, m (about 1.5 vehicle lengths)."""
    control_rate_hz: int = 20
    """Controller updates per second; must divide SimConfig.physics_rate_hz."""
    cruise_speed_m_s: float = 1.0
    """Target speed along the path, m/s (paper: 1 m/s); capped by the vehicle's max speed."""
    speed_gain_1_s: float = 1.0
    """Proportional gain of the wheel-speed command on the progress error (reference minus measured
    progress), 1/s (offroadbench.sim.trial.controller)."""
    speed_integral_gain_1_s2: float = 0.25
    """Integral gain on the progress error, 1/s^2; with ``speed_gain_1_s`` = 1 the error's poles are
    both at -0.5/s (critically damped)."""
    speed_lag_bound_m: float = 0.5
    """The speed reference is re-planned when the measured progress is more than this behind (or
    ahead of) it, m: it is moved to this distance from the vehicle, keeping its speed."""
    traction_slip_limit: float = 0.0
    """Traction control: hold the wheel-speed command to ``max(v, 0.1 v_cruise) / (1 - limit)`` of
    the measured speed ``v`` along the path, so the wheels slip at most about this much; 0: off
    (the default)."""

    def __post_init__(self) -> None:
        check_range(self, "lookahead_m", self.lookahead_m, lo=0, lo_open=True)
        check_int(self, "control_rate_hz", self.control_rate_hz, lo=1, hi=1000)
        check_range(self, "cruise_speed_m_s", self.cruise_speed_m_s, lo=0, lo_open=True)
        check_range(self, "speed_gain_1_s", self.speed_gain_1_s, lo=0)
        check_range(self, "speed_integral_gain_1_s2", self.speed_integral_gain_1_s2, lo=0)
        check_range(self, "speed_lag_bound_m", self.speed_lag_bound_m, lo=0, lo_open=True)
        check_range(self, "traction_slip_limit", self.traction_slip_limit, lo=0, hi=1, hi_open=True)


def tile_spans(cells: int, tile_cells: int) -> list[tuple[int, int]]:
    """Split ``cells`` grid cells (``cells + 1`` samples) into near-equal tiles of at most
    ``tile_cells`` cells: (first sample, last sample) per tile, neighbours sharing their edge sample.
    ``tile_cells = 0`` gives one tile."""
    n = 1 if tile_cells == 0 else max(1, -(-cells // tile_cells))
    edges = [round(i * cells / n) for i in range(n + 1)]
    return list(zip(edges[:-1], edges[1:], strict=True))
