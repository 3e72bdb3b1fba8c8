"""Terrains are bit-identical on every x86-64 CPU, and a refactor moves no bit of them.

The pinned sha256 are of ``z`` (float64, C order) as ``generate_terrain`` returns it by default,
i.e. quantised to the 16-bit levels of the PNG export (``[grid] quantise = "png16"``,
:mod:`offroadbench.levels16`). Those bits do not depend on the CPU's SIMD or BLAS kernels (checked in
``tests/test_portable.py`` by recomputing them with numpy's and OpenBLAS's dispatch switched down),
so these hashes hold on the AMD AVX2, AMD AVX-512 and Intel AVX-512 machines alike. They were
recorded when quantisation became the default (issue 24); the float64 terrain under them is the one
the nested-config redesign pinned on commit 2992680. Every preset in ``terrains/`` is covered on a
small grid at seeds 0 and 1, the full 1009 x 1009 ``paper-d2.45`` at seed 0, and one small recipe
per generator and modifier setting that no preset covers. A change that means to move them must
say so and record new hashes. ``quantise = "none"`` (float64 as generated) is platform-dependent in
its last bits and is checked for same-machine determinism only (last test).
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from offroadbench.terrain.craters import recipe_craters
from offroadbench.terrain.recipe import apply_overrides, generate_terrain, load_recipe, recipe_from_dict

PRESETS = {
    ("jacksboro-rover", 0): "5d0230b2187234981c24569a21e6c711ba13c2f0eb0ab49d53ad3a9299cd9e64",
    ("jacksboro-rover", 1): "8b62cca7bef42df4cab5c26a5f98221361266afa8bec1fe9e8b6642dfe536eb6",
    ("asteroid-regolith", 0): "85262fade144ecfba1ccca662d36acadc5f67d08ac81d23b4b0d81bd9b538f69",
    ("asteroid-regolith", 1): "b289b05c1213c337f828f63b795d426829c356de106c4c70a1928389bb41d36d",
    ("lunar-highland", 0): "b736a7e7008e3ebd6287c291ebc448c04b23f4793d623f57edab0c88ff24dbbe",
    ("lunar-highland", 1): "a53539fe18fa400073a94e53c044c00937950769cc50a3372d463c0335b7933e",
    # lunar-highland's layers with a soil map: the same heights (the map changes no height)
    ("lunar-highland-crater-floors", 0): "b736a7e7008e3ebd6287c291ebc448c04b23f4793d623f57edab0c88ff24dbbe",
    ("lunar-highland-crater-floors", 1): "a53539fe18fa400073a94e53c044c00937950769cc50a3372d463c0335b7933e",
    ("lunar-mare", 0): "bec3e10a9364d20d641eab46005110a18739258d6b7e3e06ba5fa7b02bcc593d",
    ("lunar-mare", 1): "6f32b18524e3918b428b9de035914cd78e6693d529f3cc6d8e8af781aa281234",
    ("lunar-mare-3.5ga", 0): "d7006abb89e78146bd3742178fc0d7d591a6e4c52204d7bb8c7c1e716252ef7a",
    ("lunar-mare-3.5ga", 1): "4842e7ef98042595a9e4b40f6cd8641800ed73de5cd04454dbad534e8f877150",
    ("multifractal-cratered", 0): "de962c48add44c8bc55044f128c89c2be7d9b12ac555418d84f66030008ecfd0",
    ("multifractal-cratered", 1): "51ab0189a84d2d2e408db58028f54baec7a5132df7f0274032b650eb56970aa1",
    ("paper-d2.3", 0): "a9f18ffeff1d4ab916df1910f9a6bbee4d9fbf63cf6a282ff8659088117686bc",
    ("paper-d2.3", 1): "9953a21b2eaedff776a06f1b76eb96c13634656e0df244b656ae745233c32b84",
    ("paper-d2.45", 0): "30947d815d53343bf96e90a83bc705ebe335ec21e00e6e9134a3825e650d5d22",
    ("paper-d2.45", 1): "8a62df43b9cc5f5a38eb701d7ad87f9034b51c7d9dde43250a1f0885ef54f73a",
    ("paper-d2.6", 0): "784e2686b048da9d2a96facd3d195c213f4aad1822873c9b69c9458eb1baaaa2",
    ("paper-d2.6", 1): "2ea71f37fd264d0dcdafe55ddecd67f1593748b22c79ffb482b344d76d13dbb7",
}
#: the presets were hashed on this grid (their own cell size)
SMALL = {"grid.rows": 129, "grid.cols": 97}
#: ... except a real DEM restored below a 185 m cut-off, which needs a map longer than that
#: (the same grid at 4 m: 512 x 384 m)
SMALL_FOR = {"jacksboro-rover": {**SMALL, "grid.cell_size_m": 4.0}}

FULL_PAPER_D245_SEED0 = "08933cba7fda4b39f4c9482a36b18a4cdbd626a4195b6589ea38266ad8ecba7f"

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
        "88b6cfa67c819bda2a4b0f03d4d526c1b5550196c35dceb5712ffa2a625a73c9",
    ),
    "wm-metres": (
        {"base": {"generator": "wm", "M": 8, "D": 2.3, "coordinates": "metres", "L": 10.0, "origin_offset_px": 30.0}},
        GRID,
        "c774fdafbe67b5124ff42bfb8965deb37c3c4b8174e1ff2ee1d3408bdd2bb52e",
    ),
    "fbm-H": (
        {"base": {"generator": "fbm", "H": 0.7, "relief_m": 2.0}},
        GRID,
        "6acbb0139bb88217497f91c7c2a5f55a280b529a01142b11767e91b682c5901b",
    ),
    "diamond_square": (
        {"base": {"generator": "diamond_square", "D": 2.3}, "up": {"generator": "rmd_expand", "levels": 1}},
        GRID,
        "427e31280c290dfebf80ef1ca7a6fed675d48c38798d1004fb0c79e68f311a9c",
    ),
    "ds-relief-spectral": (
        {
            "base": {"generator": "diamond_square", "D": 2.5, "relief_m": 1.0},
            "sp": {"generator": "spectral_restore", "cutoff_wavelength_m": 1.0},
        },
        GRID,
        "d211fa27ebb25dcc8f9577ca99c2362923955c3e5bc9be76f91241af7bdcf35f",
    ),
    "dem-sample": (
        {"base": {"generator": "dem"}},
        DEM_GRID,
        "c6395f234ac83c81d616a17bdb0e516de6a67bd1403bba4d95bbea464e673478",
    ),
    "dem-sample-sum": (
        {
            "base": {"generator": "dem", "origin_x_m": 1.0, "origin_y_m": 2.0},
            "fb": {"generator": "fbm", "relief_m": 0.1, "weight": 0.5},
        },
        DEM_GRID,
        "933780e71c9261b66bafc7ffeabf1e127ebd36c30ecc7c180c9378f15812b0b0",
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
        "e0dce6bba82565eabbe16231656bf59e9b1a4b846bd11d9f3eb0de492ff98ae3",
    ),
    "craters-li": (
        {"base": {"generator": "fbm", "relief_m": 0.3}, "cr": LI_CRATERS},
        GRID,
        "978e7a135dd5529066518e0f8cd9f369f25a5d48b86632ed66f02bfaf0160678",
    ),
    "multifractal-product": (
        {
            "base": {"generator": "fbm", "relief_m": 1.0},
            "m": {"generator": "multifractal", "combine": "product", "M": [4, 8, 16], "wm": {"n_max": 200, "band_limited": True}},
        },
        GRID,
        "7ba9d417543c26c61230107a27e1e650618b8bb96d18ff78cc4f3384c2a78812",
    ),
}
#: sha256 of the terrains with a W-M layer under the default ``method = "nufft"`` (same keys)
NUFFT = {
    ('multifractal-cratered', 0): "de962c48add44c8bc55044f128c89c2be7d9b12ac555418d84f66030008ecfd0",
    ('multifractal-cratered', 1): "51ab0189a84d2d2e408db58028f54baec7a5132df7f0274032b650eb56970aa1",
    ('paper-d2.3', 0): "a9f18ffeff1d4ab916df1910f9a6bbee4d9fbf63cf6a282ff8659088117686bc",
    ('paper-d2.3', 1): "96f8d90a84b923e827c21129cf8a0e0157c9a6afd1818cd68d0a51ffa0ab50a8",
    ('paper-d2.45', 0): "30947d815d53343bf96e90a83bc705ebe335ec21e00e6e9134a3825e650d5d22",
    ('paper-d2.45', 1): "8a62df43b9cc5f5a38eb701d7ad87f9034b51c7d9dde43250a1f0885ef54f73a",
    ('paper-d2.6', 0): "854be351b3f4036742e43a21703b863178fa1ac081ca0a8bbd012e62f011b24b",
    ('paper-d2.6', 1): "bde6a19ade6671495008848f8030ce6f7122c855f61b97c5448280015f384aba",
    'full': "deaccc13168d076f2619e172289c7144d7ceb9c90115a391b84af82db03056a1",
    'multifractal-product': "7ba9d417543c26c61230107a27e1e650618b8bb96d18ff78cc4f3384c2a78812",
    'wm': "88b6cfa67c819bda2a4b0f03d4d526c1b5550196c35dceb5712ffa2a625a73c9",
    'wm-metres': "427426666a94cac9b1f8782870bb9393124d694b5853e7849a13a63b0446041c",
}
CRATER_FILE_SHA = "abbc9152c04a32914ade990ec232885466248affccaa6d9880ab764431a96e74"


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
    recipe = apply_overrides(load_recipe(name), SMALL_FOR.get(name, SMALL))
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


def test_unquantised_terrain_is_deterministic_on_one_machine():
    """``quantise = "none"``: same seed, same bits, but only on one machine (the bits depend on the CPU)."""
    recipe = apply_overrides(load_recipe("paper-d2.45"), {**SMALL, "grid.quantise": "none"})
    a, b = generate_terrain(recipe, 4), generate_terrain(recipe, 4)
    assert sha(a) == sha(b)
    quantised = generate_terrain(apply_overrides(load_recipe("paper-d2.45"), SMALL), 4)
    assert sha(a) != sha(quantised)
    assert np.max(np.abs(a.z - quantised.z)) <= quantised.relief_m / 65535 / 2 * (1 + 1e-9)
