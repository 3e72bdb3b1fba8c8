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

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        if tasks:
            _LocalRun(self, tasks, trial_fn, handle).run()


class _LocalRun:
    """One :meth:`LocalExecutor.run`: the task queue, the workers (each with its own pipe), the
    tasks in flight and how many are pending; one method per step (start, receive, replace a hung
    worker, wait, stop)."""

    def __init__(self, executor: LocalExecutor, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None,
                 handle: Handle) -> None:
        import multiprocessing as mp

        self.limit_s, self.poll_s, self.workers = executor.trial_timeout_s, executor.poll_s, executor.workers
        self.tasks, self.trial_fn, self.handle = tasks, trial_fn, handle
        self.ctx = mp.get_context("fork")
        self.task_q = self.ctx.Queue()
        # at once, before its feeder thread exists: a stop may leave that thread blocked writing tasks
        # to workers that are gone, and the interpreter must not wait for it at exit (issue 43)
        self.task_q.cancel_join_thread()
        self.procs: dict = {}  # reading end of a worker's pipe -> its process
        self.serial = iter(range(10**9))
        self.by_key = {(t.cell.index, t.terrain): t for t in tasks}
        self.running: dict[tuple[int, int], _Running] = {}
        self.pending = len(tasks)

    def run(self) -> None:
        finished = False
        try:
            for task in self.tasks:
                self.task_q.put(task)
            for _ in range(min(self.workers, len(self.tasks))):
                self.start()
            while self.pending:
                self.step()
            finished = True
        finally:
            self.close(finished)

    def step(self) -> None:
        """Replace the workers past the limit, then wait for messages (at most until the next deadline)."""
        from multiprocessing.connection import wait

        if self.limit_s is not None:
            now = time.monotonic()
            for key in [k for k, r in self.running.items() if now - r.since > self.limit_s]:
                self.replace_hung(key)
            if not self.pending:
                return
        for reader in wait(list(self.procs), timeout=self.wait_s()):
            if reader in self.procs:
                self.receive(reader)

    def wait_s(self) -> float:
        """How long to wait for messages: the poll, or less when a task's deadline comes sooner."""
        if self.limit_s is None or not self.running:
            return self.poll_s
        first = min(r.since for r in self.running.values()) + self.limit_s
        return min(self.poll_s, max(0.0, first - time.monotonic()) + 1e-3)

    def start(self) -> None:
        """Start one worker on its own pipe."""
        reader, writer = self.ctx.Pipe(duplex=False)
        p = self.ctx.Process(target=_worker, args=(self.task_q, writer, self.trial_fn, os.getpid()), daemon=True,
                             name=f"study-{next(self.serial)}")
        p.start()
        writer.close()  # the worker holds its own copy: EOF on the reader once it is gone
        self.procs[reader] = p

    def stop(self, reader) -> None:
        """Stop one worker (killed if alive: a hung trial may ignore SIGTERM) and close its pipe."""
        p = self.procs.pop(reader)
        if p.is_alive():
            p.kill()
        p.join(timeout=5)
        reader.close()

    def receive(self, reader) -> None:
        """Take one message from a worker: a task's message goes to ``handle``, a control message
        updates the tasks in flight, a task's error is raised, a worker gone is stopped (or an
        error when it died)."""
        try:
            msg = reader.recv()
        except (EOFError, OSError):
            p = self.procs[reader]
            p.join(timeout=5)
            if p.exitcode not in (None, 0):
                raise StudyError(f"worker {p.name} died (exit code {p.exitcode}); "
                                 "finished trials are saved, run the same command again to resume") from None
            self.stop(reader)
            return
        if isinstance(msg, (TerrainBuilt, TrialDone, TrialFaulted)):  # a task's message for the store
            self.progressed(msg)
            self.handle(msg)
            return
        kind = msg[0]  # the executor's own control messages: (kind, task key, ...)
        if kind == "begin":
            self.running[msg[1]] = _Running(self.by_key[msg[1]], msg[2], time.monotonic())
        elif kind == "done":
            self.running.pop(msg[1], None)
            self.pending -= 1
        elif kind == "error":
            raise task_failure(msg[1], msg[2], msg[3], msg[4])

    def progressed(self, msg: TerrainBuilt | TrialDone | TrialFaulted) -> None:
        """A task sent something: its clock restarts; note its terrain built or its mission finished."""
        r = self.running.get(msg.key)
        if r is None:
            return
        r.since = time.monotonic()
        if isinstance(msg, TerrainBuilt):
            r.built = True
        else:
            r.finished.add(msg.mission)

    def replace_hung(self, key: tuple[int, int]) -> None:
        """A task past the limit: take what its worker sent before, store its hung trial as a fault,
        queue its later missions, and replace the worker."""
        r = self.running[key]
        reader = next((rd for rd, p in self.procs.items() if p.pid == r.pid), None)
        while reader is not None and reader in self.procs and not reader.closed and reader.poll(0):
            self.receive(reader)  # what it sent before the limit passed counts
            if key not in self.running or time.monotonic() - self.running[key].since <= self.limit_s:
                return
        del self.running[key]
        hung = r.hung_mission()
        log.info("cell %d, terrain %d: %s ran longer than %g s; stored as a fault, its worker replaced",
                 key[0], key[1], "the terrain build" if hung is None else f"mission {hung}", self.limit_s)
        if reader is not None and reader in self.procs:
            self.stop(reader)
        faults, rest = timeout_faults(r.task, hung, r.finished, self.limit_s)
        for f in faults:
            self.handle(f)
        if rest is not None:
            self.by_key[key] = rest
            self.task_q.put(rest)
        else:
            self.pending -= 1
        self.start()

    def close(self, finished: bool) -> None:
        """End every worker (idle ones told to end, the rest terminated) and close the queue."""
        for p in self.procs.values():
            if finished:  # every worker is idle: let it end
                self.task_q.put(None)
            elif p.is_alive():  # all at once: a stop takes one worker's time, not the sum
                p.terminate()
        for reader in list(self.procs):
            self.procs[reader].join(timeout=5)
            self.stop(reader)
        self.task_q.close()
