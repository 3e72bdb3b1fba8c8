"""Terrains are bit-identical to the ones the code made before the nested-config redesign.

The sha256 of ``z`` (float64, C order) was recorded on commit 2992680 (flat configs, grid fields
in every generator config) for every preset in ``terrains/`` on a small grid at seeds 0 and 1, for
the full 1009 x 1009 ``paper-d2.45`` at seed 0, and for one small recipe per generator and modifier
setting that no preset covers. A refactor of configs, grids, seeding or file loading must not move
a single bit; a change that means to move them must say so and record new hashes.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from offroadbench.terrain.craters import recipe_craters
from offroadbench.terrain.recipe import apply_overrides, generate_terrain, load_recipe, recipe_from_dict

PRESETS = {
    ("asteroid-regolith", 0): "99514c747eef648d38ee80a2b93efe4cefc1a2508134dd5b71ad135cfea5d3b4",
    ("asteroid-regolith", 1): "3b753dd48f7bcd7cb46b77e44471db42f9f476715b2f5cc23466dfecb0bc9d0e",
    ("lunar-highland", 0): "8ef545a6089ddb5e5e58258ef1befa1ad7d506d390ad38fd4033572c7df59883",
    ("lunar-highland", 1): "abf680b12cf2ce2aa77496548e844eec55c94a07e8d33019df465c6008a2b664",
    ("lunar-mare", 0): "6076ef6e33526de950307f6143d412fcdfd04dcde60a841eaeb542d7157441af",
    ("lunar-mare", 1): "d7dd6306105963bdb4fad45d53db397a577ebad15b00bb82ca22f2df9b456e69",
    ("multifractal-cratered", 0): "6c03bd496ce58a56fce6465ed82fb42fa9d583fc3e9fdc280e1e53dcd151819a",
    ("multifractal-cratered", 1): "19ad0f5bb397ed758b99fb3b349b43128d4b52a11b5a9c7cb8f78c9b2da45bb3",
    ("paper-d2.3", 0): "b156571a30ab0a71a28998f8cd078b684c989034080004598a4e1ad47638f596",
    ("paper-d2.3", 1): "d8677b439a689500422083e8626d9dd4aaf86ed8cf1728533662ec8d852dfa09",
    ("paper-d2.45", 0): "4372343e4850afa59db9317e228cc78ca286bf3b3649c5199c8119c85fea2407",
    ("paper-d2.45", 1): "f717df0dcd13a4604781d6e8181741508cfb8f9f34204c65836155a5428e8f07",
    ("paper-d2.6", 0): "11eb239afee92747fd4fa9a736c8a79c1cfcbc83c846adbe068a1474e36c6ed8",
    ("paper-d2.6", 1): "6472be324f58702a58a539fa433e9e664fb3ea490ce0c4cc3aeb92f2ef3e15f2",
}
#: the presets were hashed on this grid (their own cell size)
SMALL = {"grid.rows": 129, "grid.cols": 97}

FULL_PAPER_D245_SEED0 = "35e3d925248795164773c589603a164f2a47b966a7a9e47fa088fdabbad54456"

GRID = {"rows": 65, "cols": 81, "cell_size_m": 0.1}
DEM_GRID = {"rows": 60, "cols": 50, "cell_size_m": 0.3}
LI_CRATERS = {
    "generator": "craters",
    "population": {"profile": "li_complex", "c": 0.1, "d_max_m": 4.0},
    "stamp": {"rim_irregularity": 0.1, "roughness": 0.05},
}
#: name: (recipe layers, grid, sha256 of z at seed 3)
RECIPES = {
    "wm": (
        {"base": {"generator": "wm", "M": 8, "D": 2.4, "smoothing_sigma_px": 0.5}},
        GRID,
        "8741e01210d9617580859c5b7892f325fd6c769c1926edbafccfefc383a62f7e",
    ),
    "wm-metres": (
        {"base": {"generator": "wm", "M": 8, "D": 2.3, "coordinates": "metres", "L": 10.0, "origin_offset_px": 30.0}},
        GRID,
        "dd669d4201601cac6b070550575a5ac2f593e6a6018e9083e261d4a5728605f9",
    ),
    "fbm-H": (
        {"base": {"generator": "fbm", "H": 0.7, "relief_m": 2.0}},
        GRID,
        "a81740c56022a4b598867f626b17091bd73b6a24e58c470c4fdccffeae8d2c10",
    ),
    "diamond_square": (
        {"base": {"generator": "diamond_square", "D": 2.3}, "up": {"generator": "rmd_expand", "levels": 1}},
        GRID,
        "5f1ae24f16bd815c5417d7673efc5b06a82f66b90d0755e6dd2cf869c3939332",
    ),
    "ds-relief-spectral": (
        {
            "base": {"generator": "diamond_square", "D": 2.5, "relief_m": 1.0},
            "sp": {"generator": "spectral_restore", "cutoff_wavelength_m": 1.0},
        },
        GRID,
        "d0f42ac2653c977695810c2fb1c0d9ee6e18751dcd59d0dba750f97ce6675476",
    ),
    "dem-sample": (
        {"base": {"generator": "dem"}},
        DEM_GRID,
        "c0f205293c948a3d2c8157ac185f9e9b9661b6c3bc4069a6ebb717fa37e13860",
    ),
    "dem-sample-sum": (
        {
            "base": {"generator": "dem", "origin_x_m": 1.0, "origin_y_m": 2.0},
            "fb": {"generator": "fbm", "relief_m": 0.1, "weight": 0.5},
        },
        DEM_GRID,
        "a3a89098f787b301dfdea9d336a8dd2ea248126902db002550780f74cc1e7c69",
    ),
    "craters-kth": (
        {
            "base": {"generator": "fbm", "relief_m": 0.3},
            "cr": {
                "generator": "craters",
                "degradation": 0.3,
                "population": {"sampling": "kth_largest", "c": 0.2, "k": 2.0, "d_max_m": 3.0, "profile": "yoshikawa"},
            },
        },
        GRID,
        "19e0374a27a66eca559674fe9e17fa64ef8a826333526a70be1bc2fe5fe67898",
    ),
    "craters-li": (
        {"base": {"generator": "fbm", "relief_m": 0.3}, "cr": LI_CRATERS},
        GRID,
        "8a1a4e131c567810042ba4c38ecb41c52e1c942cacd26159c61951dfdf1445d0",
    ),
    "multifractal-product": (
        {
            "base": {"generator": "fbm", "relief_m": 1.0},
            "m": {"generator": "multifractal", "combine": "product", "M": [4, 8, 16], "wm": {"n_max": 200, "band_limited": True}},
        },
        GRID,
        "dbb87cc62897f6bc90bcdc7c228bce024008ace00866ed2e0348bd5633ace245",
    ),
}
#: sha256 of the terrains with a W-M layer under the default ``method = "nufft"`` (same keys)
NUFFT = {
    ('multifractal-cratered', 0): "0a33f34c46b40b326d5bdaaecee6feff576a53821c1cd1e66c650473ce41eea7",
    ('multifractal-cratered', 1): "9d834483a88ab7a66840e37a7da809e1850b6109c3b662c362f48bd5ae350765",
    ('paper-d2.3', 0): "fa35cd20be7e5976b0775115cb5cb445d7292536cb73e4c9973d10a77e914a9c",
    ('paper-d2.3', 1): "69f87ea50f3ac35320127ee1a79cf927ebc527233f3a18407680481b7004c7cf",
    ('paper-d2.45', 0): "d7ebe94e1174d0435e56aa75e56d3ebbcf5d50af1c28b417976f9d729fa261bd",
    ('paper-d2.45', 1): "19955865bf03e72301e27cf4b48bbf92ab546ee7a154dc2793c468c9b2c9f6a4",
    ('paper-d2.6', 0): "1e50aa9163c396810182c39e7aa0fc93a4216bbc3ebce77f939d30ec9bb94782",
    ('paper-d2.6', 1): "3d068500187e1457e216e5c47663cd869876b32f8c8aeb051685b337e5d9b3b3",
    'full': "fa2fe9de43f58f7982cdc8e6b64979c1916d30776de7ab0581d2c5f31522d923",
    'multifractal-product': "fb01e2b4d194926108c31a7a2edc68749d040bde7f4fe9ae9f39dff8502c917a",
    'wm': "cedae6f2a76c96b5f34d1da6921b707afad41296e6b6e877eb4f268ea2a5f1f5",
    'wm-metres': "d869afa7d942baa084836b72ca2133d5826567013696fcc344b8447b31ff1989",
}
CRATER_FILE_SHA = "68e8c099924714ca34dd07e2d333601f2edacb79786fcaf2a8025e59a79e1195"


def sha(hm) -> str:
    return hashlib.sha256(np.ascontiguousarray(hm.z, dtype=np.float64).tobytes()).hexdigest()


def expected(key, table: dict, method: str) -> str:
    return NUFFT.get(key, table[key]) if method == "nufft" else table[key]


@pytest.fixture(params=["nufft", "gemm"])
def method(request, monkeypatch) -> str:
    """Run with the default W-M evaluation, or with the reference GEMM forced everywhere."""
    import offroadbench.terrain.fractal.wm as wm

    if request.param == "gemm":
        monkeypatch.setattr(wm, "wm_surface_nufft", wm._wm_surface_gemm)
    return request.param


@pytest.mark.parametrize("name, seed", sorted(PRESETS))
def test_every_preset_is_bit_identical(name, seed, method):
    recipe = apply_overrides(load_recipe(name), SMALL)
    assert sha(generate_terrain(recipe, seed)) == expected((name, seed), PRESETS, method)


def test_every_preset_is_covered():
    from offroadbench.terrain.recipe import list_presets

    assert set(list_presets()) == {name for name, _ in PRESETS}


def test_full_size_paper_terrain_is_bit_identical(method):
    hm = generate_terrain(load_recipe("paper-d2.45"), 0)
    assert hm.shape == (1009, 1009)
    assert sha(hm) == expected("full", {"full": FULL_PAPER_D245_SEED0}, method)


@pytest.mark.parametrize("name", sorted(RECIPES))
def test_generator_recipes_are_bit_identical(name, method):
    layers, grid, _ = RECIPES[name]
    recipe = recipe_from_dict({"grid": grid, "layers": layers}, source=name)
    assert sha(generate_terrain(recipe, 3)) == expected(name, {k: v[2] for k, v in RECIPES.items()}, method)


def test_crater_file_layer_is_bit_identical(tmp_path):
    from offroadbench.io.craters_csv import write_craters

    sampled = recipe_from_dict({"grid": GRID, "layers": {"base": {"generator": "fbm", "relief_m": 0.3}, "cr": LI_CRATERS}})
    path = write_craters(recipe_craters(sampled, 5)["cr"], tmp_path / "craters.csv")
    layers = {"base": {"generator": "fbm", "relief_m": 0.3}, "cr": {"generator": "craters", "crater_file": str(path)}}
    assert sha(generate_terrain(recipe_from_dict({"grid": GRID, "layers": layers}), 3)) == CRATER_FILE_SHA
