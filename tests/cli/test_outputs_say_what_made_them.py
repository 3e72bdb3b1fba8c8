"""Every output says what made it, and one flag grammar (issue 33, items 1-8)."""

from __future__ import annotations

import json
import logging
import math
import tomllib

import pytest
from PIL import Image

from offroadbench.cli import build_parser, main
from offroadbench.cli._common import count_text, medians_text, plot_path, sets_text

SMALL = ["--set", "grid.rows=81", "--set", "grid.cols=81"]


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_overrides_are_in_the_label_and_the_sidecar(tmp_path, capsys):
    png = tmp_path / "t.png"
    code, out, err = run(capsys, "generate", "paper-d2.45", "-o", str(png), "--set", "layers.base.D_high=2.6", *SMALL)
    assert code == 0, err
    label = "paper-d2.45 + layers.base.D_high=2.6, grid.rows=81, grid.cols=81 seed 0"
    assert out.startswith(label + ":")
    side = json.loads((tmp_path / "t.json").read_text())
    assert side["recipe_name"] == "paper-d2.45" and side["label"] == label
    assert side["overrides"] == {"layers.base.D_high": 2.6, "grid.rows": 81, "grid.cols": 81}
    # a command reading the PNG names what generate made
    code, out, err = run(capsys, "analyze", str(png), "--border-m", "0.5")
    assert code == 0, err
    assert out.startswith(f"t ({label}):")
    # a preset without overrides keeps its plain name
    code, out, err = run(capsys, "analyze", "paper-d2.45", "--border-m", "0.5", "--set", "grid.rows=81",
                         "--set", "grid.cols=81")
    assert "paper-d2.45 + grid.rows=81, grid.cols=81 seed 0" in out
    assert sets_text({}) == "" and sets_text({"a.b": "x", "c": True}) == "a.b=x, c=true"


def test_generate_takes_the_clip_the_spire_warning_names(tmp_path, capsys, caplog):
    png = tmp_path / "t.png"
    grid = ["--set", "grid.rows=257", "--set", "grid.cols=257"]
    with caplog.at_level(logging.WARNING):
        code, _, err = run(capsys, "generate", "paper-d2.45", "-o", str(png), *grid)
    assert code == 0, err
    warned = [r.getMessage() for r in caplog.records if "narrow spike" in r.getMessage()]
    assert warned and "--clip-percentile P" in warned[0]  # generate has the option it names
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        code, out, err = run(capsys, "generate", "paper-d2.45", "-o", str(png), "--clip-percentile", "0.1", *grid)
    assert code == 0, err
    assert "clipped to the 0.1..99.9 percentiles" in out
    side = json.loads((tmp_path / "t.json").read_text())
    assert side["clip_percentile"] == 0.1 and side["relief_m"] < 0.5 * 3.84  # the spire is gone
    assert not [r for r in caplog.records if "narrow spike" in r.getMessage()]
    assert run(capsys, "generate", "paper-d2.45", "-o", str(png), "--clip-percentile", "50", *grid)[0] == 2


def test_drive_names_an_option_that_exists():
    from offroadbench.cli.terrain import CLIP_ELSEWHERE

    assert "offroadbench generate" in CLIP_ELSEWHERE and "--clip-percentile" in CLIP_ELSEWHERE
    drive = build_parser().parse_args(["drive", "x.png"])
    assert not hasattr(drive, "clip_percentile")  # so drive's warning points at generate
    gen = build_parser().parse_args(["generate", "paper-d2.45", "-o", "x.png", "--clip-percentile", "0.1"])
    assert gen.clip_percentile == 0.1


@pytest.mark.parametrize("argv", [
    ["drive", "t.png", "--out", "d"],
    ["study", "replay", "run", "--cell", "0", "--terrain", "0", "--mission", "0"],
    ["analyze", "t.png"],
    ["soil", "check", "lunar-regolith"],
    ["roughness-study"],
])
def test_plot_takes_an_optional_path_everywhere(argv):
    parser = build_parser()
    assert parser.parse_args([*argv, "--plot"]).plot is True
    assert parser.parse_args([*argv, "--plot", "f.png"]).plot == "f.png"
    assert parser.parse_args(argv).plot is None


def test_plot_path(tmp_path):
    assert plot_path(None, tmp_path / "a.png") is None
    assert plot_path(True, tmp_path / "a.png") == tmp_path / "a.png"
    assert plot_path(str(tmp_path / "b.svg"), tmp_path / "a.png") == tmp_path / "b.svg"
    from offroadbench.errors import InputError

    with pytest.raises(InputError, match="--plot"):
        plot_path(str(tmp_path / "b.txt"), tmp_path / "a.png")


def test_bare_plot_of_analyze_writes_beside(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "analyze", "paper-d2.45", "--border-m", "0.5", "--plot", *SMALL)
    assert code == 0, err
    for name in ("paper-d2.45_seed0_classes.png", "paper-d2.45_seed0_classes_surface.png"):
        with Image.open(tmp_path / name) as img:
            assert img.size[0] > 300


def test_config_shows_grid_and_recipe_overrides(capsys):
    from offroadbench.study import study_from_dict
    from offroadbench.study.spec.config import plan_cells

    code, out, _ = run(capsys, "config")
    assert code == 0
    assert "\n[grid]\n" in out and "\n[recipe_overrides]\n" in out
    # the examples, uncommented, make a study that loads
    text = out.replace('# "recipe.layers.base.D_high" = ', '"recipe.layers.base.D_high" = ').replace(
        '# "grid.rows" = 257', '"grid.rows" = 257')
    data = tomllib.loads(text)
    assert data["grid"] == {"recipe.layers.base.D_high": [2.3, 2.45, 2.6]} and data["recipe_overrides"] == {"grid.rows": 257}
    study = study_from_dict(data)
    assert len(plan_cells(study)) == 3
    code, out, _ = run(capsys, "config", "grid")
    assert code == 0 and out.startswith("[grid]\n") and "[sim]" not in out
    assert tomllib.loads(out) == {"grid": {}}
    code, out, _ = run(capsys, "config", "recipe_overrides")
    assert code == 0 and tomllib.loads(out) == {"recipe_overrides": {}}


def test_drive_summary_words():
    from offroadbench.cli._common import run_caption
    from offroadbench.sim import SimConfig

    assert run_caption(SimConfig(gravity_m_s2=1.62)) == "pybullet, g = 1.62 m/s^2"  # in drive's figure titles
    assert count_text(1, "mission") == "1 mission" and count_text(3, "mission") == "3 missions"
    none = {"successes": 0, "trials": 2, "median_traversal_time_s": math.nan}
    assert "nan" not in medians_text(none) and "no trial succeeded" in medians_text(none)
    some = {"successes": 1, "median_traversal_time_s": 12.5, "median_rms_roll_rate_deg_s": math.nan}
    assert medians_text(some) == "medians of successful trials:\n  traversal_time_s 12.500"


def test_analyze_says_when_d_from_the_psd_does_not_hold(capsys):
    code, out, err = run(capsys, "analyze", "lunar-mare", "--border-m", "0.5", "--set", "grid.rows=201",
                         "--set", "grid.cols=201")
    assert code == 0, err
    assert "caveat: D = 4 - beta/2 holds for a self-affine" in out and "craters" in out
    code, out, err = run(capsys, "analyze", "paper-d2.45", "--border-m", "0.5", *SMALL)
    d = float(out.split("-> D = ")[1].split()[0])
    assert ("caveat" in out) == (not 2 < d < 3)


def test_the_rules_row_states_the_capped_stuck_window():
    from offroadbench.navigation.rules import FailureRules, stuck_window_s, trial_timeout_s
    from offroadbench.study.report.header import stuck_window_text
    from offroadbench.study.spec.config import build_section

    secs = {name: build_section(name, table, where="test") for name, table in
            (("missions", {"length_m": 6.0}), ("controller", {}), ("vehicle", {"name": "husky"}))}
    rules = FailureRules()
    timeout = trial_timeout_s(rules, 6.0, secs["controller"].cruise_speed_m_s, secs["vehicle"].max_speed_m_s)
    window = stuck_window_s(rules, timeout)
    assert window < 30.0
    text = stuck_window_text(rules, secs)
    assert text.startswith(f"{window:.3g} s (30 s capped at 0.5 x the {timeout:.3g} s timeout of a 6 m mission)")
    secs["missions"] = build_section("missions", {"length_m": 35.0}, where="test")
    assert stuck_window_text(rules, secs) == "30 s"  # the paper's missions keep the paper's window


def test_exported_rows_carry_the_fixed_settings(tmp_path, capsys):
    import pandas as pd

    from offroadbench.study import run_study, study_from_dict
    from offroadbench.study.spec.config import plan_cells
    from tests.study.test_run import STUDY, fake_trials

    study = study_from_dict({**STUDY, "sim": {"gravity_m_s2": 1.62}})
    run_dir = tmp_path / "run"
    run_study(study, plan_cells(study), run_dir, executor="inline", trial_fn=fake_trials)
    code, _, err = run(capsys, "study", "export", str(run_dir), "--format", "csv", "--out", str(tmp_path / "x"))
    assert code == 0, err
    rows = pd.read_csv(tmp_path / "x" / "trials.csv")
    assert len(rows) == 24 and set(rows["D_high"]) == {2.3, 2.6}  # the grid axis, as before
    assert (rows["sim.gravity_m_s2"] == 1.62).all() and (rows["vehicle.name"] == "husky").all()
    assert (rows["planner.name"] == "straight").all() and (rows["sim.engine"] == "pybullet").all()
    assert (rows["missions.length_m"] == 3.0).all()
    assert rows["recipe"].iloc[0] == "paper-d2.45 with grid.cols = 121, grid.rows = 121"  # as stored (sorted)
    assert rows["rules"].iloc[0].startswith("tipped > 75 deg; stuck < 0.2 m in ")
    assert not [c for c in rows.columns if c.startswith("recipe.layers")]  # an axis is not repeated


def test_the_model_file_that_drove_is_recorded(tmp_path):
    import dataclasses
    import hashlib

    from offroadbench.navigation.drivers import PlannerChoice
    from offroadbench.study.report.header import files_rows, driver_files

    @dataclasses.dataclass(frozen=True)
    class ModelConfig:
        model: str = ""
        algorithm: str = "PPO"

    model = tmp_path / "ppo.zip"
    model.write_bytes(b"weights" * 100)
    files = driver_files(PlannerChoice("sb3", ModelConfig(model=str(model)), "policy"))
    assert files == {"planner.model": {"path": str(model.resolve()), "bytes": 700,
                                       "sha256": hashlib.sha256(b"weights" * 100).hexdigest()}}
    assert driver_files(PlannerChoice("straight")) == {}
    assert driver_files(PlannerChoice("sb3", ModelConfig(model=str(tmp_path / "gone.zip")), "policy")) == {}
    meta = {"cells": [{"index": 0, "files": {}}, {"index": 1, "files": files}]}
    (row,) = files_rows(meta)
    assert row["setting"] == "planner.model (file)" and row["note"] == "cells 1"
    assert str(model.resolve()) in row["value"] and files["planner.model"]["sha256"][:16] in row["value"]
