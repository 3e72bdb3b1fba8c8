"""Every run ends (issue 23, Deliver 5): a per-trial wall-clock limit for the local executor, with
a default from the trials' nominal time."""

from __future__ import annotations

import copy
import multiprocessing
import time

import pytest

from offroadbench.errors import InputError, StudyError
from offroadbench.study import load, load_meta, run_study, study_from_dict
from offroadbench.study.runner import TRIAL_LIMIT_BASE_S, default_trial_timeout_s
from offroadbench.study.spec import plan_cells

from tests.study.test_run import STUDY, fake_trials


def hangs_on(cell: int, mission: int):
    def trials(hm, missions, plan):
        for row in fake_trials(hm, missions, plan):
            if plan.index == cell and row["mission_index"] == mission:
                time.sleep(600)  # a plug-in that never returns
            yield row

    return trials


def study_and_cells():
    study = study_from_dict(copy.deepcopy(STUDY))
    return study, plan_cells(study)


def test_a_hung_trial_stops_a_local_study_in_one_line_and_keeps_the_rest(tmp_path):
    study, cells = study_and_cells()
    t0 = time.monotonic()
    with pytest.raises(StudyError, match=r"cell 1, terrain 0: a trial \(or the terrain build\) ran longer than 3 s"):
        run_study(study, cells, tmp_path, executor="local", workers=2, trial_fn=hangs_on(1, 2),
                  executor_options={"trial_timeout_s": 3})
    assert time.monotonic() - t0 < 120
    assert multiprocessing.active_children() == []
    stored = load(tmp_path)
    assert 0 < len(stored) < study.n_trials
    assert not ((stored["cell"] == 1) & (stored["terrain"] == 0) & (stored["mission"] == 2)).any()
    session = load_meta(tmp_path)["runs"][0]
    assert session["status"] == "failed" and "ran longer than 3 s" in session["error"]
    resumed = run_study(study, cells, tmp_path, executor="local", workers=2, trial_fn=fake_trials)
    assert resumed.done == study.n_trials


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
