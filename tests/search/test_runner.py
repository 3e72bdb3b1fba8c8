"""A search drives study trials into a study store, resumes after a kill with the same proposals,
and runs on every executor (a stand-in trial function: no physics, see stand_in.py)."""

import copy
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.search import run_search, search_from_data
from tests.search.stand_in import SEARCH, stand_in_trials

ROOT = Path(__file__).resolve().parents[2]


def _table(run_dir):
    con = sqlite3.connect(f"file:{run_dir / 'study.sqlite'}?mode=ro", uri=True)
    try:
        proposals = con.execute("SELECT cell, grp, method, batch, slot, stage, x, z, log_w FROM search_trials "
                                "ORDER BY cell").fetchall()
        rows = con.execute("SELECT cell, terrain, mission, terrain_seed, mission_seed, row FROM trials ORDER BY cell").fetchall()
    finally:
        con.close()
    return proposals, rows


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("search-ref")
    plan = search_from_data(SEARCH)
    summary = run_search(plan, d, executor="inline", trial_fn=stand_in_trials)
    return plan, d, summary


def test_a_search_stores_every_trial_of_every_stream_and_finds_failures(reference):
    plan, d, summary = reference
    assert summary.total == summary.done == 3 * 24
    proposals, rows = _table(d)
    assert [p[0] for p in proposals] == [r[0] for r in rows] == list(range(72))
    by_method = {}
    for (_, _, method, *_), (*_, row) in zip(proposals, rows, strict=True):
        by_method.setdefault(method, []).append('"success": false' in row)
    # the falsifier concentrates on the failure region: more failures than nominal sampling
    assert sum(by_method["falsify"]) > 2 * max(sum(by_method["random"]), 1)
    # every proposal lies inside the search ranges
    for p in proposals:
        x = np.array(eval(p[6]))
        assert 0.5 <= x[0] <= 2.0 and 2.3 <= x[1] <= 2.6


def test_the_same_seed_gives_the_same_search(reference, tmp_path):
    plan, d, _ = reference
    run_search(plan, tmp_path, executor="inline", trial_fn=stand_in_trials)
    assert _table(tmp_path) == _table(d)


def interrupting(after):
    count = {"n": 0}

    def trials(prepared, settings):
        for row in stand_in_trials(prepared, settings):
            count["n"] += 1
            if count["n"] > after:
                raise KeyboardInterrupt
            yield row

    return trials


@pytest.mark.parametrize("after", [6, 31, 55])  # inside a falsifier batch, a CE stage, a CE final batch
def test_an_interrupted_search_resumes_with_identical_proposals(reference, tmp_path, after):
    plan, d, _ = reference
    with pytest.raises(KeyboardInterrupt):
        run_search(plan, tmp_path, executor="inline", trial_fn=interrupting(after))
    assert len(_table(tmp_path)[1]) == after
    summary = run_search(plan, tmp_path, executor="inline", trial_fn=stand_in_trials)
    assert summary.ran == 72 - after
    assert _table(tmp_path) == _table(d)


KILLED = textwrap.dedent("""
    import sys, time
    sys.path.insert(0, {root!r})
    from offroadbench.search import run_search, search_from_data
    from tests.search.stand_in import SEARCH, stand_in_trials

    def slow(prepared, settings):
        for row in stand_in_trials(prepared, settings):
            time.sleep(0.05)
            yield row

    run_search(search_from_data(SEARCH), {out!r}, executor="local", workers=2, trial_fn=slow)
""")


@pytest.mark.timeout(300)
def test_a_killed_search_resumes_with_identical_proposals(reference, tmp_path, stored_trials):
    plan, d, _ = reference
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-c", KILLED.format(root=str(ROOT), out=str(out))], cwd=ROOT,
                            start_new_session=True)
    try:
        deadline = time.monotonic() + 200
        while stored_trials(out) < 20 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, "the search ended before it could be killed"
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the coordinator and its workers
        proc.wait()
    assert 20 <= stored_trials(out) < 72
    summary = run_search(plan, out, executor="inline", trial_fn=stand_in_trials)
    assert summary.done == 72
    assert _table(out) == _table(d)


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", ["local", "dask"])
def test_a_search_gives_the_same_trials_on_every_executor(reference, tmp_path, name):
    if name == "dask":
        pytest.importorskip("distributed")
    plan, d, _ = reference
    data = copy.deepcopy(SEARCH)
    data["search"].update(methods=["falsify"], budget=8, batch_size=8)  # one batch: one Dask cluster start
    small = search_from_data(data)
    inline = tmp_path / "inline"
    run_search(small, inline, executor="inline", trial_fn=stand_in_trials)
    run_search(small, tmp_path / name, executor=name, workers=2, trial_fn=stand_in_trials)
    assert _table(tmp_path / name) == _table(inline)


def test_a_larger_budget_goes_on_where_the_search_stopped(reference, tmp_path):
    plan, d, _ = reference
    run_search(plan, tmp_path, budget=12, executor="inline", trial_fn=stand_in_trials)
    summary = run_search(plan, tmp_path, budget=24, executor="inline", trial_fn=stand_in_trials)
    assert summary.ran == 36
    proposals, _ = _table(tmp_path)
    ref = {(p[1], p[2], p[3], p[4]): p[5:] for p in _table(d)[0]}
    # the falsifier and nominal streams are the same as a run with the larger budget from the start
    for p in proposals:
        if p[2] != "ce-is":
            assert ref[(p[1], p[2], p[3], p[4])] == p[5:]


def test_a_study_directory_is_refused(tmp_path, write_tiny_study):
    from offroadbench.study import load_study, run_study
    from tests.study.test_run import fake_trials

    study, cells = load_study(write_tiny_study(tmp_path, name="s", root_seed=1, terrains=1, missions=1))
    run_study(study, cells, tmp_path / "run", executor="inline", trial_fn=fake_trials)
    with pytest.raises(InputError, match="holds a study, not a search"):
        run_search(search_from_data(SEARCH), tmp_path / "run", executor="inline", trial_fn=stand_in_trials)


@pytest.mark.parametrize("executor", ["inline", "local"])
def test_proposals_whose_terrain_holds_no_mission_are_stored_apart_and_the_search_goes_on(tmp_path, executor):
    from offroadbench.search.report import search_table
    from offroadbench.search.runner import NO_MISSION

    data = copy.deepcopy(SEARCH)
    data["search"].update(methods=["random", "falsify"], budget=12)
    # a 6 m map with a 0.5 m border has a 7.07 m diagonal: longer missions cannot be placed
    data["search"]["params"][1] = {"key": "missions.length_m", "low": 3.0, "high": 12.0}
    plan = search_from_data(data)
    summary = run_search(plan, tmp_path, executor=executor, workers=2, trial_fn=stand_in_trials)
    assert summary.done == 24
    df, _ = search_table(tmp_path)
    none = df["failure_reason"] == NO_MISSION
    assert none.any() and (df.loc[none, "missions.length_m"] > 6.0).all()  # near the diagonal: no goal found
    assert not df.loc[none, "failed"].any() and df.loc[none, "margin"].isna().all()
    assert (df.loc[~none, "missions.length_m"] <= 7.1).all()


def _local_search_data() -> dict:
    data = copy.deepcopy(SEARCH)
    data["search"].update(methods=["falsify"], local_step=0.12, explore_slots=1)
    return data


def test_the_local_search_redrives_failing_terrains_one_parameter_step_away(tmp_path):
    plan = search_from_data(_local_search_data())
    run_search(plan, tmp_path, executor="inline", trial_fn=stand_in_trials)
    from offroadbench.search.report import search_table

    df, _ = search_table(tmp_path)
    unit = plan.search.unit(df[list(plan.search.keys)].to_numpy(dtype=float))
    redriven = 0
    for i in range(len(df)):
        earlier = [j for j in range(i) if df["terrain_seed"][j] == df["terrain_seed"][i]
                   and df["mission_seed"][j] == df["mission_seed"][i]]
        if not earlier:
            continue
        redriven += 1
        assert any(df["failed"][j] for j in earlier)  # only a failure's terrain is driven again
        steps = [np.abs(unit[i] - unit[j]) for j in earlier if df["failed"][j]]
        # one parameter moved by the step (less where the range ends), the others kept
        assert any(((s > 1e-9).sum() == 1) and 0 < s.max() <= 0.12 + 1e-9 for s in steps)
        assert min(np.abs(unit[i] - unit[j]).max() for j in earlier) >= 0.1 - 1e-9
    assert redriven >= 8


def test_a_local_search_resumes_with_identical_proposals(tmp_path):
    plan = search_from_data(_local_search_data())
    whole, part = tmp_path / "whole", tmp_path / "part"
    run_search(plan, whole, executor="inline", trial_fn=stand_in_trials)
    run_search(plan, part, budget=12, executor="inline", trial_fn=stand_in_trials)
    summary = run_search(plan, part, executor="inline", trial_fn=stand_in_trials)
    assert summary.ran == 12
    assert _table(part) == _table(whole)


def test_importance_sampling_drives_terrains_of_its_own(reference):
    """The ce-is stream's nuisance draws are not the random stream's (trial k of each would
    otherwise drive the same terrain), so the Monte Carlo reference is independent of the
    importance-sampling estimate it checks."""
    _, d, _ = reference
    proposals, rows = _table(d)
    method = {cell: m for cell, _, m, *_ in proposals}
    seeds = {m: {r[3] for r in rows if method[r[0]] == m} for m in ("random", "ce-is")}
    assert len(seeds["random"]) == len(seeds["ce-is"]) == 24
    assert not seeds["random"] & seeds["ce-is"]


@pytest.mark.parametrize("fixed", [False, True])
def test_a_replicate_draws_other_proposals_and_nuisance_on_the_same_domain(reference, tmp_path, fixed):
    """replicate = 1 is an independent repeat: other proposals in every stream; other terrains where
    the terrain is random nuisance, the same site where it is fixed."""
    _, d, _ = reference
    data = copy.deepcopy(SEARCH)
    data["search"].update(replicate=1, fix_terrain=fixed, fix_mission=fixed)
    run_search(search_from_data(data), tmp_path, executor="inline", trial_fn=stand_in_trials)
    (p0, r0), (p1, r1) = _table(d), _table(tmp_path)
    for method in ("falsify", "random", "ce-is"):
        x0 = [p[6] for p in p0 if p[2] == method]
        x1 = [p[6] for p in p1 if p[2] == method]
        assert len(x0) == len(x1) == 24 and not set(x0) & set(x1), method
    terrains1 = {r[3] for r in r1}
    if fixed:
        assert len(terrains1) == 1
    else:
        terrains0 = {r[3] for r in r0}
        assert len(terrains1) == len(terrains0) > 24 and not terrains1 & terrains0


def always_faulting(calls):
    """A trial function whose every trial faults (the vehicle thrown while it settles), counting its calls."""
    from offroadbench.errors import TrialFault

    def trials(prepared, settings):
        calls.append(prepared.missions[0].index)
        raise TrialFault("the vehicle was thrown while it settled")
        yield  # pragma: no cover - a generator that faults at its first trial

    return trials


def _search_faults(run_dir) -> list[tuple]:
    con = sqlite3.connect(f"file:{run_dir / 'study.sqlite'}?mode=ro", uri=True)
    try:
        return con.execute("SELECT f.cell, f.reason FROM faults f JOIN search_trials s ON s.cell = f.cell "
                           "ORDER BY f.cell").fetchall()
    finally:
        con.close()


@pytest.mark.timeout(120)
def test_a_search_whose_trials_always_fault_ends_with_its_faults_stored(tmp_path):
    """Issue 43: a faulted proposal is done (stored as a fault, no margin), not proposed again forever;
    a second call runs nothing."""
    data = copy.deepcopy(SEARCH)
    data["search"].update(methods=["random", "falsify"], budget=8)
    plan = search_from_data(data)
    calls: list = []
    summary = run_search(plan, tmp_path, executor="inline", trial_fn=always_faulting(calls))
    assert len(calls) == 16  # each proposal driven once
    faults = _search_faults(tmp_path)
    assert [c for c, _ in faults] == list(range(16))
    assert all("thrown while it settled" in reason for _, reason in faults)
    assert _table(tmp_path)[1] == [] and summary.ran == 0
    again = run_search(plan, tmp_path, executor="inline", trial_fn=always_faulting(calls))
    assert len(calls) == 16 and again.ran == 0


@pytest.mark.timeout(120)
def test_retry_faults_runs_each_faulted_proposal_once_more_and_keeps_the_proposals(tmp_path):
    """--retry-faults: every faulted proposal is driven once more in place (bounded: once per call), its
    row says which fault it follows, the proposals stay as stored, and a later resume runs nothing."""
    from offroadbench.search.runner import RETRIED

    data = copy.deepcopy(SEARCH)
    data["search"].update(methods=["random", "falsify"], budget=8)
    plan = search_from_data(data)
    calls: list = []
    run_search(plan, tmp_path, executor="inline", trial_fn=always_faulting(calls))
    proposals = _table(tmp_path)[0]
    driven: list = []

    def counted(prepared, settings):
        driven.append(prepared.missions[0].index)
        yield from stand_in_trials(prepared, settings)

    summary = run_search(plan, tmp_path, executor="inline", trial_fn=counted, retry_faults=True)
    assert len(driven) == 16 and summary.ran == 16 and summary.faults == 0
    after, rows = _table(tmp_path)
    assert after == proposals
    assert all(f'"{RETRIED}": "the vehicle was thrown while it settled"' in r[5] for r in rows)
    assert run_search(plan, tmp_path, executor="inline", trial_fn=counted).ran == 0 and len(driven) == 16


def test_a_killed_search_session_is_recorded_as_killed_by_the_next_run(reference, tmp_path):
    plan, _, _ = reference
    with pytest.raises(KeyboardInterrupt):
        run_search(plan, tmp_path, executor="inline", trial_fn=interrupting(5))
    con = sqlite3.connect(tmp_path / "study.sqlite")
    con.execute("UPDATE runs SET status='running', finished=NULL")  # as a SIGKILLed run leaves it
    con.commit()
    con.close()
    run_search(plan, tmp_path, budget=4, executor="inline", trial_fn=stand_in_trials)
    con = sqlite3.connect(tmp_path / "study.sqlite")
    try:
        assert [s for (s,) in con.execute("SELECT status FROM runs ORDER BY id")] == ["killed", "finished"]
    finally:
        con.close()
