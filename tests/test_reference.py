"""The settings reference: docs/reference.md is current, complete and true to the configs' checks."""

from __future__ import annotations

import dataclasses
import re
import tomllib
from pathlib import Path

import pytest

from offroadbench import reference
from offroadbench.cli import main
from offroadbench.errors import InputError
from offroadbench.navigation.planners import planner_from_table
from offroadbench.sim.trial.runner import TELEMETRY_COLUMNS, TrialResult
from offroadbench.study.spec.config import _STUDY_KEYS, SECTIONS, plan_cells, study_from_dict

REPO = Path(__file__).resolve().parents[1]
REGENERATE = "offroadbench config --write-reference docs/reference.md"


def test_committed_reference_is_current():
    committed = (REPO / reference.REFERENCE_PATH).read_text(encoding="utf-8")
    assert committed == reference.render_reference(), f"docs/reference.md is stale: run `{REGENERATE}`"


def test_every_study_table_and_key_is_documented():
    sections = {s.name: s for s in reference.study_sections()}
    assert set(SECTIONS) | {"study"} <= set(sections)
    assert {f.name for f in sections["study"].fields} == set(_STUDY_KEYS)
    for name, builder in SECTIONS.items():
        cls = reference._builder_class(builder)
        if cls is None:
            continue
        documented = {f.name for f in sections[name].fields}
        accepted = {f.name for f in dataclasses.fields(cls) if f.init} - ({"count"} if name == "missions" else set())
        assert documented == accepted, name
        for f in sections[name].fields:
            assert f.doc, f"[{name}] {f.name} has no docstring"
            builder({f.name: f.default}, "test")  # the documented default is accepted as written


def test_trial_and_telemetry_columns_are_documented():
    cols = {c.name: c for c in reference.trial_columns()}
    fields = {f.name for f in dataclasses.fields(TrialResult)} - {"mission_index"}
    assert fields <= set(cols) and all(cols[f].doc for f in fields)
    assert cols["rms_vertical_accel_m_s2"].unit == "m/s^2" and cols["traversal_time_s"].unit == "s"
    assert set(TELEMETRY_COLUMNS) <= set(reference.TELEMETRY_DOCS), "document the new telemetry column"


def _bounds(allowed: str):
    m = re.fullmatch(r"([\[(])(-?[\d.e+]+|-inf), (-?[\d.e+]+|inf)([\])])", allowed)
    if not m:
        return None
    lo = None if m[2] == "-inf" else float(m[2])
    hi = None if m[3] == "inf" else float(m[3])
    return lo, m[1] == "(", hi, m[4] == ")"


def test_the_documented_ranges_are_the_enforced_ones():
    """Just outside a documented bound the config refuses the value; on a closed bound it accepts it."""
    sections = {s.name: s for s in reference.study_sections()}
    checked = 0
    builders = {n: b for n, b in SECTIONS.items() if reference._builder_class(b) is not None}
    for name in sections:
        if name.startswith("planner."):
            entry = name.split(".", 1)[1]
            builders[name] = lambda t, w, entry=entry: planner_from_table({"name": entry, **t}, w)
    for name, builder in builders.items():
        for f in sections[name].fields:
            b = _bounds(f.allowed) if f.type == "float" else None
            if b is None:
                continue
            lo, lo_open, hi, hi_open = b
            for edge, is_open, step in ((lo, lo_open, -1e-9), (hi, hi_open, 1e-9)):
                if edge is None:
                    continue
                with pytest.raises(InputError):
                    builder({f.name: edge + step * max(1.0, abs(edge))}, "test")
                if not is_open and f.name not in ("semi_max_slope",):
                    builder({f.name: edge}, "test")
                checked += 1
    assert checked > 40
    sim = {f.name: f for f in sections["sim"].fields}
    assert sim["physics_rate_hz"].allowed == "integer 30 .. 2000"
    assert sim["tyre_model"].allowed.startswith('one of "bullet", "coulomb"')
    assert sim["gravity_m_s2"].unit == "m/s^2" and sim["gravity_m_s2"].allowed == "[0, inf)"
    rules = {f.name: f for f in sections["rules"].fields}
    assert rules["tip_angle_deg"].allowed == "(0, 180]"


def test_config_prints_a_study_that_loads(capsys):
    assert main(["config"]) == 0
    data = tomllib.loads(capsys.readouterr().out)
    study = study_from_dict(data)
    assert study.root_seed == 0 and data["sim"]["physics_rate_hz"] == 60
    assert data["vehicle"] == {"name": "husky"}  # its figures are printed commented out
    plan_cells(study)  # every table validates as printed


def test_config_section_and_unknown_section(capsys):
    assert main(["config", "rules"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("[rules]") and "tip_angle_deg = 75.0" in out and "[sim]" not in out
    assert main(["config", "simm"]) == 2
    assert "did you mean 'sim'" in capsys.readouterr().err


def test_write_reference(tmp_path, capsys):
    out = tmp_path / "new" / "reference.md"
    assert main(["config", "--write-reference", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == reference.render_reference()


def test_recipe_tables_are_documented_with_their_file_keys():
    from offroadbench.terrain.recipe import _FILE_READERS
    from offroadbench.terrain.registry import TERRAIN_REGISTRY

    assert set(_FILE_READERS) <= set(reference.FILE_KEYS), "document the new file key in reference.FILE_KEYS"
    sections = reference.recipe_sections()
    tops = {s.generator: s for s in sections if s.name == "layers.NAME" and s.generator}
    assert set(tops) == set(TERRAIN_REGISTRY.names())
    assert [f.name for f in tops["dem"].fields][:1] == ["path"] and "dem" not in {f.name for f in tops["dem"].fields}
    assert "crater_file" in {f.name for f in tops["craters"].fields}
    nested = {s.name for s in sections if s.generator == "craters"}
    assert nested == {"layers.NAME", "layers.NAME.population", "layers.NAME.stamp"}
    wm = {f.name: f for f in tops["wm"].fields}
    assert wm["D"].allowed == "(2, 3)"
