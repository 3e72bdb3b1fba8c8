"""A lock and a clean start (issue 23, Deliver 4): one study per run directory at a time, an
atomic store creation, and SIGTERM ending a run as Ctrl-C does."""

from __future__ import annotations

import copy
import errno
import multiprocessing
import os
import signal
import sqlite3
import subprocess
import sys
import time

import pandas as pd
import pytest

from offroadbench.errors import InputError
from offroadbench.study import load, load_meta, run_study, study_from_dict
from offroadbench.study.store import writes as store_writes
from offroadbench.study.spec.config import plan_cells
from offroadbench.study.store.store import STORE_NAME, RunDirLocked, RunLock, Store
from tests.study.test_run import STUDY, fake_trials

CLI = [sys.executable, "-c", "import sys; from offroadbench.cli import main; sys.exit(main())"]


def study_and_cells(**changes):
    data = copy.deepcopy(STUDY)
    data["study"].update(changes)
    study = study_from_dict(data)
    return study, plan_cells(study)


def _hold_lock(run_dir, ready) -> None:
    RunLock(run_dir).acquire()
    ready.set()
    time.sleep(120)


@pytest.fixture
def holder(tmp_path):
    """A process that holds the lock of ``tmp_path / "run"`` until killed."""
    ctx = multiprocessing.get_context("fork")
    ready = ctx.Event()
    p = ctx.Process(target=_hold_lock, args=(tmp_path / "run", ready), daemon=True)
    p.start()
    assert ready.wait(30)
    yield p
    if p.is_alive():
        p.kill()
    p.join()


def test_a_second_run_is_refused_naming_the_pid_and_goes_on_once_the_holder_is_killed(tmp_path, holder):
    study, cells = study_and_cells()
    run_dir = tmp_path / "run"
    with pytest.raises(RunDirLocked, match=rf"a study is running in {run_dir} \(pid {holder.pid}\)"):
        run_study(study, cells, run_dir, executor="inline", trial_fn=fake_trials)
    assert not (run_dir / STORE_NAME).exists()
    os.kill(holder.pid, signal.SIGKILL)  # the kernel drops a dead process's lock
    holder.join()
    summary = run_study(study, cells, run_dir, executor="inline", trial_fn=fake_trials)
    assert summary.done == study.n_trials
    assert not (run_dir / "study.lock").exists()


def test_the_cli_exits_2_naming_the_running_pid(tmp_path, holder):
    path = tmp_path / "study.toml"
    path.write_text('[study]\nname = "x"\nrecipe = "paper-d2.45"\nroot_seed = 1\nterrains_per_cell = 1\nmissions_per_terrain = 1\n'
                    '[recipe_overrides]\n"grid.rows" = 121\n"grid.cols" = 121\n')
    r = subprocess.run([*CLI, "study", "run", str(path), "--out", str(tmp_path / "run"), "--workers", "1"],
                       capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 2, r.stderr
    assert f"a study is running in {tmp_path / 'run'} (pid {holder.pid})" in r.stderr
    assert r.stderr.count("\n") == 1


def _start(run_dir, barrier, results) -> None:
    study, cells = study_and_cells()
    barrier.wait()
    try:
        s = run_study(study, cells, run_dir, executor="inline", trial_fn=fake_trials)
        results.put(("ok", s.ran))
    except RunDirLocked as exc:
        results.put(("locked", str(exc)))
    except BaseException as exc:  # noqa: BLE001 - anything else is the failure this test looks for
        results.put(("error", f"{type(exc).__name__}: {exc}"))


def test_fifty_simultaneous_starts_raise_nothing_uncaught_and_run_every_trial_once(tmp_path):
    n = 50
    ctx = multiprocessing.get_context("fork")
    barrier, results = ctx.Barrier(n), ctx.Queue()
    procs = [ctx.Process(target=_start, args=(tmp_path / "run", barrier, results)) for _ in range(n)]
    for p in procs:
        p.start()
    got = [results.get(timeout=120) for _ in range(n)]
    for p in procs:
        p.join(30)
    errors = [g for g in got if g[0] == "error"]
    assert errors == []
    assert sum(g[1] for g in got if g[0] == "ok") == 24  # every trial ran exactly once
    for kind, text in got:
        if kind == "locked":
            assert "a study is running in" in text and "(pid " in text
    study, cells = study_and_cells()
    run_study(study, cells, tmp_path / "one", executor="inline", trial_fn=fake_trials)
    pd.testing.assert_frame_equal(load(tmp_path / "run"), load(tmp_path / "one"))


def _die_at_link(run_dir) -> None:
    def link(a, b):
        os._exit(9)

    store_writes.os.link = link
    study, cells = study_and_cells()
    run_study(study, cells, run_dir, executor="inline", trial_fn=fake_trials)


def test_a_kill_while_the_store_is_created_leaves_no_store_and_the_next_run_cleans_up(tmp_path):
    ctx = multiprocessing.get_context("fork")
    p = ctx.Process(target=_die_at_link, args=(tmp_path,))
    p.start()
    p.join(60)
    assert p.exitcode == 9
    assert not (tmp_path / STORE_NAME).exists()
    assert [q.name for q in tmp_path.iterdir() if q.name.endswith(".tmp")]  # what the killed run left
    study, cells = study_and_cells()
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    assert sorted(q.name for q in tmp_path.iterdir()) == [STORE_NAME]
    con = sqlite3.connect(tmp_path / STORE_NAME)
    assert con.execute("PRAGMA journal_mode").fetchone() == ("wal",)
    con.close()


def test_a_full_disk_at_creation_is_one_line_and_leaves_nothing(tmp_path, monkeypatch):
    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(store_writes.tempfile, "mkstemp", full)
    study, cells = study_and_cells()
    out = tmp_path / "new" / "run"
    with pytest.raises(InputError, match=rf"{out / STORE_NAME}: cannot create the study store \(no space left"):
        run_study(study, cells, out, executor="inline", trial_fn=fake_trials)
    assert not (tmp_path / "new").exists()


def test_an_empty_store_of_an_older_run_is_replaced(tmp_path):
    (tmp_path / STORE_NAME).write_bytes(b"")
    study, cells = study_and_cells()
    assert run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials).done == 24
    with pytest.raises(InputError, match="is empty"):  # a reader never changes it
        (tmp_path / "other").mkdir()
        (tmp_path / "other" / STORE_NAME).write_bytes(b"")
        Store(tmp_path / "other")


@pytest.mark.timeout(300)
def test_sigterm_ends_a_run_like_ctrl_c(tmp_path, write_tiny_study, stored_trials):
    study_path = write_tiny_study(tmp_path, name="term-test", root_seed=11, terrains=2, missions=6)
    out = tmp_path / "run"
    proc = subprocess.Popen([*CLI, "study", "run", str(study_path), "--out", str(out), "--workers", "2", "--no-report"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while stored_trials(out) < 2 and proc.poll() is None and time.monotonic() - t0 < 200:
        time.sleep(0.02)
    assert proc.poll() is None and stored_trials(out) >= 2, "the run ended before it could be terminated"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    if stored_trials(out) < 24:
        assert proc.returncode == 143, err
        assert "terminated" in err and err.count("\n") == 1
        # it says how many trials are saved (issue 33): this run's and the store's, of the study's 24
        assert f", {stored_trials(out)} of 24 stored in {out};" in err and "trial(s) of this run saved" in err
        assert load_meta(out)["runs"][-1]["status"] == "interrupted"
    assert not (out / "study.lock").exists()
