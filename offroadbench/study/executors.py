"""Executors: run terrain tasks somewhere and hand every message back to the coordinator.

Registry :data:`EXECUTORS` (name -> class). Each executor's ``run(tasks, trial_fn, handle)``
calls ``handle(message)`` in the calling process for every message of every task (see
:mod:`offroadbench.study.tasks`); the coordinator commits them to the store. Whatever the
executor, a task's results depend only on the task, so all of them give the same table.

* ``local`` (default): ``workers`` forked processes pull tasks from a queue and stream each
  trial back as soon as it finishes. Workers ignore Ctrl-C (the coordinator stops them) and die
  with the coordinator (``PR_SET_PDEATHSIG``), so a killed study leaves no orphans behind.
* ``inline``: runs in the calling process (debugging, profiling).
* ``dask``: one Dask task per terrain on a ``distributed`` cluster (``scheduler`` address, or a
  ``LocalCluster`` of ``workers`` processes when no address is given). A task's trials arrive
  when its terrain is done, so a killed coordinator loses the terrains in flight.
"""

from __future__ import annotations

import os
import queue
import signal
import sys
import traceback
from typing import Callable, Sequence

from offroadbench.errors import InputError
from offroadbench.study.tasks import TerrainTask, TrialFn, collect_terrain, run_terrain

__all__ = ["EXECUTORS", "get_executor", "StudyError", "InlineExecutor", "LocalExecutor", "DaskExecutor"]

Handle = Callable[[tuple], None]


class StudyError(RuntimeError):
    """A worker failed (an exception in a trial, or a worker process died)."""


class InlineExecutor:
    """Run every task in this process, one after the other."""

    def __init__(self, workers: int = 1, scheduler: str | None = None) -> None:
        self.workers = 1

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        for task in tasks:
            for msg in run_terrain(task, trial_fn):
                handle(msg)


# ---------------------------------------------------------------------------- local processes
def _die_with_parent(parent_pid: int) -> None:
    """Ask Linux to SIGKILL this process when its parent dies; exit if it already has."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:  # pragma: no cover - no libc: the ppid check below still applies
            pass
    if os.getppid() != parent_pid:
        os._exit(1)


def _worker(task_q, result_q, trial_fn: TrialFn | None, parent_pid: int) -> None:
    _die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while True:
        task = task_q.get()
        if task is None:
            return
        key = (task.cell.index, task.terrain)
        try:
            for msg in run_terrain(task, trial_fn):
                if os.getppid() != parent_pid:
                    os._exit(1)
                result_q.put(msg)
        except BaseException:  # report and stop: the coordinator decides
            result_q.put(("error", key, traceback.format_exc()))
            return
        result_q.put(("done", key))


class LocalExecutor:
    """``workers`` local processes (default: the number of cores)."""

    poll_s = 0.5

    def __init__(self, workers: int | None = None, scheduler: str | None = None) -> None:
        if scheduler:
            raise InputError("--scheduler is only for --executor dask")
        self.workers = workers or os.cpu_count() or 1

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        import multiprocessing as mp

        if not tasks:
            return
        ctx = mp.get_context("fork")
        task_q, result_q = ctx.Queue(), ctx.Queue()
        n = min(self.workers, len(tasks))
        for task in tasks:
            task_q.put(task)
        for _ in range(n):
            task_q.put(None)
        procs = [
            ctx.Process(target=_worker, args=(task_q, result_q, trial_fn, os.getpid()), daemon=True, name=f"study-{i}")
            for i in range(n)
        ]
        for p in procs:
            p.start()
        pending = len(tasks)
        try:
            while pending:
                try:
                    msg = result_q.get(timeout=self.poll_s)
                except queue.Empty:
                    dead = [p for p in procs if p.exitcode not in (None, 0)]
                    if dead:
                        raise StudyError(
                            f"worker {dead[0].name} died (exit code {dead[0].exitcode}); "
                            "finished trials are saved, run the same command again to resume"
                        )
                    continue
                kind = msg[0]
                if kind == "done":
                    pending -= 1
                elif kind == "error":
                    raise StudyError(f"terrain {msg[1]} failed in a worker:\n{msg[2]}")
                else:
                    handle(msg)
        finally:
            for p in procs:
                if p.is_alive():
                    p.terminate()
            for p in procs:
                p.join(timeout=5)
                if p.is_alive():  # pragma: no cover
                    p.kill()
                    p.join()
            for q in (task_q, result_q):
                q.cancel_join_thread()
                q.close()


# ---------------------------------------------------------------------------- dask
class DaskExecutor:
    """One Dask task per terrain on a ``distributed`` cluster (``pip install offroadbench[dask]``)."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None) -> None:
        try:
            import distributed  # noqa: F401
        except ImportError:  # pragma: no cover
            raise InputError("--executor dask needs dask and distributed: pip install 'offroadbench[dask]'") from None
        self.workers = workers or os.cpu_count() or 1
        self.scheduler = scheduler

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        from distributed import Client, LocalCluster, as_completed

        if not tasks:
            return
        cluster = None
        if self.scheduler:
            client = Client(self.scheduler)
        else:
            cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
        futures = []
        try:
            futures = [client.submit(collect_terrain, task, trial_fn, pure=False) for task in tasks]
            for fut in as_completed(futures):
                try:
                    messages = fut.result()
                except Exception as exc:
                    raise StudyError(f"a terrain failed on the Dask cluster: {exc!r}") from exc
                for msg in messages:
                    handle(msg)
        finally:
            client.cancel(futures)
            client.close()
            if cluster is not None:
                cluster.close()


#: executor name -> class(workers, scheduler)
EXECUTORS = {"local": LocalExecutor, "inline": InlineExecutor, "dask": DaskExecutor}


def get_executor(name: str, workers: int | None = None, scheduler: str | None = None):
    """An executor by name; an unknown name lists the known ones."""
    if name not in EXECUTORS:
        raise InputError(f"--executor {name!r} is not known; known: {', '.join(EXECUTORS)}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InputError(f"--workers = {workers!r}; must be an integer >= 1")
    return EXECUTORS[name](workers, scheduler)
