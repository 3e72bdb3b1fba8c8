"""A batch of missions on one terrain: classify, sample, drive, summarise (``offroadbench drive``).

:func:`drive_missions` is the whole ``drive`` command as a library call: it classifies the
terrain and closes its rough areas (Majhor & Bos 2023, Sec. 2.3-2.4), samples ``n`` straight
missions on the closed map, drives them in one PyBullet World and returns a :class:`DriveRun`
with the missions, one :class:`~offroadbench.sim.trial.runner.TrialResult` per mission, each trial's
20 Hz telemetry (in memory) and the summary of Eq. 5. It writes no file and prints nothing.

Importing this module does not import pybullet; calling :func:`drive_missions` does.

Seeds (:mod:`offroadbench.seeding`). ``seed`` is a root seed, as a study's ``root_seed``: the
run is terrain 0 of it (whose integer seed :func:`~offroadbench.seeding.terrain_seed` gives;
``offroadbench drive`` builds its preset terrains from it) and mission k is drawn alone from
``mission_seed(seed, 0, k)``. So ``drive --seed s`` drives the missions of terrain 0 of a paired
study with ``root_seed = s``, and the same seed gives the same missions and the same table.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from offroadbench.analysis.roughness import RoughnessConfig
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission, MissionConfig
from offroadbench.progress import ProgressFn
from offroadbench.seeding import mission_seed
from offroadbench.sim.config import ControllerConfig, FailureRules, SimConfig

__all__ = ["DriveRun", "drive_missions", "SUMMARY_MEDIANS"]

#: metrics whose median over the successful trials the summary reports
SUMMARY_MEDIANS = ("traversal_time_s", "rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s")


@dataclass(frozen=True, eq=False)
class DriveRun:
    """The missions driven on one terrain and what happened on each."""

    heightmap: Heightmap
    """The terrain."""
    closed: np.ndarray
    """Closed class map the missions were drawn on (0 low, 1 semi, 2 high)."""
    mission_config: MissionConfig
    """How the missions were drawn."""
    vehicle_name: str
    """Name of the vehicle driven."""
    sim: SimConfig
    """Physics settings used."""
    missions: tuple[Mission, ...]
    """The missions, in sampling order."""
    mission_seeds: tuple[int, ...] = ()
    """Each mission's seed (offroadbench.seeding.mission_seed), same order."""
    terrain_seed: int | None = None
    """The terrain's seed (what ``offroadbench generate --seed`` takes), None for a terrain not
    generated from a seed (e.g. read from a PNG)."""
    results: tuple = ()
    """One TrialResult per mission, same order."""
    telemetry: Mapping[int, Mapping[str, np.ndarray]] = field(default_factory=dict)
    """Mission index -> telemetry columns (offroadbench.sim.trial.runner.TELEMETRY_COLUMNS)."""
    planner: str = "straight"
    """Name of the planner or policy that drove."""
    paths: Mapping[int, np.ndarray] = field(default_factory=dict)
    """Mission index -> planned waypoints (N, 2), map metres (a policy's: start and goal)."""
    beliefs: Mapping[int, Any] = field(default_factory=dict)
    """Mission index -> what the ``mast`` sensor left (offroadbench.navigation.sensor.Belief); empty for the oracle."""
    settings: Any = None
    """The TrialSettings the missions were driven with (offroadbench.sim.trial.pipeline), the
    terrain's gravity and soil filled in."""

    @property
    def summary(self) -> dict[str, float]:
        """``trials``, ``successes``, ``success_rate_pct`` (Majhor & Bos 2023, Eq. 5) and the
        median of each of :data:`SUMMARY_MEDIANS` over the successful trials (NaN if none)."""
        from offroadbench.navigation.metrics import success_rate

        ok = [r for r in self.results if r.success]
        out = {
            "trials": float(len(self.results)),
            "successes": float(len(ok)),
            "success_rate_pct": success_rate([r.success for r in self.results]),
        }
        for col in SUMMARY_MEDIANS:
            out[f"median_{col}"] = float(np.median([getattr(r, col) for r in ok])) if ok else math.nan
        return out

    def rows(self) -> list[dict]:
        """One flat row per trial: the terrain and mission seeds, then ``TrialResult.as_row()``."""
        return [
            {"terrain_seed": self.terrain_seed, "mission_seed": mseed, **r.as_row()}
            for r, mseed in zip(self.results, self.mission_seeds, strict=True)
        ]


def drive_missions(
    hm: Heightmap,
    n: int,
    seed: int,
    *,
    terrain_seed: int | None = None,
    length_m: float = 35.0,
    vehicle="husky",
    sim: SimConfig = SimConfig(),
    controller: ControllerConfig = ControllerConfig(),
    rules: FailureRules = FailureRules(),
    roughness: RoughnessConfig = RoughnessConfig(),
    planner="straight",
    settings=None,
    gravity_m_s2: float | None = None,
    soil: str | None = None,
    progress: ProgressFn | None = None,
    soil_map=None,
) -> DriveRun:
    """Sample ``n`` missions of ``length_m`` on ``hm`` from the root ``seed`` and drive them all.

    Mission k is drawn alone from ``mission_seed(seed, 0, k)`` (see the module docstring);
    ``terrain_seed`` is only recorded (the seed ``hm`` was generated from, if any).

    ``vehicle`` is a VehicleSpec or a vehicle name / ``vehicle.toml`` path; ``planner`` a planner or
    policy name (offroadbench.navigation) or a PlannerChoice, planning on the closed map inside the
    mission border. An impossible
    request (a map too small for the mission length, no low-roughness start) is an InputError
    raised before any physics runs.

    ``settings`` (a TrialSettings, as ``offroadbench drive`` builds from its options) replaces
    ``length_m``, ``vehicle``, ``sim``, ``controller``, ``rules``, ``roughness`` and ``planner``
    (its ``missions`` give the length and border; ``n`` the count). ``gravity_m_s2`` and ``soil``
    are the terrain's (offroadbench.sim.trial.pipeline.terrain_body), used where ``sim`` leaves
    them open; so is ``soil_map`` (offroadbench.terrain.soil_map.soil_map_for), used where ``sim``
    names no soil.
    """
    from offroadbench.navigation.planners import PlannerChoice, planner_from_table
    from offroadbench.sim.trial.pipeline import TrialSettings, drive_terrain, prepare_terrain
    from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle

    if settings is None:
        choice = planner if isinstance(planner, PlannerChoice) else planner_from_table({"name": planner},
                                                                                       where="planner")
        spec = vehicle if isinstance(vehicle, VehicleSpec) else load_vehicle(vehicle)
        settings = TrialSettings(vehicle=spec, sim=sim, controller=controller, rules=rules, roughness=roughness,
                                 missions=MissionConfig(count=n, length_m=length_m, border_m=roughness.border_m),
                                 planner=choice)
    settings = settings.replace(missions=dataclasses.replace(settings.missions, count=n))
    mseeds = tuple(mission_seed(seed, 0, k) for k in range(n))
    prepared = prepare_terrain(hm, terrain_seed, settings, list(enumerate(mseeds)), gravity_m_s2=gravity_m_s2,
                               soil=soil, soil_map=soil_map)
    records = list(drive_terrain(prepared, settings, progress=progress))
    sim = prepared.sim_for(settings.sim)
    return DriveRun(
        heightmap=hm, closed=prepared.maps.closed, mission_config=settings.missions,
        vehicle_name=settings.vehicle.name, sim=sim, missions=prepared.missions, mission_seeds=mseeds,
        terrain_seed=terrain_seed, results=tuple(r.result for r in records),
        telemetry={r.result.mission_index: r.telemetry for r in records}, planner=settings.planner.name,
        paths={r.result.mission_index: r.path_xy for r in records}, settings=settings.replace(sim=sim),
        beliefs={r.result.mission_index: r.belief for r in records if r.belief is not None},
    )
