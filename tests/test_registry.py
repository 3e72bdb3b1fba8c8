"""The one Registry type: duplicate check, did-you-mean, entry-point plug-ins."""

from importlib import metadata

import pytest

from offroadbench.errors import InputError
from offroadbench.registry import Registry


def test_register_get_names_and_decorator():
    reg = Registry("widget")
    reg.register("alpha", 1)

    @reg.register("beta")
    def beta():
        return 2

    assert reg.get("alpha") == 1 and reg.get("beta") is beta
    assert reg.names() == ["alpha", "beta"] and "alpha" in reg and len(reg) == 2


def test_duplicate_name_is_refused():
    reg = Registry("widget")
    reg.register("alpha", 1)
    with pytest.raises(ValueError, match="registered twice"):
        reg.register("alpha", 2)


def test_unknown_name_suggests_close_matches():
    reg = Registry("planner")
    reg.register("straight", 1)
    reg.register("astar", 2)
    with pytest.raises(InputError, match=r"unknown planner 'straigt'; did you mean 'straight'\? known: astar, straight"):
        reg.get("straigt")
    with pytest.raises(InputError, match=r"unknown planner 'zzz'; known: astar, straight$"):
        reg.get("zzz")


def test_loader_runs_once_before_first_read():
    calls = []
    reg = Registry("widget", loader=lambda: calls.append(1) or reg.register("built-in", 0))
    assert reg.names() == ["built-in"] and reg.get("built-in") == 0
    assert calls == [1]


def test_entry_points_are_loaded_and_adapted(monkeypatch):
    eps = [
        metadata.EntryPoint(name="sqrt", value="math:sqrt", group="offroadbench.test"),
        metadata.EntryPoint(name="broken", value="no_such_module_xyz:thing", group="offroadbench.test"),
    ]

    def fake_entry_points(*, group):
        return [ep for ep in eps if ep.group == group]

    monkeypatch.setattr(metadata, "entry_points", fake_entry_points)
    reg = Registry("function", entry_point_group="offroadbench.test", adapt=lambda name, obj: (name, obj))
    import math

    assert reg.get("sqrt") == ("sqrt", math.sqrt)
    assert "broken" not in reg  # a plug-in that fails to import is skipped with a warning


def _fake_distribution(monkeypatch, *eps):
    """Make importlib.metadata report the entry points ``eps`` (as an installed package would)."""
    monkeypatch.setattr(metadata, "entry_points", lambda *, group: [ep for ep in eps if ep.group == group])


# objects the fake entry points below name (module:attribute of this test module)
def _flat(cfg, grid, rng):
    from offroadbench.heightmap import Heightmap

    return Heightmap.flat(grid.rows, grid.cols, grid.cell_size_m)


def _make_specs():
    from offroadbench.terrain.registry import TerrainSpec
    from offroadbench.terrain.fractal.fbm import FBMConfig

    return TerrainSpec("whatever", "generator", FBMConfig, _flat, "flat"), TerrainSpec("m", "modifier", FBMConfig, _flat)


FLAT_SPEC, MOD_SPEC = _make_specs()
NOT_A_SPEC = 42


def test_terrain_plugins_from_both_groups_are_renamed_to_their_entry_point(monkeypatch):
    from offroadbench.terrain import registry as treg

    here = __name__
    _fake_distribution(
        monkeypatch,
        metadata.EntryPoint(name="flat", value=f"{here}:FLAT_SPEC", group="offroadbench.generators"),
        metadata.EntryPoint(name="nudge", value=f"{here}:MOD_SPEC", group="offroadbench.modifiers"),
        metadata.EntryPoint(name="bad", value=f"{here}:NOT_A_SPEC", group="offroadbench.generators"),
        metadata.EntryPoint(name="wm", value=f"{here}:FLAT_SPEC", group="offroadbench.generators"),
    )
    reg = Registry(treg.TERRAIN_REGISTRY.kind, entry_point_group=treg.TERRAIN_REGISTRY.entry_point_group,
                   adapt=treg._from_entry_point)
    reg.register("wm", treg.TERRAIN_REGISTRY.get("wm"))
    assert reg.get("flat").name == "flat" and reg.get("flat").fn is _flat
    assert reg.get("nudge").kind == "modifier"
    assert "bad" not in reg  # not a TerrainSpec: skipped with a warning
    assert reg.get("wm") is treg.TERRAIN_REGISTRY.get("wm")  # a plug-in cannot take a built-in's name


def test_vehicle_plugin_is_loaded_by_name(monkeypatch, tmp_path):
    from offroadbench import resources
    from offroadbench.sim.trial import vehicle

    husky = resources.vehicle_files()["husky"].parent
    rover = tmp_path / "rover"
    rover.mkdir()
    for f in ("vehicle.toml", "husky.urdf"):
        (rover / f).write_text((husky / f).read_text())
    global ROVER_DIR
    ROVER_DIR = str(rover)
    _fake_distribution(monkeypatch, metadata.EntryPoint(name="rover", value=f"{__name__}:ROVER_DIR",
                                                        group="offroadbench.vehicles"))
    monkeypatch.setattr(vehicle, "VEHICLES", Registry("vehicle", entry_point_group="offroadbench.vehicles",
                                                      adapt=vehicle._toml_of))
    assert {"husky", "rover"} <= set(vehicle.list_vehicles())
    assert vehicle.load_vehicle("rover").urdf == str((rover / "husky.urdf").resolve())


ROVER_DIR = ""
