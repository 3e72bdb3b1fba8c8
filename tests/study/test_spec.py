"""Study configs, grid cells and seeds (issue 4, items 1-2)."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from offroadbench.errors import InputError
from offroadbench.study.spec.config import load_study, plan_cells, study_from_dict, study_id
from offroadbench.study.runner import plan_tasks

ROOT = Path(__file__).resolve().parents[2]

BASE = {
    "study": {"name": "t", "recipe": "paper-d2.45", "root_seed": 3, "terrains_per_cell": 2, "missions_per_terrain": 3},
    "grid": {"recipe": {"layers": {"base": {"D_high": [2.3, 2.6]}}}},
    "recipe_overrides": {"grid.rows": 101, "grid.cols": 101},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5},
}


def with_(path: str, value):
    data = copy.deepcopy(BASE)
    node = data
    *head, last = path.split("/")
    for part in head:
        node = node.setdefault(part, {})
    node[last] = value
    return data


def test_shipped_studies_load_and_match_the_paper_protocol():
    study, cells = load_study(ROOT / "experiments" / "majhor2023.toml")
    assert study.n_trials == 1200  # 3 D x 20 terrains x 20 missions (Sec. 2.4)
    assert [c.values["recipe.layers.base.D_high"] for c in cells] == [2.3, 2.45, 2.6]
    for c in cells:
        assert c.recipe_data["grid"]["rows"] == 1009
        assert c.recipe().layers[0].config.D_high == c.values["recipe.layers.base.D_high"]
        assert c.section("missions").length_m == 35.0
        assert c.section("rules").tip_angle_deg == 75.0
    smoke, _ = load_study(ROOT / "experiments" / "smoke.toml")
    assert smoke.n_trials <= 30


def test_nested_and_quoted_grid_keys_are_the_same_axis():
    nested = study_from_dict(BASE)
    quoted = study_from_dict(with_("grid", {"recipe.layers.base.D_high": [2.3, 2.6]}))
    assert nested.grid == quoted.grid
    assert nested.column_names() == {"recipe.layers.base.D_high": "D_high"}


def test_cells_are_the_cartesian_product_first_axis_slowest():
    data = with_("grid", {"recipe.layers.base.D_high": [2.3, 2.6], "rules.tip_angle_deg": [60.0, 75.0, 80.0]})
    study = study_from_dict(data)
    cells = plan_cells(study)
    assert study.n_cells == 6 and len(cells) == 6
    assert [(c.values["recipe.layers.base.D_high"], c.values["rules.tip_angle_deg"]) for c in cells] == [
        (2.3, 60.0), (2.3, 75.0), (2.3, 80.0), (2.6, 60.0), (2.6, 75.0), (2.6, 80.0)
    ]
    assert cells[4].section("rules").tip_angle_deg == 75.0
    assert cells[4].section("roughness").border_m == 0.5  # fixed tables still apply


@pytest.mark.parametrize(
    "path, value, words",
    [
        ("study/colour", "red", ["colour", "known keys"]),
        ("studyy", {}, ["studyy", "known"]),
        ("study/terrains_per_cell", 0, ["terrains_per_cell", "0"]),
        ("study/root_seed", -1, ["root_seed"]),
        ("grid", {"recipe.layers.base.D_high": []}, ["D_high", "non-empty"]),
        ("grid", {"recipe.layers.base.D_high": 2.3}, ["D_high", "list"]),
        ("grid", {"tyres.width": [1, 2]}, ["tyres.width"]),
        ("grid", {"recipe.layers.base.D_high": [2.3, 3.5]}, ["D_high", "3.5"]),
        ("grid", {"rules.tip_angle_deg": [75.0, -1.0]}, ["tip_angle_deg", "-1"]),
        ("missions/count", 5, ["missions_per_terrain"]),
        ("missions/lenght_m", 5.0, ["lenght_m", "known keys"]),
        ("vehicle/name", "tank", ["tank", "husky"]),
        ("vehicle/wheel_radius_m", -0.1, ["wheel_radius_m"]),
        ("study/recipe", "no-such-preset", ["no-such-preset"]),
    ],
)
def test_bad_input_is_refused_with_the_field_named(path, value, words):
    with pytest.raises(InputError) as err:
        plan_cells(study_from_dict(with_(path, value)))
    for w in words:
        assert w in str(err.value)


def test_study_file_errors_name_the_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('[study]\nname = "x"\nrecipe = "paper-d2.45"\nroot_seed = 1\n[grid]\n"recipe.layers.base.D_high" = [4.0]\n')
    with pytest.raises(InputError, match=r"s\.toml.*D_high"):
        load_study(p)


def test_seeds_do_not_depend_on_counts_or_order():
    study = study_from_dict(BASE)
    cells = plan_cells(study)
    small = {(t.cell.index, t.terrain): (t.terrain_seed, t.missions) for t in plan_tasks(study, cells, set())}
    data = copy.deepcopy(BASE)
    data["study"].update(missions_per_terrain=5, terrains_per_cell=4)
    bigger = study_from_dict(data)
    big = {(t.cell.index, t.terrain): (t.terrain_seed, t.missions) for t in plan_tasks(bigger, plan_cells(bigger), set())}
    for key, (tseed, missions) in small.items():
        assert big[key][0] == tseed
        assert big[key][1][: len(missions)] == missions
    # paired: terrain j has the same seed in every cell; unpaired: all differ
    assert small[(0, 1)][0] == small[(1, 1)][0]
    unpaired = study_from_dict(with_("study/paired_terrains", False))
    ups = {(t.cell.index, t.terrain): t.terrain_seed for t in plan_tasks(unpaired, plan_cells(unpaired), set())}
    assert len(set(ups.values())) == len(ups)


def test_plan_tasks_skips_done_trials_and_is_terrain_major():
    study = study_from_dict(BASE)
    cells = plan_cells(study)
    tasks = plan_tasks(study, cells, {(0, 0, 0), (0, 0, 2), (1, 1, 0), (1, 1, 1), (1, 1, 2)})
    assert [(t.cell.index, t.terrain) for t in tasks] == [(0, 0), (1, 0), (0, 1)]
    assert [k for k, _ in tasks[0].missions] == [1]


def test_study_id_changes_with_the_config_and_the_recipe():
    a = study_from_dict(BASE)
    b = study_from_dict(with_("study/root_seed", 4))
    c = study_from_dict(with_("recipe_overrides", {"grid.rows": 103, "grid.cols": 101}))
    ids = {study_id(s, plan_cells(s)) for s in (a, b, c)}
    assert len(ids) == 3
    assert study_id(a, plan_cells(a)) == study_id(study_from_dict(BASE), plan_cells(study_from_dict(BASE)))


def test_worker_memory_estimate_counts_one_heightfield_tile():
    """A worker's peak is its map plus PyBullet's temporary copy of one tile's triangles: tiling
    a 1009^2 map must bring the estimate from ~0.9 GB down to the map's share."""
    from offroadbench.memory import TILE_BUILD_BYTES_PER_CELL, WORKER_BASE_BYTES, WORKER_BYTES_PER_CELL
    from offroadbench.study.runner import worker_memory_bytes

    import tomllib

    data = tomllib.loads((ROOT / "experiments" / "majhor2023.toml").read_text())
    tiled = worker_memory_bytes(plan_cells(study_from_dict(data)))
    data.setdefault("sim", {})["heightfield_tile_cells"] = 0
    whole = worker_memory_bytes(plan_cells(study_from_dict(data)))
    n = 1009 * 1009
    assert whole == WORKER_BASE_BYTES + (WORKER_BYTES_PER_CELL + TILE_BUILD_BYTES_PER_CELL) * n
    assert tiled == WORKER_BASE_BYTES + WORKER_BYTES_PER_CELL * n + TILE_BUILD_BYTES_PER_CELL * 253 * 253
    assert tiled < 0.3 * 2**30 < 0.8 * 2**30 < whole
