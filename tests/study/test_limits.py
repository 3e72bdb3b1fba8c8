"""Every run ends (issue 23, Deliver 5): a per-trial wall-clock limit for the local executor, with
a default from the trials' nominal time."""

from __future__ import annotations

import copy
import multiprocessing
import time

import pytest

from offroadbench.errors import InputError
from offroadbench.study import load, load_meta, run_study, study_from_dict
from offroadbench.study.runner import TRIAL_LIMIT_BASE_S, default_trial_timeout_s
from offroadbench.study.spec.config import plan_cells

from tests.study.test_run import STUDY, fake_trials


def hangs_on(mission: int):
    def trials(prepared, settings):
        for row in fake_trials(prepared, settings):
            if row["mission_index"] == mission:
                time.sleep(600)  # a plug-in that never returns
            yield row

    return trials


def study_and_cells():
    study = study_from_dict(copy.deepcopy(STUDY))
    return study, plan_cells(study)


def test_a_hung_trial_is_a_fault_and_the_local_study_goes_on(tmp_path):
    """Issue 30 (Deliver 2): a trial past its limit is stored as a fault, its worker replaced, and
    every other trial runs; no statistic sees the fault; a resume skips it unless asked."""
    study, cells = study_and_cells()
    t0 = time.monotonic()
    summary = run_study(study, cells, tmp_path, executor="local", workers=2, trial_fn=hangs_on(2),
                        executor_options={"trial_timeout_s": 3})
    assert time.monotonic() - t0 < 120
    assert multiprocessing.active_children() == []
    n_faults = study.n_cells * study.terrains_per_cell  # mission 2 of every terrain hangs
    assert (summary.done, summary.faults) == (study.n_trials - n_faults, n_faults) and summary.complete
    stored = load(tmp_path)
    assert len(stored) == study.n_trials - n_faults and not (stored["mission"] == 2).any()
    session = load_meta(tmp_path)["runs"][0]
    assert session["status"] == "finished"
    assert run_study(study, cells, tmp_path, executor="local", workers=2, trial_fn=fake_trials).ran == 0
    resumed = run_study(study, cells, tmp_path, executor="local", workers=2, trial_fn=fake_trials, retry_faults=True)
    assert (resumed.done, resumed.faults, resumed.ran) == (study.n_trials, 0, n_faults)


def test_the_default_limit_follows_the_nominal_time():
    study, cells = study_and_cells()
    limit = default_trial_timeout_s(cells)
    # 3 m missions at 1 m/s, timeout factor 3, path allowance 3: 27 simulated s at RTF 0.1
    assert limit == pytest.approx(TRIAL_LIMIT_BASE_S + 10 * 27 + 20e-6 * 121 * 121)
    longer = copy.deepcopy(STUDY)
    longer["missions"]["length_m"] = 4.0
    study2 = study_from_dict(longer)
    assert default_trial_timeout_s(plan_cells(study2)) > limit


def test_a_bad_limit_is_refused(tmp_path):
    study, cells = study_and_cells()
    with pytest.raises(InputError, match="trial_timeout_s"):
        run_study(study, cells, tmp_path, executor="local", trial_fn=fake_trials, executor_options={"trial_timeout_s": 0})


# ---------------------------------------------------------------------------- study size
def test_a_huge_grid_or_mission_is_refused_with_the_estimate_before_any_work(tmp_path):
    import subprocess
    import sys

    from offroadbench.study.runner import MAX_CELLS, check_study_size, estimate_study

    huge = copy.deepcopy(STUDY)
    huge["grid"] = {"missions.length_m": [3.0 + 1e-6 * i for i in range(MAX_CELLS + 1)]}
    study = study_from_dict(huge)
    est = estimate_study(study)
    assert est.cells == MAX_CELLS + 1 and est.trials == 12 * (MAX_CELLS + 1)
    with pytest.raises(InputError, match=rf"{MAX_CELLS + 1} grid cell\(s\), {12 * (MAX_CELLS + 1)} trial\(s\).*--force"):
        check_study_size(study)
    assert check_study_size(study, force=True) == est
    far = copy.deepcopy(STUDY)
    far["missions"]["length_m"] = 1e7  # 10^7 s of driving per trial
    with pytest.raises(InputError, match="CPU-hours"):
        check_study_size(study_from_dict(far))
    ok, _ = study_and_cells()
    assert estimate_study(ok).cpu_s < 3600

    path = tmp_path / "huge.toml"
    values = ", ".join(repr(3.0 + 1e-6 * i) for i in range(200_000))
    path.write_text(f'[study]\nname = "huge"\nrecipe = "paper-d2.45"\nroot_seed = 1\nterrains_per_cell = 1\n'
                    f'missions_per_terrain = 1\n[grid]\n"missions.length_m" = [{values}]\n')
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-c", "import sys; from offroadbench.cli import main; sys.exit(main())",
                        "study", "run", str(path), "--out", str(tmp_path / "run")],
                       capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "200000 grid cell(s)" in r.stderr, r.stderr
    assert time.monotonic() - t0 < 120
    assert not (tmp_path / "run").exists()


def test_a_limit_below_the_shortest_possible_trial_is_refused_saying_why():
    """Issue 44: a limit no trial can meet (every trial a fault) is refused, with the floor's derivation."""
    from offroadbench.study.execution.common import MAX_STEPS_PER_S, check_trial_floor, shortest_trial_s

    data = copy.deepcopy(STUDY)
    data["grid"] = {"missions.length_m": [3.0, 2.0]}
    data["sim"] = {"settle_time_s": 0.5, "physics_rate_hz": 120}
    data["controller"] = {"cruise_speed_m_s": 0.5}
    cells = plan_cells(study_from_dict(data))
    floor, how = shortest_trial_s(cells)
    # the shorter cell: (0.5 s settling + 2 m at 0.5 m/s) x 120 Hz = 540 steps
    assert floor == pytest.approx(540 / MAX_STEPS_PER_S)
    assert "(0.5 s)" in how and "2 m at 0.5 m/s" in how and "540 physics steps at 120 Hz" in how
    for value in (1e-9, 0.001, 0.9 * floor):
        with pytest.raises(InputError, match=r"^--trial-timeout-s .* is below this study's shortest possible trial, "
                                             r"0.0054 s: a trial that reaches its goal"):
            check_trial_floor(value, cells)
    check_trial_floor(floor, cells)
    check_trial_floor(None, cells)
