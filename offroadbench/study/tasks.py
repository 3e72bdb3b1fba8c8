"""The unit of work of a study: build one terrain, sample its missions, run its trials.

A :class:`TerrainTask` is plain picklable data (the resolved cell, the terrain's seed and the
pending missions with their seeds), so any worker (a local process, a Dask worker on another
machine) runs it without reading the study file. :func:`run_terrain` yields messages:

* ``("terrain", cell, terrain, terrain_seed, stats)`` once the terrain is built and classified;
  ``stats`` holds the class area fractions of Sec. 2.4 (inside the border, before the closing);
* ``("trial", cell, terrain, mission, terrain_seed, mission_seed, row, kept)`` after each trial;
  ``kept`` is None, or ``{"telemetry": columns, "path_xy": waypoints}`` when the task's
  ``telemetry`` setting keeps this trial's telemetry (``failed``: failed trials only; ``all``).

The trial function is a parameter (``trial_fn(hm, missions, cell) -> iterator of rows``, or of
``TrialRecord``s that carry telemetry), so tests and benchmarks can swap the physics for a cheap
stand-in; :func:`sim_trials` is the real one (PyBullet, through ``offroadbench.sim``). It drives
with the cell's ``[planner]`` (a planner or a policy), which sees the closed class map of the
cell's own ``[roughness]`` config and plans inside the ``[missions]`` border.

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
from typing import Any, Callable, Iterator, Mapping, Sequence

from offroadbench.navigation.missions import sample_mission
from offroadbench.study.spec import CellPlan

__all__ = ["TerrainTask", "TrialFn", "run_terrain", "collect_terrain", "sim_trials", "keeps_telemetry",
           "Replay", "replay_trial"]

#: ``trial_fn(hm, missions, cell) -> iterator of TrialResult.as_row() dicts, one per mission, in order``
TrialFn = Callable[[Any, Sequence[Any], CellPlan], Iterator[Mapping[str, Any]]]


@dataclass(frozen=True)
class TerrainTask:
    """One terrain of one grid cell and its pending missions ((index, seed) pairs)."""

    cell: CellPlan
    terrain: int
    terrain_seed: int
    missions: tuple[tuple[int, int], ...]
    telemetry: str = "failed"
    """Which trials' telemetry to send back: ``none``, ``failed`` or ``all``."""


def keeps_telemetry(setting: str, success: bool) -> bool:
    """Whether a trial's telemetry is kept under ``setting`` (none / failed / all)."""
    return setting == "all" or (setting == "failed" and not success)


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
    for mission, item in zip(missions, trial_fn(hm, missions, cell)):
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
        yield ("trial", cell.index, task.terrain, k, task.terrain_seed, seeds[k], row, kept)


def collect_terrain(task: TerrainTask, trial_fn: TrialFn | None = None) -> list[tuple]:
    """All messages of :func:`run_terrain` as a list (for executors that return per task)."""
    return list(run_terrain(task, trial_fn))


# ---------------------------------------------------------------------------- physics
def _closed_classes(hm, cell: CellPlan):
    from offroadbench.analysis.roughness import classify_terrain

    return classify_terrain(hm, cell.section("roughness")).closed


def _drive_kwargs(hm, cell: CellPlan) -> dict[str, Any]:
    """The planner, class map and border of the cell's trials (the class map only when the
    planner's or policy's registry entry declares that it needs it)."""
    choice = cell.section("planner")
    return {"planner": choice, "classes": _closed_classes(hm, cell) if "classes" in choice.needs else None,
            "border_m": cell.section("missions").border_m,
            "controller": cell.section("controller"), "rules": cell.section("rules")}


def sim_trials(hm, missions, cell: CellPlan) -> Iterator[Any]:
    """The real trials (PyBullet): one World per terrain, one TrialRecord per mission as it finishes."""
    from offroadbench.sim import World
    from offroadbench.sim.runner import drive_mission

    kwargs = _drive_kwargs(hm, cell)
    with World(hm, cell.section("vehicle"), cell.section("sim")) as world:
        for mission in missions:
            yield drive_mission(world, mission, **kwargs)


# ---------------------------------------------------------------------------- replay
@dataclass(frozen=True, eq=False)
class Replay:
    """One stored trial driven again: the new record, the stored row and what it was driven on."""

    record: Any
    """The new offroadbench.sim.runner.TrialRecord."""
    stored: Mapping[str, Any]
    """The stored row of the trial."""
    identical: bool
    """Whether every field of the new row equals the stored one (NaN equal to NaN)."""
    hm: Any
    classes: Any
    """The closed class map of the cell's roughness config."""
    cell: CellPlan
    mission: Any


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    return a == b


def replay_trial(run_dir, cell: int, terrain: int, mission: int) -> Replay:
    """Drive trial (cell, terrain, mission) of a run directory again, from its stored recipe,
    settings and seeds. Unknown keys are InputErrors naming what exists."""
    import json

    from offroadbench.errors import InputError
    from offroadbench.sim import World
    from offroadbench.sim.runner import drive_mission
    from offroadbench.study.store import Store
    from offroadbench.terrain.recipe import generate_terrain

    with Store(run_dir) as store:
        meta = store.meta()
        hit = store.con.execute("SELECT terrain_seed, mission_seed, row FROM trials WHERE cell=? AND terrain=? AND mission=?",
                                (cell, terrain, mission)).fetchone()
    if hit is None:
        raise InputError(f"{run_dir}: no stored trial cell {cell}, terrain {terrain}, mission {mission} "
                         f"(cells 0-{len(meta.get('cells', [])) - 1}; see `study export` for the stored keys)")
    tseed, mseed, text = hit
    info = meta["cells"][cell]
    plan = CellPlan(index=cell, values=info["values"], key=info["seed_key"], recipe_data=info["recipe"],
                    settings=info["settings"])
    hm = generate_terrain(plan.recipe(), tseed)
    closed = _closed_classes(hm, plan)
    m = sample_mission(hm, closed, plan.section("missions"), mission, mseed)
    kwargs = _drive_kwargs(hm, plan)
    kwargs["classes"] = closed
    with World(hm, plan.section("vehicle"), plan.section("sim")) as world:
        rec = drive_mission(world, m, **kwargs)
    stored = json.loads(text)
    new = json.loads(json.dumps(rec.result.as_row()))  # the stored row went through JSON too
    identical = set(new) == set(stored) and all(_same(new[k], stored[k]) for k in new)
    return Replay(record=rec, stored=stored, identical=identical, hm=hm, classes=closed, cell=plan, mission=m)
