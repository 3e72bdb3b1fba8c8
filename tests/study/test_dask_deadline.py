"""The Dask executor's per-trial limit when the worker cannot keep it (issue 44, Deliver 3), on a
real ``dask.distributed`` LocalCluster:

* a worker frozen by SIGSTOP mid-terrain (its own limit cannot fire) has its trial stored as a fault
  by the coordinator's deadline (the limit plus ``DaskExecutor.deadline_grace_s``) within a minute,
  and the study finishes;
* a worker frozen right after its task ended, holding the result, is replaced and its terrain run
  again (the coordinator's fetch used to wait for it forever: CI saw a study hang there);
* a trial past its limit on a healthy worker (its thread stoppable) is a fault without a worker
  restart.

The coordinator's grace is :data:`GRACE_S` here, not its 10 s default (the first two tests wait out
the limit plus the grace once): every message of these studies, a terrain build or one trial, takes
well under 1 s of CPU, and the grace stays above the worker's own ``STOP_WAIT_S`` (5 s), as the
default does, so a worker that can answer still answers first.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

pytest.importorskip("distributed")
psutil = pytest.importorskip("psutil")

from offroadbench.study import load_study, run_study  # noqa: E402
from offroadbench.study.execution.dask import DaskExecutor  # noqa: E402
from offroadbench.study.store.store import Store  # noqa: E402

#: the coordinator's grace in these tests, seconds (DaskExecutor.deadline_grace_s, 10 s by default)
GRACE_S = 6.0


@pytest.fixture(autouse=True)
def _short_grace(monkeypatch):
    monkeypatch.setattr(DaskExecutor, "deadline_grace_s", GRACE_S)


def _frozen_gone(pid: int) -> bool:
    try:
        proc = psutil.Process(pid)
        return proc.status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


def _trial_plugin(tmp_path, monkeypatch, module: str, source: str, env: str, path):
    """The trial function of ``source`` (written as ``module``, importable by the LocalCluster's
    spawned workers, which inherit sys.path), ``env`` set to ``path``; and the list of workers the
    executor restarts (none is restarted: each is recorded)."""
    import importlib

    (tmp_path / f"{module}.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(env, str(path))
    fn = next(v for k, v in vars(importlib.import_module(module)).items() if k.endswith("_once"))
    restarts: list = []
    monkeypatch.setattr(DaskExecutor, "_restart", staticmethod(lambda client, worker: restarts.append(worker)))
    return fn, restarts


FREEZE_MODULE = """
import os, signal, time
from pathlib import Path


def freeze_once(prepared, settings):
    \"\"\"Real trials; the first worker to finish a trial SIGSTOPs its own process before the next one
    (every thread stops: the worker's own limit cannot fire, its heartbeats stop).\"\"\"
    from offroadbench.sim.trial.pipeline import drive_terrain

    marker = Path(os.environ["OFFROADBENCH_TEST_FREEZE_MARKER"])
    for record in drive_terrain(prepared, settings):
        yield record
        try:
            fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            continue
        os.write(fd, str(os.getpid()).encode())
        os.close(fd)
        time.sleep(1.0)  # the coordinator hears of the finished trial first
        os.kill(os.getpid(), signal.SIGSTOP)
"""


@pytest.mark.timeout(600)
def test_a_sigstopped_worker_s_trial_is_a_fault_within_a_minute_and_the_study_finishes(tmp_path, write_tiny_study,
                                                                                          monkeypatch):
    study_path = write_tiny_study(tmp_path, name="frozen", root_seed=7, terrains=2, missions=3)
    study, cells = load_study(study_path)
    marker = tmp_path / "frozen.pid"
    freeze_once, restarts = _trial_plugin(tmp_path, monkeypatch, "freeze_trials", FREEZE_MODULE,
                                          "OFFROADBENCH_TEST_FREEZE_MARKER", marker)
    try:
        summary = run_study(study, cells, tmp_path / "out", executor="dask", workers=2, trial_fn=freeze_once,
                            executor_options={"trial_timeout_s": 8})
    finally:
        if marker.exists() and not _frozen_gone(int(marker.read_text())):
            os.kill(int(marker.read_text()), signal.SIGKILL)
    total = 2 * 2 * 3
    assert (summary.done, summary.faults) == (total - 1, 1) and summary.complete
    with Store(tmp_path / "out") as store:
        (fault,) = store.fault_rows()
        done = store.done_trials()
    reason = fault[5]
    assert "did not answer" in reason and "longer than 8 s" in reason and f"{GRACE_S:g} s grace" in reason, reason
    silent_s = float(reason.split("did not answer for ")[1].split(" s")[0])
    assert 8 + GRACE_S <= silent_s < 60, reason  # the limit plus the grace, then at most a few polls
    assert len(done) == total - 1 and tuple(fault[:3]) not in done  # every trial: a row or a fault
    assert restarts == []  # the frozen worker was killed and replaced by its nanny, not restarted
    assert _frozen_gone(int(marker.read_text()))


@pytest.mark.timeout(600)
def test_a_worker_frozen_holding_a_finished_result_is_replaced_and_its_terrain_run_again(tmp_path, write_tiny_study,
                                                                                          monkeypatch, caplog):
    """The worker stops right after its task ended, before the coordinator fetched the result: the
    fetch gives up after the limit plus the grace (it used to wait forever), the worker is killed and
    the terrain runs again elsewhere, with the same rows and no fault."""
    # one task per worker: the frozen one is handed no other task (one it had begun would be a fault)
    study_path = write_tiny_study(tmp_path, name="fetch", root_seed=11, terrains=1, missions=3)
    study, cells = load_study(study_path)
    collect = DaskExecutor._collect
    frozen: list[int] = []

    def freeze_then_collect(self, client, cluster, fut, task, handle):
        if not frozen:
            (address,) = client.who_has([fut])[fut.key]
            pid = client.run(os.getpid, workers=[address])[address]
            os.kill(pid, signal.SIGSTOP)
            frozen.append(pid)
        return collect(self, client, cluster, fut, task, handle)

    monkeypatch.setattr(DaskExecutor, "_collect", freeze_then_collect)
    t0 = time.monotonic()
    try:
        with caplog.at_level("WARNING", logger="offroadbench.study.execution.dask"):
            summary = run_study(study, cells, tmp_path / "out", executor="dask", workers=2,
                                executor_options={"trial_timeout_s": 6})
    finally:
        for pid in frozen:
            if not _frozen_gone(pid):
                os.kill(pid, signal.SIGKILL)
    assert (summary.done, summary.faults) == (2 * 1 * 3, 0) and summary.complete
    assert time.monotonic() - t0 < 300
    assert any("did not arrive from Dask worker" in r.getMessage() for r in caplog.records), caplog.text
    assert frozen and _frozen_gone(frozen[0])


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
    log = tmp_path / "pids.log"
    slow_once, restarts = _trial_plugin(tmp_path, monkeypatch, "slow_trials", SLOW_MODULE,
                                        "OFFROADBENCH_TEST_SLOW_LOG", log)
    summary = run_study(study, cells, tmp_path / "out", executor="dask", workers=1, trial_fn=slow_once,
                        executor_options={"trial_timeout_s": 6})
    assert (summary.done, summary.faults) == (3, 1) and summary.complete
    with Store(tmp_path / "out") as store:
        (fault,) = store.fault_rows()
    assert "longer than 6 s" in fault[5] and "Dask worker" in fault[5] and "did not answer" not in fault[5]
    assert restarts == []
    assert len(set(log.read_text().split())) == 1  # every later trial ran in the same worker process
