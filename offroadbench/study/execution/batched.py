"""The ``batched`` executor: a study's trials across terrains as batches of worlds of a batched engine.

For an engine that declares a ``batch_module`` (offroadbench.sim.engine.EngineCapabilities; the
``mujoco_warp`` engine), the executor builds every pending terrain (TerrainBuilt messages, as
offroadbench.study.execution.tasks.run_terrain sends them; in ``workers`` forked processes, default
the number of cores, each terrain as the ``local`` executor's workers build it, so the terrains
are the same to the bit whatever the count; a paper study's 60 terrains take ~1 s each on one
core), groups the terrains whose
trials can share one model (the same vehicle and physics, the same grid), and drives each group's
missions as one batch (the module's ``drive_batch``): a paper study's 60 terrains x 20 missions
are then one batch of 1,200 worlds, where the ``local`` executor gives the engine one terrain's 20
at a time. With ``--workers N`` given, a group is split into up to N batches of whole terrains
with about the same number of missions, each driven in a spawned process of its own (a fresh
interpreter: no device state is inherited; each loads the engine's kernels, ~10 s); a trial's
row does not depend on its batch, so the table is the same. Every trial's row is the trial runner's, so the study's table is the one ``inline``
gives on the same engine. A trial that could not give an outcome (TrialFault, PlannerRefusal) is
a TrialFaulted message, as under the other executors.

Tasks on an engine without a batch module, and runs with a stand-in ``trial_fn``, run one task at
a time in this process (the ``inline`` executor). A terrain's messages are sent as soon as all its
missions have ended, while the batch goes on: a study stopped mid-batch keeps every terrain that
ended (resume runs the others again).
"""

from __future__ import annotations

import importlib
import os
import signal
from typing import Iterator, Sequence

from offroadbench.errors import InputError, StudyError, TrialFault
from offroadbench.navigation.problem import PlannerRefusal
from offroadbench.sim.engine import engine_capabilities
from offroadbench.study.execution.common import Handle, worker_bootstrap
from offroadbench.study.execution.tasks import (REFUSED_FAULT, REFUSED_KIND, TerrainTask, TrialFaulted, TrialFn,
                                                build_terrain, run_terrain, trial_done)

__all__ = ["BatchedExecutor"]


class BatchedExecutor:
    """Run a study's trials as batches of a batched engine. Its terrains are built first, by
    ``workers`` forked processes (default: the number of cores). Then each group of terrains that
    share a model is one batch in this process (the default: the engine's device does the trials'
    parallel work), or, with ``workers`` given, split into up to ``workers`` batches of whole
    terrains, each in a spawned process of its own (on Warp's CPU device, which runs one core a
    batch, the way to use every core)."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 trial_timeout_s: float | None = None) -> None:
        if scheduler:
            raise InputError("--scheduler is only for --executor dask")
        if trial_timeout_s is not None:
            raise InputError("--trial-timeout-s is not for --executor batched (a batch's trials end together)")
        self.workers = workers or os.cpu_count() or 1
        self.batches = workers or 1
        """How many batches (processes) a group of terrains is split into."""

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        groups: dict[tuple, list] = {}
        batched = []
        for task in tasks:
            module = engine_capabilities(task.cell.trial_settings.sim.engine).batch_module
            if trial_fn is not None or module is None:
                for msg in run_terrain(task, trial_fn):
                    handle(msg)
                continue
            batched.append((task, module))
        for (task, module), (prepared, msgs) in zip(batched, build_terrains([t for t, _ in batched], self.workers),
                                                    strict=True):
            for msg in msgs:
                handle(msg)
            if prepared is None:  # no mission could be drawn: its faults are sent
                continue
            settings = task.cell.trial_settings
            key = (module, settings.vehicle.name, prepared.sim_for(settings.sim), prepared.hm.rows, prepared.hm.cols,
                   prepared.hm.cell_size_m)
            groups.setdefault(key, []).append((task, prepared, settings))
        for (module, *_), members in groups.items():
            chunks = split_terrains(members, self.batches)
            if len(chunks) == 1:
                drive_members(module, members, handle)
            else:
                _drive_in_processes(module, chunks, handle)


def split_terrains(members: Sequence, parts: int) -> list[list]:
    """``members`` (task, prepared, settings) in at most ``parts`` runs of whole terrains, in order,
    with about the same number of missions each: a terrain goes to the run whose share of the
    missions holds its middle mission."""
    parts = max(1, min(parts, len(members)))
    sizes = [len(p.missions) for _, p, _ in members]
    total, before = sum(sizes), 0
    chunks: list[list] = [[] for _ in range(parts)]
    for member, n in zip(members, sizes, strict=True):
        chunks[min(parts - 1, int(parts * (before + n / 2) / total))].append(member)
        before += n
    return [c for c in chunks if c]


def drive_members(module: str, members: Sequence, handle: Handle) -> None:
    """Drive the missions of ``members`` (task, prepared, settings) as one batch of ``module``'s
    engine, each terrain's messages handled as soon as its missions have ended."""
    importlib.import_module(module).drive_batch(
        [p for _, p, _ in members], [s for _, _, s in members],
        on_terrain=lambda k, records: _send(members[k][0], records, handle))


def _drive_in_processes(module: str, chunks: list[list], handle: Handle) -> None:
    """Each chunk of terrains as its own batch in its own spawned process (a fresh interpreter: no
    device state is inherited), their messages handled here as they come; an error in one ends
    the run, and a stop here ends the processes."""
    import multiprocessing as mp
    from multiprocessing.connection import wait

    from offroadbench import stop
    from offroadbench.study.execution.common import task_failure

    ctx = mp.get_context("spawn")
    procs = {}
    try:
        for chunk in chunks:
            reader, writer = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_batch_worker, args=(module, chunk, writer), daemon=True)
            proc.start()
            writer.close()
            procs[reader] = proc
        while procs:
            stop.check()
            for reader in wait(list(procs), timeout=0.5):
                try:
                    msg = reader.recv()
                except EOFError:  # the process died without its last message
                    proc = procs.pop(reader)
                    proc.join()
                    raise StudyError(f"a batch process ended with exit code {proc.exitcode} before its trials did") from None
                if isinstance(msg, tuple) and msg[0] == "done":
                    procs.pop(reader).join()
                elif isinstance(msg, tuple) and msg[0] == "error":
                    raise task_failure(msg[1], msg[2], msg[3], msg[4])
                else:
                    handle(msg)
    finally:
        for proc in procs.values():
            proc.terminate()
        for proc in procs.values():
            proc.join()


def _batch_worker(module: str, members: list, conn) -> None:
    """A batch process: drive ``members`` as one batch, sending every message through ``conn``,
    then ("done",); an exception as an ("error", ...) message. Ctrl-C is the coordinator's."""
    import traceback

    from offroadbench.study.execution.common import error_message

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    worker_bootstrap()
    try:
        drive_members(module, members, conn.send)
    except BaseException as exc:  # report and stop: the coordinator decides
        task = members[0][0]
        conn.send(error_message((task.cell.index, task.terrain), exc, traceback.format_exc()))
        return
    conn.send(("done",))


def build_terrains(tasks: Sequence[TerrainTask], workers: int) -> Iterator[tuple]:
    """offroadbench.study.execution.tasks.build_terrain of each task, in order, built by at most
    ``workers`` forked processes (here, for one task or one worker). A worker ignores Ctrl-C; the
    coordinator's stops the pool."""
    n = min(workers, len(tasks))
    if n <= 1:
        yield from map(build_terrain, tasks)
        return
    import multiprocessing as mp

    pool = mp.get_context("fork").Pool(n, initializer=_build_worker)
    try:
        yield from pool.imap(build_terrain, tasks)
        pool.close()
    except BaseException:  # an error, a stop, or the caller done early: the builders go at once
        pool.terminate()
        raise
    finally:
        pool.join()


def _build_worker() -> None:
    """A terrain builder's start, as a local executor's worker: Ctrl-C is the coordinator's, SIGTERM
    (the pool's terminate) ends it without the coordinator's stop handler."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    worker_bootstrap()


def _send(task: TerrainTask, records, handle: Handle) -> None:
    """One message per mission of ``task``: TrialDone for a record, TrialFaulted for a trial that
    raised TrialFault or PlannerRefusal; any other exception ends the run, as in run_terrain."""
    cell, seeds = task.cell, dict(task.missions)
    for (k, _), rec in zip(task.missions, records, strict=True):
        if isinstance(rec, TrialFault):
            handle(TrialFaulted(cell.index, task.terrain, k, task.terrain_seed, seeds[k], " ".join(str(rec).split())))
        elif isinstance(rec, PlannerRefusal):
            handle(TrialFaulted(cell.index, task.terrain, k, task.terrain_seed, seeds[k],
                                REFUSED_FAULT + " ".join(str(rec).split()), REFUSED_KIND))
        elif isinstance(rec, BaseException):
            raise rec
        else:
            handle(trial_done(task, k, seeds[k], rec))
