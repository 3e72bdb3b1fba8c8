"""Faults a Dask cluster produces, with real ``dask scheduler`` and ``dask worker`` processes on
127.0.0.1: a worker SIGKILLed mid-trial, a hung trial (per-trial wall-clock limit), the scheduler
going away. Each time the study finishes or stops with one line, and a resume completes it with
exactly one row per trial, equal to an uninterrupted run.

Small on purpose: 257^2 maps, 6 m missions, 8 trials.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

pytest.importorskip("distributed")

from offroadbench.study import load, load_study, run_study  # noqa: E402

TOTAL = 8
BIN = Path(sys.executable).parent
ENV = {**os.environ, "DASK_LOGGING__DISTRIBUTED": "warning", "DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "5s"}
CLI = [sys.executable, "-c", "import sys; from offroadbench.cli import main; sys.exit(main())"]


class Cluster:
    """A scheduler and ``n`` single-threaded workers (each with its nanny) as real processes."""

    def __init__(self, tmp: Path, n: int = 2, env: dict[str, str] | None = None) -> None:
        self.tmp = tmp
        self.env = env or ENV
        self.file = tmp / f"scheduler-{time.monotonic_ns()}.json"
        self.logs: list[Path] = []
        self.procs: list[subprocess.Popen] = []
        self.scheduler = self._start([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                      "--no-dashboard", "--scheduler-file", str(self.file)], "scheduler")
        for _ in range(100):
            if self.file.exists() and self.file.stat().st_size:
                break
            time.sleep(0.1)
        self.address = json.loads(self.file.read_text())["address"]
        for i in range(n):
            self._start([str(BIN / "dask"), "worker", self.address, "--nworkers", "1", "--nthreads", "1",
                         "--host", "127.0.0.1", "--no-dashboard", "--death-timeout", "20"], f"worker{i}")
        from distributed import Client

        self.client = Client(self.address, timeout=30)
        self.client.wait_for_workers(n, timeout=60)

    def _start(self, cmd: list[str], name: str) -> subprocess.Popen:
        log = self.tmp / f"{name}-{time.monotonic_ns()}.log"
        self.logs.append(log)
        proc = subprocess.Popen(cmd, stdout=log.open("w"), stderr=subprocess.STDOUT, env=self.env, start_new_session=True)
        self.procs.append(proc)
        return proc

    def busy_worker_pid(self, timeout_s: float = 60) -> int:
        """The pid of a worker process that is running a task right now."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout_s:
            busy = [w for w, keys in self.client.processing().items() if keys]
            if busy:
                return self.client.run(os.getpid, workers=[busy[0]])[busy[0]]
            time.sleep(0.05)
        raise AssertionError("no worker got a task")

    def close(self) -> None:
        try:
            self.client.close(timeout=5)
        except Exception:
            pass
        for p in self.procs:  # our own processes, by their session (nanny + worker)
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            p.wait(timeout=30)

    def banner_seen(self) -> bool:
        return any("pybullet build time" in log.read_text(errors="replace") for log in self.logs)


def run_cli(study: Path, out: Path, address: str, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([*CLI, "study", "run", str(study), "--out", str(out), "--executor", "dask",
                             "--scheduler", address, "--no-report", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)


@pytest.fixture(scope="module")
def reference(tmp_path_factory, write_tiny_study):
    tmp = tmp_path_factory.mktemp("dask-ref")
    path = write_tiny_study(tmp, name="dask-faults", root_seed=5, terrains=2, missions=2)
    study, cells = load_study(path)
    run_study(study, cells, tmp / "straight", executor="inline")
    return path, load(tmp / "straight")


def _assert_same(out: Path, expected: pd.DataFrame) -> None:
    got = load(out)
    assert len(got) == TOTAL and not got.duplicated(["cell", "terrain", "mission"]).any()
    pd.testing.assert_frame_equal(got, expected)


@pytest.mark.timeout(400)
def test_worker_sigkilled_mid_trial_then_resume_equals_uninterrupted(tmp_path, reference):
    study, expected = reference
    cluster = Cluster(tmp_path)
    try:
        out = tmp_path / "killed"
        proc = run_cli(study, out, cluster.address)
        pid = cluster.busy_worker_pid()
        time.sleep(0.5)  # inside the terrain task: building the world or driving
        os.kill(pid, signal.SIGKILL)
        _, err = proc.communicate(timeout=300)
        assert proc.returncode in (0, 1), err
        assert err.count("\n") <= 1 and "Traceback" not in err, err
        resumed = subprocess.run([*CLI, "study", "run", str(study), "--out", str(out), "--executor", "dask",
                                  "--scheduler", cluster.address, "--no-report"],
                                 capture_output=True, text=True, timeout=300, env=ENV)
        assert resumed.returncode == 0, resumed.stderr
        assert resumed.stderr == "", resumed.stderr
        assert f"{TOTAL} / {TOTAL} trials" in resumed.stdout
        _assert_same(out, expected)
        assert not cluster.banner_seen(), "pybullet banner in a worker's output"
    finally:
        cluster.close()


@pytest.mark.timeout(400)
def test_scheduler_gone_stops_cleanly_and_resume_completes(tmp_path, reference, stored_trials):
    stored = stored_trials
    study, expected = reference
    out = tmp_path / "lost"
    cluster = Cluster(tmp_path)
    try:
        proc = run_cli(study, out, cluster.address)
        t0 = time.monotonic()
        while stored(out) < 1 and proc.poll() is None and time.monotonic() - t0 < 200:
            time.sleep(0.05)
        cluster.scheduler.send_signal(signal.SIGKILL)
        _, err = proc.communicate(timeout=120)
    finally:
        cluster.close()
    n = stored(out)
    if n < TOTAL:  # it stopped: one line, exit 1, trials kept, and says how to resume
        assert proc.returncode == 1, err
        assert err.count("\n") == 1 and "lost the Dask scheduler" in err and "resume" in err, err
    cluster = Cluster(tmp_path)
    try:
        resumed = subprocess.run([*CLI, "study", "run", str(study), "--out", str(out), "--executor", "dask",
                                  "--scheduler", cluster.address, "--no-report"],
                                 capture_output=True, text=True, timeout=300, env=ENV)
        assert resumed.returncode == 0, resumed.stderr
        _assert_same(out, expected)
    finally:
        cluster.close()


HANG_MODULE = """
import os, time
from pathlib import Path


def hang_once(prepared, settings):
    \"\"\"Real trials, except that the first call on the cluster hangs (a stuck simulation).\"\"\"
    from offroadbench.sim.trial.pipeline import drive_terrain

    marker = Path(os.environ["OFFROADBENCH_TEST_HANG_MARKER"])
    if not marker.exists():
        marker.write_text("hung")
        time.sleep(3600)
    yield from drive_terrain(prepared, settings)
"""


@pytest.mark.timeout(400)
def test_hung_trial_hits_the_wall_clock_limit_and_resume_completes(tmp_path, reference, monkeypatch):
    from offroadbench.study.store.store import Store

    study_path, expected = reference
    study, cells = load_study(study_path)
    marker = tmp_path / "hung.marker"
    (tmp_path / "hang_trials.py").write_text(HANG_MODULE)  # importable by the workers and by us
    monkeypatch.syspath_prepend(str(tmp_path))
    from hang_trials import hang_once

    env = {**ENV, "OFFROADBENCH_TEST_HANG_MARKER": str(marker),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    cluster = Cluster(tmp_path, n=1, env=env)
    out = tmp_path / "hung"
    try:
        # the hung trial is a fault, its worker restarted, and every other trial runs (issue 30); the
        # limit is 8 s: every message here (a terrain build, one trial) takes well under 1 s of CPU
        summary = run_study(study, cells, out, executor="dask", scheduler=cluster.address, trial_fn=hang_once,
                            executor_options={"trial_timeout_s": 8})
        assert marker.exists()
        assert (summary.done, summary.faults) == (TOTAL - 1, 1) and summary.complete
        with Store(out) as store:
            (fault,) = store.fault_rows()
        assert "longer than 8 s" in fault[5] and "Dask worker" in fault[5]
        assert run_study(study, cells, out, executor="dask", scheduler=cluster.address, trial_fn=hang_once,
                         executor_options={"trial_timeout_s": 60}).ran == 0  # a resume skips the fault
        summary = run_study(study, cells, out, executor="dask", scheduler=cluster.address, trial_fn=hang_once,
                            executor_options={"trial_timeout_s": 60}, retry_faults=True)
        assert (summary.done, summary.faults) == (TOTAL, 0)
        _assert_same(out, expected)
    finally:
        cluster.close()


def test_scheduler_lost_while_fetching_a_result_is_one_study_error():
    """The race the test above can hit: a task finished, and the scheduler dies while its results
    are fetched (``CommClosedError``, an OSError). That must be the study's one-line error, not
    a traceback."""
    from types import SimpleNamespace

    from distributed.comm.core import CommClosedError

    from offroadbench.study.execution.executors import DaskExecutor, StudyError

    class Finished:
        status = "finished"

        def result(self, timeout=None):
            raise CommClosedError("in <TCP (closed) ConnectionPool.gather>: ConnectionResetError")

    task = SimpleNamespace(cell=SimpleNamespace(index=2), terrain=5)
    with pytest.raises(StudyError, match=r"^lost the Dask scheduler while fetching cell 2, terrain 5 \(CommClosedError\)$"):
        DaskExecutor(workers=1)._collect(None, None, Finished(), task, lambda msg: None)
