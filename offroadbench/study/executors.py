"""Executors: run terrain tasks somewhere and hand every message back to the coordinator.

Registry :data:`EXECUTORS` (name -> class). Each executor's ``run(tasks, trial_fn, handle)``
calls ``handle(message)`` in the calling process for every message of every task (see
:mod:`offroadbench.study.tasks`); the coordinator commits them to the store. Whatever the
executor, a task's results depend only on the task, so all of them give the same table.

* ``local`` (default): ``workers`` forked processes pull tasks from a queue and stream each
  trial back as soon as it finishes. Workers ignore Ctrl-C (the coordinator stops them) and die
  with the coordinator (``PR_SET_PDEATHSIG``), so a killed study leaves no orphans behind. With
  ``trial_timeout_s`` a worker that sends nothing for that long (a terrain build, or one trial,
  that hangs) is killed and replaced, the trial is stored as a fault and the study goes on.
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
from offroadbench.study.tasks import (TerrainBuilt, TerrainTask, TrialDone, TrialFaulted, TrialFn, collect_terrain,
                                      remaining_task, run_terrain)

__all__ = ["EXECUTORS", "MAX_TRIAL_TIMEOUT_S", "check_trial_timeout", "get_executor", "StudyError", "TrialTimeout", "InlineExecutor", "LocalExecutor", "DaskExecutor"]

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


#: the largest per-trial wall-clock limit accepted, seconds (30 days): a larger one is no limit in
#: practice, and timeouts beyond ``threading.TIMEOUT_MAX`` overflow (Dask's helper thread)
MAX_TRIAL_TIMEOUT_S = 30 * 86400.0


def check_trial_timeout(value: float | None) -> float | None:
    """``trial_timeout_s`` validated: None (no limit) or a finite number of seconds in (0, 30 days]."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= MAX_TRIAL_TIMEOUT_S:
        raise InputError(f"trial_timeout_s = {value!r}; must be > 0 and at most {MAX_TRIAL_TIMEOUT_S:g} seconds "
                         "(30 days)")
    return float(value)


def _worker(task_q, conn, trial_fn: TrialFn | None, parent_pid: int) -> None:
    """A worker process: pull tasks, send every message through its own pipe ``conn`` (a worker
    killed for a hung trial takes only its own pipe with it)."""
    _die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the coordinator's SIGTERM handler is not the worker's
    _worker_bootstrap()
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
            conn.send(_error_message(key, exc, traceback.format_exc()))
            return
        conn.send(("done", key))


def task_failure(key: tuple[int, int], exc: BaseException | None, text: str, tb: str = "") -> Exception:
    """The error the coordinator raises for a failed terrain task: bad input stays an InputError
    (naming the terrain), anything else is a one-line StudyError; the traceback goes to the log."""
    if tb:
        log.info("terrain %d of cell %d failed:\n%s", key[1], key[0], tb)
    where = f"cell {key[0]}, terrain {key[1]}"
    if isinstance(exc, InputError):
        return InputError(f"{where}: {exc}")
    return StudyError(f"{where} failed in a worker: {' '.join(text.split())}")


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


def timeout_faults(task: TerrainTask, hung: int | None, finished: set, limit_s: float,
                   where: str = "") -> tuple[list[TrialFaulted], TerrainTask | None]:
    """The fault message(s) of a task whose trial (``hung``; None: the terrain build) ran past
    ``limit_s``, and the task of the missions still to run after it (None if none)."""
    seeds = dict(task.missions)
    cell, terrain = task.cell.index, task.terrain
    if hung is None:  # the build hung: none of the task's missions can run
        reason = f"the terrain build ran longer than {limit_s:g} s, the per-trial limit{where}"
        return [TrialFaulted(cell, terrain, k, task.terrain_seed, s, reason)
                for k, s in task.missions if k not in finished], None
    reason = f"the trial ran longer than {limit_s:g} s, the per-trial limit{where}"
    return [TrialFaulted(cell, terrain, hung, task.terrain_seed, seeds[hung], reason)], remaining_task(task, hung)


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
        for task in tasks:
            task_q.put(task)
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
            log.warning("cell %d, terrain %d: %s ran longer than %g s; stored as a fault, its worker replaced",
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

        for _ in range(min(self.workers, len(tasks))):
            start()
        finished = False
        try:
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
            task_q.cancel_join_thread()
            task_q.close()


# ---------------------------------------------------------------------------- dask
class TrialTimeout(RuntimeError):
    """A trial (or a terrain build) ran longer than the per-trial wall-clock limit on a Dask worker."""


def _dask_task(task: TerrainTask, trial_fn: TrialFn | None, limit_s: float | None) -> list:
    """A terrain task on a Dask worker: quiet bootstrap, then every message of :func:`run_terrain`.

    With ``limit_s`` the work runs in a helper thread and every message (the terrain build, then
    each trial) must arrive within ``limit_s`` seconds. Otherwise the task returns what arrived,
    the fault of the hung trial (:class:`TrialFaulted`) and a ``("restart", worker address,
    missions after the hung one)`` request: the coordinator stores the fault, restarts this
    worker (a hung trial cannot be interrupted from Python) and submits the rest. The wait is
    sliced into short waits, so any limit up to MAX_TRIAL_TIMEOUT_S works.
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
    out: list = []
    built, finished = False, set()
    deadline = time.monotonic() + limit_s
    while True:
        try:
            kind, value = q.get(timeout=min(60.0, max(0.0, deadline - time.monotonic())))
        except queue.Empty:
            if time.monotonic() < deadline:
                continue
            from distributed import get_worker

            address = get_worker().address
            hung = next((k for k, _ in task.missions if k not in finished), None) if built else None
            faults, rest = timeout_faults(task, hung, finished, limit_s, where=f" (Dask worker {address})")
            return out + faults + [("restart", address, rest)]
        if kind == "end":
            return out
        if kind == "exc":
            raise value
        out.append(value)
        deadline = time.monotonic() + limit_s
        if isinstance(value, TerrainBuilt):
            built = True
        elif isinstance(value, (TrialDone, TrialFaulted)):
            finished.add(value.mission)


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
    than ``trial_timeout_s`` is stored as a fault, its worker restarted, and the task's later
    missions submitted again: the study goes on. A lost scheduler, or no
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
        self.trial_timeout_s = check_trial_timeout(trial_timeout_s)

    def _connect(self):
        from distributed import Client, LocalCluster

        if self.scheduler:
            try:
                return Client(self.scheduler, timeout=self.connect_timeout_s), None
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"--scheduler {self.scheduler}: cannot connect to a Dask scheduler there ({exc})") from None
        # the workers' and scheduler's own log lines (a restarted worker's ERRORs) stay quiet unless
        # this process logs at INFO (-v): the study reports every stop in one line itself
        quiet = logging.getLogger("distributed").getEffectiveLevel() > logging.INFO
        cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.CRITICAL if quiet else logging.INFO)
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
                    for rest in self._collect(client, fut, futures[fut], handle):
                        new = client.submit(_dask_task, rest, trial_fn, self.trial_timeout_s, pure=False)
                        futures[new] = rest
                        pending.add(new)
                if pending:
                    no_workers_since = self._check_workers(client, where, no_workers_since, time.monotonic())
        except BaseException:
            failed = True
            raise
        finally:
            self._close(client, cluster, list(futures), failed)
            logging.getLogger("distributed.client").removeFilter(quiet)

    def _collect(self, client, fut, task: TerrainTask, handle: Handle) -> list[TerrainTask]:
        """Hand a finished task's messages to ``handle``; returns the tasks to submit next (the
        missions after a trial that ran past its limit, whose worker is restarted here)."""
        from distributed import KilledWorker

        key = (task.cell.index, task.terrain)
        if fut.status == "cancelled":
            raise StudyError(f"lost the Dask scheduler, or the task of cell {key[0]}, terrain {key[1]} was cancelled")
        if fut.status == "error":
            exc = fut.exception()
            if isinstance(exc, KilledWorker):
                raise StudyError(f"cell {key[0]}, terrain {key[1]} killed every Dask worker that ran it ({exc})")
            tb = "".join(traceback.format_exception(exc)) if exc is not None else ""
            raise task_failure(key, exc, f"{type(exc).__name__}: {exc}", tb)
        try:
            msgs = fut.result()  # fetches the task's results from its worker through the scheduler
        except (OSError, TimeoutError) as exc:  # CommClosedError is an OSError: the scheduler went away
            raise StudyError(f"lost the Dask scheduler while fetching cell {key[0]}, terrain {key[1]} "
                             f"({type(exc).__name__})") from None
        follow: list[TerrainTask] = []
        for msg in msgs:
            if isinstance(msg, tuple) and msg and msg[0] == "restart":
                self._restart(client, msg[1])
                if msg[2] is not None:
                    follow.append(msg[2])
                continue
            handle(msg)
        return follow

    @staticmethod
    def _restart(client, worker: str) -> None:
        """Restart a Dask worker whose trial hung (its helper thread cannot be stopped)."""
        quiet = logging.getLogger("distributed")  # the restart's own ERROR lines: the study says it in one
        old_level = quiet.level
        quiet.setLevel(logging.CRITICAL + 1)
        try:
            client.restart_workers([worker], timeout=30)
        except Exception as rexc:  # noqa: BLE001 - best effort: a nanny-less worker cannot be restarted
            log.warning("could not restart the hung Dask worker %s (%s); its hung trial keeps a thread busy",
                        worker, " ".join(str(rexc).split())[:200])
        finally:
            quiet.setLevel(old_level)

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
