"""The unit of work of a study: build one terrain, sample its missions, run its trials.

A :class:`TerrainTask` is plain picklable data (the resolved cell, the terrain's seed and the
pending missions with their seeds), so any worker (a local process, a Dask worker on another
machine) runs it without reading the study file. :func:`run_terrain` yields messages:

* :class:`TerrainBuilt` once the terrain is built and classified (its ``stats`` hold the class
  area fractions of Sec. 2.4, inside the border, before the closing);
* :class:`TrialDone` after each trial (its ``kept`` is None, or ``{"telemetry": columns,
  "path_xy": waypoints}`` when the task's ``telemetry`` setting keeps this trial's telemetry:
  ``failed``, failed trials only; ``all``).

The trial function is a parameter (``trial_fn(prepared, settings) -> iterator of rows``, or of
``TrialRecord``s that carry telemetry, one per prepared mission in order), so tests and benchmarks
can swap the physics for a cheap stand-in; :func:`~offroadbench.sim.trial.pipeline.drive_terrain` is the
real one (PyBullet). The terrain, its class maps and its missions come from
:func:`~offroadbench.sim.trial.pipeline.prepare_terrain` with the cell's
:class:`~offroadbench.sim.trial.pipeline.TrialSettings`, built once per cell.

Replays. :func:`replay_trial` re-runs one stored trial from the run directory alone (its recipe,
settings and seeds) and says whether the new row equals the stored one.

Seeds (:mod:`offroadbench.seeding`). The terrain is ``generate_terrain(recipe, terrain_seed)``;
mission k of terrain j is drawn alone from its ``mission_seed`` on the
closed class map (Majhor & Bos 2023, Sec. 2.3: start in low roughness, goal in low or semi, 35 m
apart, 5 m border), so it does not depend on which other missions are drawn or pending.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Mapping

from offroadbench.sim.trial.pipeline import PreparedTerrain, TrialSettings, drive_terrain, prepare_terrain
from offroadbench.study.spec import CellPlan

__all__ = ["TerrainTask", "TerrainBuilt", "TrialDone", "TrialFn", "run_terrain", "collect_terrain", "keeps_telemetry",
           "Replay", "replay_trial"]

#: ``trial_fn(prepared, settings) -> iterator of TrialRecords or TrialResult.as_row() dicts, one per
#: prepared mission, in order`` (see :func:`offroadbench.sim.trial.pipeline.drive_terrain`)
TrialFn = Callable[[PreparedTerrain, TrialSettings], Iterator[Any]]


@dataclass(frozen=True)
class TerrainTask:
    """One terrain of one grid cell and its pending missions ((index, seed) pairs)."""

    cell: CellPlan
    terrain: int
    terrain_seed: int
    missions: tuple[tuple[int, int], ...]
    telemetry: str = "failed"
    """Which trials' telemetry to send back: ``none``, ``failed`` or ``all``."""


@dataclass(frozen=True)
class TerrainBuilt:
    """Message: terrain ``terrain`` of cell ``cell`` is built and classified."""

    cell: int
    terrain: int
    terrain_seed: int
    stats: Mapping[str, float]
    """``area_low`` / ``area_semi`` / ``area_high`` (fractions inside the border) and ``build_s``."""

    @property
    def key(self) -> tuple[int, int]:
        """(cell, terrain): the task this message belongs to."""
        return (self.cell, self.terrain)


@dataclass(frozen=True)
class TrialDone:
    """Message: one trial of a terrain task is finished."""

    cell: int
    terrain: int
    mission: int
    terrain_seed: int
    mission_seed: int
    row: Mapping[str, Any]
    """The trial's row (offroadbench.sim.trial.runner.TrialResult.as_row)."""
    kept: Mapping[str, Any] | None = None
    """None, or ``{"telemetry": columns, "path_xy": waypoints}`` to store beside the row."""

    @property
    def key(self) -> tuple[int, int]:
        """(cell, terrain): the task this message belongs to."""
        return (self.cell, self.terrain)


def keeps_telemetry(setting: str, success: bool) -> bool:
    """Whether a trial's telemetry is kept under ``setting`` (none / failed / all)."""
    return setting == "all" or (setting == "failed" and not success)


def run_terrain(task: TerrainTask, trial_fn: TrialFn | None = None) -> Iterator[TerrainBuilt | TrialDone]:
    """Build the task's terrain once and run all its pending missions, yielding messages."""
    trial_fn = trial_fn or drive_terrain
    cell = task.cell
    settings = cell.trial_settings
    t0 = time.perf_counter()
    prepared = prepare_terrain(cell.recipe(), task.terrain_seed, settings, task.missions)
    stats = {f"area_{k}": v for k, v in prepared.maps.fractions.items()}
    stats["build_s"] = time.perf_counter() - t0
    yield TerrainBuilt(cell.index, task.terrain, task.terrain_seed, stats)
    seeds = dict(task.missions)
    for mission, item in zip(prepared.missions, trial_fn(prepared, settings)):
        k = mission.index
        kept = None
        if hasattr(item, "result"):  # a TrialRecord
            row = item.result.as_row()
            if keeps_telemetry(task.telemetry, bool(row["success"])):
                kept = {"telemetry": item.telemetry, "path_xy": item.path_xy}
        else:
            row = dict(item)
        if int(row.get("mission_index", k)) != k:
            raise RuntimeError(f"trial function returned mission {row.get('mission_index')} for mission {k}")
        yield TrialDone(cell.index, task.terrain, k, task.terrain_seed, seeds[k], row, kept)


def collect_terrain(task: TerrainTask, trial_fn: TrialFn | None = None) -> list[TerrainBuilt | TrialDone]:
    """All messages of :func:`run_terrain` as a list (for executors that return per task)."""
    return list(run_terrain(task, trial_fn))


# ---------------------------------------------------------------------------- replay
@dataclass(frozen=True, eq=False)
class Replay:
    """One stored trial driven again: the new record, the stored row and what it was driven on."""

    record: Any
    """The new offroadbench.sim.trial.runner.TrialRecord."""
    stored: Mapping[str, Any]
    """The stored row of the trial."""
    identical: bool
    """Whether every field of the new row equals the stored one (NaN equal to NaN)."""
    prepared: PreparedTerrain
    """The terrain, its class maps and the one mission, as driven."""
    cell: CellPlan

    @property
    def hm(self):
        """The terrain."""
        return self.prepared.hm

    @property
    def classes(self):
        """The closed class map of the cell's roughness config."""
        return self.prepared.maps.closed

    @property
    def mission(self):
        """The mission driven."""
        return self.prepared.missions[0]


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    return a == b


def replay_trial(run_dir, cell: int, terrain: int, mission: int) -> Replay:
    """Drive trial (cell, terrain, mission) of a run directory again, from its stored recipe,
    settings and seeds. Unknown keys are InputErrors naming what exists."""
    import json

    from offroadbench.errors import InputError
    from offroadbench.study.store import Store

    with Store(run_dir) as store:
        meta = store.meta()
        hit = store.con.execute("SELECT terrain_seed, mission_seed, row FROM trials WHERE cell=? AND terrain=? AND mission=?",
                                (cell, terrain, mission)).fetchone()
    if hit is None:
        raise InputError(f"{run_dir}: no stored trial cell {cell}, terrain {terrain}, mission {mission} "
                         f"(cells 0-{len(meta.get('cells', [])) - 1}; see `study export` for the stored keys)")
    tseed, mseed, text = hit
    plan = CellPlan.from_meta(meta, cell)
    settings = plan.trial_settings
    prepared = prepare_terrain(plan.recipe(), tseed, settings, [(mission, mseed)])
    rec = next(iter(drive_terrain(prepared, settings)))
    stored = json.loads(text)
    new = json.loads(json.dumps(rec.result.as_row()))  # the stored row went through JSON too
    identical = set(new) == set(stored) and all(_same(new[k], stored[k]) for k in new)
    return Replay(record=rec, stored=stored, identical=identical, prepared=prepared, cell=plan)
