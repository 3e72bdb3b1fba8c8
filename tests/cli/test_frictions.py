"""Issue 46's frictions: `vehicle list`, the input kind named, did-you-mean for choices and keys."""

import pytest

from offroadbench.cli import main
from offroadbench.errors import InputError


def _cli(capsys, *args):
    rc = main(list(args))
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_vehicle_list_lists_the_five_vehicles(capsys):
    rc, out, _ = _cli(capsys, "vehicle", "list")
    assert rc == 0
    names = [line.split()[0] for line in out.splitlines()[1:]]
    assert {"husky", "jackal", "talon", "hunter", "sojourner"} <= set(names)
    talon = next(line for line in out.splitlines() if line.startswith("talon"))
    assert "skid (tracks)" in talon and "10" in talon.split()


@pytest.mark.parametrize("name, data, kind", [
    ("photo.jpg", b"\xff\xd8\xff\xe0" + b"\0" * 40, "a JPEG image"),
    ("terrain.json", b'{"cell_size_m": 0.05}', "a JSON file"),
    ("map.tif", b"II*\x00" + b"\0" * 40, "a TIFF image"),
    ("heights.npy", b"\x93NUMPY" + b"\0" * 40, "a NumPy array"),
])
def test_analyze_names_the_kind_of_a_file_that_is_not_a_terrain(tmp_path, capsys, name, data, kind):
    path = tmp_path / name
    path.write_bytes(data)
    rc, _, err = _cli(capsys, "analyze", str(path))
    assert rc == 2 and kind in err and "not valid TOML" not in err and err.count("\n") == 1


def test_a_broken_toml_still_says_not_valid_toml(tmp_path, capsys):
    path = tmp_path / "r.toml"
    path.write_text("[grid\nrows = 3")
    rc, _, err = _cli(capsys, "analyze", str(path))
    assert rc == 2 and "not valid TOML" in err


def test_a_mistyped_engine_horizon_or_study_key_names_the_closest():
    from offroadbench.sim import SimConfig
    from offroadbench.navigation.drivers import planner_from_table
    from offroadbench.study import study_from_dict

    with pytest.raises(InputError, match="did you mean 'mujoco'"):
        SimConfig(engine="mujuco")
    with pytest.raises(InputError, match="did you mean 'horizon_s'"):
        planner_from_table({"name": "mppi", "horizon": 2.0})
    with pytest.raises(InputError, match="did you mean 'terrains_per_cell'"):
        study_from_dict({"study": {"name": "x", "recipe": "paper-d2.45", "root_seed": 1, "terrain_per_cell": 2}})
    with pytest.raises(InputError, match="did you mean 'missions'"):
        study_from_dict({"study": {"name": "x", "recipe": "paper-d2.45", "root_seed": 1}, "mission": {}})


def test_drive_of_a_generated_png_records_its_terrain_seed(tmp_path, capsys):
    import pandas as pd

    png = tmp_path / "t.png"
    assert main(["generate", "paper-d2.45", "--seed", "123", "--set", "grid.rows=129", "--set", "grid.cols=129",
                 "-o", str(png)]) == 0
    assert main(["drive", str(png), "--missions", "1", "--length-m", "3", "--border-m", "1", "--out", str(tmp_path / "d")]) == 0
    capsys.readouterr()
    assert list(pd.read_csv(tmp_path / "d" / "trials.csv")["terrain_seed"]) == [123]


def test_drive_help_names_both_engines(capsys):
    from offroadbench.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    help_text = next(a.help for a in sub._choices_actions if a.dest == "drive")
    assert "PyBullet or MuJoCo" in help_text


def test_a_clipped_terrain_says_so_in_its_label_and_sidecar(tmp_path, capsys):
    import json

    png = tmp_path / "c.png"
    assert main(["generate", "paper-d2.45", "--set", "grid.rows=129", "--set", "grid.cols=129", "--seed", "1",
                 "--clip-percentile", "0.1", "-o", str(png)]) == 0
    assert json.loads(png.with_suffix(".json").read_text())["label"].endswith("seed 1, clipped to the 0.1..99.9 percentiles")
    capsys.readouterr()
    assert main(["analyze", "paper-d2.45", "--set", "grid.rows=129", "--set", "grid.cols=129", "--seed", "1", "--border-m", "1",
                 "--clip-percentile", "0.1"]) == 0
    assert "seed 1, clipped to the 0.1..99.9 percentiles" in capsys.readouterr().out
