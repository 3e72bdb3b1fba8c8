"""Recipes: presets by name, layering, overrides, validation, seeds per layer."""

import numpy as np
import pytest

from offroadbench import InputError
from offroadbench.terrain.recipe import apply_overrides, generate_terrain, list_presets, load_recipe, recipe_from_dict


def _wm_recipe(**extra_layers):
    data = {
        "recipe": {"name": "t"},
        "grid": {"rows": 30, "cols": 40, "cell_size_m": 0.1},
        "layers": {"a": {"generator": "wm", "M": 4, "n_max": 12}},
    }
    data["layers"].update(extra_layers)
    return data


def test_paper_presets_exist():
    presets = list_presets()
    for d in ("2.3", "2.45", "2.6"):
        r = load_recipe(f"paper-d{d}")
        assert r.layers[0].config.D_high == float(d)
        assert f"paper-d{d}" in presets


def test_layers_sum_product_and_independent_rngs():
    def unquantised(data):  # the layer arithmetic itself, before the 16-bit levels
        data["grid"]["quantise"] = "none"
        return recipe_from_dict(data)

    one = unquantised(_wm_recipe())
    two = unquantised(_wm_recipe(b={"generator": "wm", "M": 3, "n_max": 10, "weight": 0.5}))
    prod = unquantised(_wm_recipe(b={"generator": "wm", "M": 3, "n_max": 10, "combine": "product"}))
    only_b = unquantised(
        {"grid": {"rows": 30, "cols": 40, "cell_size_m": 0.1}, "layers": {"b": {"generator": "wm", "M": 3, "n_max": 10}}}
    )
    a = generate_terrain(one, 5).z
    b = generate_terrain(only_b, 5).z  # same layer name -> same random numbers
    np.testing.assert_allclose(generate_terrain(two, 5).z, a + 0.5 * b, atol=1e-12)
    np.testing.assert_allclose(generate_terrain(prod, 5).z, a * b, atol=1e-12)


def test_relief_and_grid_injection():
    data = _wm_recipe()
    data["recipe"]["relief_m"] = 2.0
    hm = generate_terrain(recipe_from_dict(data), 1)
    assert hm.shape == (30, 40) and hm.cell_size_m == 0.1
    assert hm.relief_m == 2.0 and hm.z_min_m == 0.0  # exactly: the 16-bit levels span [0, relief]


def test_terrain_is_quantised_to_the_png_levels_by_default(tmp_path):
    from offroadbench.io.png16 import encode_png16, read_png16, write_png16

    data = _wm_recipe()
    data["recipe"]["relief_m"] = 2.0
    hm = generate_terrain(recipe_from_dict(data), 1)
    data["grid"]["quantise"] = "none"
    raw = generate_terrain(recipe_from_dict(data), 1)
    step = 2.0 / 65535
    levels = encode_png16(hm)
    assert levels.min() == 0 and levels.max() == 65535
    np.testing.assert_array_equal(hm.z, levels * step)  # z_min + level * relief / 65535
    assert np.max(np.abs(hm.z - raw.z)) <= step / 2 * (1 + 1e-9)
    write_png16(hm, tmp_path / "t.png")
    assert read_png16(tmp_path / "t.png").z.tobytes() == hm.z.tobytes()  # the PNG is the terrain, bit for bit
    with pytest.raises(InputError, match="quantise"):
        data["grid"]["quantise"] = "float32"
        recipe_from_dict(data)


def test_overrides_and_ids():
    r = load_recipe("paper-d2.45")
    r2 = apply_overrides(r, {"layers.base.D_high": 2.6, "grid.rows": 50, "grid.cols": 50})
    assert r2.layers[0].config.D_high == 2.6 and r2.grid.rows == 50
    assert r.layers[0].config.D_high == 2.45  # original untouched
    assert r2.terrain_id(1) == apply_overrides(r, {"layers.base.D_high": 2.6, "grid.rows": 50, "grid.cols": 50}).terrain_id(1)
    assert r2.terrain_id(1) != r2.terrain_id(2) != r.terrain_id(1)


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d["layers"]["a"].update(bogus=1), "unknown key.*bogus"),
        (lambda d: d["layers"]["a"].update(generator="nope"), "unknown terrain generator 'nope'; known:.*wm"),
        (lambda d: d["layers"]["a"].update(combine="blend"), "combine"),
        (lambda d: d["grid"].update(rows=0), "grid.rows"),
        (lambda d: d["grid"].update(cell_size_m=-1), "cell_size_m"),
        (lambda d: d.update(extra={}), "unknown key.*extra"),
        (lambda d: d["layers"]["a"].update(D=3.5), r"D = 3.5 is out of range"),
        (lambda d: d.pop("grid"), r"\[grid\]"),
    ],
)
def test_bad_recipes(mutate, match):
    data = _wm_recipe()
    mutate(data)
    with pytest.raises(InputError, match=match):
        recipe_from_dict(data)


def test_unknown_preset_lists_known():
    with pytest.raises(InputError, match="unknown terrain preset 'paper-d9'; .*known: .*paper-d2.45"):
        load_recipe("paper-d9")
    with pytest.raises(InputError, match="no such file"):
        load_recipe("/no/such/recipe.toml")


def test_bad_seed():
    with pytest.raises(InputError, match="seed"):
        generate_terrain(recipe_from_dict(_wm_recipe()), -1)


def test_nested_tables_build_nested_configs_and_keep_the_other_defaults():
    from offroadbench.terrain.craters import PopulationConfig, StampOptions
    from offroadbench.terrain.fractal.multifractal import PAPER_WM

    data = _wm_recipe(
        cr={"generator": "craters", "population": {"k": 2.0, "profile": "yoshikawa"}, "stamp": {"roughness": 0.1}}
    )
    cfg = recipe_from_dict(data).layers[1].config
    assert cfg.population == PopulationConfig(k=2.0, profile="yoshikawa")
    assert cfg.stamp == StampOptions(roughness=0.1)
    # a nested table starts from the field's default, not the nested class's
    mf = recipe_from_dict(
        {"grid": {"rows": 30, "cols": 40, "cell_size_m": 0.1}, "layers": {"m": {"generator": "multifractal", "wm": {"L": 50.0}}}}
    ).layers[0].config
    assert mf.wm.L == 50.0 and mf.wm.smoothing_sigma_px == PAPER_WM.smoothing_sigma_px == 0.5


def test_dotted_overrides_reach_nested_configs_and_create_their_tables():
    r = load_recipe("lunar-mare")
    r2 = apply_overrides(r, {"layers.craters.population.k": 2, "layers.craters.stamp.min_diameter_cells": 4})
    cfg = r2.layers[1].config
    assert cfg.population.k == 2.0 and isinstance(cfg.population.k, float)
    assert cfg.stamp.min_diameter_cells == 4.0
    assert cfg.population.c == r.layers[1].config.population.c  # untouched keys stay
    r3 = apply_overrides(load_recipe("paper-d2.45"), {"layers.base.wm.origin_offset_px": 300})
    assert r3.layers[0].config.wm.origin_offset_px == 300.0


@pytest.mark.parametrize(
    "key, match",
    [
        ("layers.craters.population.kk", r"unknown key\(s\) layers\.craters\.population\.kk; known keys of layers\.craters\.population: .*\bk\b"),
        ("layers.craters.populaton.k", r"unknown key\(s\) layers\.craters\.populaton;"),
        ("layers.craters.population.k", r"layers\.craters\.population\.k = 9\.0 is out of range"),
        ("layers.crater.population.k", r"no layer 'crater'; layers: base, craters"),
        ("layers.craters.population.k.x", r"layers\.craters\.population\.k is a value"),
        ("grid.rows", r"grid\.rows must be an integer"),
    ],
)
def test_bad_nested_overrides_name_the_dotted_path(key, match):
    value = 9.0 if key.endswith(".k") else 9.5
    with pytest.raises(InputError, match=match):
        apply_overrides(load_recipe("lunar-mare"), {key: value})


def test_multifractal_refuses_per_layer_fields_in_the_shared_wm_table():
    data = {"grid": {"rows": 30, "cols": 40, "cell_size_m": 0.1}, "layers": {"m": {"generator": "multifractal", "wm": {"D": 2.3}}}}
    with pytest.raises(InputError, match=r"layers\.m\.wm\.D = 2\.3 is not used.*D_low, D_mid, D_high"):
        recipe_from_dict(data)


def test_a_value_where_a_nested_table_belongs_is_refused():
    data = _wm_recipe(cr={"generator": "craters", "population": 3})
    with pytest.raises(InputError, match=r"layers\.cr\.population must be a table of PopulationConfig settings"):
        recipe_from_dict(data)
