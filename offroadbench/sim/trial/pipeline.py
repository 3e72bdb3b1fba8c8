"""The one trial pipeline: settings, a prepared terrain, and the function that drives its missions.

Every place that drives a terrain's missions (a study worker, ``offroadbench drive``, ``study
replay``, the report's replay figure, :func:`run_missions`) goes through
the same three steps:

1. :class:`TrialSettings`: every setting of a trial (vehicle, physics, controller, failure rules,
   missions, roughness classes, planner or policy, observation), frozen and nested, built once
   (:meth:`TrialSettings.from_tables` from a study cell's or a command's TOML tables).
2. :func:`prepare_terrain`: the terrain (a Heightmap, or a recipe and a seed), its roughness class
   maps (Majhor & Bos 2023, Eq. 3-4 and the closing, computed once and shared by the mission
   sampler and the planners), and its missions, each drawn alone from its seed (Sec. 2.3).
3. :func:`drive_terrain`: one World for the terrain, one :class:`~offroadbench.sim.trial.runner.TrialRecord`
   per mission, in the prepared order. Each mission gets a freshly loaded vehicle
   (:meth:`~offroadbench.sim.engines.pybullet.world.World.spawn`), so a record does not depend on the order.

Importing this module does not import pybullet; :func:`drive_terrain` does.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Sequence

import numpy as np

from offroadbench.analysis.roughness import ClassMaps, classify_terrain
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.memory import reusing_freed_blocks
from offroadbench.navigation.drivers import PlannerChoice
from offroadbench.navigation.missions import Mission, MissionConfig, mission_sites, sample_mission
from offroadbench.progress import ProgressFn, report
from offroadbench.sim.config import ControllerConfig, FailureRules, SimConfig
from offroadbench.sim.trial.settings import SETTINGS_TABLES, TrialSettings, settings_part  # noqa: F401  (re-exported)
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle

if TYPE_CHECKING:
    from offroadbench.sim.trial.runner import TrialResult

__all__ = ["TrialSettings", "SETTINGS_TABLES", "settings_part", "PreparedTerrain", "prepare_terrain", "drive_terrain", "run_missions",
           "terrain_body"]


@dataclass(frozen=True, eq=False)
class PreparedTerrain:
    """A terrain ready to drive: its heights, class maps and missions (in driving order)."""

    hm: Heightmap
    """The terrain."""
    maps: ClassMaps | None
    """Its roughness classes and closed map (None only for missions given directly to a
    driver that needs no class map)."""
    missions: tuple[Mission, ...]
    """The missions, in the order they are driven."""
    terrain_seed: int | None = None
    """The seed the terrain was generated from (None for a terrain read from a file)."""
    mission_seeds: tuple[int | None, ...] = ()
    """Each mission's seed (:func:`offroadbench.seeding.mission_seed`), same order."""
    gravity_m_s2: float | None = None
    """The gravity of the terrain's body (``[body]`` of its recipe; None: not named)."""
    soil: str | None = None
    """The terrain's soil (``[soil]`` of its recipe; None: not named); with a soil map, its default."""
    soil_map: Any = None
    """The terrain's soil map (offroadbench.terrain.soil_map.SoilMap; None: one soil everywhere)."""

    def sim_for(self, sim: SimConfig) -> SimConfig:
        """``sim`` with this terrain's gravity and soil where ``sim`` leaves them open (SimConfig.for_terrain)."""
        return sim.for_terrain(self.gravity_m_s2, self.soil)

    def soil_map_for(self, sim: SimConfig) -> Any:
        """The soil map the trials use: the terrain's, unless ``sim`` names a soil (which then lies everywhere)."""
        return self.soil_map if sim.soil is None else None


def terrain_body(terrain: Any = None, recipe: Any = None) -> tuple[float | None, str | None]:
    """(gravity m/s^2, soil name) that a terrain names, None for what it names none of: the
    ``[body]`` and ``[soil]`` of its recipe (``recipe``, or ``terrain`` itself when it is a Recipe),
    or those of the recipe stored in a 16-bit PNG's sidecar (``terrain`` a ``.png`` path); a bare
    Heightmap names neither. The one place a terrain's body and soil are read; SimConfig.for_terrain
    then fills what the settings leave open."""
    from offroadbench.terrain.recipe import Recipe

    if recipe is None and isinstance(terrain, Recipe):
        recipe = terrain
    if recipe is not None:
        return recipe.gravity_m_s2, recipe.soil
    if isinstance(terrain, (str, Path)) and str(terrain).lower().endswith(".png"):
        from offroadbench.bodies import terrain_gravity_and_soil
        from offroadbench.io.png16 import read_png16_metadata

        return terrain_gravity_and_soil(read_png16_metadata(terrain).get("recipe"))
    return None, None


def prepare_terrain(terrain, seed: int | None, settings: TrialSettings,
                    missions: Sequence[tuple[int, int]] | Sequence[Mission], *,
                    gravity_m_s2: float | None = None, soil: str | None = None,
                    soil_map: Any = None) -> PreparedTerrain:
    """The terrain, its class maps and its missions.

    ``terrain`` is a Heightmap (``seed`` is then only recorded; ``gravity_m_s2`` and ``soil`` say
    its body's gravity and its soil, if known, and ``soil_map`` its soil map) or a recipe
    (:class:`offroadbench.terrain.recipe.Recipe`, generated with ``seed``; its ``[body]`` and
    ``[soil]`` give gravity and soil). ``missions`` are
    ``(index, mission_seed)`` pairs, each drawn alone on the closed class map (Majhor & Bos 2023,
    Sec. 2.3), or Mission objects used as they are; either way in the order they will be driven.

    In a study worker the heap keeps the blocks the preparation frees for its next ones and returns
    them at the end (offroadbench.memory.reusing_freed_blocks); the results do not depend on it.
    """
    with reusing_freed_blocks():
        return _prepare(terrain, seed, settings, missions, gravity_m_s2, soil, soil_map)


def _prepare(terrain, seed, settings, missions, gravity_m_s2, soil, soil_map) -> PreparedTerrain:
    """:func:`prepare_terrain`'s work."""
    if isinstance(terrain, Heightmap):
        hm = terrain
    else:
        from offroadbench.terrain.recipe import generate_terrain
        from offroadbench.terrain.soil_map import soil_map_for

        hm = generate_terrain(terrain, seed)
        gravity_m_s2, soil = terrain_body(terrain)
        soil_map = soil_map_for(terrain, hm, seed)
    maps = classify_terrain(hm, settings.roughness)
    items = list(missions)
    if items and isinstance(items[0], Mission):
        drawn, seeds = tuple(items), (None,) * len(items)
    else:
        sites = mission_sites(hm, maps.closed, settings.missions) if items else None  # once per terrain
        drawn = tuple(sample_mission(hm, maps.closed, settings.missions, int(k), int(s), sites) for k, s in items)
        seeds = tuple(int(s) for _, s in items)
    return PreparedTerrain(hm=hm, maps=maps, missions=drawn, terrain_seed=seed, mission_seeds=seeds,
                           gravity_m_s2=gravity_m_s2, soil=soil, soil_map=soil_map)


def drive_terrain(prepared: PreparedTerrain, settings: TrialSettings, *,
                  progress: ProgressFn | None = None) -> Iterator[Any]:
    """Drive every prepared mission in one world of ``sim.engine`` (offroadbench.sim.engine.open_world),
    or, on an engine that declares a ``batch_module`` (``mujoco_warp``), as one batch of worlds; yield
    one TrialRecord per mission, in order, as it finishes."""
    from offroadbench.sim.trial.runner import drive_mission
    from offroadbench.sim.engine import engine_capabilities, open_world

    needs = settings.planner.needs
    if "classes" in needs and prepared.maps is None:
        raise InputError(f"planner {settings.planner.name!r} needs the terrain's class map; prepare the terrain first")
    classes = prepared.maps.closed if "classes" in needs else None
    n = len(prepared.missions)
    batched = engine_capabilities(settings.sim.engine).batch_module
    if batched is not None:  # the engine drives the terrain's missions as one batch of worlds
        import importlib

        try:
            module = importlib.import_module(batched)
        except ModuleNotFoundError as exc:
            raise InputError(f"engine {settings.sim.engine!r} needs the {exc.name} package, which is not installed "
                             f"(see the engine's extra in pyproject.toml)") from None
        yield from module.drive_terrain_batched(prepared, settings, progress=progress)
        return
    with open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim),
                    soil_map=prepared.soil_map_for(settings.sim)) as world:
        for i, mission in enumerate(prepared.missions):
            yield drive_mission(world, mission, settings=settings, classes=classes)
            report(progress, i + 1, n)


def run_missions(
    hm: Heightmap,
    missions: Sequence[Mission],
    *,
    vehicle: VehicleSpec | str = "husky",
    planner: PlannerChoice = PlannerChoice(),
    classes: np.ndarray | None = None,
    border_m: float = 0.0,
    controller: ControllerConfig = ControllerConfig(),
    sim: SimConfig = SimConfig(),
    rules: FailureRules = FailureRules(),
    progress: ProgressFn | None = None,
    telemetry_dir: str | Path | None = None,
) -> list[TrialResult]:
    """Run every mission on one terrain (built once) and return one TrialResult per mission.

    ``planner``, ``classes`` (a closed class map, used as it is) and ``border_m`` as in
    :func:`offroadbench.sim.trial.runner.drive_mission`; the missions are driven through
    :func:`drive_terrain`, in the order given. With ``telemetry_dir``
    the telemetry of each trial is saved there as ``mission_<index>.npz`` (see
    offroadbench.io.telemetry) and its planned path as ``mission_<index>_path.npz``.
    """
    from offroadbench.io.telemetry import save_telemetry

    out_dir = Path(telemetry_dir) if telemetry_dir is not None else None
    if out_dir is not None and not out_dir.is_dir():
        raise InputError(f"telemetry_dir {out_dir} is not a directory")
    spec = vehicle if isinstance(vehicle, VehicleSpec) else load_vehicle(vehicle)
    settings = TrialSettings(vehicle=spec, sim=sim, controller=controller, rules=rules, planner=planner,
                             missions=MissionConfig(border_m=border_m))
    maps = None if classes is None else ClassMaps(classes=np.asarray(classes), closed=np.asarray(classes),
                                                  cell_size_m=hm.cell_size_m, border_m=border_m)
    prepared = PreparedTerrain(hm=hm, maps=maps, missions=tuple(missions))
    results = []
    for rec in drive_terrain(prepared, settings, progress=progress):
        results.append(rec.result)
        if out_dir is not None:
            index = rec.result.mission_index
            save_telemetry(rec.telemetry, out_dir / f"mission_{index:03d}.npz")
            save_telemetry({"x_m": rec.path_xy[:, 0], "y_m": rec.path_xy[:, 1]}, out_dir / f"mission_{index:03d}_path.npz")
    return results