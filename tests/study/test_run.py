"""Runner, store, resumption and report with a cheap stand-in for the physics (issue 4, items 2-5)."""

from __future__ import annotations

import copy
import os
import sqlite3

import numpy as np
import pandas as pd
import pytest

from offroadbench.errors import InputError
from offroadbench.study import load, load_meta, load_terrains, run_study, study_from_dict
from offroadbench.study.spec.config import plan_cells
from offroadbench.study.execution.executors import StudyError
from offroadbench.study.report.markdown import build_report
from offroadbench.study.stats.terrain import box_stats, median_changes
from offroadbench.study.store.store import Store

STUDY = {
    "study": {"name": "fake", "recipe": "paper-d2.45", "root_seed": 5, "terrains_per_cell": 3, "missions_per_terrain": 4},
    "grid": {"recipe.layers.base.D_high": [2.3, 2.6]},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5},
}


def fake_trials(prepared, settings):
    """A deterministic stand-in for a trial: a pure function of the terrain along the mission line."""
    hm = prepared.hm
    for m in prepared.missions:
        (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
        t = np.linspace(0.0, 1.0, 61)
        z = hm.height_at(sx + t * (gx - sx), sy + t * (gy - sy))
        slope = np.abs(np.diff(z)) / (m.length_m / 60)
        ok = bool(slope.max() < 0.6)
        yield {
            "mission_index": m.index, "success": ok, "failure_reason": "" if ok else "stuck",
            "traversal_time_s": m.length_m + 10 * float(slope.mean()) if ok else float("nan"),
            "rms_vertical_accel_m_s2": float(np.sqrt(np.mean(np.diff(z, 2) ** 2))) * 100,
            "rms_pitch_rate_deg_s": float(np.degrees(slope.mean())) * 5,
            "rms_roll_rate_deg_s": float(z.std()) * 50,
            "start_x_m": sx, "start_y_m": sy, "goal_x_m": gx, "goal_y_m": gy,
        }


def failing_after(limit):
    """fake_trials that raises on terrain 1's mission 2 (a crash in the middle of a study)."""

    def trials(prepared, settings):
        for row in fake_trials(prepared, settings):
            if row["mission_index"] == 2 and limit["armed"]:
                raise RuntimeError("simulated crash")
            yield row

    return trials


def study_and_cells(**changes):
    data = copy.deepcopy(STUDY)
    data["study"].update(changes)
    study = study_from_dict(data)
    return study, plan_cells(study)


def test_run_stores_one_tidy_row_per_trial(tmp_path):
    study, cells = study_and_cells()
    summary = run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    assert (summary.total, summary.done, summary.ran) == (24, 24, 24)
    df = load(tmp_path)
    assert len(df) == 24
    assert not df.duplicated(["cell", "terrain", "mission"]).any()
    assert list(df.columns[:6]) == ["cell", "D_high", "terrain", "mission", "terrain_seed", "mission_seed"]
    assert set(df["D_high"]) == {2.3, 2.6}
    assert summary.successes == int(df["success"].sum())
    terrains = load_terrains(tmp_path)
    assert len(terrains) == 6
    fractions = terrains[["area_low", "area_semi", "area_high"]].sum(axis=1)
    assert np.allclose(fractions, 1.0)
    # paired terrains: terrain j has the same seed for both D values, and a rougher D never has
    # more low-roughness area on the same seeds (only the high-frequency layer's D differs)
    pivot = terrains.pivot(index="terrain", columns="D_high", values="area_low")
    assert (pivot[2.6] <= pivot[2.3] + 1e-12).all()
    meta = load_meta(tmp_path)
    assert meta["study"]["root_seed"] == 5 and meta["version"]
    assert meta["runs"][0]["status"] == "finished" and meta["runs"][0]["trials_run"] == 24


def test_rerun_skips_finished_trials(tmp_path):
    study, cells = study_and_cells()
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    before = load(tmp_path)
    again = run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    assert again.ran == 0 and again.done == 24
    pd.testing.assert_frame_equal(load(tmp_path), before)


def test_a_crash_keeps_finished_trials_and_the_resume_equals_an_uninterrupted_run(tmp_path):
    study, cells = study_and_cells()
    flag = {"armed": True}
    with pytest.raises(StudyError, match="simulated crash"):
        run_study(study, cells, tmp_path / "a", executor="local", workers=2, trial_fn=failing_after(flag))
    partial = load(tmp_path / "a")
    assert 0 < len(partial) < 24
    assert not (partial["mission"] == 2).any()
    assert load_meta(tmp_path / "a")["runs"][0]["status"] == "failed"
    flag["armed"] = False
    resumed = run_study(study, cells, tmp_path / "a", executor="local", workers=2, trial_fn=failing_after(flag))
    assert resumed.ran == 24 - len(partial)
    run_study(study, cells, tmp_path / "b", executor="inline", trial_fn=fake_trials)
    pd.testing.assert_frame_equal(load(tmp_path / "a"), load(tmp_path / "b"))
    pd.testing.assert_frame_equal(load_terrains(tmp_path / "a"), load_terrains(tmp_path / "b"))


def test_worker_count_and_executor_do_not_change_the_table(tmp_path):
    study, cells = study_and_cells()
    frames = []
    for name, workers in (("inline", 1), ("local", 1), ("local", 2)):
        out = tmp_path / f"{name}{workers}"
        run_study(study, cells, out, executor=name, workers=workers, trial_fn=fake_trials)
        frames.append(load(out))
    for other in frames[1:]:
        pd.testing.assert_frame_equal(frames[0], other)


def test_a_store_refuses_another_study(tmp_path):
    study, cells = study_and_cells()
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    other, other_cells = study_and_cells(root_seed=6)
    with pytest.raises(InputError, match="another study"):
        run_study(other, other_cells, tmp_path, executor="inline", trial_fn=fake_trials)


def test_store_never_holds_a_trial_twice(tmp_path):
    with Store(tmp_path, create=True) as store:
        row = {"mission_index": 0, "success": True, "x": 1.0}
        assert store.add_trial(0, 0, 0, 1, 2, row)
        assert not store.add_trial(0, 0, 0, 1, 2, row)
        assert store.counts() == (1, 1)
    con = sqlite3.connect(tmp_path / "study.sqlite")
    assert con.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    with pytest.raises(sqlite3.IntegrityError):
        con.execute("INSERT INTO trials (cell, terrain, mission, terrain_seed, mission_seed, success, row) VALUES (0, 0, 0, 1, 2, 1, '{}')")


def test_unknown_executor_and_bad_worker_count_are_refused(tmp_path):
    study, cells = study_and_cells()
    with pytest.raises(InputError, match="inline, dask|local"):
        run_study(study, cells, tmp_path, executor="slurm", trial_fn=fake_trials)
    with pytest.raises(InputError, match="workers"):
        run_study(study, cells, tmp_path, executor="local", workers=0, trial_fn=fake_trials)


def test_box_stats_follow_eq_6_to_8():
    x = [1, 2, 3, 4, 5, 6, 7, 8, 100]
    s = box_stats(x)
    q1, q3 = np.percentile(x, [25, 75], method="hazen")
    assert s["median"] == 5 and s["q1"] == q1 and s["q3"] == q3
    assert s["iqr"] == pytest.approx(q3 - q1)
    assert s["upper_fence"] == pytest.approx(q3 + 1.5 * (q3 - q1))
    assert s["n_outliers"] == 1 and list(s["fliers"]) == [100]
    assert s["whishi"] == 8 and s["whislo"] == 1
    assert box_stats([np.nan])["n"] == 0


def test_median_changes():
    summary = pd.DataFrame({"group": ["a", "b", "c"], "median_v": [2.0, 3.0, 1.5]})
    ch = median_changes(summary, ["v"])
    assert list(ch["change"]) == [1.0, -1.5]
    assert list(ch["change_pct"]) == [50.0, -50.0]


def test_report_tables_agree_with_the_trial_table(tmp_path):
    study, cells = study_and_cells()
    data = copy.deepcopy(STUDY)
    data["reference"] = {"source": "test", "trials": [12, 12], "successes": [11, 5],
                         "median_change": {"rms_roll_rate_deg_s": [[1.0, 10.0]]}}
    study = study_from_dict(data)
    run_study(study, plan_cells(study), tmp_path, executor="inline", trial_fn=fake_trials)
    report = build_report(tmp_path)
    df = load(tmp_path)
    summary = report.tables["summary.csv"]
    for cell in (0, 1):
        ok = df[(df["cell"] == cell) & df["success"]]
        row = summary[summary["cell"] == cell].iloc[0]
        assert row["successes"] == len(ok) and row["trials"] == 12
        assert row["median_rms_roll_rate_deg_s"] == pytest.approx(np.median(ok["rms_roll_rate_deg_s"]))
        rates = df[df["cell"] == cell].groupby("terrain")["success"].mean() * 100
        assert row["median_success_rate_pct"] == pytest.approx(np.median(rates))
    failures = report.tables["failures.csv"]
    assert failures[["success", "stuck"]].to_numpy().sum() == 24
    for name in ("fig4_missions.png", "fig5_class_areas.png", "fig6_success_rate.png", "fig7_traversal_metrics.png"):
        assert name in report.figures
    assert "Side by side" in report.markdown and "11 / 12" in report.markdown
    ref = report.tables["reference_median_changes.csv"]
    assert ref.loc[0, "ours change"] == pytest.approx(
        summary["median_rms_roll_rate_deg_s"].iloc[1] - summary["median_rms_roll_rate_deg_s"].iloc[0]
    )


def test_workers_leave_no_processes_behind(tmp_path):
    study, cells = study_and_cells()
    run_study(study, cells, tmp_path, executor="local", workers=2, trial_fn=fake_trials)
    import multiprocessing

    assert multiprocessing.active_children() == []
    assert os.getpid() > 0
