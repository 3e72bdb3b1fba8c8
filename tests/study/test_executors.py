"""Real PyBullet trials through every executor; SIGKILL and Ctrl-C in the middle of a study.

Tiny maps (257^2 at 5 cm), 6 m missions: a few seconds per study.
"""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from offroadbench.study import load, load_meta, load_study, load_terrains, run_study

CLI = [sys.executable, "-c", "import sys; from offroadbench.cli import main; sys.exit(main())"]


def processes_mentioning(text: str) -> list[int]:
    """PIDs of live processes whose command line contains ``text`` (orphaned workers)."""
    pids = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            state = next(l for l in (d / "status").read_text().splitlines() if l.startswith("State:"))
        except (OSError, StopIteration):
            continue
        if text in cmd and "Z" not in state.split()[1]:
            pids.append(int(d.name))
    return pids


def start_run(study: Path, out: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [*CLI, "study", "run", str(study), "--out", str(out), "--workers", "2", "--no-report"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def wait_for(proc: subprocess.Popen, out: Path, at_least: int, stored, timeout_s: float = 120) -> int:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        n = stored(out)
        if n >= at_least or proc.poll() is not None:
            return n
        time.sleep(0.02)
    raise AssertionError(f"no {at_least} trials after {timeout_s} s")


def assert_no_orphans(marker: str) -> None:
    for _ in range(100):
        left = processes_mentioning(marker)
        if not left:
            return
        time.sleep(0.05)
    raise AssertionError(f"processes left behind: {left}")


@pytest.mark.timeout(300)
def test_sigkill_and_ctrl_c_then_resume_equal_an_uninterrupted_run(tmp_path, write_tiny_study, stored_trials):
    stored = stored_trials
    study_path = write_tiny_study(tmp_path, name="kill-test", root_seed=11, terrains=3, missions=6)  # 36 trials
    out = tmp_path / "killed"
    total = 36

    proc = start_run(study_path, out)
    n_kill = wait_for(proc, out, 4, stored)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert 0 < n_kill < total, "the study finished before it could be killed"
    assert_no_orphans(str(out))
    after_kill = stored(out)
    assert after_kill < total

    # resume, and stop it with Ctrl-C (SIGINT) once it made progress
    proc = start_run(study_path, out)
    n_int = wait_for(proc, out, after_kill + 3, stored)
    proc.send_signal(signal.SIGINT)
    out_int, err = proc.communicate(timeout=60)
    # the count is read before the signal is sent: a resume with only a few trials left can finish
    # all of them in between (then it exits 0 with the full summary, and the Ctrl-C part is moot)
    interrupted = n_int < total and f"{total} / {total} trials" not in out_int
    if interrupted:
        assert proc.returncode == 130, err
        assert "interrupted" in err
    assert_no_orphans(str(out))

    # resume to the end
    done = subprocess.run([*CLI, "study", "run", str(study_path), "--out", str(out), "--workers", "2", "--no-report"],
                          capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr
    assert f"{total} / {total} trials" in done.stdout

    con = sqlite3.connect(out / "study.sqlite")
    assert con.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    con.close()
    resumed = load(out)
    assert len(resumed) == total
    assert not resumed.duplicated(["cell", "terrain", "mission"]).any()
    sessions = load_meta(out)["runs"]
    second = "interrupted" if interrupted else "finished"
    assert [s["status"] for s in sessions] == ["killed", second, "finished"]  # SIGKILL, Ctrl-C, done
    assert sum(s["trials_run"] for s in sessions) == total

    study, cells = load_study(study_path)
    run_study(study, cells, tmp_path / "straight", executor="inline")
    pd.testing.assert_frame_equal(resumed, load(tmp_path / "straight"))
    pd.testing.assert_frame_equal(load_terrains(out), load_terrains(tmp_path / "straight"))


@pytest.mark.timeout(300)
def test_one_and_two_workers_and_a_dask_cluster_give_the_same_table(tmp_path, write_tiny_study):
    distributed = pytest.importorskip("distributed")
    study, cells = load_study(write_tiny_study(tmp_path, name="kill-test", root_seed=11, terrains=2, missions=3))  # 12 trials
    run_study(study, cells, tmp_path / "w1", executor="local", workers=1)
    run_study(study, cells, tmp_path / "w2", executor="local", workers=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        run_study(study, cells, tmp_path / "dask", executor="dask", scheduler=cluster.scheduler_address)
    one = load(tmp_path / "w1")
    assert len(one) == 12
    assert one["success"].any()
    for name in ("w2", "dask"):
        pd.testing.assert_frame_equal(one, load(tmp_path / name))
        pd.testing.assert_frame_equal(load_terrains(tmp_path / "w1"), load_terrains(tmp_path / name))
    assert [r["executor"] for r in load_meta(tmp_path / "dask")["runs"]] == ["dask"]


def test_cli_run_export_and_report(tmp_path, write_tiny_study):
    study_path = write_tiny_study(tmp_path, name="kill-test", root_seed=11, terrains=1, missions=2)
    out = tmp_path / "run"
    r = subprocess.run([*CLI, "study", "run", str(study_path), "--out", str(out), "--workers", "1"],
                       capture_output=True, text=True, timeout=240)
    assert r.returncode == 0, r.stderr
    assert f"report: {out / 'report' / 'report.md'}" in r.stdout
    for name in ("report.md", "summary.csv", "fig4_missions.png", "fig5_class_areas.png",
                 "fig6_success_rate.png", "fig7_traversal_metrics.png", "study.toml"):
        assert (out / "report" / name).is_file(), name
    for fmt in ("csv", "parquet"):
        r = subprocess.run([*CLI, "study", "export", str(out), "--format", fmt], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        read = pd.read_csv if fmt == "csv" else pd.read_parquet
        trials = read(out / f"trials.{fmt}")
        assert len(trials) == 4 and {"D_high", "terrain_seed", "mission_seed", "failure_reason"} <= set(trials.columns)
        assert len(read(out / f"terrains.{fmt}")) == 2
    bad = subprocess.run([*CLI, "study", "report", str(tmp_path / "nothing")], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
    bad = subprocess.run([*CLI, "study", "run", str(tmp_path / "missing.toml")], capture_output=True, text=True)
    assert bad.returncode == 2 and "missing.toml" in bad.stderr
    assert os.path.exists(out / "study.sqlite")
