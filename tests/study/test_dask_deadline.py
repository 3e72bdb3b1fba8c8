"""The Dask executor's per-trial limit when the worker cannot keep it (issue 44, Deliver 3), on a
real ``dask.distributed`` LocalCluster:

* a worker frozen by SIGSTOP mid-study (its own limit cannot fire) has its trial stored as a fault
  by the coordinator's deadline (the limit plus ``DaskExecutor.deadline_grace_s``) within a minute,
  and ``study run --executor dask --trial-timeout-s 8`` finishes;
* a trial past its limit on a healthy worker (its thread stoppable) is a fault without a worker
  restart.
"""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")
psutil = pytest.importorskip("psutil")

from offroadbench.study import load_study, run_study  # noqa: E402
from offroadbench.study.execution.dask import DaskExecutor  # noqa: E402
from offroadbench.study.store.store import Store  # noqa: E402

CLI = [sys.executable, "-c", "import sys; from offroadbench.cli import main; sys.exit(main())"]
ENV = {**os.environ, "DASK_LOGGING__DISTRIBUTED": "warning"}


def _faults(out: Path) -> list[tuple]:
    db = out / "study.sqlite"
    if not db.exists():
        return []
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5)
        try:
            return con.execute("SELECT cell, terrain, mission, reason FROM faults").fetchall()
        finally:
            con.close()
    except sqlite3.Error:
        return []


def _cpu_s(proc) -> float:
    try:
        t = proc.cpu_times()
        return t.user + t.system
    except psutil.Error:
        return -1.0


def _busy_worker(pid: int, timeout_s: float = 120.0):
    """A worker process of the LocalCluster under ``pid`` that is computing (a trial or a build)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        kids = [k for k in psutil.Process(pid).children(recursive=True)
                if "spawn_main" in " ".join(k.cmdline()) and "resource_tracker" not in " ".join(k.cmdline())]
        before = {k.pid: _cpu_s(k) for k in kids}
        time.sleep(1.0)
        busy = [(_cpu_s(k) - before[k.pid], k) for k in kids]
        busy = [(d, k) for d, k in busy if d > 0.05]
        if busy:
            return max(busy, key=lambda b: b[0])[1]
    raise AssertionError("no worker got to work")


@pytest.mark.timeout(600)
def test_a_sigstopped_worker_s_trial_is_a_fault_within_a_minute_and_the_study_finishes(tmp_path, write_tiny_study,
                                                                                          stored_trials):
    study = write_tiny_study(tmp_path, name="frozen", root_seed=7, terrains=3, missions=4)
    out = tmp_path / "out"
    proc = subprocess.Popen([*CLI, "study", "run", str(study), "--out", str(out), "--executor", "dask",
                             "--workers", "2", "--trial-timeout-s", "8", "--no-report"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
                            start_new_session=True)
    frozen = None
    try:
        # once the first terrain's trials are stored, the workers are inside their next terrain
        # tasks (a worker frozen before its task began only has the task run elsewhere: no fault)
        t0 = time.monotonic()
        while stored_trials(out) == 0 and proc.poll() is None and time.monotonic() - t0 < 200:
            time.sleep(0.05)
        frozen = _busy_worker(proc.pid)
        frozen.send_signal(signal.SIGSTOP)
        stopped = time.monotonic()
        while not _faults(out) and proc.poll() is None and time.monotonic() - stopped < 120:
            time.sleep(0.2)
        fault_after_s = time.monotonic() - stopped
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        if frozen is not None and frozen.is_running():  # the executor kills it; if not, we do
            frozen.kill()
    faults = _faults(out)
    assert faults, f"no fault stored; stdout {stdout!r}, stderr {stderr!r}"
    assert fault_after_s < 60, f"the fault came {fault_after_s:.0f} s after the SIGSTOP"
    for *_, reason in faults:
        assert "did not answer" in reason and "longer than 8 s" in reason and "10 s grace" in reason, reason
    assert proc.returncode == 0, stderr
    assert "Traceback" not in stderr and "Restarting worker" not in stderr, stderr
    total = 2 * 3 * 4
    assert f"{total - len(faults)} / {total} trials" in stdout and f"{len(faults)} fault(s)" in stdout, stdout
    with Store(out) as store:
        done = store.done_trials()
    assert not done & {f[:3] for f in faults} and len(done) + len(faults) == total  # every trial: a row or a fault
    assert not frozen.is_running() or frozen.status() == psutil.STATUS_ZOMBIE


SLOW_MODULE = """
import os, time
from pathlib import Path


def slow_once(prepared, settings):
    \"\"\"Real trials, each noting its worker's pid; the first call loops in Python past any limit.\"\"\"
    from offroadbench.sim.trial.pipeline import drive_terrain

    log = Path(os.environ["OFFROADBENCH_TEST_SLOW_LOG"])
    marker = log.with_suffix(".marker")
    if not marker.exists():
        marker.write_text("slow")
        while True:  # Python code: a healthy worker can stop it
            time.sleep(0.05)
    for record in drive_terrain(prepared, settings):
        with log.open("a") as fh:
            fh.write(f"{os.getpid()}\\n")
        yield record
"""


@pytest.mark.timeout(600)
def test_a_trial_past_its_limit_on_a_healthy_worker_costs_no_restart(tmp_path, write_tiny_study, monkeypatch):
    study_path = write_tiny_study(tmp_path, name="healthy", root_seed=5, terrains=1, missions=2)
    study, cells = load_study(study_path)
    (tmp_path / "slow_trials.py").write_text(SLOW_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))  # the LocalCluster's spawned workers inherit sys.path
    log = tmp_path / "pids.log"
    monkeypatch.setenv("OFFROADBENCH_TEST_SLOW_LOG", str(log))
    from slow_trials import slow_once

    restarts = []
    monkeypatch.setattr(DaskExecutor, "_restart", staticmethod(lambda client, worker: restarts.append(worker)))
    summary = run_study(study, cells, tmp_path / "out", executor="dask", workers=1, trial_fn=slow_once,
                        executor_options={"trial_timeout_s": 6})
    assert (summary.done, summary.faults) == (3, 1) and summary.complete
    with Store(tmp_path / "out") as store:
        (fault,) = store.fault_rows()
    assert "longer than 6 s" in fault[5] and "Dask worker" in fault[5] and "did not answer" not in fault[5]
    assert restarts == []
    assert len(set(log.read_text().split())) == 1  # every later trial ran in the same worker process
