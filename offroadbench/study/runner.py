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

from offroadbench import resources
from offroadbench.config import to_dict
from offroadbench.progress import ProgressFn, report
from offroadbench import seeding
from offroadbench.study.spec import CellPlan, StudyConfig, study_id
from offroadbench.errors import InputError
from offroadbench.io.outputs import missing_dirs
from offroadbench.memory import world_bytes
from offroadbench.study.executors import StudyError, get_executor
from offroadbench.study.store import Store, remove_store
from offroadbench.study.tasks import TerrainTask, TrialFn

log = logging.getLogger(__name__)

__all__ = ["RunSummary", "plan_tasks", "run_study", "study_meta", "telemetry_paths", "save_trial_telemetry",
           "worker_memory_bytes"]



def telemetry_paths(run_dir: str | Path, cell: int, terrain: int, mission: int) -> tuple[Path, Path]:
    """(telemetry, planned path) Parquet files of one trial in a run directory."""
    stem = Path(run_dir) / "telemetry" / f"cell{cell}_terrain{terrain}_mission{mission}"
    return stem.with_name(stem.name + ".parquet"), stem.with_name(stem.name + "_path.parquet")


def save_trial_telemetry(run_dir: str | Path, cell: int, terrain: int, mission: int, kept: Mapping[str, Any]) -> None:
    """Write a kept trial's 20 Hz telemetry and planned path (atomic Parquet files)."""
    from offroadbench.io.telemetry import save_telemetry

    tel_path, path_path = telemetry_paths(run_dir, cell, terrain, mission)
    tel_path.parent.mkdir(exist_ok=True)
    save_telemetry(kept["telemetry"], tel_path)
    xy = kept["path_xy"]
    save_telemetry({"x_m": xy[:, 0], "y_m": xy[:, 1]}, path_path)


@dataclass(frozen=True)
class RunSummary:
    """What one ``run_study`` call did."""

    run_dir: Path
    total: int
    """Trials in the whole study."""
    done: int
    """Trials stored after this call."""
    ran: int
    """Trials run by this call."""
    successes: int
    """Successful trials stored after this call."""
    wall_s: float
    """Wall time of this call, seconds."""


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


def worker_memory_bytes(plans: list[CellPlan]) -> int:
    """Peak memory estimate of one trial worker of the study: its largest terrain's world
    (offroadbench.memory.world_bytes)."""
    return max(_world_bytes(p) for p in plans)


def _world_bytes(plan: CellPlan) -> int:
    grid = plan.recipe_data["grid"]
    return world_bytes(grid["rows"], grid["cols"], plan.section("sim").heightfield_tile_cells)


def code_version() -> str:
    """The package version, plus the git commit (and ``-dirty``) when the package is a git checkout."""
    import subprocess

    from offroadbench import __version__

    src = resources.package_dir()

    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(src), *args], capture_output=True, text=True, timeout=10)

    try:
        # an installed copy inside some other checkout (e.g. a .venv in it) is not that checkout's code
        if git("ls-files", "--error-unmatch", "__init__.py").returncode != 0:
            return __version__
        head = git("rev-parse", "--short", "HEAD")
        if head.returncode != 0:
            return __version__
        dirty = git("status", "--porcelain", "--untracked-files=no", "--", ".")
        return f"{__version__}+git.{head.stdout.strip()}{'-dirty' if dirty.stdout.strip() else ''}"
    except (OSError, subprocess.SubprocessError):
        return __version__


def study_meta(study: StudyConfig, plans: list[CellPlan], source_text: str = "", version: str = "") -> dict[str, Any]:
    """What the store records about the study (config, cells, seeds' root, version)."""
    return {
        "study_id": study_id(study, plans),
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
) -> RunSummary:
    """Run (or resume) ``study`` into ``run_dir``; every finished trial is committed at once.

    ``progress(done, total)`` counts stored trials of the whole study; ``on_trial(row)`` sees
    every new trial's row (e.g. for a success-rate display). Ctrl-C stops the workers and
    re-raises KeyboardInterrupt; what was committed stays. A run that fails before its first
    trial removes the store (and the directories) it created; one that fails later keeps every
    committed trial and its error says how to resume. ``executor_options`` go to the executor
    (e.g. ``trial_timeout_s`` for dask).
    """
    ex = get_executor(executor, workers, scheduler, **dict(executor_options or {}))
    version = code_version()
    t0 = time.perf_counter()
    run_dir = Path(run_dir)
    made_dirs = missing_dirs(run_dir)  # the output-path policy (offroadbench.io.outputs)
    store = Store(run_dir, create=True)
    ran = 0
    running = False
    try:
        store.init_meta(study_meta(study, plans, source_text, version))
        tasks = plan_tasks(study, plans, store.done_trials())
        total = study.n_trials
        done, _ = store.counts()
        report(progress, done, total)
        run_id = store.start_run(executor, ex.workers, version)
        log.info("%s: %d of %d trials stored, %d terrain tasks to run", run_dir, done, total, len(tasks))

        def handle(msg: tuple) -> None:
            nonlocal ran, done
            if msg[0] == "terrain":
                _, cell, terrain, tseed, stats = msg
                store.add_terrain(cell, terrain, tseed, stats)
                return
            _, cell, terrain, mission, tseed, mseed, row, kept = msg
            if store.add_trial(cell, terrain, mission, tseed, mseed, row, run_id=run_id):
                if kept is not None:
                    save_trial_telemetry(run_dir, cell, terrain, mission, kept)
                ran += 1
                done += 1
                if on_trial is not None:
                    on_trial(row)
                report(progress, done, total)

        status = "interrupted"
        running = True
        try:
            ex.run(tasks, trial_fn, handle)
            status = "finished"
        except KeyboardInterrupt:
            raise
        except BaseException:
            status = "failed"
            raise
        finally:
            store.finish_run(run_id, status)
        done, successes = store.counts()
    except BaseException as exc:
        stored = store.counts()[0]
        store.close()
        if store.created and stored == 0:
            # failed before any trial: leave no store (and no directory) behind
            remove_store(run_dir)
            for d in made_dirs:
                try:
                    d.rmdir()
                except OSError:
                    break
            raise
        if running and isinstance(exc, (StudyError, InputError)) and stored:
            # keep every finished trial and say how to go on
            hint = (f"{stored} of {study.n_trials} trials are saved in {run_dir}; "
                    "fix the cause and run the same command again to resume")
            raise type(exc)(f"{exc}; {hint}") from None
        raise
    store.close()
    return RunSummary(
        run_dir=run_dir, total=total, done=done, ran=ran, successes=successes, wall_s=time.perf_counter() - t0
    )
