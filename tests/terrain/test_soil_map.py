"""Soil maps (issue 47): a recipe's ``[soil]`` gives a soil per region (rules over the terrain's own
features, patches, a raster of soil indices), and the tyre model reads the soil under each wheel's
contact every step."""

import importlib.util

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.recipe import load_recipe, recipe_from_dict
from offroadbench.terrain.soil_map import SoilMap, SoilMapConfig, SoilRegion, build_soil_map, soil_map_for

needs_mujoco = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")

GRID = {"rows": 21, "cols": 31, "cell_size_m": 0.1}


def _recipe(soil: dict, layers: dict | None = None):
    return recipe_from_dict({"recipe": {"name": "t"}, "grid": GRID, "soil": soil,
                             "layers": layers or {"base": {"generator": "fbm", "D": 2.3, "relief_m": 0.5}}})


def _ramp() -> Heightmap:
    """Flat for x < 1 m, a 30 deg ramp from x = 1 m (heights 0 .. 1.15 m)."""
    x = np.arange(GRID["cols"]) * 0.1
    return Heightmap(np.tile(np.tan(np.radians(30.0)) * np.maximum(0.0, x - 1.0), (GRID["rows"], 1)), 0.1)


def test_rules_and_patches_paint_in_order_over_the_default():
    hm = _ramp()
    cfg = SoilMapConfig(default="lunar-regolith", regions=(
        SoilRegion(soil="snow", slope_min_deg=20.0),                              # the ramp
        SoilRegion(soil="lete-sand", height_min_m=0.9),                           # its top, painted over
        SoilRegion(soil="clayey-soil", centre_m=(0.5, 1.0), radius_m=0.25),       # a disc on the flat
        SoilRegion(soil="lunar-simulant-ishigami2007", x_range_m=(0.0, 0.25), y_range_m=(0.0, 0.25)),
    ))
    sm = build_soil_map(cfg, hm)
    assert sm.soils == ("lunar-regolith", "snow", "lete-sand", "clayey-soil", "lunar-simulant-ishigami2007")
    assert sm.index.shape == hm.shape and sm.index.dtype == np.uint8
    assert sm.soils[sm.soil_index_at(0.8, 0.2)] == "lunar-regolith"   # flat, outside every patch
    assert sm.soils[sm.soil_index_at(1.5, 1.0)] == "snow"             # on the ramp, below 0.9 m
    assert sm.soils[sm.soil_index_at(2.8, 1.0)] == "lete-sand"        # 1.04 m high
    assert sm.soils[sm.soil_index_at(0.5, 1.1)] == "clayey-soil"
    assert sm.soils[sm.soil_index_at(0.1, 0.1)] == "lunar-simulant-ishigami2007"
    assert sm.soils[sm.soil_index_at(-5.0, 50.0)] == sm.soils[sm.index[-1, 0]]  # clamped to the map
    assert sum(sm.fractions().values()) == pytest.approx(1.0)


def test_crater_floors_come_from_the_recipes_own_population():
    """``in_crater``: the samples within the fraction of a crater's radius of the craters the recipe placed."""
    from offroadbench.terrain.craters.layer import recipe_craters
    from offroadbench.terrain.recipe import generate_terrain

    layers = {"base": {"generator": "fbm", "D": 2.3, "relief_m": 0.2},
              "craters": {"generator": "craters", "population": {"c": 0.5, "d_min_m": 0.6, "d_max_m": 1.5}}}
    recipe = _recipe({"name": "lunar-regolith", "regions": [{"soil": "snow", "in_crater": True,
                                                             "crater_radius_fraction": 0.5}]}, layers)
    hm = generate_terrain(recipe, 3)
    sm = soil_map_for(recipe, hm, 3)
    (table,) = recipe_craters(recipe, 3).values()
    assert table.x_m.size > 0
    for x, y in zip(table.x_m, table.y_m, strict=True):
        if 0.0 <= x <= hm.width_m and 0.0 <= y <= hm.height_m:
            assert sm.soils[sm.soil_index_at(x, y)] == "snow"
    craters = list(zip(table.x_m, table.y_m, table.diameter_m, strict=True))
    far = [(x, y) for x in np.arange(0, hm.width_m, 0.1) for y in np.arange(0, hm.height_m, 0.1)
           if all(np.hypot(x - cx, y - cy) > 0.5 * d + 0.1 for cx, cy, d in craters)]
    assert far and all(sm.soils[sm.soil_index_at(x, y)] == "lunar-regolith" for x, y in far)


def test_a_raster_of_soil_indices_aligned_with_the_heights(tmp_path):
    from offroadbench.io.soil_raster import read_soil_raster, write_soil_raster

    idx = np.zeros((GRID["rows"], GRID["cols"]), dtype=np.uint8)
    idx[:, 15:] = 1
    idx[10, 3] = 2
    png = write_soil_raster(idx, ["a", "b", "c"], 0.1, tmp_path / "soil.png")
    assert np.array_equal(read_soil_raster(png), idx)
    recipe = _recipe({"name": "lunar-regolith", "raster": str(png), "raster_soils": ["lete-sand", "snow", "lunar-regolith"]})
    hm = Heightmap.flat(GRID["rows"], GRID["cols"], 0.1)
    sm = soil_map_for(recipe, hm, 0)
    assert sm.soils == ("lunar-regolith", "lete-sand", "snow")
    assert sm.soils[sm.soil_index_at(0.3, 1.0)] == "lunar-regolith"
    assert sm.soils[sm.soil_index_at(0.2, 0.2)] == "lete-sand" and sm.soils[sm.soil_index_at(2.0, 0.2)] == "snow"


@pytest.mark.parametrize("soil, match", [
    ({"name": "x", "regions": [{"soil": "snow"}]}, "no condition"),
    ({"name": "x", "regions": [{"soil": "snow", "slope": 3}]}, "unknown key"),
    ({"name": "x", "regions": [{"soil": "snow", "centre_m": [1, 2]}]}, "centre_m and radius_m"),
    ({"name": "x", "regions": [{"soil": "snow", "centre_m": [1], "radius_m": 1}]}, "centre_m"),
    ({"name": "x", "regions": [{"soil": "snow", "slope_min_deg": 95}]}, "slope_min_deg"),
    ({"name": "x", "raster_soils": ["snow"]}, "without soil.raster"),
    ({"name": "x", "raster": "nowhere.png"}, "raster_soils"),
    ({"name": "x", "raster": "nowhere.png", "raster_soils": ["snow"]}, "no such file"),
    ({"name": "x", "colour": 1}, "colour"),
])
def test_bad_soil_maps_are_refused_naming_the_key(soil, match):
    with pytest.raises(InputError, match=match):
        _recipe(soil)


def test_one_soil_is_no_map_and_the_shipped_preset_has_one():
    assert _recipe({"name": "lunar-regolith"}).soil_map is None
    preset = load_recipe("lunar-highland-crater-floors")
    assert preset.soil == "lunar-regolith" and preset.soil_map is not None
    assert [r.in_crater for r in preset.soil_map.regions] == [True]


def _two_halves(hm: Heightmap, x_m: float, left: str, right: str) -> SoilMap:
    idx = np.zeros(hm.shape, dtype=np.uint8)
    idx[:, hm.x_coords_m() >= x_m] = 1
    return SoilMap(soils=(left, right), index=idx, cell_size_m=hm.cell_size_m)


def test_a_wheels_forces_switch_soil_at_the_boundary():
    """The same wheel state on either side of a boundary gets exactly the forces of each soil alone."""
    from offroadbench.sim.trial.vehicle import load_vehicle
    from offroadbench.sim.tyre_laws.soil_wheels import soil_setup

    spec = load_vehicle("husky")
    hm = Heightmap.flat(21, 61, 0.1)
    sm = _two_halves(hm, 3.0, "lunar-regolith", "lete-sand")
    mapped = soil_setup(spec, "lunar-regolith", 50.0, 4, 1.62, 1 / 60, soil_map=sm).wheels(1, hm, 1 / 60)
    alone = {name: soil_setup(spec, name, 50.0, 4, 1.62, 1 / 60).wheels(1, hm, 1 / 60) for name in sm.soils}
    r = spec.wheel_radius_m
    for x, name in ((2.5, "lunar-regolith"), (3.5, "lete-sand")):
        args = ((x, 1.0, r - 0.004), (0.0, 1.0, 0.0), (0.3, 0.0, 0.0), (0.0, 0.4 / r, 0.0))
        mapped.reset()
        got = mapped.wheel_force(0, *args)
        want = alone[name].wheel_force(0, *args)
        assert got == want and mapped.last_soil == {0: sm.soils.index(name)}
    assert mapped.wheel_force(0, *args) != alone["lunar-regolith"].wheel_force(0, *args)


@pytest.mark.parametrize("engine", ["pybullet", pytest.param("mujoco", marks=needs_mujoco)])
def test_a_vehicle_driving_across_a_boundary_changes_soil_on_both_engines(engine):
    """Husky, lunar gravity, lunar regolith (static sinkage 9 mm) then LETE sand (under 1 mm) from
    x = 3 m: the trial's sinkage drops as the wheels cross."""
    from offroadbench.navigation.missions import Mission
    from offroadbench.sim import SimConfig, open_world
    from offroadbench.sim.trial.runner import drive_mission

    hm = Heightmap.flat(41, 71, 0.1)
    sm = _two_halves(hm, 3.0, "lunar-regolith", "lete-sand")
    sim = SimConfig(tyre_model="terramechanics", soil="lunar-regolith", gravity_m_s2=1.62, engine=engine)
    with open_world(hm, "husky", sim, soil_map=sm) as world:
        rec = drive_mission(world, Mission.between(0, (1.0, 2.0), (6.0, 2.0)))
    tel = rec.telemetry
    before = tel["penetration_m"][tel["x_m"] < 2.2]
    after = tel["penetration_m"][tel["x_m"] > 3.8]
    assert rec.result.success and before.size and after.size
    assert np.median(before) > 0.006 and np.median(after) < 0.002


SMALL_TOML = """
[recipe]
name = "soil-map-small"
[grid]
rows = 41
cols = 61
cell_size_m = 0.1
[layers.base]
generator = "fbm"
D = 2.3
relief_m = 0.3
[soil]
name = "lunar-regolith"
[[soil.regions]]
soil = "lete-sand"
x_range_m = [3.0, 6.0]
y_range_m = [0.0, 4.0]
"""


def test_the_pipeline_builds_the_map_unless_the_settings_name_a_soil():
    import dataclasses

    from offroadbench.sim.trial.pipeline import TrialSettings, prepare_terrain

    recipe = recipe_from_dict(__import__("tomllib").loads(SMALL_TOML))
    settings = TrialSettings()
    prepared = prepare_terrain(recipe, 5, settings, [])
    sm = prepared.soil_map
    assert sm is not None and sm.soils == ("lunar-regolith", "lete-sand")
    assert sm.soils[sm.soil_index_at(4.0, 2.0)] == "lete-sand" and sm.soils[sm.soil_index_at(1.0, 2.0)] == "lunar-regolith"
    assert prepared.soil_map_for(settings.sim) is sm
    assert prepared.soil_map_for(dataclasses.replace(settings.sim, soil="snow")) is None  # one soil everywhere


def test_exports_carry_the_soil_map_and_analyze_draws_it(tmp_path, capsys):
    import json

    from offroadbench.cli import main
    from offroadbench.io.soil_raster import read_soil_raster
    from offroadbench.terrain.recipe import generate_terrain

    toml = tmp_path / "small.toml"
    toml.write_text(SMALL_TOML)
    assert main(["export", str(toml), "--seed", "2", "--format", "unreal", "-o", str(tmp_path / "out")]) == 0
    pngs = sorted((tmp_path / "out").glob("*_soil.png"))
    assert len(pngs) == 1
    meta = json.loads(pngs[0].with_suffix(".json").read_text())
    assert meta["soils"] == ["lunar-regolith", "lete-sand"] and (meta["rows"], meta["cols"]) == (41, 61)
    recipe = recipe_from_dict(__import__("tomllib").loads(SMALL_TOML))
    want = soil_map_for(recipe, generate_terrain(recipe, 2), 2).index
    assert np.array_equal(read_soil_raster(pngs[0]), want)
    plot = tmp_path / "a.png"
    assert main(["analyze", str(toml), "--seed", "2", "--border-m", "0.5", "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    assert "Soil map: lunar-regolith" in out and (tmp_path / "a_soil.png").stat().st_size > 0
