"""The store knows the platform (issue 24, Deliver 4): every session records a fingerprint, a
resume on another one is allowed and recorded, the report lists the platforms, and replay says
whether bit-identity is promised for a trial stored elsewhere."""

from __future__ import annotations

import copy
import json
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from offroadbench.study import load_meta, load_study, run_study, study_from_dict
from offroadbench.study.fingerprint import (
    cpu_kind,
    describe,
    identity_promise,
    platform_fingerprint,
)
from offroadbench.study.report.markdown import build_report
from offroadbench.study.store.results import load_platforms, trial_platform
from offroadbench.study.spec.config import plan_cells
from tests.study.test_run import STUDY, failing_after

ROOT = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-c", "import sys; from offroadbench.cli import main; sys.exit(main())"]
#: numpy's and OpenBLAS's dispatch switched down to the x86-64 baseline (DESIGN.md, portability)
BASELINE_ENV = {"NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR", "OPENBLAS_CORETYPE": "Nehalem"}


def test_the_fingerprint_names_cpu_dispatch_and_versions():
    fp = platform_fingerprint()
    from numpy._core import _multiarray_umath as umath

    assert fp["arch"] and fp["cpu"]
    assert set(fp["numpy_dispatch"]) <= set(umath.__cpu_dispatch__)
    assert fp["numpy_dispatch"] == [t for t in umath.__cpu_dispatch__ if umath.__cpu_features__.get(t)]
    assert fp["versions"]["numpy"] == np.__version__
    for name in ("pybullet", "ruckig", "finufft", "glibc"):
        assert fp["versions"][name]
    assert fp["avx2_fma"] in (True, False)
    assert fp["openblas"].get("version")
    json.dumps(fp)  # stored as JSON


def _fingerprint_in(env: dict[str, str]) -> dict:
    code = "import json; from offroadbench.study.fingerprint import platform_fingerprint as f; print(json.dumps(f()))"
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env}, capture_output=True, text=True,
                         check=True, timeout=60)
    return json.loads(out.stdout)


@pytest.mark.skipif(os.uname().machine != "x86_64", reason="the dispatch switches are x86-64 names")
def test_switching_dispatch_down_changes_the_cpu_kind_not_the_versions():
    here = platform_fingerprint()
    low = _fingerprint_in(BASELINE_ENV)
    assert low["numpy_dispatch"] == []
    assert low["openblas"]["core"] == "Nehalem"
    assert low["env"] == BASELINE_ENV
    assert low["versions"] == here["versions"]
    if here["numpy_dispatch"] or here["openblas"].get("core") != "Nehalem":
        assert cpu_kind(low) != cpu_kind(here)


def test_the_promise_follows_the_projects_rule():
    here = platform_fingerprint()
    other_kind = {**here, "cpu": "Intel Xeon", "numpy_dispatch": ["X86_V3", "X86_V4", "AVX512_ICL"],
                  "openblas": {**here["openblas"], "core": "SkylakeX"}}
    if cpu_kind(other_kind) == cpu_kind(here):
        other_kind["numpy_dispatch"] = ["X86_V3"]
    assert identity_promise(here, here, "png16")[0] is True
    assert identity_promise(here, here, "none")[0] is True
    if here["arch"] == "x86_64":
        assert identity_promise(other_kind, here, "png16")[0] is True
    ok, why = identity_promise(other_kind, here, "none")
    assert ok is False and "same CPU kind" in why
    newer = {**here, "versions": {**here["versions"], "numpy": "99.0"}}
    ok, why = identity_promise(newer, here, "png16")
    assert ok is False and "numpy 99.0" in why
    for name in ("finufft", "glibc", "ruckig"):
        other = {**here, "versions": {**here["versions"], name: "0.1"}}
        ok, why = identity_promise(other, here, "png16")
        assert ok is False and f"{name} 0.1" in why
    no_fma = {**other_kind, "avx2_fma": False}
    if here["arch"] == "x86_64":
        ok, why = identity_promise(no_fma, here, "png16")
        assert ok is False and "AVX2 and FMA" in why
    arm = {**here, "arch": "aarch64"}
    ok, why = identity_promise(arm, here, "png16")
    assert ok is False and "architecture" in why
    assert identity_promise(None, here, "png16")[0] is None
    ok, why = identity_promise(here, here, "png16", "0.1", "0.2")
    assert ok is False and "0.1" in why
    assert "numpy" in describe(here) and "not recorded" in describe(None)


def _study(tmp_path):
    data = copy.deepcopy(STUDY)
    study = study_from_dict(data)
    return study, plan_cells(study)


RESUME = """
import sys
sys.path.insert(0, {root!r})
from offroadbench.study import run_study, study_from_dict
from offroadbench.study.spec.config import plan_cells
from tests.study.test_run import STUDY, fake_trials
study = study_from_dict(STUDY)
run_study(study, plan_cells(study), {out!r}, executor="inline", trial_fn=fake_trials)
"""


@pytest.mark.skipif(os.uname().machine != "x86_64", reason="the dispatch switches are x86-64 names")
def test_a_resume_on_another_platform_is_recorded_and_reported(tmp_path):
    study, cells = _study(tmp_path)
    out = tmp_path / "run"
    with pytest.raises(RuntimeError, match="simulated crash"):
        run_study(study, cells, out, executor="inline", trial_fn=failing_after({"armed": True}))
    first = load_meta(out)["runs"][0]
    assert first["platform"] == platform_fingerprint()
    subprocess.run([sys.executable, "-c", RESUME.format(root=str(ROOT), out=str(out))], cwd=ROOT,
                   env={**os.environ, **BASELINE_ENV}, check=True, timeout=120, capture_output=True)
    runs = load_meta(out)["runs"]
    assert [r["status"] for r in runs] == ["failed", "finished"]
    assert runs[1]["platform"]["env"] == BASELINE_ENV
    plats = load_platforms(out)
    assert len(plats) == 2 and plats["trials"].sum() == study.n_trials
    assert set(plats["sessions"]) == {"1", "2"}
    assert list(plats["trials"]) == sorted(
        [runs[0]["trials_run"], runs[1]["trials_run"]], reverse=True)
    report = build_report(out)
    assert "## Platforms" in report.markdown and "The trials ran on 2 platforms" in report.markdown
    assert "OPENBLAS_CORETYPE=Nehalem" in report.markdown
    assert "yes: quantised terrain" in report.markdown  # the paper preset is quantised by default
    assert all(r["platform"]["avx2_fma"] for r in runs)
    fp, version = trial_platform(out, 0, 0, 0)
    assert fp == runs[0]["platform"] and version == runs[0]["version"]


def test_a_schema_1_session_is_listed_as_not_recorded(tmp_path):
    study, cells = _study(tmp_path)
    from tests.study.test_run import fake_trials

    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    con = sqlite3.connect(tmp_path / "study.sqlite")
    with con:
        con.execute("UPDATE runs SET platform=NULL")
        con.execute("UPDATE trials SET run_id=NULL WHERE cell=1")
    con.close()
    plats = load_platforms(tmp_path)
    assert list(plats["platform"]) == [describe(None)] and list(plats["trials"]) == [24]
    assert "All trials ran on one platform" in build_report(tmp_path).markdown


@pytest.mark.timeout(300)
def test_replay_says_when_the_trial_came_from_another_platform(tmp_path, write_tiny_study):
    study, cells = load_study(write_tiny_study(tmp_path, name="replay-test", root_seed=3, terrains=1, missions=1))
    out = tmp_path / "run"
    run_study(study, cells, out, executor="inline")

    def replay() -> subprocess.CompletedProcess:
        return subprocess.run([*CLI, "study", "replay", str(out), "--cell", "0", "--terrain", "0", "--mission", "0"],
                              capture_output=True, text=True, timeout=240, check=False)

    r = replay()
    assert r.returncode == 0, r.stderr
    assert "identical to the stored row: yes" in r.stdout and "platform" not in r.stdout
    here = platform_fingerprint()
    if not (here["arch"] == "x86_64" and here["avx2_fma"]):
        pytest.skip("the cross-CPU promise covers x86-64 CPUs with AVX2 and FMA only")
    elsewhere = {**here, "cpu": "Some Other CPU", "numpy_dispatch": ["X86_V3"]}
    con = sqlite3.connect(out / "study.sqlite")
    with con:
        con.execute("UPDATE runs SET platform=?", (json.dumps(elsewhere),))
    r = replay()
    assert r.returncode == 0, r.stderr
    assert "ran on another platform (Some Other CPU" in r.stdout
    assert "bit-identity with it is promised here: quantised terrain and the same versions" in r.stdout
    elsewhere["versions"] = {**here["versions"], "pybullet": "1.0"}
    with con:
        con.execute("UPDATE runs SET platform=?", (json.dumps(elsewhere),))
    con.close()
    r = replay()
    assert "bit-identity with it is not promised here: other versions (pybullet 1.0" in r.stdout
