"""Stopping well (issue 43, Deliver 4): Ctrl-C ends ``study run`` within seconds every time with
one line saying what was saved and how to resume; a run whose every trial faulted exits 1 with
one line; faults are summarised per kind, not a line each."""

from __future__ import annotations

import copy
import random
import signal
import subprocess
import sys
import threading
import time

import pytest

from offroadbench import stop
from offroadbench.errors import Stopped
from offroadbench.study import load_meta, run_study, study_from_dict
from offroadbench.study.spec.config import plan_cells
from offroadbench.study.store.store import LOCK_NAME, Store
from tests.study.test_run import STUDY, fake_trials

CLI = [sys.executable, "-c", "import sys; from offroadbench.cli import main; sys.exit(main())"]


def _run(study, out, *extra) -> subprocess.Popen:
    return subprocess.Popen([*CLI, "study", "run", str(study), "--out", str(out), "--workers", "2", "--no-report",
                             *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.timeout(600)
def test_ctrl_c_at_random_moments_ends_the_run_within_10_s_with_one_line(tmp_path, write_tiny_study, stored_trials):
    """SIGINT at a random moment of the run (from the lock's taking to 4 s later: opening the store,
    starting the workers, building terrains, trials: on a 2-core machine the first trials are stored
    about 1 s after the lock, and every later moment falls among trials), 8 times on the same run
    directory: every time the process is gone within 10 s, says one line (the trials saved, how to resume) and records
    the session as interrupted. (A Ctrl-C raised inside a fork's callback used to be swallowed, and
    the run went on; one that stopped the workers could leave the exit waiting on the task queue.)"""
    terrains, missions = 60, 20
    total = 2 * terrains * missions  # 2400 trials: more than 8 stops of at most 4 s can reach on a quiet, fast machine
    study = write_tiny_study(tmp_path, name="ctrl-c", root_seed=5, terrains=terrains, missions=missions)
    out = tmp_path / "run"
    rng = random.Random(43)
    interrupted = 0
    for attempt in range(8):
        proc = _run(study, out)
        t0 = time.monotonic()
        while not (out / LOCK_NAME).exists() and proc.poll() is None and time.monotonic() - t0 < 120:
            time.sleep(0.01)
        time.sleep(rng.uniform(0.0, 4.0))
        proc.send_signal(signal.SIGINT)
        sent = time.monotonic()
        try:
            stdout, err = proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise AssertionError(f"try {attempt}: still running 10 s after SIGINT") from None
        assert time.monotonic() - sent < 10
        if f"{total} / {total} trials" in stdout:  # it finished before the signal came, or as it came (exiting)
            assert proc.returncode in (0, 130, -signal.SIGINT) and len(err.splitlines()) <= 1, err
            break
        assert proc.returncode == 130, err
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("offroadbench: interrupted; "), err
        assert "run the same command again to" in lines[0]
        if stored_trials(out):
            assert f"of {total} stored in {out};" in lines[0]
            assert load_meta(out)["runs"][-1]["status"] == "interrupted"
        assert not (out / LOCK_NAME).exists()
        interrupted += 1
    assert interrupted == 8


#: a [roughness] line that makes every pixel rougher than "low": no start cell anywhere
ROUGH_EVERYWHERE = "low_max_slope = 1e-09\n"


def _no_mission_study(tmp_path) -> "object":
    """A study whose terrains hold no start cell: every cell of the class map is high roughness (a
    threshold of 0 m), so no mission can be drawn on any terrain."""
    from tests.conftest import TINY_STUDY_TOML

    path = tmp_path / "study.toml"
    text = TINY_STUDY_TOML.format(name="no-mission", root_seed=3, terrains=2, missions=3)
    path.write_text(text.replace("border_m = 1.0\n", "border_m = 1.0\n" + ROUGH_EVERYWHERE, 1))
    return path


@pytest.mark.timeout(300)
def test_a_study_without_a_drawable_mission_exits_1_with_one_line_and_stores_its_faults(tmp_path):
    study = _no_mission_study(tmp_path)
    out = tmp_path / "run"
    r = subprocess.run([*CLI, "study", "run", str(study), "--out", str(out), "--workers", "2", "--no-report"],
                       capture_output=True, text=True, timeout=240)
    assert r.returncode == 1, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) <= 2, r.stderr
    assert "every trial of this run faulted" in r.stderr and "12 x no mission can be drawn" in r.stderr
    with Store(out) as store:
        assert len(store.fault_rows()) == 12 and store.counts()[0] == 0
    # a resume has nothing to run: it says so and exits 0; --retry-faults runs them once more
    again = subprocess.run([*CLI, "study", "run", str(study), "--out", str(out), "--no-report"],
                           capture_output=True, text=True, timeout=240)
    assert again.returncode == 0 and "0 / 12 trials" in again.stdout and "12 fault(s)" in again.stdout, again.stderr
    retry = subprocess.run([*CLI, "study", "run", str(study), "--out", str(out), "--no-report", "--retry-faults"],
                           capture_output=True, text=True, timeout=240)
    assert retry.returncode == 1 and len(retry.stderr.splitlines()) <= 2, retry.stderr
    with Store(out) as store:
        assert len(store.fault_rows()) == 12


def test_faults_are_summarised_one_line_per_kind(tmp_path, capsys, monkeypatch):
    """Some trials fault, others run: the run says one line per kind of fault with its count."""
    from offroadbench.cli import main
    from offroadbench.errors import TrialFault
    from tests.study.test_run import fake_trials

    def thrown_on_mission_1(prepared, settings):
        for row in fake_trials(prepared, settings):
            if row["mission_index"] == 1:
                raise TrialFault("the vehicle was thrown while it settled")
            yield row

    monkeypatch.setattr("offroadbench.study.execution.tasks.drive_terrain", thrown_on_mission_1)
    from tests.conftest import TINY_STUDY_TOML

    path = tmp_path / "study.toml"
    path.write_text(TINY_STUDY_TOML.format(name="some-faults", root_seed=3, terrains=2, missions=3))
    assert main(["study", "run", str(path), "--out", str(tmp_path / "run"), "--executor", "inline",
                 "--no-report"]) == 0
    out = capsys.readouterr()
    assert "8 / 12 trials" in out.out and "4 fault(s)" in out.out and "trials/s)" in out.out
    assert [line for line in out.out.splitlines() if line.startswith("faults of this run")] == [
        "faults of this run: 4 x the vehicle was thrown while it settled"]
    assert "thrown" not in out.err


@pytest.mark.timeout(600)
@pytest.mark.parametrize("signum, word", [(signal.SIGINT, "interrupted"), (signal.SIGTERM, "terminated")])
def test_a_search_stops_within_10_s_with_the_same_one_line(tmp_path, stored_trials, signum, word):
    """``search run`` through the same session: Ctrl-C and SIGTERM once trials are stored end it
    within 10 s with the study's one line, and the session is recorded as interrupted."""
    from pathlib import Path

    small = Path(__file__).parents[1] / "search" / "small-search.toml"
    out = tmp_path / "run"
    proc = subprocess.Popen([*CLI, "search", "run", str(small), "--out", str(out), "--workers", "2", "--no-report"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while stored_trials(out) < 1 and proc.poll() is None and time.monotonic() - t0 < 300:
        time.sleep(0.02)
    assert proc.poll() is None, "the search ended before it could be stopped"
    proc.send_signal(signum)
    sent = time.monotonic()
    try:
        _, err = proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise AssertionError("still running 10 s after the signal") from None
    assert time.monotonic() - sent < 10
    assert proc.returncode == 128 + signum, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"offroadbench: {word}; "), err
    assert "stored in" in lines[0] and "run the same command again to resume" in lines[0]
    assert load_meta(out)["runs"][-1]["status"] == "interrupted"


_RELEASE = threading.Event()


def _slow_trials(prepared, settings):
    """fake_trials that first wait (up to 60 s) for the test to release them: no message reaches the
    coordinator while the test looks."""
    _RELEASE.wait(60)
    yield from fake_trials(prepared, settings)


def test_a_swallowed_stop_ends_a_dask_run_within_one_poll(tmp_path):
    """A Ctrl-C swallowed where it was raised (a fork's callback) stops a Dask run at the coordinator's
    next poll (0.5 s), not at the next message: here none comes for 60 s (issue 43)."""
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    study = study_from_dict(copy.deepcopy(STUDY))
    cells = plan_cells(study)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        try:
            with stop.handled():
                try:
                    signal.raise_signal(signal.SIGINT)
                except Stopped:
                    pass  # swallowed, as an at-fork callback swallows it
                t0 = time.monotonic()
                with pytest.raises(Stopped):
                    run_study(study, cells, tmp_path / "run", executor="dask", scheduler=cluster.scheduler_address,
                              trial_fn=_slow_trials)
                assert time.monotonic() - t0 < 20
        finally:
            _RELEASE.set()
    assert not (tmp_path / "run" / "study.sqlite").exists()  # a stop before any trial leaves no store


def test_a_stop_just_after_the_session_row_is_written_records_it_interrupted(tmp_path, capsys, monkeypatch):
    """SIGINT arriving right after ``start_run`` wrote the session's row, before its id was kept (CI
    hit this window once in the random Ctrl-C test): the row must say ``interrupted``, not stay
    ``running`` (shown later as ``killed``). The first session stores the trials, so the second's
    store is kept whatever it stores. Other threads are alive, as in a full test run (Dask, tqdm): the
    kernel may hand the signal to one of them, which a signal mask on the main thread does not hold
    back (the first fix failed so in 2 of 3 runs)."""
    import os

    from offroadbench.cli import main
    from tests.conftest import TINY_STUDY_TOML

    path = tmp_path / "study.toml"
    path.write_text(TINY_STUDY_TOML.format(name="stop-at-row", root_seed=3, terrains=2, missions=3))
    out = tmp_path / "run"
    assert main(["study", "run", str(path), "--out", str(out), "--executor", "inline", "--no-report"]) == 0
    capsys.readouterr()
    real = Store.start_run

    def signalled(self, *args, **kwargs):
        run_id = real(self, *args, **kwargs)
        os.kill(os.getpid(), signal.SIGINT)  # delivered at the next bytecode: before the caller keeps run_id
        return run_id

    monkeypatch.setattr(Store, "start_run", signalled)
    quit_ = threading.Event()
    others = [threading.Thread(target=quit_.wait, daemon=True) for _ in range(4)]
    for t in others:
        t.start()
    try:
        assert main(["study", "run", str(path), "--out", str(out), "--executor", "inline", "--no-report"]) == 130
    finally:
        quit_.set()
    err = capsys.readouterr().err
    assert err.startswith("offroadbench: interrupted; ")
    assert [r["status"] for r in load_meta(out)["runs"]][-1] == "interrupted"
