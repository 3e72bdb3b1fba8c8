"""Suite files: the shipped suite loads, an edited task needs a new version, what the suite fixes."""

import tomllib

import pytest

from offroadbench.errors import InputError
from offroadbench.suite import load_suite, plan_suite
from offroadbench.suite.spec import category_study

from .conftest import TINY_SUITE, suite_text


def test_the_shipped_suite_loads_with_its_tiers_and_categories():
    suite, path = load_suite("offroadbench-v1")
    assert suite.name == "offroadbench-v1" and path.name == "offroadbench-v1.toml"
    assert suite.tier_names == ("quick", "full")
    assert [c.name for c in suite.categories] == ["multifractal", "lunar-craters", "real-dem", "soft-soil"]


def test_every_tier_of_the_shipped_suite_plans(tmp_path):
    suite, _ = load_suite("offroadbench-v1")
    for tier in suite.tier_names:
        planned = plan_suite(suite, tier, "astar")
        assert all(p.study.name == f"offroadbench-v1-{tier}-{p.category.name}" for p in planned)
        assert all(p.plans[0].trial_settings.planner.name == "astar" for p in planned)
    soft = next(p for p in plan_suite(suite, "quick", "straight") if p.category.name == "soft-soil")
    assert soft.plans[0].trial_settings.sim.tyre_model == "terramechanics"


def test_an_edited_task_is_refused_until_the_suite_is_renamed(tiny_suite):
    text = tiny_suite.read_text()
    tiny_suite.write_text(text.replace("missions_per_terrain = 1", "missions_per_terrain = 2", 1))
    with pytest.raises(InputError, match="tasks of suite tiny-v1 changed.*new suite version"):
        load_suite(str(tiny_suite))
    # a description is not a task: editing it keeps the version
    tiny_suite.write_text(text.replace("paper terrain at two roughness levels", "two levels"))
    load_suite(str(tiny_suite))


def test_unknown_keys_tiers_and_planners_name_the_closest(tmp_path, tiny_suite):
    bad = tmp_path / "bad.toml"
    bad.write_text(suite_text(TINY_SUITE.replace("sensor = ", "sensr = ")))
    with pytest.raises(InputError, match="did you mean 'sensor'"):
        load_suite(str(bad))
    suite, _ = load_suite(str(tiny_suite))
    with pytest.raises(InputError, match="did you mean 'quick'"):
        suite.tier("quik")
    with pytest.raises(InputError, match="unknown planner or policy 'astr'.*did you mean 'astar'"):
        plan_suite(suite, "quick", "astr")
    with pytest.raises(InputError, match="unknown suite 'tiny'"):
        load_suite("tiny")


def test_a_category_may_not_set_what_the_suite_fixes(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(suite_text(TINY_SUITE.replace('missions = {{ length_m = 4.0, border_m = 1.0 }}\n[categories.tiers.quick]\nstudy = {{ terrains_per_cell = 2, missions_per_terrain = 1 }}\n\n[[categories]]',
                                                  'missions = {{ length_m = 4.0, border_m = 1.0 }}\nvehicle = {{ name = "jackal" }}\n[categories.tiers.quick]\nstudy = {{ terrains_per_cell = 2, missions_per_terrain = 1 }}\n\n[[categories]]', 1)))
    with pytest.raises(InputError, match=r"\[vehicle\] name is set by the suite"):
        load_suite(str(path))


def test_the_tier_is_laid_over_the_category_and_the_suite_fixes_the_rest(tiny_suite):
    suite, _ = load_suite(str(tiny_suite))
    data = category_study(suite, suite.categories[0], "quick", "lattice")
    assert data["study"]["terrains_per_cell"] == 2 and data["study"]["recipe"] == "paper-d2.45"
    assert data["planner"] == {"name": "lattice", "sensor": "oracle"}
    assert data["vehicle"] == {"name": "husky"} and data["controller"] == {"cruise_speed_m_s": 1.0}
    assert tomllib.loads(tiny_suite.read_text())["categories"][0]["study"]["study"] == {"recipe": "paper-d2.45", "root_seed": 5}


def test_a_category_may_not_vary_the_planner_either(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(suite_text(TINY_SUITE.replace('grid = {{ "recipe.layers.base.D_high" = [2.3, 2.6] }}',
                                                  'grid = {{ "planner.name" = ["straight", "astar"] }}')))
    with pytest.raises(InputError, match=r"\[planner\] name is set by the suite"):
        load_suite(str(path))
