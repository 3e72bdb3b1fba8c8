"""A study's store keeps each cell's resolved TrialSettings, and the report reads them from there:
equal to what the study resolves, read without building any table again; a store made before the
settings were kept still reports, resumes and is not refused."""

from __future__ import annotations

import copy
import json
import sqlite3
from pathlib import Path

import pandas as pd
import pytest

from offroadbench.errors import InputError
from offroadbench.sim.trial import settings as settings_module
from offroadbench.sim.trial.pipeline import TrialSettings
from offroadbench.study import run_study, spec, study_from_dict
from offroadbench.study.report.markdown import build_report
from offroadbench.study.store.results import load, load_meta
from offroadbench.study.spec.config import CellPlan, plan_cells

ROOT = Path(__file__).resolve().parents[2]

STUDY = {
    "study": {"name": "kept-settings", "recipe": "paper-d2.45", "root_seed": 3, "terrains_per_cell": 1,
              "missions_per_terrain": 2},
    "grid": {"recipe.layers.base.D_high": [2.3, 2.6], "rules.stuck_distance_m": [0.2, 0.3]},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5},
    "planner": {"name": "astar", "grid_m": 0.5},
    "sim": {"gravity_m_s2": 1.62, "physics_rate_hz": 120},
    "controller": {"cruise_speed_m_s": 0.8},
}


def fake_trials(prepared, settings):
    """A stand-in for the physics: the row depends on the mission and on the settings it was given."""
    for m in prepared.missions:
        ok = m.index != 1
        yield {"mission_index": m.index, "success": ok, "failure_reason": "" if ok else "stuck",
               "traversal_time_s": m.length_m / settings.controller.cruise_speed_m_s if ok else float("nan"),
               "rms_vertical_accel_m_s2": settings.rules.stuck_distance_m, "rms_pitch_rate_deg_s": 1.0 + m.index,
               "rms_roll_rate_deg_s": 2.0, "start_x_m": m.start_xy_m[0], "start_y_m": m.start_xy_m[1],
               "goal_x_m": m.goal_xy_m[0], "goal_y_m": m.goal_xy_m[1]}


def _study():
    study = study_from_dict(copy.deepcopy(STUDY))
    return study, plan_cells(study)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    study, cells = _study()
    run_study(study, cells, out, executor="inline", trial_fn=fake_trials)
    return out


def _forget_settings(run_dir) -> None:
    """Make the store look like one written before the settings were kept (its cells without them)."""
    con = sqlite3.connect(run_dir / "study.sqlite")
    (text,) = con.execute("SELECT value FROM meta WHERE key='cells'").fetchone()
    cells = json.loads(text)
    for c in cells:
        del c["trial_settings"]
    con.execute("UPDATE meta SET value=? WHERE key='cells'", (json.dumps(cells, sort_keys=True),))
    con.commit()
    con.close()


def _count_builds(monkeypatch) -> dict:
    """Count every build of settings from tables (the study's tables, a vehicle file, a default)."""
    calls = {"n": 0}
    for owner, name in ((spec, "build_section"), (settings_module, "load_vehicle")):
        real = getattr(owner, name)

        def counted(*args, _real=real, **kwargs):
            calls["n"] += 1
            return _real(*args, **kwargs)

        monkeypatch.setattr(owner, name, counted)
    real_tables = TrialSettings.from_tables.__func__

    def tables(cls, *args, **kwargs):
        calls["n"] += 1
        return real_tables(cls, *args, **kwargs)

    monkeypatch.setattr(TrialSettings, "from_tables", classmethod(tables))
    return calls


def test_the_store_keeps_the_settings_the_study_resolves(run):
    _, cells = _study()
    meta = load_meta(run)
    assert len(meta["cells"]) == len(cells) == 4
    for plan in cells:
        kept = meta["cells"][plan.index]["trial_settings"]
        assert TrialSettings.from_dict(kept) == plan.trial_settings
        assert CellPlan.from_meta(meta, plan.index).trial_settings == plan.trial_settings
    # the grid axis and the study's own tables are in the stored form as the cells ran them
    assert [c["trial_settings"]["rules"]["stuck_distance_m"] for c in meta["cells"]] == [0.2, 0.3, 0.2, 0.3]
    first = meta["cells"][0]["trial_settings"]
    assert first["sim"]["gravity_m_s2"] == 1.62 and first["sim"]["physics_rate_hz"] == 120
    assert first["planner"]["name"] == "astar" and first["planner"]["config"]["grid_m"] == 0.5
    assert first["vehicle"]["name"] == "husky" and first["vehicle"]["wheel_radius_m"] > 0


def test_stored_settings_read_back_equal_for_every_committed_study():
    for name in ("vehicle-planner", "lunar-soil", "engines"):  # policies, the mast sensor, soils, MuJoCo
        path = ROOT / "experiments" / f"{name}.toml"
        _, cells = spec.load_study(path)
        for plan in cells:
            text = json.dumps(plan.trial_settings.to_dict(), sort_keys=True)  # as the store writes it
            assert TrialSettings.from_dict(json.loads(text)) == plan.trial_settings, (path, plan.index)


def test_a_report_reads_the_settings_from_the_store_and_builds_none(run, monkeypatch):
    want = build_report(run)
    calls = _count_builds(monkeypatch)
    got = build_report(run)
    assert calls["n"] == 0
    assert got.markdown == want.markdown
    pd.testing.assert_frame_equal(got.tables["held_fixed.csv"], want.tables["held_fixed.csv"])
    fixed = got.tables["held_fixed.csv"].set_index("setting")
    assert fixed.loc["gravity (m/s^2)", "value"] == "1.62" and fixed.loc["physics rate (Hz)", "value"] == "120"
    assert fixed.loc["cruise speed (m/s)", "value"] == "0.8" and fixed.loc["planner", "value"] == "astar"


def test_a_store_made_before_the_settings_were_kept_reports_and_resumes(tmp_path, monkeypatch):
    study, cells = _study()
    run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    want = build_report(tmp_path)
    rows = load(tmp_path)
    _forget_settings(tmp_path)
    assert all("trial_settings" not in c for c in load_meta(tmp_path)["cells"])
    calls = _count_builds(monkeypatch)
    got = build_report(tmp_path)
    assert calls["n"] > 0  # rebuilt from the tables, the one fallback
    assert got.markdown == want.markdown
    pd.testing.assert_frame_equal(got.tables["held_fixed.csv"], want.tables["held_fixed.csv"])
    # a resume is not refused (the fingerprint of issue 30 is unchanged) and runs what is missing
    con = sqlite3.connect(tmp_path / "study.sqlite")
    con.execute("DELETE FROM trials WHERE cell=3 AND mission=1")
    con.commit()
    con.close()
    again = run_study(study, cells, tmp_path, executor="inline", trial_fn=fake_trials)
    assert again.ran == 1
    pd.testing.assert_frame_equal(load(tmp_path), rows)


def test_stored_settings_whose_vehicle_model_is_not_here_are_built_from_the_tables(run):
    _, cells = _study()
    meta = copy.deepcopy(load_meta(run))
    meta["cells"][1]["trial_settings"]["vehicle"]["urdf"] = "/nonexistent/elsewhere/husky.urdf"
    meta["cells"][1]["trial_settings"]["rules"]["tip_angle_deg"] = 12.0  # not read: the tables are
    plan = CellPlan.from_meta(meta, 1)
    assert plan.trial_settings == cells[1].trial_settings
    assert CellPlan.from_meta(meta, 2).trial_settings == cells[2].trial_settings


def test_stored_settings_with_a_missing_part_are_refused_by_name():
    kept = TrialSettings().to_dict()
    del kept["rules"]
    with pytest.raises(InputError, match="rules"):
        TrialSettings.from_dict(kept)
    kept = TrialSettings().to_dict()
    kept["rules"]["tip_angle_deg"] = 500.0
    with pytest.raises(InputError, match="tip_angle_deg"):
        TrialSettings.from_dict(kept)
    assert TrialSettings.from_dict(TrialSettings().to_dict()) == TrialSettings()
