"""The unit of work of a study: build one terrain, sample its missions, run its trials.

A :class:`TerrainTask` is plain picklable data (the resolved cell, the terrain's seed and the
pending missions with their seeds), so any worker (a local process, a Dask worker on another
machine) runs it without reading the study file. :func:`run_terrain` yields messages:

* ``("terrain", cell, terrain, terrain_seed, stats)`` once the terrain is built and classified;
  ``stats`` holds the class area fractions of Sec. 2.4 (inside the border, before the closing);
* ``("trial", cell, terrain, mission, terrain_seed, mission_seed, row)`` after each trial.

The trial function is a parameter (``trial_fn(hm, missions, cell) -> iterator of rows``), so
tests and benchmarks can swap the physics for a cheap stand-in; :func:`sim_trials` is the real
one (PyBullet, through ``offroadbench.sim``).

Missions. Mission k of terrain j is drawn alone from ``default_rng(mission_seed(j, k))`` on the
closed class map (Majhor & Bos 2023, Sec. 2.3: start in low roughness, goal in low or semi, 35 m
apart, 5 m border), so it does not depend on which other missions are drawn or pending.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from offroadbench.study.spec import CellPlan

__all__ = ["TerrainTask", "TrialFn", "run_terrain", "collect_terrain", "sample_mission", "sim_trials"]

#: ``trial_fn(hm, missions, cell) -> iterator of TrialResult.as_row() dicts, one per mission, in order``
TrialFn = Callable[[Any, Sequence[Any], CellPlan], Iterator[Mapping[str, Any]]]


@dataclass(frozen=True)
class TerrainTask:
    """One terrain of one grid cell and its pending missions ((index, seed) pairs)."""

    cell: CellPlan
    terrain: int
    terrain_seed: int
    missions: tuple[tuple[int, int], ...]


def sample_mission(hm, closed, mcfg, index: int, seed: int):
    """Mission ``index`` drawn alone from its own seed (see the module docstring)."""
    from offroadbench.navigation.missions import sample_missions

    one = dataclasses.replace(mcfg, count=1)
    (mission,) = sample_missions(hm, closed, one, np.random.default_rng(seed))
    return dataclasses.replace(mission, index=index)


def run_terrain(task: TerrainTask, trial_fn: TrialFn | None = None) -> Iterator[tuple]:
    """Build the task's terrain once and run all its pending missions, yielding messages."""
    from offroadbench.analysis.roughness import classify_terrain
    from offroadbench.terrain.recipe import generate_terrain

    trial_fn = trial_fn or sim_trials
    cell = task.cell
    t0 = time.perf_counter()
    hm = generate_terrain(cell.recipe(), task.terrain_seed)
    rcfg = cell.section("roughness")
    maps = classify_terrain(hm, rcfg)
    mcfg = cell.section("missions")
    missions = [sample_mission(hm, maps.closed, mcfg, k, seed) for k, seed in task.missions]
    stats = {f"area_{k}": v for k, v in maps.fractions.items()}
    stats["build_s"] = time.perf_counter() - t0
    yield ("terrain", cell.index, task.terrain, task.terrain_seed, stats)
    seeds = dict(task.missions)
    for mission, row in zip(missions, trial_fn(hm, missions, cell)):
        k = mission.index
        if int(row.get("mission_index", k)) != k:
            raise RuntimeError(f"trial function returned mission {row.get('mission_index')} for mission {k}")
        yield ("trial", cell.index, task.terrain, k, task.terrain_seed, seeds[k], dict(row))


def collect_terrain(task: TerrainTask, trial_fn: TrialFn | None = None) -> list[tuple]:
    """All messages of :func:`run_terrain` as a list (for executors that return per task)."""
    return list(run_terrain(task, trial_fn))


# ---------------------------------------------------------------------------- physics
def sim_trials(hm, missions, cell: CellPlan) -> Iterator[Mapping[str, Any]]:
    """The real trials (PyBullet): one World per terrain, one row per mission as it finishes."""
    from offroadbench.sim import World, run_mission

    controller, rules = cell.section("controller"), cell.section("rules")
    with World(hm, cell.section("vehicle"), cell.section("sim")) as world:
        for mission in missions:
            result, _ = run_mission(world, mission, controller=controller, rules=rules)
            yield result.as_row()
