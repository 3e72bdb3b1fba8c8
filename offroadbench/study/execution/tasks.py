"""The unit of work of a study: build one terrain, sample its missions, run its trials.

A :class:`TerrainTask` is plain picklable data (the resolved cell, the terrain's seed and the
pending missions with their seeds), so any worker (a local process, a Dask worker on another
machine) runs it without reading the study file. :func:`run_terrain` yields messages:

* :class:`TerrainBuilt` once the terrain is built and classified (its ``stats`` hold the class
  area fractions of Sec. 2.4, inside the border, before the closing);
* :class:`TrialDone` after each trial (its ``kept`` is None, or ``{"telemetry": columns,
  "path_xy": waypoints}`` when the task's ``telemetry`` setting keeps this trial's telemetry:
  ``failed``, failed trials only; ``all``);
* :class:`TrialFaulted` for a trial that gave no outcome (:class:`offroadbench.errors.TrialFault`:
  the vehicle was thrown while settling; executors send it too for a trial past its limit): the
  task goes on with its next mission in a new world. A terrain on which no mission can be drawn
  (:class:`offroadbench.navigation.missions.NoMissionError`) gives one for each of its missions and
  no :class:`TerrainBuilt`.

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
apart, 5 m border), so it does not depend on which other missions are drawn or pending. A cell whose
missions come from another cell's terrain (``[study] missions_from``) draws them on that terrain
(same seed) and drives them on its own (:func:`prepare_cell`), and its terrain row records
``twin_unexplained_var``: the share of the two surfaces' height variance that one does not
explain linearly in the other, 1 - r^2 (for a band-limited arm against its aliased twin: the
share carried by the W-M terms above the grid's Nyquist frequency). For one W-M surface (Majhor &
Bos 2023, Eq. 1) the terms are plane waves with the same phases in both twins, and 1 - r^2 equals
the amplitude share sum_{n above Nyquist} gamma^(2 (D-3) n) / sum_n gamma^(2 (D-3) n) to within
1 % (tests/study/test_run_sets.py); on the multifractal product (filtered, multiplied, rescaled
layers) it is the same measure taken on the finished surface.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Mapping

from offroadbench.errors import TrialFault
from offroadbench.navigation.missions import NoMissionError
from offroadbench.navigation.problem import PlannerRefusal
from offroadbench.sim.trial.pipeline import PreparedTerrain, TrialSettings, drive_terrain, prepare_terrain
from offroadbench.study.spec.config import CellPlan

__all__ = ["NO_MISSION_FAULT", "NO_MISSION_KIND", "REFUSED_FAULT", "REFUSED_KIND", "TIMEOUT_KIND", "TRIAL_FAULT_KIND", "prepare_cell", "unexplained_variance", "TerrainTask", "TerrainBuilt", "TrialDone", "TrialFaulted", "TrialFn",
           "remaining_task", "run_terrain", "collect_terrain", "keeps_telemetry",
           "Replay", "replay_trial"]

#: the start of a fault's reason when its terrain admits no mission (:func:`run_terrain`)
NO_MISSION_FAULT = "no mission can be drawn on this terrain: "
#: the reason of a trial whose planner or policy refuses the cell's vehicle (PlannerRefusal)
REFUSED_FAULT = "the planner refuses this vehicle: "

#: :attr:`TrialFaulted.kind` of a trial on a terrain that admits no mission (NoMissionError)
NO_MISSION_KIND = "no_mission"
#: ... of a trial whose planner or policy refuses the cell's vehicle (PlannerRefusal)
REFUSED_KIND = "refused"
#: ... of a trial (or its terrain build) past the per-trial wall-clock limit (the executors)
TIMEOUT_KIND = "timeout"
#: ... of a trial that gave no outcome (offroadbench.errors.TrialFault: thrown while it settled)
TRIAL_FAULT_KIND = "trial_fault"

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


@dataclass(frozen=True)
class TrialFaulted:
    """Message: one trial of a terrain task gave no outcome (a fault, stored apart from the trials)."""

    cell: int
    terrain: int
    mission: int
    terrain_seed: int
    mission_seed: int
    reason: str
    """One line: why (e.g. "ran longer than 60 s, the per-trial limit")."""
    kind: str = TRIAL_FAULT_KIND
    """What kind of fault: :data:`NO_MISSION_KIND`, :data:`REFUSED_KIND`, :data:`TIMEOUT_KIND` or
    :data:`TRIAL_FAULT_KIND` (repeated faults are summarised per kind; a search stores a trial on a
    terrain without a mission as a row of its own)."""

    @property
    def key(self) -> tuple[int, int]:
        """(cell, terrain): the task this message belongs to."""
        return (self.cell, self.terrain)


def remaining_task(task: TerrainTask, after: int | None) -> TerrainTask | None:
    """``task`` with only the missions after mission ``after`` (None: all of them); None if none is left."""
    order = [k for k, _ in task.missions]
    rest = task.missions if after is None else task.missions[order.index(after) + 1:]
    return dataclasses.replace(task, missions=tuple(rest)) if rest else None


def unexplained_variance(z, twin) -> float:
    """1 - r^2 of two surfaces of the same shape (r: Pearson correlation of their heights)."""
    import numpy as np

    a = np.asarray(z, float).ravel() - np.mean(z)
    b = np.asarray(twin, float).ravel() - np.mean(twin)
    den = float(np.sqrt(np.dot(a, a) * np.dot(b, b)))
    return float(1.0 - (np.dot(a, b) / den) ** 2) if den > 0 else float("nan")


def prepare_cell(cell: CellPlan, terrain_seed: int, missions) -> tuple[PreparedTerrain, dict[str, float]]:
    """The cell's terrain with its missions ((index, seed) pairs), drawn on the cell's own terrain or,
    with ``missions_from``, on the reference cell's terrain of the same seed; and the extra terrain
    statistics (``twin_unexplained_var`` with a reference terrain)."""
    settings = cell.trial_settings
    ref = cell.missions_recipe()
    if ref is None:
        return prepare_terrain(cell.recipe(), terrain_seed, settings, missions), {}
    twin = prepare_terrain(ref, terrain_seed, settings, missions)
    own = prepare_terrain(cell.recipe(), terrain_seed, settings, twin.missions)
    import dataclasses

    own = dataclasses.replace(own, mission_seeds=twin.mission_seeds)
    return own, {"twin_unexplained_var": unexplained_variance(own.hm.z, twin.hm.z)}


def keeps_telemetry(setting: str, success: bool) -> bool:
    """Whether a trial's telemetry is kept under ``setting`` (none / failed / all)."""
    return setting == "all" or (setting == "failed" and not success)


def build_terrain(task: TerrainTask) -> tuple[PreparedTerrain | None, list[TerrainBuilt | TrialFaulted]]:
    """The task's terrain and missions, and its messages: ``(prepared, [TerrainBuilt])``, or ``(None,
    [one TrialFaulted per mission])`` when the drawn terrain admits no mission (e.g. no low-roughness
    cell inside the border at high D): those trials are faults, excluded from every statistic and
    listed in the report, and the study goes on (the design: a terrain is never redrawn, so no seed
    is picked after the fact)."""
    cell = task.cell
    t0 = time.perf_counter()
    try:
        prepared, extra = prepare_cell(cell, task.terrain_seed, task.missions)
    except NoMissionError as exc:
        reason = NO_MISSION_FAULT + " ".join(str(exc).split())
        return None, [TrialFaulted(cell.index, task.terrain, k, task.terrain_seed, seed, reason, NO_MISSION_KIND)
                      for k, seed in task.missions]
    stats = {f"area_{k}": v for k, v in prepared.maps.fractions.items()} | extra
    stats["build_s"] = time.perf_counter() - t0
    return prepared, [TerrainBuilt(cell.index, task.terrain, task.terrain_seed, stats)]


def trial_done(task: TerrainTask, mission: int, seed: int, item: Any) -> TrialDone:
    """A trial's message: its row (from a TrialRecord, or a trial function's own mapping) and, as
    the study's ``telemetry`` setting asks, its telemetry and planned path."""
    kept = None
    if hasattr(item, "result"):  # a TrialRecord
        row = item.result.as_row()
        if keeps_telemetry(task.telemetry, bool(row["success"])):
            kept = {"telemetry": item.telemetry, "path_xy": item.path_xy}
    else:
        row = dict(item)
    return TrialDone(task.cell.index, task.terrain, mission, task.terrain_seed, seed, row, kept)


def run_terrain(task: TerrainTask, trial_fn: TrialFn | None = None) -> Iterator[TerrainBuilt | TrialDone]:
    """Build the task's terrain once and run all its pending missions, yielding messages."""
    trial_fn = trial_fn or drive_terrain
    cell = task.cell
    settings = cell.trial_settings
    prepared, msgs = build_terrain(task)
    yield from msgs
    if prepared is None:
        return
    seeds = dict(task.missions)
    pending = list(prepared.missions)
    while pending:
        # a faulted trial ends its world (the engine's state is not to be trusted): the missions
        # after it are driven in a new one
        part = dataclasses.replace(prepared, missions=tuple(pending),
                                   mission_seeds=tuple(seeds[m.index] for m in pending))
        try:
            # not strict: a trial function may stop early (a stand-in that only builds terrains); the
            # missions it did not drive stay pending
            for mission, item in zip(part.missions, trial_fn(part, settings), strict=False):
                k = mission.index
                done = trial_done(task, k, seeds[k], item)
                if int(done.row.get("mission_index", k)) != k:
                    raise RuntimeError(f"trial function returned mission {done.row.get('mission_index')} for mission {k}")
                pending.pop(0)
                yield done
            return
        except TrialFault as exc:
            k = pending.pop(0).index
            yield TrialFaulted(cell.index, task.terrain, k, task.terrain_seed, seeds[k], " ".join(str(exc).split()))
        except PlannerRefusal as exc:
            # the (planner, vehicle) pair cannot be driven (a cartesian grid of both may hold such
            # pairs): every pending trial is a fault naming the refusal, and the study goes on
            reason = REFUSED_FAULT + " ".join(str(exc).split())
            for mission in pending:
                yield TrialFaulted(cell.index, task.terrain, mission.index, task.terrain_seed, seeds[mission.index], reason,
                                   REFUSED_KIND)
            return


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
    """Whether every field of the stored row equals the new row's (NaN equal to NaN). A field the new
    row has and the stored one lacks (a column added after the run, e.g. ``dropped_contacts``) is not
    compared: it is in :attr:`unrecorded`."""
    prepared: PreparedTerrain
    """The terrain, its class maps and the one mission, as driven."""
    cell: CellPlan
    unrecorded: tuple[str, ...] = ()
    """The new row's fields that the stored row predates (not compared)."""

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
    from offroadbench.study.spec import vehicle_changed
    from offroadbench.study.store.store import Store

    with Store(run_dir) as store:
        meta = store.meta()
        hit = store.trial(cell, terrain, mission)
    if hit is None:
        raise InputError(f"{run_dir}: no stored trial cell {cell}, terrain {terrain}, mission {mission} "
                         f"(cells 0-{len(meta.get('cells', [])) - 1}; see `study export` for the stored keys)")
    tseed, mseed, stored = hit
    plan = CellPlan.from_meta(meta, cell)
    settings = plan.trial_settings
    changed = vehicle_changed(meta.get("trial_inputs", {}), settings)
    if changed:
        raise InputError(f"{run_dir}: cannot replay cell {cell}, terrain {terrain}, mission {mission}: {changed} "
                         "(restore the model file the run used)")
    prepared, _ = prepare_cell(plan, tseed, [(mission, mseed)])
    rec = next(iter(drive_terrain(prepared, settings)))
    new = json.loads(json.dumps(rec.result.as_row()))  # the stored row went through JSON too
    identical = set(stored) <= set(new) and all(_same(new[k], stored[k]) for k in stored)
    unrecorded = tuple(k for k in new if k not in stored)  # columns added to TrialResult after the run
    return Replay(record=rec, stored=stored, identical=identical, prepared=prepared, cell=plan, unrecorded=unrecorded)
