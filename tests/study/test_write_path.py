"""Nothing finished is lost (issue 23, Deliver 2): a trial and its telemetry are committed together.

A study runs in a forked child that is killed (``os._exit``, as abrupt as SIGKILL for the files
and the store) at each point of the write path of its third trial; the resume must then leave
every stored trial with its telemetry files, no temporary file behind, and the same table as an
uninterrupted run. A cheap stand-in replaces the physics.
"""

from __future__ import annotations

import copy
import multiprocessing
import os
import sqlite3
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from offroadbench.study import load, load_meta, run_study, study_from_dict
from offroadbench.study import session as runner_mod
from offroadbench.study.store.results import telemetry_paths
from offroadbench.study.spec.config import plan_cells
from offroadbench.study.store.store import Store
from tests.study.test_run import STUDY, fake_trials

KILL_AT = 3  # the third trial's write path is cut


def records(prepared, settings):
    """fake_trials with telemetry: objects shaped like sim.runner.TrialRecord."""
    for m, row in zip(prepared.missions, fake_trials(prepared, settings), strict=True):
        n = 5 + m.index
        t = np.arange(n) * 0.05
        tel = {"t_s": t, "x_m": m.start_xy_m[0] + t, "y_m": m.start_xy_m[1] + 0 * t}
        path = np.array([m.start_xy_m, m.goal_xy_m], dtype=float)
        yield SimpleNamespace(result=SimpleNamespace(as_row=lambda row=row: dict(row)), telemetry=tel, path_xy=path)


def study_and_cells():
    data = copy.deepcopy(STUDY)
    data["study"].update(terrains_per_cell=2, missions_per_terrain=3, telemetry="all")
    study = study_from_dict(data)
    return study, plan_cells(study)


def _die_on(counter: dict, n: int) -> None:
    counter["n"] += 1
    if counter["n"] == n:
        os._exit(9)


def _child(run_dir, point: str) -> None:
    """Run the study and die at ``point`` of the KILL_AT-th trial's write path."""
    from offroadbench.io import atomic, telemetry
    from offroadbench.study.store import store as store_mod

    count = {"n": 0}
    if point == "before_telemetry":
        real = runner_mod.save_trial_telemetry

        def patched(*a, **k):
            _die_on(count, KILL_AT)
            return real(*a, **k)

        runner_mod.save_trial_telemetry = patched
    elif point in ("between_files", "after_files"):
        real = telemetry.save_telemetry
        nth = 2 * KILL_AT - 1 if point == "between_files" else 2 * KILL_AT

        def patched(*a, **k):
            out = real(*a, **k)
            _die_on(count, nth)
            return out

        telemetry.save_telemetry = patched
    elif point == "in_temp_file":  # the temp file is written, its rename never happens
        real = atomic.os.replace

        class OsProxy:
            def __getattr__(self, name):
                return getattr(os, name)

            @staticmethod
            def replace(a, b):
                _die_on(count, 2 * KILL_AT - 1)
                return real(a, b)

        atomic.os = OsProxy()
    elif point == "after_commit":
        real = store_mod.Store.add_trial

        def patched(self, *a, **k):
            out = real(self, *a, **k)
            _die_on(count, KILL_AT)
            return out

        store_mod.Store.add_trial = patched
    else:  # pragma: no cover
        raise AssertionError(point)
    study, cells = study_and_cells()
    run_study(study, cells, run_dir, executor="inline", trial_fn=records)
    os._exit(0)


def run_killed(run_dir, point: str) -> int:
    ctx = multiprocessing.get_context("fork")
    p = ctx.Process(target=_child, args=(run_dir, point))
    p.start()
    p.join(60)
    return p.exitcode


def assert_complete(run_dir, study) -> None:
    """Every stored trial names its telemetry files and they exist; no temporary file anywhere."""
    with Store(run_dir) as store:
        rows = store.trial_telemetry()
    assert len(rows) == study.n_trials
    for cell, terrain, mission, _, files, _ in rows:
        expected = [str(q.relative_to(run_dir)) for q in telemetry_paths(run_dir, cell, terrain, mission)]
        assert files == expected
        for f in files:
            assert (run_dir / f).is_file(), f
    leftovers = [q.name for d in (run_dir, run_dir / "telemetry") for q in d.iterdir() if q.name.endswith(".tmp")]
    assert leftovers == []


@pytest.mark.parametrize("point", ["before_telemetry", "in_temp_file", "between_files", "after_files", "after_commit"])
def test_a_kill_anywhere_in_the_write_path_loses_no_telemetry(tmp_path, point):
    study, cells = study_and_cells()
    out = tmp_path / "killed"
    assert run_killed(out, point) == 9
    with Store(out) as store:
        stored = store.counts()[0]
    assert stored == (KILL_AT if point == "after_commit" else KILL_AT - 1)
    if point == "in_temp_file":  # the killed writer left its temporary file
        assert any(q.name.endswith(".tmp") for q in (out / "telemetry").iterdir())
    resumed = run_study(study, cells, out, executor="inline", trial_fn=records)
    assert resumed.ran == study.n_trials - stored
    assert_complete(out, study)
    run_study(study, cells, tmp_path / "straight", executor="inline", trial_fn=records)
    pd.testing.assert_frame_equal(load(out), load(tmp_path / "straight"))
    sessions = load_meta(out)["runs"]
    assert sum(s["trials_run"] for s in sessions) == study.n_trials


def test_a_resume_repairs_trials_whose_telemetry_is_missing(tmp_path):
    study, cells = study_and_cells()
    run_study(study, cells, tmp_path, executor="inline", trial_fn=records)
    gone = telemetry_paths(tmp_path, 1, 0, 2)[0]
    gone.unlink()
    again = run_study(study, cells, tmp_path, executor="inline", trial_fn=records)
    assert again.ran == 1
    assert gone.is_file()
    assert_complete(tmp_path, study)


def test_a_schema_1_store_is_read_migrated_and_repaired(tmp_path):
    """A store of the previous schema (row committed before the telemetry, no file names in the
    row): readers accept it, a run migrates it and re-runs the kept trials that lack files."""
    study, cells = study_and_cells()
    run_study(study, cells, tmp_path, executor="inline", trial_fn=records)
    before = load(tmp_path)
    con = sqlite3.connect(tmp_path / "study.sqlite")
    with con:
        con.execute("ALTER TABLE trials DROP COLUMN telemetry")
        con.execute("ALTER TABLE trials DROP COLUMN run_id")
        con.execute("ALTER TABLE runs DROP COLUMN platform")
        con.execute("ALTER TABLE runs DROP COLUMN error")
    con.execute("PRAGMA user_version=1")
    con.close()
    pd.testing.assert_frame_equal(load(tmp_path), before)
    assert load_meta(tmp_path)["runs"][0].get("platform") is None
    telemetry_paths(tmp_path, 0, 1, 0)[1].unlink()  # lost by the old write order
    again = run_study(study, cells, tmp_path, executor="inline", trial_fn=records)
    assert again.ran == 1
    con = sqlite3.connect(tmp_path / "study.sqlite")
    assert con.execute("PRAGMA user_version").fetchone() == (2,)
    con.close()
    pd.testing.assert_frame_equal(load(tmp_path), before)
    for cell, terrain, mission in ((0, 1, 0), (1, 1, 2)):
        for q in telemetry_paths(tmp_path, cell, terrain, mission):
            assert q.is_file()


def test_a_non_utf8_run_directory_keeps_its_telemetry(tmp_path):
    study, cells = study_and_cells()
    out = tmp_path / os.fsdecode(b"run-\xff")
    run_study(study, cells, out, executor="inline", trial_fn=records)
    assert_complete(out, study)
    assert run_study(study, cells, out, executor="inline", trial_fn=records).ran == 0


def test_a_full_disk_while_writing_telemetry_stores_nothing_half_and_resumes(tmp_path, monkeypatch):
    import errno
    import tempfile

    from offroadbench.errors import StudyError
    from offroadbench.io import atomic

    calls = {"n": 0}

    class FillsUp:
        def __getattr__(self, name):
            return getattr(tempfile, name)

        @staticmethod
        def mkstemp(*a, **k):
            calls["n"] += 1
            if calls["n"] > 5:  # the third trial's second file
                raise OSError(errno.ENOSPC, "No space left on device")
            return tempfile.mkstemp(*a, **k)

    study, cells = study_and_cells()
    monkeypatch.setattr(atomic, "tempfile", FillsUp())
    with pytest.raises(StudyError, match=r"cannot write the telemetry of cell 0, terrain 0, mission 2 .*no space left"):
        run_study(study, cells, tmp_path, executor="inline", trial_fn=records)
    monkeypatch.undo()
    with Store(tmp_path) as store:
        assert store.counts()[0] == 2
    run_study(study, cells, tmp_path, executor="inline", trial_fn=records)
    assert_complete(tmp_path, study)
