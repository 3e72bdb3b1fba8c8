"""``--set SECTION.TABLE.FIELD=VALUE``: a nested settings table ([sim.mujoco], [sim.mujoco_warp])
set from the command line (``drive --set``, ``study run --set``), validated as the TOML's is."""

import json

import pytest

from offroadbench.cli import main
from offroadbench.cli.study import apply_sets
from offroadbench.errors import InputError
from offroadbench.study.spec.config import plan_cells, study_from_dict

BASE = {"study": {"name": "s", "recipe": "paper-d2.45", "root_seed": 1, "terrains_per_cell": 1},
        "grid": {"sim.engine": ["pybullet", "mujoco"]}, "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
        "sim": {"mujoco": {"ccd_iterations": 20}}}
SMALL = ["--set", "grid.rows=257", "--set", "grid.cols=257", "--length-m", "6", "--seed", "1", "--missions", "1",
         "--border-m", "2"]


def _cell_sim(data: dict):
    study = study_from_dict(data)
    return plan_cells(study)[1].trial_settings.sim


def test_study_set_reaches_a_nested_table_and_keeps_the_file_s_keys():
    data = apply_sets(BASE, ["sim.mujoco.hfield_collision=exact", "sim.mujoco_warp.worlds=8"])
    sim = _cell_sim(data)
    assert sim.mujoco.hfield_collision == "exact" and sim.mujoco.ccd_iterations == 20  # the file's key kept
    assert sim.mujoco_warp.worlds == 8
    assert BASE["sim"] == {"mujoco": {"ccd_iterations": 20}}  # the file's dict is left alone
    assert _cell_sim(apply_sets(BASE, [])).mujoco.hfield_collision == "closed_form"


@pytest.mark.parametrize(("item", "message"), [
    ("sim.mujoco.hfield_collision=bogus", "mujoco.hfield_collision = 'bogus' is not known; allowed: mujoco, exact"),
    ("sim.mujoco.nope=1", "unknown key(s) mujoco.nope; known keys of mujoco: ccd_iterations"),
    ("sim.mujoco_warp.worlds=0", "mujoco_warp.worlds = 0 is out of range"),
])
def test_study_set_of_a_bad_nested_field_or_value_names_it(item, message):
    with pytest.raises(InputError) as exc:
        _cell_sim(apply_sets(BASE, [item]))
    assert message in str(exc.value)


@pytest.mark.parametrize("item", ["sim.engine.x=1", "sim..x=1", "controller.a.b=1", "sim.mujoco.solimp.a=1"])
def test_a_key_below_a_value_is_refused_naming_the_nested_tables(item):
    with pytest.raises(InputError, match="a settings key is") as exc:
        apply_sets(BASE, [item])
    if item.startswith("sim.") and "mujoco" not in item:
        assert "sim.TABLE.FIELD=VALUE with TABLE one of mujoco, mujoco_warp" in str(exc.value)


@pytest.mark.parametrize(("item", "message"), [
    ("sim.mujoco.hfield_collision=bogus", "allowed: mujoco, exact, closed_form"),
    ("sim.mujoco.nope=1", "unknown key(s) mujoco.nope"),
    ("sim.engine.x=1", "a settings key is sim.FIELD=VALUE or sim.TABLE.FIELD=VALUE"),
])
def test_drive_set_of_a_bad_nested_key_is_one_line_exit_2(tmp_path, capsys, item, message):
    out = tmp_path / "run"
    assert main(["drive", "paper-d2.3", *SMALL, "--engine", "mujoco", "--set", item, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not out.exists()


def test_drive_set_of_a_nested_mujoco_setting_drives_with_it(tmp_path):
    pytest.importorskip("mujoco")
    out = tmp_path / "run"
    assert main(["drive", "paper-d2.3", *SMALL, "--engine", "mujoco", "--out", str(out),
                 "--set", "sim.mujoco.hfield_collision=exact", "--set", "sim.mujoco.ccd_iterations=12"]) == 0
    sim = json.loads((out / "settings.json").read_text())["settings"]["sim"]
    assert sim["mujoco"]["hfield_collision"] == "exact" and sim["mujoco"]["ccd_iterations"] == 12
    assert sim["mujoco"]["min_rate_hz"] == 120  # the keys not set keep their defaults
