"""The Dask executor's worker side: one terrain task run under the per-trial limit, with progress
events for the coordinator's own deadline (offroadbench.study.execution.dask)."""

from __future__ import annotations

import ctypes
import os
import queue
import threading
import time

from offroadbench.study.execution.common import timeout_faults, worker_bootstrap
from offroadbench.study.execution.tasks import TerrainBuilt, TerrainTask, TrialDone, TrialFaulted, TrialFn, collect_terrain, run_terrain


class TrialTimeout(RuntimeError):
    """A trial (or a terrain build) ran longer than the per-trial wall-clock limit on a Dask worker."""


#: how long past its limit a trial's helper thread, told to stop, may take to end before its
#: Dask worker counts as unhealthy and is restarted, seconds
STOP_WAIT_S = 5.0


class _Abandoned(BaseException):
    """Raised inside a trial's helper thread that ran past its limit, to end it (a BaseException:
    no ``except Exception`` of a trial or plug-in keeps it running)."""


def _stop_thread(thread: threading.Thread, wait_s: float) -> bool:
    """Raise :class:`_Abandoned` in ``thread`` and wait up to ``wait_s`` seconds for it to end.
    True if it ended: a thread running Python code stops at its next bytecode; one blocked in C
    code (a sleep, a stuck native loop) does not, and its worker must be restarted."""
    if thread.ident is not None and thread.is_alive():
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread.ident), ctypes.py_object(_Abandoned))
    thread.join(wait_s)
    return not thread.is_alive()


def _reporter(topic: str | None):
    """``tell(what, mission=None)``: a progress event (``begin``, ``built``, ``finished``) of the
    running task on ``topic`` for the coordinator's deadline (:class:`DaskExecutor`); a no-op
    without a topic (or outside a Dask worker)."""
    if topic is None:
        return lambda what, mission=None: None
    from distributed import get_worker

    worker = get_worker()
    key, address, pid = str(worker.get_current_task()), worker.address, os.getpid()

    def tell(what: str, mission: int | None = None) -> None:
        worker.log_event(topic, {"key": key, "worker": address, "pid": pid, "what": what, "mission": mission})

    return tell


def dask_task(task: TerrainTask, trial_fn: TrialFn | None, limit_s: float | None, topic: str | None = None) -> list:
    """A terrain task on a Dask worker: quiet bootstrap, then every message of :func:`run_terrain`.

    With ``limit_s`` the work runs in a helper thread and every message (the terrain build, then
    each trial) must arrive within ``limit_s`` seconds. Otherwise the task returns what arrived
    and the fault of the hung trial (:class:`TrialFaulted`), and the missions after it as a
    ``("rest", missions after the hung one)`` message, which the coordinator submits again. The
    helper thread is told to stop (:func:`_stop_thread`); if it has not ended after
    :data:`STOP_WAIT_S` (a trial blocked in native code) the message is ``("restart", worker
    address, missions after the hung one)`` instead and the coordinator restarts this worker too,
    since nothing in Python can stop such a thread. A healthy worker is not restarted. The wait is
    sliced into short waits, so any limit up to MAX_TRIAL_TIMEOUT_S works. With ``topic`` each
    message is also announced as a progress event (:func:`_reporter`), which lets the coordinator
    tell a worker that stopped answering (SIGSTOP, a native loop holding the GIL) from a long trial.
    """
    worker_bootstrap()
    if limit_s is None:
        return collect_terrain(task, trial_fn)
    tell = _reporter(topic)
    tell("begin")
    q: queue.Queue = queue.Queue()

    def work() -> None:
        try:
            for msg in run_terrain(task, trial_fn):
                q.put(("msg", msg))
            q.put(("end", None))
        except _Abandoned:
            pass
        except BaseException as exc:  # handed to the task thread below
            q.put(("exc", exc))

    thread = threading.Thread(target=work, daemon=True, name="offroadbench-trials")
    thread.start()
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
            if _stop_thread(thread, STOP_WAIT_S):
                return out + faults + [("rest", rest)]
            return out + faults + [("restart", address, rest)]
        if kind == "end":
            return out
        if kind == "exc":
            raise value
        out.append(value)
        deadline = time.monotonic() + limit_s
        if isinstance(value, TerrainBuilt):
            built = True
            tell("built")
        elif isinstance(value, (TrialDone, TrialFaulted)):
            finished.add(value.mission)
            tell("finished", value.mission)
