"""Run (or resume) a failure search into a run directory: propose a batch, store it, drive it, repeat.

A search's run directory is a study's: the same ``study.sqlite`` (offroadbench.study.store.store), in
which every trial is a study cell of its own (cell c, terrain 0, mission 0; its recipe and
settings in the meta data, so ``study replay`` and ``study export`` work on it), plus one table
of the search's own::

    search_trials(cell, grp, method, batch, slot, stage, x, z, log_w)

which says which stream (grid cell ``grp``, ``method``) and batch each cell belongs to, where it
lies in the parameter space (``x`` and the standard-normal ``z``, JSON lists) and its log
likelihood ratio for the estimators (NULL for the falsifier).

A proposal whose terrain holds no mission (no low-roughness start cell, no goal: the mission rules
of Majhor & Bos 2023, Sec. 2.3, cannot be met) is stored with ``failure_reason = "no_mission"``:
it is outside what a mission is, not a failure of the vehicle, so the falsifier is not told it,
the cross-entropy levels rank it last, and the estimators count it as no failure (the report
counts these trials apart).

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
import json
import logging
import math
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench import seeding
from offroadbench.config import to_dict
from offroadbench.errors import InputError, StudyError
from offroadbench.progress import ProgressFn, report
from offroadbench.search.falsifier import Batch, plan_batch, propose, stream_seed
from offroadbench.search.objective import failure_margin
from offroadbench.search.plan import SearchPlan, trial_cell
from offroadbench.study.spec.config import CellPlan
from offroadbench.study.store.store import RunLock, Store, remove_stale_temp_files
from offroadbench.study.execution.tasks import NO_MISSION_FAULT, TerrainBuilt, TerrainTask, TrialDone, TrialFaulted, TrialFn

log = logging.getLogger(__name__)

__all__ = ["NO_MISSION", "SearchSummary", "SEARCH_TABLE", "infeasible_cell", "margin_of", "no_mission_row", "run_search",
           "stream_trials"]

SEARCH_TABLE = """
CREATE TABLE IF NOT EXISTS search_trials (
    cell INTEGER PRIMARY KEY, grp INTEGER NOT NULL, method TEXT NOT NULL, batch INTEGER NOT NULL,
    slot INTEGER NOT NULL, stage TEXT NOT NULL, x TEXT NOT NULL, z TEXT NOT NULL, log_w REAL,
    UNIQUE (grp, method, batch, slot));
"""


@dataclass(frozen=True)
class SearchSummary:
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


def _columns(plan: SearchPlan) -> dict[str, str]:
    keys = [a.key for a in plan.study.grid] + list(plan.search.keys)
    lasts = [k.split(".", 1)[0] if k in ("planner.name", "vehicle.name") else k.rsplit(".", 1)[-1] for k in keys]
    return {k: (last if lasts.count(last) == 1 else k) for k, last in zip(keys, lasts, strict=True)}


def _cell_meta(c: CellPlan) -> dict[str, Any]:
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
        "groups": [_cell_meta(g) for g in plan.groups],
        "columns": _columns(plan),
        "cells": [],
        "n_trials": len(plan.groups) * sum(plan.search.method_budget(m, budget) for m in plan.search.methods),
        "version": version,
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


#: failure_reason of a proposal whose terrain holds no mission (no start or goal cell of the
#: mission rules): not a vehicle failure, so the search leaves it out (margin NaN, not counted as failed)
NO_MISSION = "no_mission"
_MISSION_ERRORS = re.compile(r"^(cell (\d+), terrain 0: )?(no start cell|could not place mission|map [^:]* leaves)")


def infeasible_cell(exc: InputError, cells: list[int]) -> int | None:
    """The cell of a study error saying that its terrain holds no mission (the mission sampler's
    InputError as the process executors report it, ``cell C, terrain 0: no start cell ...``, or
    bare from the inline executor, which runs ``cells`` in order: then the first of them), if it
    is one of ``cells``."""
    m = _MISSION_ERRORS.match(str(exc))
    if m is None or not cells:
        return None
    cell = int(m.group(2)) if m.group(2) else cells[0]
    return cell if cell in cells else None


def no_mission_row(message: str) -> dict[str, Any]:
    """The stored row of a proposal whose terrain holds no mission."""
    nan = float("nan")
    return {"mission_index": 0, "success": False, "failure_reason": NO_MISSION, "error": " ".join(message.split()),
            "start_x_m": nan, "start_y_m": nan, "goal_x_m": nan, "goal_y_m": nan, "final_distance_to_goal_m": nan}


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


def stream_trials(store: Store, grp: int, method: str) -> list[dict[str, Any]]:
    """The stored proposals of one stream in order, each with its trial row (None if not run yet)."""
    cur = store.con.execute(
        "SELECT s.cell, s.batch, s.slot, s.stage, s.x, s.z, s.log_w, t.row, t.terrain_seed, t.mission_seed "
        "FROM search_trials s LEFT JOIN trials t ON t.cell = s.cell AND t.terrain = 0 AND t.mission = 0 "
        "WHERE s.grp = ? AND s.method = ? ORDER BY s.batch, s.slot", (grp, method))
    out = []
    for cell, batch, slot, stage, x, z, log_w, row, tseed, mseed in cur.fetchall():
        out.append({"cell": cell, "batch": batch, "slot": slot, "stage": stage, "x": json.loads(x), "z": json.loads(z),
                    "log_w": float("nan") if log_w is None else log_w,
                    "row": None if row is None else json.loads(row), "terrain_seed": tseed, "mission_seed": mseed})
    return out


def _history(plan: SearchPlan, group: CellPlan, stored: list[dict[str, Any]]) -> tuple[list[Batch], list[list[dict]]]:
    """(finished batches, every stored batch's entries) of one stream."""
    batches: dict[int, list[dict]] = {}
    for e in stored:
        batches.setdefault(e["batch"], []).append(e)
    ordered = [batches[b] for b in sorted(batches)]
    done = []
    for entries in ordered:
        if any(e["row"] is None for e in entries):
            break
        x = np.array([e["x"] for e in entries], dtype=float)
        m = np.array([margin_of(plan, group, plan.search.values(e["x"]), e["row"]) for e in entries])
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
        if chosen is not None and e["row"] is not None and (int(e["terrain_seed"]), int(e["mission_seed"])) != chosen:
            return False
    return True


def _json_list(a: np.ndarray) -> str:
    return json.dumps([float(v) for v in np.asarray(a, dtype=float).ravel()])


def run_search(plan: SearchPlan, run_dir: str | Path, *, budget: int | None = None, executor: str = "local",
               workers: int | None = None, scheduler: str | None = None,
               executor_options: Mapping[str, Any] | None = None, trial_fn: TrialFn | None = None,
               source_text: str = "", progress: ProgressFn | None = None) -> SearchSummary:
    """Run (or resume) the search ``plan`` into ``run_dir``, ``budget`` trials per method and group
    (every method alike; default the ``[search]`` table's ``budget``, ``mc_budget`` and ``ce_budget``). ``progress(done, total)`` counts stored trials. Ctrl-C stops the
    workers and re-raises; every committed trial stays and the next call goes on from there."""
    from offroadbench.study.execution.executors import get_executor
    from offroadbench.study.fingerprint import platform_fingerprint
    from offroadbench.study.runner import code_version, default_trial_timeout_s

    cfg = plan.search
    if budget is not None and (isinstance(budget, bool) or not isinstance(budget, int) or budget < 1):
        raise InputError(f"--budget = {budget!r}; must be an integer >= 1")
    options = dict(executor_options or {})
    if executor in ("local", "dask") and options.get("trial_timeout_s") is None:
        lo = np.array([p.low for p in cfg.params])
        hi = np.array([p.high for p in cfg.params])
        corners = [trial_cell(plan, g, 0, x) for g in plan.groups for x in (lo, hi)]
        options["trial_timeout_s"] = default_trial_timeout_s(corners)
    ex = get_executor(executor, workers, scheduler, **options)
    version = code_version()
    t0 = time.perf_counter()
    run_dir = Path(run_dir)
    lock = RunLock(run_dir).acquire()
    try:
        remove_stale_temp_files(run_dir)
        store = Store(run_dir, create=True)
    except BaseException:
        lock.release()
        raise
    ran = 0
    total = len(plan.groups) * sum(cfg.method_budget(m, budget) for m in cfg.methods)
    try:
        store.con.executescript(SEARCH_TABLE)
        meta = store.meta()
        if meta and meta.get("kind") != "search":
            raise InputError(f"{run_dir} holds a study, not a search; use another --out directory")
        store.init_meta(search_meta(plan, budget, source_text, version))
        done, _ = store.counts()
        report(progress, done, total)
        run_id = store.start_run(executor, ex.workers, version, platform_fingerprint())
        status, error = "interrupted", None
        try:
            for gi, group in enumerate(plan.groups):
                for method in cfg.methods:
                    ran += _run_stream(plan, store, run_dir, gi, group, method, cfg.method_budget(method, budget), ex,
                                       trial_fn, run_id,
                                       lambda: report(progress, store.counts()[0], total))
            status = "finished"
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            status, error = "failed", f"{type(exc).__name__}: {exc}"
            raise
        finally:
            store.finish_run(run_id, status, error)
        done, successes = store.counts()
    finally:
        store.close()
        lock.release()
    return SearchSummary(run_dir=run_dir, total=total, done=done, ran=ran, failures=done - successes,
                         wall_s=time.perf_counter() - t0)


def _run_stream(plan: SearchPlan, store: Store, run_dir: Path, gi: int, group: CellPlan, method: str, budget: int,
                ex, trial_fn: TrialFn | None, run_id: int, tick) -> int:
    """Run one stream up to ``budget`` trials; returns the trials this call ran."""
    from offroadbench.study.runner import save_trial_telemetry

    cfg = plan.search
    seed = stream_seed(plan.study.root_seed, gi, method, cfg.replicate)
    ran = 0
    while True:
        history, stored = _history(plan, group, stream_trials(store, gi, method))
        b = len(history)
        if b < len(stored):  # a stored batch whose trials did not all run: propose it again, check, finish it
            entries = stored[b]
            stage, n = entries[0]["stage"], len(entries)
            prop = propose(method, stage, n, cfg, seed, b, history)
            old = np.array([e["x"] for e in entries], dtype=float)
            if not np.array_equal(old, prop.x) or not _same_seeds(prop.seeds, entries):
                raise StudyError(f"{run_dir}: the stored batch {b} of {method} in group {gi} differs from what this "
                                 "code proposes (another offroadbench version?); use another --out directory")
            cells = [trial_cell(plan, group, e["cell"], np.asarray(e["x"])) for e in entries]
        else:
            stage, n = plan_batch(method, cfg, history, budget)
            if n == 0:
                return ran
            prop = propose(method, stage, n, cfg, seed, b, history)
            start = store.con.execute("SELECT COALESCE(MAX(cell) + 1, 0) FROM search_trials").fetchone()[0]
            cells = [trial_cell(plan, group, start + i, prop.x[i]) for i in range(n)]
            entries = [{"cell": c.index, "row": None} for c in cells]
            _store_batch(store, gi, method, b, prop, cells)
        k0 = sum(len(h.margin) for h in history)
        tasks = []
        for i, (e, c) in enumerate(zip(entries, cells, strict=True)):
            if e["row"] is None:
                chosen = prop.seeds[i] if i < len(prop.seeds) else None
                tseed, mseed = _nuisance(plan, group, k0 + i, method) if chosen is None else chosen
                tasks.append(TerrainTask(cell=c, terrain=0, terrain_seed=tseed, missions=((0, mseed),),
                                         telemetry=plan.study.telemetry))

        def handle(msg: TerrainBuilt | TrialDone | TrialFaulted) -> None:
            nonlocal ran
            if isinstance(msg, TerrainBuilt):
                store.add_terrain(msg.cell, msg.terrain, msg.terrain_seed, msg.stats)
                return
            if isinstance(msg, TrialFaulted):
                if msg.reason.startswith(NO_MISSION_FAULT):  # the proposal's terrain holds no mission
                    log.info("cell %d: %s; stored as %s", msg.cell, msg.reason, NO_MISSION)
                    store.add_trial(msg.cell, msg.terrain, msg.mission, msg.terrain_seed, msg.mission_seed,
                                    no_mission_row(msg.reason.removeprefix(NO_MISSION_FAULT)), run_id=run_id)
                else:
                    store.add_fault(msg.cell, msg.terrain, msg.mission, msg.terrain_seed, msg.mission_seed,
                                    msg.reason, run_id=run_id)
                return
            files: list[str] = []
            if msg.kept is not None and not store.has_trial(msg.cell, msg.terrain, msg.mission):
                files = save_trial_telemetry(run_dir, msg.cell, msg.terrain, msg.mission, msg.kept)
            if store.add_trial(msg.cell, msg.terrain, msg.mission, msg.terrain_seed, msg.mission_seed, msg.row,
                               run_id=run_id, telemetry=files):
                ran += 1
                tick()

        while tasks:
            try:
                ex.run(tasks, trial_fn, handle)
                break
            except InputError as exc:  # a proposal whose terrain holds no mission: record it, run the rest
                tasks = [t for t in tasks if not store.has_trial(t.cell.index, 0, 0)]
                cell = infeasible_cell(exc, [t.cell.index for t in tasks])
                if cell is None:
                    raise
                task = next(t for t in tasks if t.cell.index == cell)
                log.info("cell %d: no mission can be drawn on its terrain (%s); stored as %s", cell, exc, NO_MISSION)
                store.add_trial(cell, 0, 0, task.terrain_seed, task.missions[0][1], no_mission_row(str(exc)),
                                run_id=run_id)
                tasks = [t for t in tasks if not store.has_trial(t.cell.index, 0, 0)]
        log.info("group %d %s batch %d (%s) done", gi, method, b, stage)


def _store_batch(store: Store, gi: int, method: str, b: int, prop, cells: list[CellPlan]) -> None:
    """Commit a batch's proposals and its cells (meta ``cells``) in one transaction."""
    (text,) = store.con.execute("SELECT value FROM meta WHERE key = 'cells'").fetchone()
    all_cells = json.loads(text)
    if len(all_cells) != cells[0].index:
        raise StudyError(f"{store.run_dir}: the store's cells ({len(all_cells)}) and search trials disagree")
    all_cells.extend(_cell_meta(c) for c in cells)
    store.con.execute("BEGIN IMMEDIATE")
    try:
        for i, c in enumerate(cells):
            lw = float(prop.log_w[i])
            store.con.execute(
                "INSERT INTO search_trials (cell, grp, method, batch, slot, stage, x, z, log_w) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (c.index, gi, method, b, i, prop.stage, _json_list(prop.x[i]), _json_list(prop.z[i]),
                 None if math.isnan(lw) else lw))
        store.con.execute("UPDATE meta SET value = ? WHERE key = 'cells'", (json.dumps(all_cells, sort_keys=True),))
        store.con.execute("COMMIT")
    except BaseException:
        store.con.execute("ROLLBACK")
        raise
