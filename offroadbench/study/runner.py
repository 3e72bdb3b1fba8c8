"""Run a study into a run directory: plan the pending work, execute it, commit every trial.

:func:`run_study` is resumable by construction: it reads which trials the store already holds
and only hands out the rest, grouped by terrain (each worker builds a terrain once and runs all
its pending missions). Tasks are ordered terrain-major (terrain 0 of every cell, then terrain
1, ...), so a partial study covers every grid cell evenly.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

from offroadbench import seeding
from offroadbench.config import to_dict
from offroadbench.errors import InputError
from offroadbench.memory import world_bytes
from offroadbench.progress import ProgressFn
from offroadbench.study.execution.executors import get_executor
from offroadbench.study.execution.tasks import TerrainTask, TrialFn
from offroadbench.study.session import RunSession, RunSummary, code_version
from offroadbench.study.spec.config import CellPlan, StudyConfig, study_id
from offroadbench.study.spec.inputs import driver_files

log = logging.getLogger(__name__)

__all__ = ["RunSummary", "StudyEstimate", "check_drive_size", "check_study_size", "default_trial_timeout_s",
           "estimate_study", "plan_tasks", "run_study", "study_meta", "worker_memory_bytes"]



def plan_tasks(study: StudyConfig, plans: list[CellPlan], done: set[tuple[int, int, int]]) -> list[TerrainTask]:
    """The terrain tasks that still have missions to run, terrain-major."""
    tasks = []
    for j in range(study.terrains_per_cell):
        for plan in plans:
            pending = tuple(
                (k, seeding.mission_seed(study.root_seed, j, k, cell=plan.key))
                for k in range(study.missions_per_terrain)
                if (plan.index, j, k) not in done
            )
            if pending:
                tseed = seeding.terrain_seed(study.root_seed, j, cell=plan.key)
                tasks.append(TerrainTask(cell=plan, terrain=j, terrain_seed=tseed, missions=pending,
                                         telemetry=study.telemetry))
    return tasks


#: the per-trial wall-clock limit by default: this many seconds (a terrain build, planning) plus
TRIAL_LIMIT_BASE_S = 300.0
#: ... this many wall seconds per simulated second of a trial's timeout (a real-time factor of 0.1,
#: against the 25-80 measured: benchmarks/RESULTS.md), plus
TRIAL_LIMIT_PER_SIM_S = 10.0
#: ... this many seconds per map cell (building and classifying large maps)
TRIAL_LIMIT_PER_CELL_S = 20e-6
#: a planned path may be this many times the mission length (detours) in the default limit
PATH_ALLOWANCE = 3.0


def default_trial_timeout_s(plans: list[CellPlan]) -> float:
    """The default per-trial wall-clock limit of a study, seconds: generous against the nominal
    time (``rules.timeout_factor * PATH_ALLOWANCE * mission length / speed`` simulated seconds at
    a real-time factor of 0.1, plus the terrain build), so only a hung trial reaches it."""
    worst = 0.0
    for p in plans:
        rules, missions, ctrl = p.section("rules"), p.section("missions"), p.section("controller")
        speed = min(ctrl.cruise_speed_m_s, p.section("vehicle").max_speed_m_s)
        sim_s = rules.timeout_factor * PATH_ALLOWANCE * missions.length_m / speed
        cells = int(p.recipe_data["grid"]["rows"]) * int(p.recipe_data["grid"]["cols"])
        worst = max(worst, TRIAL_LIMIT_BASE_S + TRIAL_LIMIT_PER_SIM_S * sim_s + TRIAL_LIMIT_PER_CELL_S * cells)
    return worst


#: assumed real-time factor of a trial in a study's size estimate (25-80 measured on 2 cores,
#: benchmarks/RESULTS.md; the estimate stays on the long side)
ESTIMATE_RTF = 20.0
#: assumed seconds to build and classify one terrain in the size estimate (a 1009^2 paper map)
ESTIMATE_TERRAIN_S = 10.0
#: ``study run`` refuses, without --force, a study of more grid cells than this ...
MAX_CELLS = 10_000
#: ... or of more estimated CPU time than this, seconds (7 CPU-days)
MAX_CPU_S = 7 * 86400.0


@dataclass(frozen=True)
class StudyEstimate:
    """The size of a study, known before its cells are resolved (:func:`estimate_study`)."""

    cells: int
    trials: int
    cpu_s: float
    """Estimated CPU time: trials x nominal simulated time / ESTIMATE_RTF + terrains x ESTIMATE_TERRAIN_S."""

    def describe(self) -> str:
        return (f"{self.cells} grid cell(s), {self.trials} trial(s), about {self.cpu_s / 3600:.3g} CPU-hours "
                f"(trials at a real-time factor of {ESTIMATE_RTF:g}, {ESTIMATE_TERRAIN_S:g} s per terrain)")


def estimate_study(study: StudyConfig) -> StudyEstimate:
    """Cells, trials and CPU time of ``study`` from its config alone (no cell is resolved, so a
    grid of a million values is judged in seconds). The nominal simulated time of a trial is
    ``mission length / cruise speed`` with the longest length and slowest speed of the grid."""
    from offroadbench.navigation.missions import MissionConfig
    from offroadbench.sim.config import ControllerConfig

    def values(key: str, default: float) -> list[float]:
        for axis in study.grid:
            if axis.key == key:
                return [float(v) for v in axis.values]
        table, field = key.split(".")
        return [float(study.settings.get(table, {}).get(field, default))]

    try:
        length = max(values("missions.length_m", MissionConfig().length_m))
        speed = min(values("controller.cruise_speed_m_s", ControllerConfig().cruise_speed_m_s))
        sim_s = length / speed if speed > 0 else float("inf")
    except (TypeError, ValueError):  # not numbers: resolving the cells will name the bad value
        sim_s = 0.0
    terrains = study.n_cells * study.terrains_per_cell
    cpu = study.n_trials * sim_s / ESTIMATE_RTF + terrains * ESTIMATE_TERRAIN_S
    return StudyEstimate(cells=study.n_cells, trials=study.n_trials, cpu_s=cpu)


def check_study_size(study: StudyConfig, force: bool = False) -> StudyEstimate:
    """Refuse (InputError with the estimate) a study beyond MAX_CELLS or MAX_CPU_S unless ``force``."""
    est = estimate_study(study)
    if not force and (est.cells > MAX_CELLS or not est.cpu_s <= MAX_CPU_S):
        raise InputError(f"study {study.name!r}: {est.describe()}; more than the {MAX_CELLS} cells or "
                         f"{MAX_CPU_S / 86400:g} CPU-days run without --force: check the grid and the mission "
                         "length, or give --force to run it anyway")
    return est


def check_drive_size(missions: int, length_m: float, speed_m_s: float, force: bool = False) -> StudyEstimate:
    """``drive``'s work estimated as a study's (one terrain of ``missions`` trials of ``length_m``
    at ``speed_m_s``); refused (InputError with the estimate) past MAX_CPU_S unless ``force``."""
    sim_s = length_m / speed_m_s if speed_m_s > 0 else float("inf")
    est = StudyEstimate(cells=1, trials=int(missions), cpu_s=missions * sim_s / ESTIMATE_RTF + ESTIMATE_TERRAIN_S)
    if not force and not est.cpu_s <= MAX_CPU_S:
        raise InputError(f"drive: {missions} mission(s) of {length_m:g} m at {speed_m_s:g} m/s, about "
                         f"{est.cpu_s / 3600:.3g} CPU-hours (at a real-time factor of {ESTIMATE_RTF:g}); "
                         f"more than the {MAX_CPU_S / 86400:g} CPU-days run without --force: "
                         "check --missions and --length-m, or give --force to run it anyway")
    return est


def worker_memory_bytes(plans: list[CellPlan]) -> int:
    """Peak memory estimate of one trial worker of the study: its largest terrain's world
    (offroadbench.memory.world_bytes)."""
    return max(_world_bytes(p) for p in plans)


def _world_bytes(plan: CellPlan) -> int:
    grid = plan.recipe_data["grid"]
    sim = plan.section("sim")
    return world_bytes(grid["rows"], grid["cols"], sim.heightfield_tile_cells, engine=sim.engine)


def study_meta(study: StudyConfig, plans: list[CellPlan], source_text: str = "", version: str = "") -> dict[str, Any]:
    """What the store records about the study (config, cells, seeds' root, version)."""
    from offroadbench.study.spec.inputs import trial_inputs

    return {
        "study_id": study_id(study, plans),
        "trial_inputs": trial_inputs(study, plans),
        "study": to_dict(study),
        "study_toml": source_text,
        "columns": study.column_names(),
        "cells": [
            {
                "index": p.index,
                "values": dict(p.values),
                "seed_key": p.key,
                "recipe": dict(p.recipe_data),
                "settings": {k: dict(v) for k, v in p.settings.items()},
                "trial_settings": p.trial_settings.to_dict(),  # resolved; the report reads them (CellPlan.from_meta)
                **({"missions_recipe": dict(p.missions_recipe_data)} if p.missions_recipe_data is not None else {}),
                "files": driver_files(p.trial_settings.planner),  # e.g. a policy's model: path, size, SHA-256
            }
            for p in plans
        ],
        "n_trials": study.n_trials,
        "version": version or code_version(),
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def run_study(
    study: StudyConfig,
    plans: list[CellPlan],
    run_dir: str | Path,
    *,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    executor_options: Mapping[str, Any] | None = None,
    trial_fn: TrialFn | None = None,
    source_text: str = "",
    progress: ProgressFn | None = None,
    on_trial: Callable[[Mapping[str, Any]], None] | None = None,
    retry_faults: bool = False,
) -> RunSummary:
    """Run (or resume) ``study`` into ``run_dir``; every finished trial is committed at once.

    ``progress(stored, total)`` counts stored trials (and faults) of the whole study; ``on_trial(row)``
    sees every new trial's row (e.g. for a success-rate display). Ctrl-C stops the workers and
    raises :class:`~offroadbench.errors.RunInterrupted` (a KeyboardInterrupt saying what was saved);
    what was committed stays. A run that fails before its first trial removes the store (and the
    directories) it created; one that fails later keeps every committed trial and its error says how
    to resume (offroadbench.study.session.RunSession). ``executor_options`` go to the executor
    (``trial_timeout_s``: the per-trial wall-clock limit of the ``local`` and ``dask`` executors,
    default :func:`default_trial_timeout_s`). A trial past that limit, or one whose vehicle was
    thrown while settling, is stored as a fault (``faults`` table) and the study goes on; a
    resume skips faulted trials unless ``retry_faults`` (then each is run once more). A resume whose
    resolved inputs (:mod:`offroadbench.study.spec.inputs`) differ from the stored ones is refused,
    naming the change.
    """
    options = dict(executor_options or {})
    if executor in ("local", "dask") and options.get("trial_timeout_s") is None:
        options["trial_timeout_s"] = default_trial_timeout_s(plans)
    ex = get_executor(executor, workers, scheduler, **options)
    meta = study_meta(study, plans, source_text, code_version())
    with RunSession(run_dir, meta, kind="study", total=study.n_trials, executor=ex, executor_name=executor,
                    telemetry=study.telemetry, retry_faults=retry_faults, progress=progress,
                    on_trial=on_trial) as session:
        tasks = plan_tasks(study, plans, session.stored_keys())
        log.info("%s: %d of %d trials stored, %d terrain tasks to run", run_dir, session.stored, study.n_trials,
                 len(tasks))
        session.run(tasks, trial_fn)
    return session.summary()
