"""The ``dask`` executor: one Dask task per terrain on a ``distributed`` cluster (see
offroadbench.study.execution.executors), with the per-trial time limit on the workers, restarts of hung or
killed workers and the handling of a lost scheduler."""

from __future__ import annotations

import logging
import os
import queue
import time
import traceback
from typing import Sequence

from offroadbench.errors import InputError, StudyError
from offroadbench.study.execution.tasks import (TerrainBuilt, TerrainTask, TrialDone, TrialFaulted, TrialFn, collect_terrain,
                                      run_terrain)
from offroadbench.study.execution.common import (Handle, _worker_bootstrap, check_trial_timeout, task_failure,
                                                timeout_faults)

log = logging.getLogger(__name__)


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
