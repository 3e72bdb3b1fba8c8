"""The ``local`` executor: forked worker processes pull terrain tasks from a queue and stream each
trial back as it finishes; a worker silent for longer than ``trial_timeout_s`` is killed and
replaced (see offroadbench.study.execution.executors)."""

from __future__ import annotations

import logging
import os
import signal
import time
import traceback
from typing import Sequence

from offroadbench.errors import InputError, StudyError
from offroadbench.study.execution.tasks import TerrainBuilt, TerrainTask, TrialDone, TrialFaulted, TrialFn, run_terrain
from offroadbench.study.execution.common import (Handle, die_with_parent, error_message, worker_bootstrap,
                                                check_trial_timeout, task_failure, timeout_faults)

log = logging.getLogger(__name__)


def _worker(task_q, conn, trial_fn: TrialFn | None, parent_pid: int) -> None:
    """A worker process: pull tasks, send every message through its own pipe ``conn`` (a worker
    killed for a hung trial takes only its own pipe with it)."""
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the coordinator's SIGTERM handler is not the worker's
    worker_bootstrap()
    while True:
        task = task_q.get()
        if task is None:
            return
        key = (task.cell.index, task.terrain)
        conn.send(("begin", key, os.getpid()))
        try:
            for msg in run_terrain(task, trial_fn):
                if os.getppid() != parent_pid:
                    os._exit(1)
                conn.send(msg)
        except BaseException as exc:  # report and stop: the coordinator decides
            conn.send(error_message(key, exc, traceback.format_exc()))
            return
        conn.send(("done", key))


class _Running:
    """A task in a local worker: the task, the worker's pid, when it last sent something, whether
    its terrain is built and which missions are finished."""

    def __init__(self, task: TerrainTask, pid: int, now: float) -> None:
        self.task, self.pid, self.since, self.built, self.finished = task, pid, now, False, set()

    def hung_mission(self) -> int | None:
        """The mission running when the limit passed (None: the terrain build)."""
        if not self.built:
            return None
        return next((k for k, _ in self.task.missions if k not in self.finished), None)


class LocalExecutor:
    """``workers`` local processes (default: the number of cores).

    A worker whose task sends nothing for ``trial_timeout_s`` (a hung trial or terrain build) is
    killed and replaced; the hung trial is handed back as a :class:`TrialFaulted` (stored as a
    fault, not an outcome) and the task's later missions go back in the queue, so the study goes
    on. The limit is checked as often as it needs to be: any limit is enforced."""

    poll_s = 0.5

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 trial_timeout_s: float | None = None) -> None:
        if scheduler:
            raise InputError("--scheduler is only for --executor dask")
        self.workers = workers or os.cpu_count() or 1
        self.trial_timeout_s = check_trial_timeout(trial_timeout_s)

    def _wait_s(self, running: dict) -> float:
        if self.trial_timeout_s is None or not running:
            return self.poll_s
        first = min(r.since for r in running.values()) + self.trial_timeout_s
        return min(self.poll_s, max(0.0, first - time.monotonic()) + 1e-3)

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        import multiprocessing as mp
        from multiprocessing.connection import wait

        if not tasks:
            return
        ctx = mp.get_context("fork")
        task_q = ctx.Queue()
        # at once, before its feeder thread exists: a stop may leave that thread blocked writing tasks
        # to workers that are gone, and the interpreter must not wait for it at exit (issue 43)
        task_q.cancel_join_thread()
        procs: dict = {}  # reading end of a worker's pipe -> its process
        serial = iter(range(10**9))
        by_key = {(t.cell.index, t.terrain): t for t in tasks}
        running: dict[tuple[int, int], _Running] = {}
        state = {"pending": len(tasks)}

        def start() -> None:
            reader, writer = ctx.Pipe(duplex=False)
            p = ctx.Process(target=_worker, args=(task_q, writer, trial_fn, os.getpid()), daemon=True,
                            name=f"study-{next(serial)}")
            p.start()
            writer.close()  # the worker holds its own copy: EOF on the reader once it is gone
            procs[reader] = p

        def stop(reader) -> None:
            p = procs.pop(reader)
            if p.is_alive():
                p.kill()  # a hung trial may ignore SIGTERM
            p.join(timeout=5)
            reader.close()

        def receive(reader) -> None:
            try:
                msg = reader.recv()
            except (EOFError, OSError):
                p = procs[reader]
                p.join(timeout=5)
                if p.exitcode not in (None, 0):
                    raise StudyError(f"worker {p.name} died (exit code {p.exitcode}); "
                                     "finished trials are saved, run the same command again to resume") from None
                stop(reader)
                return
            if isinstance(msg, (TerrainBuilt, TrialDone, TrialFaulted)):  # a task's message for the store
                r = running.get(msg.key)
                if r is not None:
                    r.since = time.monotonic()
                    if isinstance(msg, TerrainBuilt):
                        r.built = True
                    else:
                        r.finished.add(msg.mission)
                handle(msg)
                return
            kind = msg[0]  # the executor's own control messages: (kind, task key, ...)
            if kind == "begin":
                running[msg[1]] = _Running(by_key[msg[1]], msg[2], time.monotonic())
            elif kind == "done":
                running.pop(msg[1], None)
                state["pending"] -= 1
            elif kind == "error":
                raise task_failure(msg[1], msg[2], msg[3], msg[4])

        def replace_hung(key: tuple[int, int]) -> None:
            r = running[key]
            reader = next((rd for rd, p in procs.items() if p.pid == r.pid), None)
            while reader is not None and reader in procs and not reader.closed and reader.poll(0):
                receive(reader)  # what it sent before the limit passed counts
                if key not in running or time.monotonic() - running[key].since <= self.trial_timeout_s:
                    return
            del running[key]
            hung = r.hung_mission()
            log.info("cell %d, terrain %d: %s ran longer than %g s; stored as a fault, its worker replaced",
                        key[0], key[1], "the terrain build" if hung is None else f"mission {hung}",
                        self.trial_timeout_s)
            if reader is not None and reader in procs:
                stop(reader)
            faults, rest = timeout_faults(r.task, hung, r.finished, self.trial_timeout_s)
            for f in faults:
                handle(f)
            if rest is not None:
                by_key[key] = rest
                task_q.put(rest)
            else:
                state["pending"] -= 1
            start()

        finished = False
        try:
            for task in tasks:
                task_q.put(task)
            for _ in range(min(self.workers, len(tasks))):
                start()
            while state["pending"]:
                if self.trial_timeout_s is not None:
                    now = time.monotonic()
                    for key in [k for k, r in running.items() if now - r.since > self.trial_timeout_s]:
                        replace_hung(key)
                    if not state["pending"]:
                        break
                for reader in wait(list(procs), timeout=self._wait_s(running)):
                    if reader in procs:
                        receive(reader)
            finished = True
        finally:
            if finished:  # every worker is idle: let them end
                for _ in procs:
                    task_q.put(None)
            for reader in list(procs):
                p = procs[reader]
                if finished:
                    p.join(timeout=5)
                elif p.is_alive():
                    p.terminate()
                    p.join(timeout=5)
                stop(reader)
            task_q.close()
