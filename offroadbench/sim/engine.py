"""The engine boundary: what a traversal trial needs from a physics engine.

A trial (offroadbench.sim.trial.runner), the vehicle check (offroadbench.sim.rigs.vehicle_check) and
the Gymnasium env talk to a physics engine only through a :class:`TrialWorld`: one terrain and one vehicle,
built when the world is opened. Its parts:

- **build terrain** (heightfield tiles or the engine's own height field) from a Heightmap, and
  **load a vehicle** from its :class:`~offroadbench.sim.trial.vehicle.VehicleSpec` (URDF + limits);
  the vehicle's measured geometry comes back once, as :class:`VehicleGeometry`
  (``world.geometry``), which the planners' envelope, the step rule and ``vehicle check`` read;
- **reset and spawn** the vehicle at rest above a point, settled;
- **command wheel speeds** (velocity control, torque-limited by the spec);
- **step** the physics (tyre forces included);
- **read** the base state, the wheel contacts (penetration, normal loads) and the vehicle's
  centre of mass; **turn gravity** (the vehicle check's tilt table);
- **cast a vertical ray** at the terrain.

Engines are looked up by name in :data:`ENGINES` (``SimConfig.engine``); :func:`open_world` opens
the configured one. Each engine is a package, ``offroadbench.sim.engines.<name>`` (its world, tyre
and soil contact), and only its own package imports the engine (``tests/test_architecture.py``);
what the engines share sits above them in ``offroadbench.sim.engines.base`` and the engine-neutral
force laws in ``offroadbench.sim.tyre_laws``. Importing this module imports no engine.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from offroadbench.errors import InputError
from offroadbench.registry import Registry

if TYPE_CHECKING:
    from offroadbench.heightmap import Heightmap
    from offroadbench.sim.config import SimConfig
    from offroadbench.sim.trial.vehicle import VehicleSpec

__all__ = ["ENGINES", "EngineCapabilities", "TYRE_MODELS", "TrialWorld", "VehicleGeometry", "engine_capabilities",
           "open_world"]

#: every tyre model (SimConfig.tyre_model); each engine declares which it implements
TYRE_MODELS = ("bullet", "coulomb", "terramechanics")


@dataclass(frozen=True, kw_only=True)
class VehicleGeometry:
    """The loaded vehicle as the engine built it, measured once when the vehicle is loaded.

    Measured in the air (no ground contact: unloaded tyres), at heading 0 (+x forward) with the
    wheels at joint angle 0, from the engine's own collision shapes and inertias. Lengths in
    metres; positions relative to the chassis' centre of mass (the point ``base_state`` reports).

    The belly is measured in the air, not on the settled vehicle: it is then a property of the
    model alone (no settle, no ground, no dependence on the tyre stiffness an engine implements),
    identical for every world of the vehicle, and it is what the planners have always used. On the
    settled Husky the belly is 1.3 mm lower (the compliant tyres' static sink, m g / (4 k)).
    """

    mass_kg: float
    """Total mass of all links, kg."""
    wheel_spin_inertia_kg_m2: tuple[float, ...]
    """Each wheel's moment of inertia about its axle as simulated, kg m^2 (spec order: left
    wheels, then right)."""
    wheel_centres_m: tuple[tuple[float, float, float], ...]
    """Each wheel's centre (x forward, y left, z up) relative to the chassis' centre of mass, m (spec order)."""
    length_m: float
    """Overall length of the vehicle's collision shapes along x, m."""
    width_m: float
    """Overall width of the vehicle's collision shapes along y, m."""
    belly_m: float
    """Height of the chassis' lowest point above the wheels' lowest points, m."""
    overhang: bool
    """True if the chassis reaches further forward than the front tyres (it strikes a step first)."""

    @property
    def wheelbase_m(self) -> float:
        """Distance between the front and rear wheel centres, m."""
        xs = [c[0] for c in self.wheel_centres_m]
        return max(xs) - min(xs)


@runtime_checkable
class TrialWorld(Protocol):
    """One terrain and one vehicle in a physics engine, built on construction (``Engine(hm,
    vehicle, sim)``) and freed by :meth:`close`; a context manager.

    Frames: world x east, y north, z up, the map's sample (r, c) at (c * cell, r * cell, z[r, c]);
    quaternions (x, y, z, w); angular velocities in the world frame.

    Optional, not a member (an engine without it is still a TrialWorld; the trial runner reads it
    with ``getattr`` at a trial's end): ``dropped_contacts() -> int | None``, the terrain contacts
    the engine took out of its solver since the last :meth:`spawn` (settling included), summed
    over its physics steps up to the last state read (a contact dropped in n steps counts n
    times); absent or None where the engine drops none by design (the row's
    TrialResult.dropped_contacts NaN).
    """

    hm: Heightmap
    """The terrain."""
    sim: SimConfig
    """The physics settings the world was built with."""
    spec: VehicleSpec
    """The vehicle."""
    dt_s: float
    """One physics step, s."""
    geometry: VehicleGeometry
    """The vehicle as loaded, measured once."""

    def close(self) -> None:
        """Free the engine's resources; safe to call twice."""

    def __enter__(self) -> TrialWorld: ...

    def __exit__(self, *exc) -> None: ...

    def spawn(self, x_m: float, y_m: float, heading_rad: float, roll_rad: float = 0.0) -> None:
        """Reset every piece of vehicle state, put the vehicle at rest just above the terrain at
        (x, y) facing ``heading_rad``, and let it settle for ``sim.settle_time_s`` with braked
        wheels. What ran before must not matter."""

    def command_wheels(self, left_rad_s: float, right_rad_s: float) -> None:
        """Velocity targets of the left and right wheels, rad/s, torque-limited by the spec."""

    def step(self) -> None:
        """One physics step of ``dt_s`` (tyre forces included)."""

    def base_state(self) -> tuple[tuple, tuple, tuple, tuple]:
        """(position m, quaternion xyzw, linear velocity m/s, angular velocity rad/s), world frame."""

    def rotation_matrix(self, quat: tuple) -> tuple:
        """Row-major 3x3 rotation matrix (body -> world) of a quaternion (x, y, z, w)."""

    def wheel_penetration_m(self) -> float:
        """Deepest penetration of any wheel into the terrain in the last step (0 if none), m."""

    def wheel_slip(self) -> float | None:
        """Mean longitudinal slip of the wheels on soft soil in the last step (1: spinning in place),
        or None where the tyre model has no soil (every model but ``terramechanics``)."""

    def wheel_outside_model(self) -> bool | None:
        """True when a wheel on the soil bottomed out in the last step (outside the soil model:
        offroadbench.sim.tyre_laws.soil_wheels.SoilWheels.outside_model), or None where the tyre
        model has no soil. Optional: the trial runner treats an engine without it as None."""

    def wheel_loads_n(self) -> tuple[float, ...]:
        """Each wheel's summed normal contact force from the terrain in the last step, N (spec
        order: left wheels, then right)."""

    def centre_of_mass_m(self) -> tuple[float, float, float]:
        """The whole vehicle's centre of mass in the world, m."""

    def push_base(self, fx: float, fy: float, fz: float) -> None:
        """An external force on the chassis at its centre of mass during the next step, N (world
        frame; the vehicle check's drawbar-pull rig)."""

    def set_gravity(self, gx: float, gy: float, gz: float) -> None:
        """Gravity vector, m/s^2 (the vehicle check tilts it to make a slope of a flat map)."""

    def ray_height(self, x_m: float, y_m: float) -> float:
        """Height of the terrain's collision surface at (x, y) by a vertical ray, m (NaN off the map)."""


@dataclass(frozen=True, kw_only=True)
class EngineCapabilities:
    """What an engine implements, declared by the engine itself (its package's ``CAPABILITIES``;
    a plug-in engine's factory may carry a ``capabilities`` attribute). SimConfig validates its
    ``tyre_model`` against it, and the rigs find their engine half through it."""

    tyre_models: tuple[str, ...]
    """The tyre models (SimConfig.tyre_model) the engine implements."""
    soil_rig_module: str | None = None
    """Module whose ``run_rig`` drives the single-wheel soil rig (offroadbench.sim.rigs.soil_check)
    on this engine; None: no rig."""
    settings: tuple[str, ...] = ()
    """The SimConfig keys that this engine alone reads (its own table, e.g. ``mujoco`` for
    ``[sim.mujoco]``, or keys of ``[sim]``); the other engines ignore them."""
    batch_module: str | None = None
    """Module whose ``drive_terrain_batched(prepared, settings, progress=...)`` drives a terrain's
    missions as one batch of worlds (offroadbench.sim.trial.pipeline.drive_terrain uses it in place
    of one world per mission); None: the engine runs one world at a time."""

    def soil_rig(self) -> Callable[..., tuple[float, float, float]]:
        """The engine's ``run_rig`` (imports the engine); an InputError where it has none."""
        if self.soil_rig_module is None:
            raise InputError("this engine has no single-wheel soil rig")
        return importlib.import_module(self.soil_rig_module).run_rig


def _lazy(module: str, name: str, package: str, extra: str, declared: str) -> Callable[..., TrialWorld]:
    """A constructor that imports its engine module only when a world is opened; a missing engine
    package is an InputError saying what to install. ``declared`` names the engine's package, whose
    ``CAPABILITIES`` (an :class:`EngineCapabilities`) it loads without importing the engine."""

    def make(hm, vehicle, sim):
        try:
            cls = getattr(importlib.import_module(module), name)
        except ModuleNotFoundError as exc:
            if exc.name != package:
                raise
            raise InputError(f"engine {sim.engine!r} needs the {package} package: "
                             f"pip install 'offroadbench[{extra}]'") from None
        return cls(hm, vehicle, sim)

    make.__qualname__ = make.__name__ = f"{name}_factory"
    make.__doc__ = f"Open a {module}.{name}."
    make.capabilities_module = declared
    return make


#: physics engines by name (``SimConfig.engine``): each a callable ``(hm, vehicle, sim) -> TrialWorld``;
#: installed packages add theirs through the entry-point group ``offroadbench.engines``
ENGINES: Registry[Callable[..., TrialWorld]] = Registry("physics engine", entry_point_group="offroadbench.engines")
ENGINES.add("pybullet", _lazy("offroadbench.sim.engines.pybullet.world", "World", "pybullet", "pybullet",
                              "offroadbench.sim.engines.pybullet"))
ENGINES.add("mujoco", _lazy("offroadbench.sim.engines.mujoco.world", "MuJoCoWorld", "mujoco", "mujoco",
                            "offroadbench.sim.engines.mujoco"))
ENGINES.add("mujoco_warp", _lazy("offroadbench.sim.engines.mujoco_warp.world", "WarpWorld", "mujoco_warp", "warp",
                                 "offroadbench.sim.engines.mujoco_warp"))


def engine_capabilities(name: str) -> EngineCapabilities:
    """What engine ``name`` declares it implements (importing no engine). A plug-in engine that
    declares nothing is taken to implement every tyre model and no soil rig."""
    factory = ENGINES.get(name)
    declared = getattr(factory, "capabilities_module", None)
    if declared is not None:
        return importlib.import_module(declared).CAPABILITIES
    caps = getattr(factory, "capabilities", None)
    return caps if isinstance(caps, EngineCapabilities) else EngineCapabilities(tyre_models=TYRE_MODELS)


def open_world(hm: Heightmap, vehicle: VehicleSpec | str, sim: SimConfig, soil_map=None) -> TrialWorld:
    """Build the world of ``sim.engine`` for terrain ``hm`` and ``vehicle`` (a spec or a name); with a
    ``soil_map`` (offroadbench.terrain.soil_map.SoilMap) and the ``terramechanics`` tyre model, each
    wheel reads its soil from the map (the engine's ``use_soil_map``; an InputError for an engine
    without one)."""
    world = ENGINES.get(sim.engine)(hm, vehicle, sim)
    if soil_map is not None and sim.tyre_model == "terramechanics":
        use = getattr(world, "use_soil_map", None)
        if use is None:
            world.close()
            raise InputError(f"engine {sim.engine!r} cannot read a soil map (no use_soil_map)")
        use(soil_map)
    return world
