"""Run (or resume) a failure search into a run directory: propose a batch, store it, drive it, repeat.

A search's run directory is a study's: the same ``study.sqlite`` (offroadbench.study.store.store), in
which every trial is a study cell of its own (cell c, terrain 0, mission 0; its recipe and
settings in the meta data, so ``study replay`` and ``study export`` work on it), plus a table of the
search's own (offroadbench.study.store.search) saying which stream and batch each proposal belongs
to and where it lies in the parameter space. The run directory is owned by one
:class:`~offroadbench.study.session.RunSession` per call, as a study's.

A proposal whose terrain holds no mission (no low-roughness start cell, no goal: the mission rules
of Majhor & Bos 2023, Sec. 2.3, cannot be met) is stored with ``failure_reason = "no_mission"``:
it is outside what a mission is, not a failure of the vehicle, so the falsifier is not told it,
the cross-entropy levels rank it last, and the estimators count it as no failure (the report
counts these trials apart).

A proposal whose trial faults (the vehicle thrown while it settles, past the per-trial limit) is
done: it is stored as a fault, it has no margin (as one whose terrain holds no mission), and it is
run again only when a call asks for it (``retry_faults``: once more per call). A retried trial's row
says so (``retried_fault``, the fault's reason): the report and the estimators count its outcome,
the history the proposals are made from keeps it without a margin, as the later proposals saw it,
so a resume still makes the same proposals.

Crash safety and resumption. A batch's proposals and cells are committed in one transaction
before any of its trials runs; each trial is committed the moment it ends (the study store's
guarantees). On a restart, every stream is rebuilt from what is stored: finished batches are its
history, a stored batch with missing trials is proposed again (:func:`offroadbench.search.
falsifier.propose` is a pure function of the history), checked to be the same as stored, and
only its missing trials run. So a search killed at any instant and run again makes the same
proposals as one that never stopped.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench import seeding
from offroadbench.config import to_dict
from offroadbench.errors import InputError, StudyError
from offroadbench.progress import ProgressFn
from offroadbench.search.falsifier import Batch, plan_batch, propose, stream_seed
from offroadbench.search.objective import failure_margin
from offroadbench.navigation.missions import map_too_small
from offroadbench.search.plan import SearchPlan, trial_cell
from offroadbench.study.execution.executors import get_executor
from offroadbench.study.execution.tasks import NO_MISSION_FAULT, NO_MISSION_KIND, TerrainTask, TrialFaulted, TrialFn
from offroadbench.study.runner import default_trial_timeout_s
from offroadbench.study.session import RunRates, RunSession, code_version
from offroadbench.study.spec.config import CellPlan
from offroadbench.study.store.search import add_search_batch, ensure_search_table, next_search_cell, stream_trials

log = logging.getLogger(__name__)

__all__ = ["NO_MISSION", "RETRIED", "SearchSummary", "cell_meta", "margin_of", "no_mission_row", "run_search", "search_meta"]

@dataclass(frozen=True)
class SearchSummary(RunRates):
    """What one ``run_search`` call did."""

    run_dir: Path
    total: int
    """Trials of the whole search (groups x methods x budget)."""
    done: int
    """Trials stored after this call."""
    ran: int
    """Trials run by this call."""
    failures: int
    """Failed trials stored after this call."""
    wall_s: float
    faults: int = 0
    """Proposals stored as faults after this call (no outcome, no margin)."""
    new_faults: tuple = ()
    """The faults this call stored, per kind (offroadbench.study.session.FaultCount)."""


def _columns(plan: SearchPlan) -> dict[str, str]:
    keys = [a.key for a in plan.study.grid] + list(plan.search.keys)
    lasts = [k.split(".", 1)[0] if k in ("planner.name", "vehicle.name") else k.rsplit(".", 1)[-1] for k in keys]
    return {k: (last if lasts.count(last) == 1 else k) for k, last in zip(keys, lasts, strict=True)}


def cell_meta(c: CellPlan) -> dict[str, Any]:
    return {"index": c.index, "values": dict(c.values), "seed_key": c.key, "recipe": dict(c.recipe_data),
            "settings": {k: dict(v) for k, v in c.settings.items()}}


def search_meta(plan: SearchPlan, budget: int | None, source_text: str, version: str) -> dict[str, Any]:
    """The store's meta data of a search (the study keys ``study report`` and ``replay`` read, plus ``search``)."""
    return {
        "study_id": plan.search_id,
        "kind": "search",
        "study": to_dict(plan.study),
        "study_toml": source_text,
        "search": to_dict(plan.search),
        "groups": [cell_meta(g) for g in plan.groups],
        "columns": _columns(plan),
        "cells": [],
        "n_trials": len(plan.groups) * sum(plan.search.method_budget(m, budget) for m in plan.search.methods),
        "version": version,
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


#: failure_reason of a proposal whose terrain holds no mission (no start or goal cell of the
#: mission rules): not a vehicle failure, so the search leaves it out (margin NaN, not counted as failed)
NO_MISSION = "no_mission"
#: key of a stored row whose trial faulted before and was run again (--retry-faults): the fault's reason
RETRIED = "retried_fault"


def no_mission_row(message: str) -> dict[str, Any]:
    """The stored row of a proposal whose terrain holds no mission."""
    nan = float("nan")
    return {"mission_index": 0, "success": False, "failure_reason": NO_MISSION, "error": " ".join(message.split()),
            "start_x_m": nan, "start_y_m": nan, "goal_x_m": nan, "goal_y_m": nan, "final_distance_to_goal_m": nan}


def _no_mission_trial(msg: TrialFaulted) -> dict[str, Any] | None:
    """A fault's stored row instead (RunSession's ``fault_row``): a proposal whose terrain holds no
    mission is a trial of the search (a row saying so); any other fault stays a fault."""
    if msg.kind != NO_MISSION_KIND:
        return None
    log.info("cell %d: %s; stored as %s", msg.cell, msg.reason, NO_MISSION)
    return no_mission_row(msg.reason.removeprefix(NO_MISSION_FAULT))


def margin_of(plan: SearchPlan, group: CellPlan, values: Mapping[str, Any], row: Mapping[str, Any]) -> float:
    """The failure margin (offroadbench.search.objective) of a stored row, with the trial's own
    rules, controller and vehicle (searched settings keys applied); NaN for a proposal whose
    terrain holds no mission."""
    if row.get("failure_reason") == NO_MISSION:
        return float("nan")
    ts = group.trial_settings
    parts = {"rules": ts.rules, "controller": ts.controller, "vehicle": ts.vehicle}
    for k, v in values.items():
        table, _, fld = k.partition(".")
        if table in parts and "." not in fld:
            parts[table] = dataclasses.replace(parts[table], **{fld: v})
    speed = min(parts["controller"].cruise_speed_m_s, parts["vehicle"].max_speed_m_s)
    return failure_margin(row, tip_angle_deg=parts["rules"].tip_angle_deg, timeout_factor=parts["rules"].timeout_factor,
                          speed_m_s=speed)


def _ended(entry: Mapping[str, Any]) -> bool:
    """Whether a stored proposal is done: its trial stored, as a row or as a fault."""
    return entry["row"] is not None or entry.get("fault") is not None


def _history(plan: SearchPlan, group: CellPlan, stored: list[dict[str, Any]]) -> tuple[list[Batch], list[list[dict]]]:
    """(finished batches, every stored batch's entries) of one stream."""
    batches: dict[int, list[dict]] = {}
    for e in stored:
        batches.setdefault(e["batch"], []).append(e)
    ordered = [batches[b] for b in sorted(batches)]
    done = []
    for entries in ordered:
        if not all(_ended(e) for e in entries):
            break
        x = np.array([e["x"] for e in entries], dtype=float)
        # a faulted trial gave no outcome: no margin (as a proposal whose terrain holds no mission); one
        # run again (--retry-faults) keeps none in the history, which stays as the later proposals saw it
        m = np.array([float("nan") if e["row"] is None or RETRIED in e["row"]
                      else margin_of(plan, group, plan.search.values(e["x"]), e["row"]) for e in entries])
        seeds = tuple(None if e["terrain_seed"] is None else (int(e["terrain_seed"]), int(e["mission_seed"]))
                      for e in entries)
        done.append(Batch(entries[0]["stage"], x, np.array([e["z"] for e in entries], dtype=float), m, seeds))
    return done, ordered


#: first terrain index of the ``ce-is`` stream's own nuisance draws: its terrains and missions are
#: not those of the ``random`` stream (trial k of which drives terrain k), so that the Monte Carlo
#: reference and the importance-sampling estimate are independent and one can check the other
CE_TERRAIN_OFFSET = 1 << 20
#: nuisance index offset of each SearchConfig.replicate: replicate r's trial k drives index
#: k + r * REPLICATE_OFFSET (beyond every stream's own range)
REPLICATE_OFFSET = 1 << 24


def _nuisance(plan: SearchPlan, group: CellPlan, k: int, method: str = "random") -> tuple[int, int]:
    """(terrain seed, mission seed) of trial k of a stream (study seed rules; see SearchConfig.fix_*;
    the ``ce-is`` stream's terrains start at :data:`CE_TERRAIN_OFFSET`)."""
    cfg, root = plan.search, plan.study.root_seed
    k = k + (CE_TERRAIN_OFFSET if method == "ce-is" else 0) + cfg.replicate * REPLICATE_OFFSET
    j = 0 if cfg.fix_terrain else k
    m = k if (cfg.fix_terrain and not cfg.fix_mission) else 0
    return seeding.terrain_seed(root, j, cell=group.key), seeding.mission_seed(root, j, m, cell=group.key)


def _same_seeds(seeds: tuple, entries: list[dict[str, Any]]) -> bool:
    """Whether the stored trials of a re-proposed batch drove the seeds the proposal names (where it names them)."""
    for i, e in enumerate(entries):
        chosen = seeds[i] if i < len(seeds) else None
        if chosen is not None and _ended(e) and (int(e["terrain_seed"]), int(e["mission_seed"])) != chosen:
            return False
    return True


def _executor(plan: SearchPlan, executor: str, workers: int | None, scheduler: str | None,
              options: Mapping[str, Any] | None):
    """The executor of a search; the per-trial limit by default generous for the slowest corner of the ranges."""
    options = dict(options or {})
    if executor in ("local", "dask") and options.get("trial_timeout_s") is None:
        lo = np.array([p.low for p in plan.search.params])
        hi = np.array([p.high for p in plan.search.params])
        corners = [trial_cell(plan, g, 0, x) for g in plan.groups for x in (lo, hi)]
        options["trial_timeout_s"] = default_trial_timeout_s(corners)
    return get_executor(executor, workers, scheduler, **options)


def run_search(plan: SearchPlan, run_dir: str | Path, *, budget: int | None = None, executor: str = "local",
               workers: int | None = None, scheduler: str | None = None,
               executor_options: Mapping[str, Any] | None = None, trial_fn: TrialFn | None = None,
               source_text: str = "", progress: ProgressFn | None = None,
               retry_faults: bool = False) -> SearchSummary:
    """Run (or resume) the search ``plan`` into ``run_dir``, ``budget`` trials per method and group
    (every method alike; default the ``[search]`` table's ``budget``, ``mc_budget`` and ``ce_budget``).
    ``progress(stored, total)`` counts stored trials and faults. A proposal whose trial faults is
    stored as a fault and the search goes on; ``retry_faults`` runs the stored faults once more.
    Ctrl-C stops the workers and raises :class:`~offroadbench.errors.RunInterrupted`; every
    committed trial stays and the next call goes on from there."""
    cfg = plan.search
    if budget is not None and (isinstance(budget, bool) or not isinstance(budget, int) or budget < 1):
        raise InputError(f"--budget = {budget!r}; must be an integer >= 1")
    ex = _executor(plan, executor, workers, scheduler, executor_options)
    total = len(plan.groups) * sum(cfg.method_budget(m, budget) for m in cfg.methods)
    meta = search_meta(plan, budget, source_text, code_version())
    with RunSession(run_dir, meta, kind="search", total=total, executor=ex, executor_name=executor,
                    telemetry=plan.study.telemetry, retry_faults=retry_faults, progress=progress,
                    fault_row=_no_mission_trial, retry_mark=RETRIED) as session:
        ensure_search_table(session.store)
        for gi, group in enumerate(plan.groups):
            for method in cfg.methods:
                _run_stream(plan, session, gi, group, method, cfg.method_budget(method, budget), trial_fn)
    s = session.summary()
    return SearchSummary(run_dir=s.run_dir, total=total, done=s.done, ran=s.ran, failures=s.done - s.successes,
                         wall_s=s.wall_s, faults=s.faults, new_faults=s.new_faults)


def _next_batch(plan: SearchPlan, session: RunSession, gi: int, group: CellPlan, method: str, budget: int):
    """The stream's next batch to run: (index, proposal, its stored entries, its cells), or None when
    the stream has spent its budget. A stored batch whose trials did not all run is proposed again
    and checked to be the same as stored; a new batch is proposed and stored before it runs."""
    cfg = plan.search
    seed = stream_seed(plan.study.root_seed, gi, method, cfg.replicate)
    history, stored = _history(plan, group, stream_trials(session.store, gi, method))
    b = len(history)
    if b < len(stored):  # a stored batch whose trials did not all run: propose it again, check, finish it
        entries = stored[b]
        prop = propose(method, entries[0]["stage"], len(entries), cfg, seed, b, history)
        old = np.array([e["x"] for e in entries], dtype=float)
        if not np.array_equal(old, prop.x) or not _same_seeds(prop.seeds, entries):
            raise StudyError(f"{session.run_dir}: the stored batch {b} of {method} in group {gi} differs from what "
                             "this code proposes (another offroadbench version?); use another --out directory")
        cells = [trial_cell(plan, group, e["cell"], np.asarray(e["x"])) for e in entries]
        return b, prop, history, entries, cells
    stage, n = plan_batch(method, cfg, history, budget)
    if n == 0:
        return None
    prop = propose(method, stage, n, cfg, seed, b, history)
    start = next_search_cell(session.store)
    cells = [trial_cell(plan, group, start + i, prop.x[i]) for i in range(n)]
    add_search_batch(session.store, gi, method, b, prop.stage,
                     [(prop.x[i], prop.z[i], prop.log_w[i]) for i in range(n)], [cell_meta(c) for c in cells])
    return b, prop, history, [{"cell": c.index, "row": None} for c in cells], cells


def _too_small(cell: CellPlan) -> str | None:
    """Why a proposal's map cannot hold its missions (offroadbench.navigation.missions.map_too_small),
    or None: such a proposal holds no mission, as one whose drawn terrain has no start or goal cell."""
    grid = cell.recipe().grid
    size = grid.cell_size_m
    return map_too_small((grid.cols - 1) * size, (grid.rows - 1) * size, cell.section("missions"))


def _run_stream(plan: SearchPlan, session: RunSession, gi: int, group: CellPlan, method: str, budget: int,
                trial_fn: TrialFn | None) -> None:
    """Run one stream, batch after batch, up to ``budget`` trials."""
    while (batch := _next_batch(plan, session, gi, group, method, budget)) is not None:
        b, prop, history, entries, cells = batch
        k0 = sum(len(h.margin) for h in history)
        tasks = []
        for i, (e, c) in enumerate(zip(entries, cells, strict=True)):
            if not _ended(e):
                chosen = prop.seeds[i] if i < len(prop.seeds) else None
                tseed, mseed = _nuisance(plan, group, k0 + i, method) if chosen is None else chosen
                tasks.append(TerrainTask(cell=c, terrain=0, terrain_seed=tseed, missions=((0, mseed),),
                                         telemetry=plan.study.telemetry))
        small = {t.cell.index: _too_small(t.cell) for t in tasks}
        for task in tasks:
            if small[task.cell.index]:  # no mission fits its map: nothing to run
                session.handle(TrialFaulted(task.cell.index, 0, 0, task.terrain_seed, task.missions[0][1],
                                            NO_MISSION_FAULT + small[task.cell.index], NO_MISSION_KIND))
        session.run([t for t in tasks if not small[t.cell.index]], trial_fn)
        stored = session.stored_keys()
        if any((c.index, 0, 0) not in stored for c in cells):  # never propose and run a batch again in a loop
            raise StudyError(f"{session.run_dir}: batch {b} of {method} in group {gi} ran, but not every trial of it "
                             "was stored as a row or a fault (a trial function that stops early?)")
        log.info("group %d %s batch %d (%s) done", gi, method, b, prop.stage)
