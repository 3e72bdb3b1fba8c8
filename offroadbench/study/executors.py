"""Executors: run terrain tasks somewhere and hand every message back to the coordinator.

Registry :data:`EXECUTORS` (name -> class). Each executor's ``run(tasks, trial_fn, handle)``
calls ``handle(message)`` in the calling process for every message of every task (see
:mod:`offroadbench.study.tasks`); the coordinator commits them to the store. Whatever the
executor, a task's results depend only on the task, so all of them give the same table.

* ``local`` (default): ``workers`` forked processes pull tasks from a queue and stream each
  trial back as soon as it finishes. Workers ignore Ctrl-C (the coordinator stops them) and die
  with the coordinator (``PR_SET_PDEATHSIG``), so a killed study leaves no orphans behind. With
  ``trial_timeout_s`` a worker that sends nothing for that long (a terrain build, or one trial,
  that hangs) is killed and the study stops with a one-line StudyError naming the terrain.
* ``inline``: runs in the calling process (debugging, profiling).
* ``dask``: one Dask task per terrain on a ``distributed`` cluster (``scheduler`` address, or a
  ``LocalCluster`` of ``workers`` processes when no address is given). A task's trials arrive
  when its terrain is done, so a killed coordinator loses the terrains in flight. Killed or
  hung workers and a lost scheduler: see :class:`DaskExecutor`.
"""

from __future__ import annotations

import logging
import os
import queue
import signal
import sys
import time
import traceback
from typing import Callable, Sequence

from offroadbench.errors import InputError, StudyError
from offroadbench.registry import Registry
from offroadbench.study.tasks import TerrainTask, TrialFn, collect_terrain, run_terrain

__all__ = ["EXECUTORS", "get_executor", "StudyError", "TrialTimeout", "InlineExecutor", "LocalExecutor", "DaskExecutor"]

Handle = Callable[[tuple], None]

log = logging.getLogger(__name__)


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


def _worker_bootstrap() -> None:
    """What every worker process does first: import pybullet without its banner."""
    from offroadbench.sim import import_pybullet_quietly

    import_pybullet_quietly()


def _error_message(key: tuple[int, int], exc: BaseException, tb: str) -> tuple:
    """An ("error", ...) message that survives pickling, whatever the exception."""
    import pickle

    try:
        pickle.dumps(exc)
        carried = exc
    except Exception:  # an unpicklable exception: keep its text
        carried = None
    return ("error", key, carried, f"{type(exc).__name__}: {exc}", tb)


def _worker(task_q, result_q, trial_fn: TrialFn | None, parent_pid: int) -> None:
    _die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the coordinator's SIGTERM handler is not the worker's
    _worker_bootstrap()
    while True:
        task = task_q.get()
        if task is None:
            return
        key = (task.cell.index, task.terrain)
        result_q.put(("begin", key))
        try:
            for msg in run_terrain(task, trial_fn):
                if os.getppid() != parent_pid:
                    os._exit(1)
                result_q.put(msg)
        except BaseException as exc:  # report and stop: the coordinator decides
            result_q.put(_error_message(key, exc, traceback.format_exc()))
            return
        result_q.put(("done", key))


def task_failure(key: tuple[int, int], exc: BaseException | None, text: str, tb: str = "") -> Exception:
    """The error the coordinator raises for a failed terrain task: bad input stays an InputError
    (naming the terrain), anything else is a one-line StudyError; the traceback goes to the log."""
    if tb:
        log.info("terrain %d of cell %d failed:\n%s", key[1], key[0], tb)
    where = f"cell {key[0]}, terrain {key[1]}"
    if isinstance(exc, InputError):
        return InputError(f"{where}: {exc}")
    return StudyError(f"{where} failed in a worker: {' '.join(text.split())}")


class LocalExecutor:
    """``workers`` local processes (default: the number of cores)."""

    poll_s = 0.5

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 trial_timeout_s: float | None = None) -> None:
        if scheduler:
            raise InputError("--scheduler is only for --executor dask")
        self.workers = workers or os.cpu_count() or 1
        if trial_timeout_s is not None and not trial_timeout_s > 0:
            raise InputError(f"trial_timeout_s = {trial_timeout_s!r}; must be > 0 seconds")
        self.trial_timeout_s = trial_timeout_s

    _timed_out = False

    def _check_time(self, active: dict[tuple[int, int], float]) -> None:
        if self.trial_timeout_s is None:
            return
        now = time.monotonic()
        for (cell, terrain), since in active.items():
            if now - since > self.trial_timeout_s:
                self._timed_out = True
                raise StudyError(f"cell {cell}, terrain {terrain}: a trial (or the terrain build) ran longer than "
                                 f"{self.trial_timeout_s:g} s, the per-trial limit; its worker was stopped")

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
        active: dict[tuple[int, int], float] = {}  # running task -> when it last sent something
        try:
            while pending:
                self._check_time(active)
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
                if kind in ("begin", "terrain", "trial"):
                    active[msg[1] if kind == "begin" else (msg[1], msg[2])] = time.monotonic()
                if kind == "begin":
                    continue
                if kind == "done":
                    active.pop(msg[1], None)
                    pending -= 1
                elif kind == "error":
                    raise task_failure(msg[1], msg[2], msg[3], msg[4])
                else:
                    handle(msg)
        finally:
            for p in procs:
                if p.is_alive():
                    p.kill() if self._timed_out else p.terminate()  # a hung trial may ignore SIGTERM
            for p in procs:
                p.join(timeout=5)
                if p.is_alive():  # pragma: no cover
                    p.kill()
                    p.join()
            for q in (task_q, result_q):
                q.cancel_join_thread()
                q.close()


# ---------------------------------------------------------------------------- dask
class TrialTimeout(RuntimeError):
    """A trial (or a terrain build) ran longer than the per-trial wall-clock limit on a Dask worker."""


def _dask_task(task: TerrainTask, trial_fn: TrialFn | None, limit_s: float | None) -> list[tuple]:
    """A terrain task on a Dask worker: quiet bootstrap, then every message of :func:`run_terrain`.

    With ``limit_s`` the work runs in a helper thread and every message (the terrain build, then
    each trial) must arrive within ``limit_s`` seconds; otherwise TrialTimeout names the worker,
    whose process the coordinator then restarts (a hung trial cannot be interrupted from Python).
    """
    _worker_bootstrap()
    if limit_s is None:
        return collect_terrain(task, trial_fn)
    import threading

    q: queue.Queue = queue.Queue()

    def work() -> None:
        try:
            for msg in run_terrain(task, trial_fn):
                q.put(("msg", msg))
            q.put(("end", None))
        except BaseException as exc:  # handed to the task thread below
            q.put(("exc", exc))

    threading.Thread(target=work, daemon=True, name="offroadbench-trials").start()
    out = []
    while True:
        try:
            kind, value = q.get(timeout=limit_s)
        except queue.Empty:
            from distributed import get_worker

            raise TrialTimeout(
                f"cell {task.cell.index}, terrain {task.terrain}: a trial ran longer than {limit_s:g} s "
                f"on Dask worker {get_worker().address}"
            ) from None
        if kind == "end":
            return out
        if kind == "exc":
            raise value
        out.append(value)


class _DropWhileDisconnected(logging.Filter):
    """Drop a client's log records while it is not connected to its scheduler."""

    def __init__(self, client) -> None:
        super().__init__()
        self.client = client

    def filter(self, record: logging.LogRecord) -> bool:
        return self.client.status == "running"


class DaskExecutor:
    """One Dask task per terrain on a ``distributed`` cluster (``pip install offroadbench[dask]``).

    Faults. A worker that dies mid-task (SIGKILL, out of memory) loses only its task, which Dask
    runs again elsewhere (tasks are pure: the same rows come back); a task that killed
    ``distributed.scheduler.allowed-failures`` workers stops the study. A trial that runs longer
    than ``trial_timeout_s`` stops the study and its worker is restarted. A lost scheduler, or no
    worker for ``no_worker_timeout_s``, stops the study. Every stop is a one-line StudyError;
    the trials committed so far stay, and running the study again resumes it.
    """

    poll_s = 0.5
    no_worker_timeout_s = 120.0
    connect_timeout_s = 20.0

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 trial_timeout_s: float | None = None) -> None:
        try:
            import distributed  # noqa: F401
        except ImportError:  # pragma: no cover
            raise InputError("--executor dask needs dask and distributed: pip install 'offroadbench[dask]'") from None
        self.workers = workers or os.cpu_count() or 1
        self.scheduler = scheduler
        if trial_timeout_s is not None and not trial_timeout_s > 0:
            raise InputError(f"trial_timeout_s = {trial_timeout_s!r}; must be > 0 seconds")
        self.trial_timeout_s = trial_timeout_s

    def _connect(self):
        from distributed import Client, LocalCluster

        if self.scheduler:
            try:
                return Client(self.scheduler, timeout=self.connect_timeout_s), None
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"--scheduler {self.scheduler}: cannot connect to a Dask scheduler there ({exc})") from None
        cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True, dashboard_address=None)
        return Client(cluster), cluster

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        import time

        from distributed import wait
        from distributed.client import FuturesCancelledError

        if not tasks:
            return
        client, cluster = self._connect()
        where = self.scheduler or "the local Dask cluster"
        futures: dict = {}
        failed = False
        # while the scheduler is unreachable the client logs its reconnect attempts as errors with
        # tracebacks; the study reports a lost scheduler itself, in one line
        quiet = _DropWhileDisconnected(client)
        logging.getLogger("distributed.client").addFilter(quiet)
        try:
            futures = {
                client.submit(_dask_task, task, trial_fn, self.trial_timeout_s, pure=False): task for task in tasks
            }
            pending = set(futures)
            no_workers_since = None
            while pending:
                if client.status in ("closing", "closed"):
                    raise StudyError(f"lost the Dask scheduler at {where}")
                try:
                    done, pending = wait(pending, timeout=self.poll_s, return_when="FIRST_COMPLETED")
                except ValueError:  # "No clients found": the client gave up reconnecting and closed
                    raise StudyError(f"lost the Dask scheduler at {where}") from None
                except (TimeoutError, FuturesCancelledError) as exc:
                    if client.status != "running" or "connection" in str(exc).lower():
                        raise StudyError(f"lost the Dask scheduler at {where}") from None
                    if isinstance(exc, FuturesCancelledError):
                        raise StudyError(f"the Dask tasks were cancelled ({' '.join(str(exc).split())[:200]})") from None
                    done = set()
                for fut in done:
                    self._collect(client, fut, futures[fut], handle)
                if pending:
                    no_workers_since = self._check_workers(client, where, no_workers_since, time.monotonic())
        except BaseException:
            failed = True
            raise
        finally:
            self._close(client, cluster, list(futures), failed)
            logging.getLogger("distributed.client").removeFilter(quiet)

    def _collect(self, client, fut, task: TerrainTask, handle: Handle) -> None:
        from distributed import KilledWorker

        key = (task.cell.index, task.terrain)
        if fut.status == "cancelled":
            raise StudyError(f"lost the Dask scheduler, or the task of cell {key[0]}, terrain {key[1]} was cancelled")
        if fut.status == "error":
            exc = fut.exception()
            if isinstance(exc, KilledWorker):
                raise StudyError(f"cell {key[0]}, terrain {key[1]} killed every Dask worker that ran it ({exc})")
            if isinstance(exc, TrialTimeout):
                worker = str(exc).rsplit(" ", 1)[-1]
                quiet = logging.getLogger("distributed")  # the restart's own ERROR lines: the study says it in one
                old_level = quiet.level
                quiet.setLevel(logging.CRITICAL + 1)
                try:
                    client.restart_workers([worker], timeout=30)
                except Exception as rexc:  # best effort: the stop below is what matters
                    log.info("could not restart the hung Dask worker %s: %s", worker, rexc)
                finally:
                    quiet.setLevel(old_level)
                raise StudyError(str(exc))
            tb = "".join(traceback.format_exception(exc)) if exc is not None else ""
            raise task_failure(key, exc, f"{type(exc).__name__}: {exc}", tb)
        try:
            msgs = fut.result()  # fetches the task's results from its worker through the scheduler
        except (OSError, TimeoutError) as exc:  # CommClosedError is an OSError: the scheduler went away
            raise StudyError(f"lost the Dask scheduler while fetching cell {key[0]}, terrain {key[1]} "
                             f"({type(exc).__name__})") from None
        for msg in msgs:
            handle(msg)

    def _check_workers(self, client, where: str, since: float | None, now: float) -> float | None:
        try:
            n = len(client.scheduler_info(n_workers=-1).get("workers", {}))
        except Exception:  # noqa: BLE001 - the next wait() reports a lost scheduler
            return since
        if n:
            return None
        since = now if since is None else since
        if now - since > self.no_worker_timeout_s:
            raise StudyError(f"no Dask worker at {where} for {self.no_worker_timeout_s:g} s")
        return since

    @staticmethod
    def _close(client, cluster, futures, failed: bool) -> None:
        # a client that lost its scheduler logs a reconnect traceback as it closes: the study's
        # one-line error already says what happened, so Dask stays quiet while it shuts down
        quiet = logging.getLogger("distributed")
        old = quiet.level
        if failed:
            quiet.setLevel(logging.CRITICAL + 1)
        try:
            if client.status == "running":
                try:
                    client.cancel(futures)
                except Exception:  # noqa: BLE001
                    pass
            client.close(timeout=10)
            if cluster is not None:
                cluster.close()
        except Exception:  # noqa: BLE001 - closing a broken connection may fail; the study already stopped
            pass
        finally:
            quiet.setLevel(old)


#: executor name -> class(workers, scheduler, **options); installed packages add executor classes
#: through the entry-point group ``offroadbench.executors``
EXECUTORS: Registry[type] = Registry("executor", entry_point_group="offroadbench.executors")
EXECUTORS.register("local", LocalExecutor)
EXECUTORS.register("inline", InlineExecutor)
EXECUTORS.register("dask", DaskExecutor)


def get_executor(name: str, workers: int | None = None, scheduler: str | None = None, **options):
    """An executor by name; an unknown name lists the known ones. ``options`` go to the executor
    (``trial_timeout_s`` for dask)."""
    cls = EXECUTORS.get(name)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InputError(f"--workers = {workers!r}; must be an integer >= 1")
    return cls(workers, scheduler, **options)
