"""One seeding module: the study's rule is the canonical one, and every table that lists a terrain
shows the integer seed that ``offroadbench generate --seed`` rebuilds it from, bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from offroadbench import seeding
from offroadbench.cli import main
from offroadbench.errors import InputError
from offroadbench.terrain.recipe import apply_overrides, generate_terrain, load_recipe

SMALL = {"grid.rows": 97, "grid.cols": 97}


def test_derived_seeds_equal_the_spawn_tree():
    root = np.random.SeedSequence(11)
    stream = root.spawn(2)[seeding.MISSION_STREAM]
    cell = stream.spawn(1)[0]
    terrain = cell.spawn(3)[2]
    mission = terrain.spawn(5)[4]
    expected = int(mission.generate_state(1, np.uint64)[0] >> np.uint64(1))
    assert seeding.mission_seed(11, 2, 4) == expected
    assert 0 <= expected < 2**63


def test_the_study_rule_keeps_its_numbers():
    """experiments/smoke.toml (root_seed 7) has stored these seeds since before the seeding module."""
    assert [seeding.terrain_seed(7, j) for j in (0, 1)] == [7424838223673998412, 8666231986299349920]
    assert [seeding.mission_seed(7, 0, k) for k in (0, 1)] == [7912314326725388857, 2001388159071612495]


def test_layer_streams_are_keyed_by_name_and_seeds_are_validated():
    root = seeding.seed_sequence(5)
    a = seeding.layer_rng(root, "base").random(3)
    assert np.array_equal(a, seeding.layer_rng(seeding.seed_sequence(5), "base").random(3))
    assert not np.array_equal(a, seeding.layer_rng(root, "craters").random(3))
    for bad in (-1, 1.5, True, "3"):
        with pytest.raises(InputError, match="seed must be an integer >= 0"):
            seeding.seed_sequence(bad)


def _png_levels(path):
    with Image.open(path) as img:
        return np.asarray(img)


def _generate_png(tmp_path, name, seed, sets):
    out = tmp_path / f"{name}.png"
    argv = ["generate", "paper-d2.45", "--seed", str(seed), "-o", str(out)]
    for k, v in sets.items():
        argv += ["--set", f"{k}={v}"]
    assert main(argv) == 0
    return _png_levels(out)


def test_roughness_study_terrain_j_is_generate_with_the_shown_seed(tmp_path, monkeypatch, capsys):
    from offroadbench.io.png16 import write_png16
    from offroadbench.study import roughness

    built = []

    def recording(recipe, seed):
        hm = generate_terrain(recipe, seed)
        built.append((seed, hm))
        return hm

    monkeypatch.setattr(roughness, "generate_terrain", recording)
    recipe = apply_overrides(load_recipe("paper-d2.45"), SMALL)
    table = roughness.roughness_study(recipe, [2.3, 2.6], 2, seed=7, roughness=roughness.RoughnessConfig(border_m=0.5))
    assert list(table["terrain_seed"]) == [seeding.terrain_seed(7, j) for j in (0, 1)] * 2
    for (seed, hm), row in zip(built, table.itertuples(), strict=True):
        assert seed == row.terrain_seed
        again = generate_terrain(apply_overrides(recipe, {"layers.base.D_high": row.D}), row.terrain_seed)
        assert np.array_equal(again.z, hm.z)  # bit for bit
    # and through the CLI: generate --seed <shown> writes the same 16-bit levels
    seed, hm = built[3]
    write_png16(hm, tmp_path / "study.png")
    cli = _generate_png(tmp_path, "cli", seed, {**SMALL, "layers.base.D_high": 2.6})
    assert np.array_equal(cli, _png_levels(tmp_path / "study.png"))
    capsys.readouterr()


def test_study_terrain_j_is_generate_with_the_shown_seed(tmp_path, capsys):
    from offroadbench.io.png16 import write_png16
    from offroadbench.study.runner import plan_tasks
    from offroadbench.study.spec.config import load_study
    from offroadbench.study.execution.tasks import run_terrain

    study, plans = load_study(Path(__file__).resolve().parents[1] / "experiments" / "smoke.toml")
    tasks = [t for t in plan_tasks(study, plans, set()) if t.terrain == 1 and t.cell.index == 2]
    (task,) = tasks
    built = []

    def no_trials(prepared, settings):
        built.append(prepared.hm)
        return iter(())

    messages = list(run_terrain(task, no_trials))
    first = messages[0]
    cell, terrain, shown_seed = first.cell, first.terrain, first.terrain_seed
    assert (type(first).__name__, cell, terrain) == ("TerrainBuilt", 2, 1)
    assert shown_seed == seeding.terrain_seed(study.root_seed, 1) == 8666231986299349920
    sets = {**study.recipe_overrides, "layers.base.D_high": 2.6}
    again = generate_terrain(apply_overrides(load_recipe(study.recipe), sets), shown_seed)
    assert np.array_equal(again.z, built[0].z)  # bit for bit
    write_png16(built[0], tmp_path / "study.png")
    assert np.array_equal(_generate_png(tmp_path, "cli", shown_seed, sets), _png_levels(tmp_path / "study.png"))
    capsys.readouterr()
