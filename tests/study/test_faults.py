"""Reliability, round three (issue 30): a resume never mixes two configurations, a trial with no
outcome is a fault and the study goes on, a full store is one line, killed sessions say so.

A cheap stand-in replaces the physics (tests.study.test_run.fake_trials).
"""

from __future__ import annotations

import copy
import errno
import json
import os
import shutil
import sqlite3
import time
from pathlib import Path

import pytest

from offroadbench import resources
from offroadbench.errors import InputError, TrialFault
from offroadbench.study import load, load_meta, run_study, study_from_dict
from offroadbench.study.execution.executors import MAX_TRIAL_TIMEOUT_S, check_trial_timeout
from offroadbench.study.spec.config import plan_cells
from offroadbench.study.store.file import RESERVE_BYTES, RESERVE_NAME
from offroadbench.study.store.store import LOCK_NAME, Store
from tests.study.test_run import STUDY, fake_trials


def cells_of(data: dict):
    study = study_from_dict(copy.deepcopy(data))
    return study, plan_cells(study)


def small(**settings) -> dict:
    data = copy.deepcopy(STUDY)
    data["study"].update(terrains_per_cell=1, missions_per_terrain=3)
    data.update(copy.deepcopy(settings))
    return data


# ---------------------------------------------------------------------------- Deliver 1: inputs
@pytest.fixture
def user_dir(tmp_path, monkeypatch):
    """An OFFROADBENCH_PATH folder with a copy of the lunar regolith and of the Husky."""
    root = tmp_path / "user"
    (root / "soils").mkdir(parents=True)
    text = resources.soil_files()["lunar-regolith"].read_text().replace('name = "lunar-regolith"', 'name = "my-soil"')
    (root / "soils" / "my-soil.toml").write_text(text)
    husky = resources.vehicle_files()["husky"].parent
    shutil.copytree(husky, root / "vehicles" / "my-husky")
    toml = root / "vehicles" / "my-husky" / "vehicle.toml"
    toml.write_text(toml.read_text().replace('name = "husky"', 'name = "my-husky"'))
    monkeypatch.setenv(resources.ENV_VAR, str(root))
    return root


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def test_a_resume_refuses_an_edited_soil_naming_the_parameter(tmp_path, user_dir):
    data = small(sim={"tyre_model": "terramechanics", "soil": "my-soil"})
    run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    _edit(user_dir / "soils" / "my-soil.toml", "k_phi = 820000.0", "k_phi = 1000000.0")
    with pytest.raises(InputError, match=r"soil parameters: .*k_phi 820000.0 -> 1000000.0"):
        run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    assert len(load(tmp_path / "run")) == 6  # nothing of the new soil was added


def test_a_resume_refuses_an_edited_vehicle_or_urdf(tmp_path, user_dir):
    data = small(vehicle={"name": "my-husky"})
    run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    toml = user_dir / "vehicles" / "my-husky" / "vehicle.toml"
    _edit(toml, "wheel_torque_limit_nm = 28.0", "wheel_torque_limit_nm = 12.0")
    with pytest.raises(InputError, match=r"another study .*vehicle .*wheel_torque_limit_nm 28.0 -> 12.0"):
        run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    _edit(toml, "wheel_torque_limit_nm = 12.0", "wheel_torque_limit_nm = 28.0")
    urdf = user_dir / "vehicles" / "my-husky" / "husky.urdf"
    # a comment and a re-indentation are no change of the model (issue 44): the resume goes on
    urdf.write_bytes(urdf.read_bytes().replace(b"<robot", b"<!-- edited -->\n  <robot", 1) + b"\n<!-- edited -->\n")
    assert run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials).ran == 0
    _edit(urdf, '<mass value="46.034"/>', '<mass value="40.0"/>')  # a real one is refused
    with pytest.raises(InputError, match=r"vehicle .*urdf_content_sha256"):
        run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)


def test_a_replay_refuses_a_urdf_replaced_since_the_run(tmp_path, user_dir):
    """Replay checks the vehicle against the run's record before it drives (issue 44): a comment is
    no change; a new mass is one line naming the model file's content hash."""
    from offroadbench.study.execution import replay_trial
    from offroadbench.study.spec import CellPlan, vehicle_changed

    data = small(vehicle={"name": "my-husky"})
    run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    with Store(tmp_path / "run") as store:
        stored = store.meta()
    urdf = user_dir / "vehicles" / "my-husky" / "husky.urdf"
    urdf.write_bytes(urdf.read_bytes() + b"\n<!-- edited -->\n")
    assert vehicle_changed(stored["trial_inputs"], CellPlan.from_meta(stored, 0).trial_settings) is None
    _edit(urdf, '<mass value="46.034"/>', '<mass value="40.0"/>')
    with pytest.raises(InputError, match=r"cannot replay cell 0, terrain 0, mission 1: the vehicle .* changed since "
                                         r"the run: .*urdf_content_sha256 .*restore the model file"):
        replay_trial(tmp_path / "run", 0, 0, 1)


def test_a_store_without_the_urdf_content_hash_compares_the_bytes(tmp_path, user_dir):
    """A store made before the content hash was recorded is resumed as before: by the file's bytes."""
    data = small(vehicle={"name": "my-husky"})
    run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    con = sqlite3.connect(tmp_path / "run" / "study.sqlite")
    with con:
        (text,) = con.execute("SELECT value FROM meta WHERE key = 'trial_inputs'").fetchone()
        old = json.loads(text)
        for v in old["vehicle"]:
            del v["urdf_content_sha256"]
        con.execute("UPDATE meta SET value = ? WHERE key = 'trial_inputs'", (json.dumps(old, sort_keys=True),))
    con.close()
    assert run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials).ran == 0
    urdf = user_dir / "vehicles" / "my-husky" / "husky.urdf"
    urdf.write_bytes(urdf.read_bytes() + b"\n<!-- edited -->\n")
    with pytest.raises(InputError, match=r"vehicle .*urdf_sha256"):
        run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)


def test_a_soil_s_description_is_cosmetic(tmp_path, user_dir):
    data = small(sim={"tyre_model": "terramechanics", "soil": "my-soil"})
    run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    soil = user_dir / "soils" / "my-soil.toml"
    text = soil.read_text()
    assert "description = " in text
    soil.write_text(text.replace("description = \"", "description = \"Edited: ", 1) + "\n# a comment\n")
    assert run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials).ran == 0


PLUGIN = """
class Policy:
    def __init__(self, cfg, context):
        pass

    def reset(self, problem):
        pass

    def act(self, obs):
        return 0.0, 0.0
"""


def test_a_plug_in_s_code_changed_without_a_version_bump_is_named(tmp_path, monkeypatch):
    from offroadbench.navigation.drivers import POLICIES, PolicySpec
    from offroadbench.study.spec import inputs

    package = tmp_path / "plugin" / "offroadbench_code_test"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text(PLUGIN)
    (package / "helpers.py").write_text("SPEED = 1.0\n")
    monkeypatch.syspath_prepend(str(tmp_path / "plugin"))
    import offroadbench_code_test

    POLICIES.add("code-test", PolicySpec(offroadbench_code_test.Policy, summary="test policy"))
    try:
        data = small(planner={"name": "code-test"})
        inputs._code_sha256.cache_clear()
        run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
        stored = load_meta(tmp_path / "run")["trial_inputs"]["planner"][0]
        assert len(stored["code_sha256"]) == 64
        inputs._code_sha256.cache_clear()
        assert run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials).ran == 0
        (package / "helpers.py").write_text("SPEED = 2.0\n")  # another file of the package, no version bump
        inputs._code_sha256.cache_clear()
        with pytest.raises(InputError, match=r"planner or policy .*: \[0\].code_sha256 "):
            run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    finally:
        POLICIES._entries.pop("code-test", None)
        inputs._code_sha256.cache_clear()


def test_a_built_in_planner_records_no_code_hash(tmp_path):
    from offroadbench.study.spec.inputs import trial_inputs

    study, cells = cells_of(small())
    assert "code_sha256" not in trial_inputs(study, cells)["planner"][0]


def test_a_changed_engine_or_planner_version_is_named(tmp_path, monkeypatch):
    from offroadbench.study.spec import inputs

    data = small()
    run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    monkeypatch.setattr(inputs, "_engine", lambda name: {"name": name, "package": f"{name} 99.0"})
    with pytest.raises(InputError, match=r"physics engine or its version: \[0\].package pybullet .* -> pybullet 99.0"):
        run_study(*cells_of(data), tmp_path / "run", executor="inline", trial_fn=fake_trials)


def test_a_cosmetic_change_is_accepted_and_recorded(tmp_path):
    data = small()
    first = run_study(*cells_of(data), tmp_path, executor="inline", trial_fn=fake_trials)
    with Store(tmp_path) as store:  # an unfinished study: drop one trial so the resume has work
        store.drop_trials([(0, 0, 2, 1)])
    cosmetic = copy.deepcopy(data)
    cosmetic["study"]["description"] = "now with words"
    cosmetic["reference"] = {"source": "a paper"}
    cosmetic["sim"] = {"physics_rate_hz": 60}  # the default, written out
    summary = run_study(*cells_of(cosmetic), tmp_path, executor="inline", trial_fn=fake_trials)
    assert summary.ran == 1 and summary.done == first.done
    meta = load_meta(tmp_path)
    (amend,) = meta["amendments"]
    assert {"description", "reference.source", "settings.sim.physics_rate_hz"} <= set(amend["changed"])
    assert meta["study"]["description"] == "now with words"
    # the study's real settings still refuse, naming the key
    real = copy.deepcopy(cosmetic)
    real["sim"] = {"physics_rate_hz": 120}
    with pytest.raises(InputError, match=r"trial settings: .*sim.physics_rate_hz 60 -> 120"):
        run_study(*cells_of(real), tmp_path, executor="inline", trial_fn=fake_trials)


def test_a_store_from_before_a_key_that_cannot_change_a_trial_resumes(tmp_path):
    """``[sim.mujoco_warp] cuda_graph`` came after stores were made; a store whose recorded trial
    settings lack it resumes (it cannot change a trial), while a change of a key that can is refused."""
    data = small()
    run_study(*cells_of(data), tmp_path, executor="inline", trial_fn=fake_trials)
    with Store(tmp_path) as store:  # an unfinished study: drop one trial so the resume has work
        store.drop_trials([(0, 0, 2, 1)])
    con = sqlite3.connect(tmp_path / "study.sqlite")
    recorded = json.loads(con.execute("SELECT value FROM meta WHERE key='trial_inputs'").fetchone()[0])
    for entry in recorded["settings"]:
        del entry["sim"]["mujoco_warp"]["cuda_graph"]  # as a store made before the key existed holds it
    con.execute("UPDATE meta SET value=? WHERE key='trial_inputs'", (json.dumps(recorded),))
    con.commit()
    con.close()
    assert run_study(*cells_of(data), tmp_path, executor="inline", trial_fn=fake_trials).ran == 1
    other = copy.deepcopy(data)
    other["sim"] = {"mujoco_warp": {"nconmax": 128}}
    with pytest.raises(InputError, match=r"trial settings: .*sim.mujoco_warp.nconmax 64 -> 128"):
        run_study(*cells_of(other), tmp_path, executor="inline", trial_fn=fake_trials)


def test_a_store_without_recorded_inputs_names_the_study_key_that_differs(tmp_path):
    data = small()
    run_study(*cells_of(data), tmp_path, executor="inline", trial_fn=fake_trials)
    con = sqlite3.connect(tmp_path / "study.sqlite")
    con.execute("DELETE FROM meta WHERE key='trial_inputs'")  # as an older offroadbench left it
    con.commit()
    con.close()
    other = copy.deepcopy(data)
    other["study"]["missions_per_terrain"] = 4
    with pytest.raises(InputError, match=r"holds another study .*changed: missions_per_terrain"):
        run_study(*cells_of(other), tmp_path, executor="inline", trial_fn=fake_trials)
    described = copy.deepcopy(data)
    described["study"]["description"] = "only words"
    assert run_study(*cells_of(described), tmp_path, executor="inline", trial_fn=fake_trials).ran == 0
    assert "trial_inputs" in load_meta(tmp_path)  # recorded from now on


# ---------------------------------------------------------------------------- Deliver 2: faults
def thrown_on(mission: int):
    """fake_trials whose trial ``mission`` throws the vehicle while it settles (a TrialFault)."""

    def trials(prepared, settings):
        for row in fake_trials(prepared, settings):
            if row["mission_index"] == mission:
                raise TrialFault("the vehicle was thrown 26 m while it settled")
            yield row

    return trials


def test_a_thrown_vehicle_is_a_fault_not_an_outcome_and_the_terrain_goes_on(tmp_path):
    study, cells = cells_of(small())
    summary = run_study(study, cells, tmp_path, executor="inline", trial_fn=thrown_on(1))
    assert (summary.done, summary.faults) == (4, 2) and summary.complete
    stored = load(tmp_path)
    assert sorted(stored["mission"].unique()) == [0, 2]  # mission 2 ran after the fault, in a new world
    with Store(tmp_path) as store:
        faults = store.fault_rows()
    assert [(c, t, m) for c, t, m, *_ in faults] == [(0, 0, 1), (1, 0, 1)]
    assert all("thrown 26 m" in f[5] for f in faults)


def test_a_terrain_with_no_drawable_mission_is_faults_and_the_study_goes_on(tmp_path, monkeypatch):
    """Issue 29: a drawn terrain with no start cell (rough everywhere inside the border) stops no
    study: each of its missions is a fault naming why, the other terrains run, nothing is redrawn."""
    from offroadbench.navigation.missions import NoMissionError
    from offroadbench.study.execution import tasks

    real = tasks.prepare_cell

    def no_start_on_cell_1(cell, terrain_seed, missions):
        if cell.index == 1:
            raise NoMissionError("no start cell: no low cell lies at least 5 m from the map edge in the class "
                                 "map after its morphological closing")
        return real(cell, terrain_seed, missions)

    monkeypatch.setattr(tasks, "prepare_cell", no_start_on_cell_1)
    study, cells = cells_of(small())
    summary = run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    assert (summary.done, summary.faults) == (3, 3) and summary.complete
    assert sorted(load(tmp_path)["cell"].unique()) == [0]
    with Store(tmp_path) as store:
        faults = store.fault_rows()
    assert [(c, t, m) for c, t, m, *_ in faults] == [(1, 0, 0), (1, 0, 1), (1, 0, 2)]
    assert all(f[5].startswith("no mission can be drawn on this terrain: no start cell") for f in faults)


def test_a_planner_that_refuses_the_vehicle_is_faults_and_the_grid_goes_on(tmp_path):
    """A cartesian grid of vehicles and planners holds pairs that cannot be driven (A* turns on the spot;
    the HUNTER, an Ackermann car, cannot): those trials are faults naming the refusal, the other cells
    run, and ``drive`` with the same pair still answers with one line (InputError)."""
    from offroadbench.navigation.problem import PlannerRefusal
    from offroadbench.study.execution.tasks import REFUSED_FAULT

    data = small(grid={"vehicle.name": ["hunter"], "planner.name": ["straight", "astar"]})
    data["study"].update(missions_per_terrain=1)
    data["recipe_overrides"] = {"grid.rows": 161, "grid.cols": 161}
    data["missions"] = {"length_m": 3.0, "border_m": 1.5}
    data["roughness"] = {"border_m": 1.5}
    study, cells = cells_of(data)
    summary = run_study(study, cells, tmp_path, executor="inline")
    assert (summary.done, summary.faults) == (1, 1) and summary.complete
    assert list(load(tmp_path)["planner"]) == ["straight"]
    with Store(tmp_path) as store:
        faults = store.fault_rows()
    assert len(faults) == 1 and faults[0][5].startswith(REFUSED_FAULT + "planner 'astar' plans paths that may turn")
    assert issubclass(PlannerRefusal, InputError)


def test_the_report_lists_faults_and_its_statistics_leave_them_out(tmp_path):
    from offroadbench.study.report.markdown import build_report

    study, cells = cells_of(small())
    run_study(study, cells, tmp_path, executor="inline", trial_fn=thrown_on(1))
    rep = build_report(tmp_path)
    assert "## Faults" in rep.markdown and "thrown 26 m" in rep.markdown and "incomplete" not in rep.markdown
    assert "**4 of 6** stored, 2 fault(s)" in rep.markdown
    assert len(rep.tables["faults.csv"]) == 2
    assert rep.tables["summary.csv"]["trials"].sum() == 4


def test_a_limit_shorter_than_the_poll_is_enforced(tmp_path, monkeypatch):
    from offroadbench.study.execution.executors import LocalExecutor

    monkeypatch.setattr(LocalExecutor, "poll_s", 60.0)  # the deadline, not the poll, sets the wait
    def slow_mission_1(prepared, settings):
        for row in fake_trials(prepared, settings):
            if row["mission_index"] == 1:
                time.sleep(30)
            yield row

    study, cells = cells_of(small())
    t0 = time.monotonic()
    summary = run_study(study, cells, tmp_path, executor="local", workers=1, trial_fn=slow_mission_1,
                        executor_options={"trial_timeout_s": 2.0})
    assert time.monotonic() - t0 < 25
    assert (summary.done, summary.faults) == (4, 2)


@pytest.mark.parametrize("value", [0, -1, float("nan"), float("inf"), 1e10, MAX_TRIAL_TIMEOUT_S * 1.01, True, "5"])
def test_a_limit_beyond_the_sane_range_is_refused(value):
    with pytest.raises(InputError, match="trial_timeout_s"):
        check_trial_timeout(value)


@pytest.mark.parametrize("limit", [MAX_TRIAL_TIMEOUT_S, 1e10])
def test_a_dask_task_waits_in_slices_so_no_limit_overflows(limit):
    """A limit past ``threading.TIMEOUT_MAX`` made every Dask task fail with OverflowError; the task
    now waits in short slices (1e10 s is refused by the CLI, but the task would cope)."""
    from offroadbench.study.execution.executors import dask_task
    from offroadbench.study.runner import plan_tasks
    from offroadbench.study.execution.tasks import TerrainBuilt, TrialDone

    study, cells = cells_of(small())
    task = plan_tasks(study, cells, set())[0]
    msgs = dask_task(task, fake_trials, limit)
    assert isinstance(msgs[0], TerrainBuilt) and [type(m) for m in msgs[1:]] == [TrialDone] * 3


def test_a_thrown_vehicle_is_told_from_one_at_rest():
    from offroadbench.bounds import check_settled

    check_settled((1.0, 2.0, 0.25), (0.01, 0.0, -0.02), ground_z_m=0.1, size_m=0.9)  # at rest on its wheels
    with pytest.raises(TrialFault, match=r"thrown while it settled \(base 26 m above"):
        check_settled((1.0, 2.0, 26.1), (0.0, 0.0, 0.5), ground_z_m=0.1, size_m=0.9)
    with pytest.raises(TrialFault, match="moving at 12 m/s"):
        check_settled((1.0, 2.0, 0.3), (12.0, 0.0, 0.0), ground_z_m=0.1, size_m=0.9)
    with pytest.raises(TrialFault):
        check_settled((1.0, 2.0, float("nan")), (0.0, 0.0, 0.0), ground_z_m=0.1)


# ---------------------------------------------------------------------------- Deliver 3: a full store
class _FullAt:
    """A connection whose INSERT INTO trials fails with SQLITE_FULL from the ``n``-th trial on,
    after SQLite has rolled the transaction back itself (as it does on a full disk): the ROLLBACK
    that followed used to raise "cannot rollback - no transaction is active" over it."""

    def __init__(self, con, n: int) -> None:
        self._con, self._n, self._seen = con, n, 0

    def __getattr__(self, name):
        return getattr(self._con, name)

    def execute(self, sql, *args):
        if sql.startswith("INSERT OR IGNORE INTO trials"):
            self._seen += 1
            if self._seen >= self._n:
                self._con.execute("ROLLBACK")
                raise sqlite3.OperationalError("database or disk is full")
        return self._con.execute(sql, *args)


def test_a_full_disk_in_a_trial_commit_is_one_oserror_naming_the_store(tmp_path, monkeypatch):
    study, cells = cells_of(small())
    real_init = Store.__init__

    def init(self, *a, **k):
        real_init(self, *a, **k)
        if k.get("create"):
            self.con = _FullAt(self.con, 3)

    monkeypatch.setattr(Store, "__init__", init)
    with pytest.raises(OSError) as info:
        run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(tmp_path / "study.sqlite")
    monkeypatch.undo()
    assert not (tmp_path / LOCK_NAME).exists()
    assert len(load(tmp_path)) == 2  # what was committed stays
    assert run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials).done == study.n_trials


class _FullUntilFreed:
    """A connection on a disk that fills at the ``n``-th trial: from then on every write fails with
    SQLITE_FULL (rolled back by SQLite itself) until the run directory's reserve is removed."""

    def __init__(self, con, n: int, run_dir: Path) -> None:
        self._con, self._n, self._seen, self._reserve = con, n, 0, run_dir / RESERVE_NAME

    def __getattr__(self, name):
        return getattr(self._con, name)

    def execute(self, sql, *args):
        if sql.startswith("INSERT OR IGNORE INTO trials"):
            self._seen += 1
        if self._seen >= self._n and sql.startswith(("INSERT", "UPDATE")) and self._reserve.exists():
            if self._con.in_transaction:
                self._con.execute("ROLLBACK")
            raise sqlite3.OperationalError("database or disk is full")
        return self._con.execute(sql, *args)


def test_a_session_stopped_by_a_full_disk_is_recorded_as_failed_not_killed(tmp_path, monkeypatch):
    """The session's end is written into the space its reserve held (issue 44: it used to be listed
    ``killed``), the error names the full disk, and no reserve is left behind."""
    study, cells = cells_of(small())
    real_init = Store.__init__
    seen_reserve = []

    def init(self, *a, **k):
        real_init(self, *a, **k)
        if k.get("create"):
            self.con = _FullUntilFreed(self.con, 3, self.run_dir)

    def trials(*a, **k):
        seen_reserve.append((tmp_path / RESERVE_NAME).stat().st_size)
        return fake_trials(*a, **k)

    monkeypatch.setattr(Store, "__init__", init)
    with pytest.raises(OSError) as info:
        run_study(study, cells, tmp_path, executor="inline", trial_fn=trials)
    assert info.value.errno == errno.ENOSPC
    monkeypatch.undo()
    assert seen_reserve and min(seen_reserve) >= RESERVE_BYTES  # set aside while the trials ran
    assert not (tmp_path / RESERVE_NAME).exists()
    (run,) = load_meta(tmp_path)["runs"]
    assert run["status"] == "failed" and "No space left on device" in run["error"]
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    assert [r["status"] for r in load_meta(tmp_path)["runs"]] == ["failed", "finished"]
    assert not (tmp_path / RESERVE_NAME).exists()


def test_a_full_disk_while_locking_leaves_no_lock_file(tmp_path, monkeypatch):
    from offroadbench.study.store.store import RunLock

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "pwrite", full)
    with pytest.raises(InputError, match=r"study.lock: cannot write the run directory's lock file \(no space left"):
        RunLock(tmp_path / "run").acquire()
    assert not (tmp_path / "run" / LOCK_NAME).exists()


# ---------------------------------------------------------------------------- Deliver 7: sessions
def test_a_killed_session_is_shown_as_killed_and_recorded_so_by_the_next_run(tmp_path):
    study, cells = cells_of(small())
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    con = sqlite3.connect(tmp_path / "study.sqlite")
    con.execute("UPDATE runs SET status='running', finished=NULL")  # as a SIGKILLed run leaves it
    con.commit()
    con.close()
    dead = os.fork()
    if dead == 0:
        os._exit(0)
    os.waitpid(dead, 0)
    (tmp_path / LOCK_NAME).write_text(f"{dead}\n")  # its lock file, naming its dead pid
    assert load_meta(tmp_path)["runs"][0]["status"] == "killed"
    (tmp_path / LOCK_NAME).write_text(f"{os.getpid()}\n")  # a live holder: still running
    assert load_meta(tmp_path)["runs"][0]["status"] == "running"
    (tmp_path / LOCK_NAME).unlink()
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    with Store(tmp_path) as store:
        stored = [r for r in store.con.execute("SELECT status FROM runs ORDER BY id")]
    assert stored == [("killed",), ("finished",)]


# ---------------------------------------------------------------------------- Deliver 5: export
def _export_rows(out: Path) -> tuple[int, int]:
    import pandas as pd

    return len(pd.read_csv(out / "trials.csv")), int(pd.read_csv(out / "terrains.csv")["trials"].sum())


@pytest.mark.parametrize("cut", ["after_first_rename", "disk_full_on_second_table"])
def test_study_export_is_all_or_nothing(tmp_path, cut):
    from offroadbench.cli import main
    from offroadbench.io import atomic

    study, cells = cells_of(small())
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    with Store(tmp_path) as store:
        store.drop_trials([(0, 0, 2, 1)])
    assert main(["study", "export", str(tmp_path), "--format", "csv"]) == 0
    assert _export_rows(tmp_path) == (5, 5)  # the old pair
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)  # now 6 trials
    pid = os.fork()
    if pid == 0:  # the export, cut at one point
        try:
            if cut == "after_first_rename":
                real, n = os.replace, [0]

                def replace(a, b):
                    real(a, b)
                    if str(b).endswith(".csv"):
                        n[0] += 1
                        if n[0] == 1:
                            os._exit(9)  # killed between the two tables

                atomic.os.replace = replace
            else:
                import pandas as pd

                real_csv, n = pd.DataFrame.to_csv, [0]

                def to_csv(self, *a, **k):
                    n[0] += 1
                    if n[0] == 2:
                        raise OSError(errno.ENOSPC, "No space left on device")
                    return real_csv(self, *a, **k)

                pd.DataFrame.to_csv = to_csv
            code = main(["study", "export", str(tmp_path), "--format", "csv"])
        finally:
            os._exit(code if "code" in locals() else 3)
    _, status = os.waitpid(pid, 0)
    if cut == "after_first_rename":
        assert os.WEXITSTATUS(status) == 9
        atomic.finish_commits(tmp_path)  # what the next export (or reader) does first
        assert _export_rows(tmp_path) == (6, 6)  # the new pair, completed
    else:
        assert os.WEXITSTATUS(status) == 1  # the CLI's one line for a full disk
        assert _export_rows(tmp_path) == (5, 5)  # the old pair, untouched
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".") and ("commit" in p.name or
                                                                                  p.name.endswith(".tmp"))]


# ---------------------------------------------------------------------------- as a user: the CLI
HUNG_STUDY = """
[study]
name = "hung"
recipe = "paper-d2.45"
root_seed = 3
terrains_per_cell = 1
missions_per_terrain = 3

[recipe_overrides]
"grid.rows" = 161
"grid.cols" = 161

[roughness]
border_m = 1.0

[missions]
length_m = 3.0
border_m = 1.0

[planner]
name = "hangs-once-test"
"""


def test_a_study_with_a_hanging_trial_finishes_the_rest_and_reports_the_fault(tmp_path, monkeypatch, capsys):
    """Done-when of issue 30: a study with one hanging trial finishes every other trial, reports the
    hung one as a fault, and its statistics exclude it; a resume skips it, --retry-faults runs it."""
    import math

    from offroadbench.cli import main
    from offroadbench.navigation.drivers import POLICIES, PolicySpec

    marker = tmp_path / "hung.marker"

    class HangsOnce:
        """Drives at the goal; the first act() of the second episode anywhere hangs (once)."""

        episodes = 0

        def __init__(self, cfg, context) -> None:
            pass

        def reset(self, problem) -> None:
            HangsOnce.episodes += 1
            self.episode = HangsOnce.episodes

        def act(self, obs):
            if self.episode == 2 and not marker.exists():
                marker.write_text("hung")
                time.sleep(600)
            gx, gy = obs["state"][:2]
            return (0.8, max(-1.5, min(1.5, 2.0 * math.atan2(gy, gx))))

    POLICIES.add("hangs-once-test", PolicySpec(HangsOnce, summary="test policy"))
    try:
        (tmp_path / "study.toml").write_text(HUNG_STUDY)
        out = tmp_path / "run"
        args = ["study", "run", str(tmp_path / "study.toml"), "--out", str(out), "--workers", "1",
                "--trial-timeout-s", "4"]
        assert main(args) == 0
        text = capsys.readouterr().out
        assert "2 / 3 trials" in text and "1 fault(s)" in text
        report = (out / "report" / "report.md").read_text()
        assert "## Faults" in report and "ran longer than 4 s" in report and "**2 of 3** stored, 1 fault(s)" in report
        assert len(load(out)) == 2
        assert main([*args, "--no-report"]) == 0 and "this run: 0 trials" in capsys.readouterr().out
        assert main([*args, "--retry-faults"]) == 0  # the marker is there: it runs now
        assert "3 / 3 trials" in capsys.readouterr().out
        assert "## Faults" not in (out / "report" / "report.md").read_text()
    finally:
        POLICIES._entries.pop("hangs-once-test", None)


def test_memory_check_reads_the_address_space_limit_per_process(monkeypatch):
    from offroadbench import memory

    monkeypatch.setattr(memory, "address_space_room_bytes", lambda: 2 * 2**30)
    monkeypatch.delenv(memory.NO_MEMORY_CHECK_ENV, raising=False)
    with pytest.raises(InputError, match="address-space limit"):
        memory.check_memory(3 * 2**30, "a 6000x6000 heightmap")
    # a study's workers: each has its own limit, so four of 1 GB fit under a 2 GB limit each ...
    monkeypatch.setattr(memory, "available_memory_bytes", lambda per_process=True: 2 * 2**30 if per_process
                        else 64 * 2**30)
    memory.check_memory(4 * 2**30, "4 workers", per_process_bytes=2**30)
    # ... but not one of 3 GB
    with pytest.raises(InputError, match="each process needs about 3.0 GB"):
        memory.check_memory(3 * 2**30, "1 worker", per_process_bytes=3 * 2**30)
