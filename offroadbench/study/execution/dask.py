"""The ``dask`` executor: one Dask task per terrain on a ``distributed`` cluster (see
offroadbench.study.execution.executors), with the per-trial time limit kept twice (on the workers,
and by the coordinator for a worker that stops answering), restarts of hung or killed workers
and the handling of a lost scheduler."""

from __future__ import annotations

import dataclasses
import logging
import os
import threading
import time
import traceback
import uuid
from typing import Sequence

from offroadbench import stop
from offroadbench.errors import InputError, StudyError
from offroadbench.study.execution.common import Handle, check_trial_timeout, task_failure, timeout_faults
from offroadbench.study.execution.dask_worker import dask_task
from offroadbench.study.execution.tasks import TerrainTask, TrialFn

log = logging.getLogger(__name__)


@dataclasses.dataclass
class _Progress:
    """What the coordinator last heard of a running Dask task (its progress events)."""

    worker: str
    pid: int
    heard: float
    """time.monotonic() of the last event, coordinator's clock"""
    built: bool = False
    finished: set = dataclasses.field(default_factory=set)


def _without(task: TerrainTask, mission: int) -> TerrainTask | None:
    """``task`` without mission ``mission`` (None if nothing is left)."""
    rest = tuple(m for m in task.missions if m[0] != mission)
    return dataclasses.replace(task, missions=rest) if rest else None


def _our_descendant(pid: int) -> bool:
    """Whether ``pid`` is a process this one started (through any number of generations)."""
    try:
        import psutil

        return any(p.pid == os.getpid() for p in psutil.Process(pid).parents())
    except Exception:  # noqa: BLE001 - gone, or no psutil: not ours to kill
        return False


class _DropWhileDisconnected(logging.Filter):
    """Drop a client's log records while it is not connected to its scheduler."""

    def __init__(self, client) -> None:
        super().__init__()
        self.client = client

    def filter(self, record: logging.LogRecord) -> bool:
        return self.client.status == "running"


class _DropRestartLines(logging.Filter):
    """Drop a nanny's "Restarting worker" warning: in this executor's LocalCluster that is the
    nanny replacing a worker the executor killed (one that stopped answering), already reported."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith("Restarting worker")


class DaskExecutor:
    """One Dask task per terrain on a ``distributed`` cluster (``pip install offroadbench[dask]``).

    Faults. A worker that dies mid-task (SIGKILL, out of memory) loses only its task, which Dask
    runs again elsewhere (tasks are pure: the same rows come back); a task that killed
    ``distributed.scheduler.allowed-failures`` workers stops the study. A trial that runs longer
    than ``trial_timeout_s`` is stored as a fault, and the task's later missions submitted again:
    the study goes on. The worker measures that limit (:func:`dask_task`) and is restarted only
    when the trial's thread cannot be stopped. The coordinator keeps a deadline of its own: a
    running task whose worker has sent no progress event for ``trial_timeout_s`` plus
    :attr:`deadline_grace_s` (10 s; a worker frozen by SIGSTOP, or stuck in native code that holds
    the GIL, whose own limit cannot fire) has its running trial stored as a fault (every mission of
    it when its terrain was not built yet), is cancelled, its worker is removed from the scheduler
    (and, in the LocalCluster this executor started, killed, so that its nanny starts a fresh one),
    and its other missions are submitted again: the study goes on. A worker that stops answering
    after its task ended, before its result was fetched, is removed the same way after the limit plus
    the grace and its terrain runs again (:meth:`_fetch`). A lost scheduler, or no
    worker for ``no_worker_timeout_s``, stops the study. Every stop is a one-line StudyError;
    the trials committed so far stay, and running the study again resumes it.
    """

    poll_s = 0.5
    no_worker_timeout_s = 120.0
    connect_timeout_s = 20.0
    #: the coordinator's deadline for a running task: its worker's last progress event plus the
    #: per-trial limit plus this many seconds (the worker's own limit fires first when it can)
    deadline_grace_s = 10.0

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
        restarts = _DropRestartLines()
        if logging.getLogger("distributed").getEffectiveLevel() > logging.INFO:  # shown with -v
            logging.getLogger("distributed.nanny").addFilter(restarts)
        progress: dict[str, _Progress] = {}  # a running task's key -> what its worker last said
        topic = None
        if self.trial_timeout_s is not None:
            topic = f"offroadbench-progress-{uuid.uuid4().hex}"
            lock = threading.Lock()

            def heard(event) -> None:  # on the client's event loop
                msg = event[1]
                with lock:
                    p = progress.get(msg["key"])
                    if p is None or p.worker != msg["worker"]:
                        p = progress[msg["key"]] = _Progress(msg["worker"], msg["pid"], time.monotonic())
                    p.heard = time.monotonic()
                    if msg["what"] == "built":
                        p.built = True
                    elif msg["what"] == "finished":
                        p.finished.add(msg["mission"])

            client.subscribe_topic(topic, heard)

        def submit(task: TerrainTask):
            fut = client.submit(dask_task, task, trial_fn, self.trial_timeout_s, topic, pure=False)
            futures[fut] = task
            pending.add(fut)

        heartbeats: dict[str, tuple[float, float]] = {}  # worker -> (its last_seen, when that was first seen here)
        try:
            pending: set = set()
            for task in tasks:
                submit(task)
            no_workers_since = None
            while pending:
                stop.check()  # a Ctrl-C swallowed where it was raised still stops the run, within one poll
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
                    progress.pop(str(fut.key), None)
                    for rest in self._collect(client, cluster, fut, futures[fut], handle):
                        submit(rest)
                if topic is not None:
                    for fut in self._overdue(pending, progress):
                        pending.discard(fut)
                        for rest in self._give_up(client, cluster, fut, futures[fut], progress.pop(str(fut.key)),
                                                  handle):
                            submit(rest)
                    for address in self._silent_workers(client, heartbeats, progress):
                        self._remove_worker(client, cluster, _Progress(address, 0, 0.0))
                if pending:
                    no_workers_since = self._check_workers(client, where, no_workers_since, time.monotonic())
        except BaseException:
            failed = True
            raise
        finally:
            self._close(client, cluster, list(futures), failed)
            logging.getLogger("distributed.client").removeFilter(quiet)
            logging.getLogger("distributed.nanny").removeFilter(restarts)

    def _collect(self, client, cluster, fut, task: TerrainTask, handle: Handle) -> list[TerrainTask]:
        """Hand a finished task's messages to ``handle``; returns the tasks to submit next (the
        missions after a trial that ran past its limit, whose worker is restarted here; the whole
        task again when its result did not arrive, see :meth:`_fetch`)."""
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
        msgs = self._fetch(client, cluster, fut, key)
        if msgs is None:
            return [task]
        follow: list[TerrainTask] = []
        for msg in msgs:
            if isinstance(msg, tuple) and msg and msg[0] == "restart":
                self._restart(client, msg[1])
                if msg[2] is not None:
                    follow.append(msg[2])
                continue
            if isinstance(msg, tuple) and msg and msg[0] == "rest":  # a trial past its limit, its worker healthy
                if msg[1] is not None:
                    follow.append(msg[1])
                continue
            handle(msg)
        return follow

    def _fetch(self, client, cluster, fut, key: tuple[int, int]) -> list | None:
        """A finished task's messages, fetched from the worker that holds them; None when that
        worker stopped answering before it handed them over (frozen right after its task ended: the
        fetch would wait forever): then, with a per-trial limit, it is removed (and killed) as in
        :meth:`_give_up` once the limit plus the grace has passed, and the caller runs the task again
        (tasks are pure: the same rows come back). Without a limit the fetch waits, as every other step."""
        limit = None if self.trial_timeout_s is None else self.trial_timeout_s + self.deadline_grace_s
        try:
            return fut.result(timeout=limit)
        except (OSError, TimeoutError) as exc:  # CommClosedError is an OSError: the scheduler went away
            if not isinstance(exc, TimeoutError) or client.status != "running":
                raise StudyError(f"lost the Dask scheduler while fetching cell {key[0]}, terrain {key[1]} "
                                 f"({type(exc).__name__})") from None
        try:
            holders = list(client.who_has([fut]).get(fut.key, ()))
        except Exception:  # noqa: BLE001 - the next wait() reports a lost scheduler
            holders = []
        log.warning("cell %d, terrain %d: its result did not arrive from Dask worker %s within %g s; the worker "
                    "removed and the terrain run again", key[0], key[1], " ".join(holders) or "(unknown)", limit)
        try:
            client.cancel([fut], force=True)
        except Exception as exc:  # noqa: BLE001 - best effort, as in _give_up
            log.info("could not cancel the task of cell %d, terrain %d (%s)", key[0], key[1], exc)
        for address in holders:
            self._remove_worker(client, cluster, _Progress(address, 0, 0.0))
        return None

    def _overdue(self, pending: set, progress: dict) -> list:
        """The running futures whose worker has said nothing for the limit plus the grace."""
        now = time.monotonic()
        limit = self.trial_timeout_s + self.deadline_grace_s
        return [fut for fut in pending if fut.status == "pending" and str(fut.key) in progress
                and now - progress[str(fut.key)].heard > limit]

    def _silent_workers(self, client, heartbeats: dict, progress: dict) -> list[str]:
        """Workers whose heartbeat (the scheduler's ``last_seen``) has not moved for the limit plus
        the grace, and that run none of this study's started tasks (those are given up by
        :meth:`_give_up`): a worker frozen before a task it was handed began, on which that task
        would otherwise wait for the scheduler's own worker-ttl (minutes)."""
        try:
            workers = client.scheduler_info(n_workers=-1).get("workers", {})
        except Exception:  # noqa: BLE001 - the next wait() reports a lost scheduler
            return []
        now = time.monotonic()
        for address in list(heartbeats):
            if address not in workers:
                del heartbeats[address]
        for key, p in list(progress.items()):  # a task whose worker died: Dask runs it again elsewhere,
            if p.worker not in workers:          # whose first event starts its clock anew
                progress.pop(key, None)
        busy = {p.worker for p in progress.values()}
        silent = []
        for address, info in workers.items():
            seen = info.get("last_seen")
            if address not in heartbeats or heartbeats[address][0] != seen:
                heartbeats[address] = (seen, now)
            elif now - heartbeats[address][1] > self.trial_timeout_s + self.deadline_grace_s and address not in busy:
                log.warning("Dask worker %s has not answered for %.0f s; removed", address, now - heartbeats[address][1])
                del heartbeats[address]
                silent.append(address)
        return silent

    def _give_up(self, client, cluster, fut, task: TerrainTask, p: _Progress, handle: Handle) -> list[TerrainTask]:
        """A task whose worker stopped answering: its running trial stored as a fault (every
        unfinished mission when its terrain was not built), the task cancelled, the worker removed
        from the scheduler (and killed when it is a process of this executor's LocalCluster); returns
        the task of its other missions (those it finished too: their rows were in the lost result)."""
        silent = time.monotonic() - p.heard
        where = (f" (Dask worker {p.worker} did not answer for {silent:.0f} s: past the limit plus the "
                 f"coordinator's {self.deadline_grace_s:g} s grace)")
        hung = next((k for k, _ in task.missions if k not in p.finished), None) if p.built else None
        faults, _ = timeout_faults(task, hung, set(), self.trial_timeout_s, where=where)
        log.warning("cell %d, terrain %d: Dask worker %s did not answer for %.0f s; %s stored as a fault",
                    task.cell.index, task.terrain, p.worker, silent,
                    f"mission {hung}" if hung is not None else "its missions")
        for fault in faults:
            handle(fault)
        try:
            client.cancel([fut], force=True)
        except Exception as exc:  # noqa: BLE001 - best effort: the next wait() reports a lost scheduler
            log.info("could not cancel the task of the silent worker %s (%s)", p.worker, exc)
        self._remove_worker(client, cluster, p)
        return [] if hung is None else [t for t in (_without(task, hung),) if t is not None]

    @staticmethod
    def _remove_worker(client, cluster, p: _Progress) -> None:
        """Take a worker that stopped answering off the scheduler, so no task waits on it (the
        scheduler's own worker-ttl takes minutes); in this executor's LocalCluster also kill its
        process (a frozen process handles no other signal), which its nanny replaces."""
        quiet = logging.getLogger("distributed")
        old_level = quiet.level
        quiet.setLevel(logging.CRITICAL + 1)
        try:
            client.sync(client.scheduler.unregister, address=p.worker, close=False,
                        stimulus_id=f"offroadbench-silent-worker-{time.time()}")
        except Exception as exc:  # noqa: BLE001 - already gone, or the scheduler is: reported by wait()
            log.info("could not remove the silent Dask worker %s (%s)", p.worker, " ".join(str(exc).split())[:200])
        finally:
            quiet.setLevel(old_level)
        if cluster is None:
            return
        pid = next((getattr(n, "pid", None) for n in getattr(cluster, "workers", {}).values()
                    if getattr(n, "worker_address", None) == p.worker), None) or p.pid
        if pid and _our_descendant(pid):
            try:
                os.kill(pid, 9)
            except ProcessLookupError:
                pass

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
