"""Shipped data is found through importlib.resources; OFFROADBENCH_PATH adds and overrides it."""

import os

import pytest

from offroadbench import resources
from offroadbench.cli import main
from offroadbench.errors import InputError
from offroadbench.sim.trial.vehicle import list_vehicles, load_vehicle
from offroadbench.terrain.recipe import list_presets, load_recipe

USER_PRESET = """
[recipe]
name = "{name}"
description = "{desc}"

[grid]
rows = 17
cols = 17
cell_size_m = 0.1

[layers.base]
generator = "fbm"
D = 2.3
"""


@pytest.fixture
def user_dir(tmp_path, monkeypatch):
    """One search-path directory with a preset that shadows a shipped one and a new vehicle."""
    (tmp_path / "terrains").mkdir()
    (tmp_path / "terrains" / "my-plain.toml").write_text(USER_PRESET.format(name="my-plain", desc="user preset"))
    (tmp_path / "terrains" / "paper-d2.45.toml").write_text(USER_PRESET.format(name="paper-d2.45", desc="shadow"))
    husky = resources.vehicle_files()["husky"].parent
    rover = tmp_path / "vehicles" / "rover"
    rover.mkdir(parents=True)
    (rover / "husky.urdf").write_text((husky / "husky.urdf").read_text())
    (rover / "vehicle.toml").write_text((husky / "vehicle.toml").read_text().replace('name = "husky"', 'name = "rover"'))
    monkeypatch.setenv(resources.ENV_VAR, os.pathsep.join([str(tmp_path), ""]))
    return tmp_path


def test_shipped_data_is_found_by_package_not_by_repository_path():
    presets = resources.terrain_presets()
    assert {"paper-d2.3", "paper-d2.45", "paper-d2.6", "lunar-mare"} <= set(presets)
    assert all(p.parent == resources.shipped("terrains") for p in presets.values())
    husky = resources.vehicle_files()["husky"]
    assert (husky.parent / "husky.urdf").is_file()
    assert resources.sample_dem().is_file() and resources.sample_dem().with_suffix(".json").is_file()
    assert {"smoke", "majhor2023"} <= set(resources.study_files())
    # the study's recipe is a preset name, so the shipped study runs from any directory
    assert load_recipe("paper-d2.45").name == "paper-d2.45"


def test_search_path_adds_and_shadows_presets_and_vehicles(user_dir):
    presets = list_presets()
    assert presets["my-plain"] == "user preset"
    assert presets["paper-d2.45"] == "shadow"  # first folder on the path wins
    assert "paper-d2.6" in presets  # shipped ones stay visible
    assert load_recipe("my-plain").layers[0].generator == "fbm"
    assert {"husky", "rover"} <= set(list_vehicles())
    rover = load_vehicle("rover")
    assert rover.name == "rover" and rover.urdf.startswith(str(user_dir))


def test_search_path_entry_that_is_not_a_directory_is_an_input_error(tmp_path, monkeypatch):
    monkeypatch.setenv(resources.ENV_VAR, str(tmp_path / "nope"))
    with pytest.raises(InputError, match="OFFROADBENCH_PATH.*nope.*not a directory"):
        list_presets()


def test_unknown_preset_and_vehicle_suggest_close_names():
    with pytest.raises(InputError, match=r"unknown terrain preset 'paper-d2.46'; did you mean [^?]*'paper-d2.45'"):
        load_recipe("paper-d2.46")
    with pytest.raises(InputError, match=r"unknown vehicle 'huskey'; did you mean 'husky'"):
        load_vehicle("huskey")


def test_no_presets_found_is_an_error_with_exit_2(tmp_path, monkeypatch, capsys):
    empty = tmp_path / "shipped"
    (empty / "terrains").mkdir(parents=True)
    real = resources.shipped
    monkeypatch.setattr(resources, "shipped", lambda kind: empty / kind if kind == "terrains" else real(kind))
    with pytest.raises(InputError, match="no terrain presets found"):
        list_presets()
    assert main(["terrains"]) == 2
    out, err = capsys.readouterr()
    assert "no terrain presets found" in err and out == ""


def test_no_module_finds_files_relative_to_its_source():
    offenders = [str(p) for p in resources.package_dir().rglob("*.py") if "__file__" in p.read_text()]
    assert offenders == []
