"""One grammar for the CLI: the spire warning wherever a terrain is generated, each warning once,
the sidecar's CRS kept in a GeoTIFF from a PNG, the seed rule in --help, study export's terrain
table as complete as the report's terrains.csv."""

from __future__ import annotations

import logging

import pandas as pd
import pytest

from offroadbench.cli import build_parser, main

SMALL = ["--set", "grid.rows=201", "--set", "grid.cols=201"]


def _warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]


def test_generate_warns_of_the_corner_spire_once(tmp_path, caplog, capsys):
    with caplog.at_level(logging.WARNING):
        assert main(["generate", "paper-d2.45", *SMALL, "-o", str(tmp_path / "t.png")]) == 0
    spire = [m for m in _warnings(caplog) if "top 0.1 % of samples" in m]
    assert len(spire) == 1 and "--clip-percentile" in spire[0]
    caplog.clear()
    with caplog.at_level(logging.WARNING):  # lunar-mare has no spike: no warning
        assert main(["generate", "lunar-mare", *SMALL, "-o", str(tmp_path / "m.png")]) == 0
    assert not [m for m in _warnings(caplog) if "top 0.1 %" in m]


def test_export_prints_each_warning_once(tmp_path, caplog, capsys):
    with caplog.at_level(logging.WARNING):
        assert main(["export", "paper-d2.45", *SMALL, "--format", "unreal", "-o", str(tmp_path / "e")]) == 0
    out = capsys.readouterr().out
    logged = _warnings(caplog)
    assert sum("top 0.1 %" in m for m in logged) == 1 and "top 0.1 %" not in out
    assert sum("recommended Landscape sizes" in m for m in logged) == 1 and "recommended" not in out


def test_geotiff_from_a_png_keeps_the_sidecar_crs(tmp_path, capsys):
    rasterio = pytest.importorskip("rasterio")
    png = tmp_path / "mare.png"
    assert main(["generate", "lunar-mare", *SMALL, "-o", str(png)]) == 0
    assert main(["export", str(png), "--format", "geotiff", "-o", str(tmp_path / "geo")]) == 0
    with rasterio.open(tmp_path / "geo" / "mare.geo.tif") as ds:
        assert "30110" in str(ds.crs)  # the Moon (IAU 2015) CRS of the lunar-mare recipe


def test_seed_help_states_root_or_terrain_seed():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices
    for name, kind in (("drive", "ROOT seed"), ("roughness-study", "ROOT seed"), ("generate", "OWN seed"),
                       ("analyze", "OWN seed"), ("export", "OWN seed")):
        seed = next(a for a in sub[name]._actions if a.dest == "seed")
        assert kind in seed.help and "terrain_seed(" in seed.help, name


def test_study_export_terrains_carry_trials_and_successes(tmp_path):
    from offroadbench.study import run_study, study_from_dict
    from offroadbench.study.spec.config import plan_cells

    def fake_trials(prepared, settings):  # a stand-in for the physics: success on even missions
        for m in prepared.missions:
            ok = m.index % 2 == 0
            yield {"mission_index": m.index, "success": ok, "failure_reason": "" if ok else "stuck"}

    study = study_from_dict({
        "study": {"name": "fake", "recipe": "paper-d2.45", "root_seed": 5, "terrains_per_cell": 2,
                  "missions_per_terrain": 3},
        "grid": {"recipe.layers.base.D_high": [2.3, 2.6]},
        "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
        "roughness": {"border_m": 0.5},
        "missions": {"length_m": 3.0, "border_m": 0.5},
    })
    run_study(study, plan_cells(study), tmp_path / "run", executor="inline", trial_fn=fake_trials)
    assert main(["study", "export", str(tmp_path / "run"), "--format", "csv", "--out", str(tmp_path / "x")]) == 0
    terrains = pd.read_csv(tmp_path / "x" / "terrains.csv")
    trials = pd.read_csv(tmp_path / "x" / "trials.csv")
    assert {"trials", "successes", "success_rate_pct", "area_low"} <= set(terrains.columns)
    assert list(terrains["trials"]) == [3] * 4 and list(terrains["successes"]) == [2] * 4
    assert terrains["successes"].sum() == trials["success"].sum()
