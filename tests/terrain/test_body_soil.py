"""A recipe's [body] and [soil]: lunar presets lie on the Moon, trials take the terrain's gravity
and soil unless the study's [sim] sets them."""

import pytest

from offroadbench.bodies import BODIES
from offroadbench.errors import InputError
from offroadbench.sim.config import EARTH_GRAVITY_M_S2, SimConfig
from offroadbench.terrain.recipe import apply_overrides, load_recipe, recipe_from_dict

BASE = {"grid": {"rows": 9, "cols": 9, "cell_size_m": 0.1}, "layers": {"base": {"generator": "fbm"}}}


def test_lunar_presets_are_on_the_moon_with_lunar_regolith():
    for name in ("lunar-mare", "lunar-highland"):
        recipe = load_recipe(name)
        assert recipe.body == "moon" and recipe.gravity_m_s2 == pytest.approx(1.62)
        assert recipe.soil == "lunar-regolith"


def test_paper_presets_name_no_body_and_keep_earth_gravity():
    recipe = load_recipe("paper-d2.45")
    assert recipe.gravity_m_s2 is None and recipe.soil is None
    assert SimConfig().for_terrain(recipe.gravity_m_s2, recipe.soil).gravity_m_s2 == EARTH_GRAVITY_M_S2 == 9.81


def test_body_by_name_or_gravity_value():
    for name, g in BODIES.items():
        assert recipe_from_dict({**BASE, "body": {"name": name}}).gravity_m_s2 == g
    custom = recipe_from_dict({**BASE, "body": {"gravity_m_s2": 0.113}})
    assert custom.body == "custom" and custom.gravity_m_s2 == pytest.approx(0.113)


@pytest.mark.parametrize("body", [{"name": "venus"}, {"gravity_m_s2": 0.0}, {"name": "moon", "g": 1}, "moon"])
def test_bad_body_is_one_clear_error(body):
    with pytest.raises(InputError, match="body"):
        recipe_from_dict({**BASE, "body": body})


def test_soil_is_a_recipe_key_and_a_grid_axis():
    recipe = recipe_from_dict({**BASE, "soil": {"name": "snow"}})
    assert recipe.soil == "snow"
    assert apply_overrides(recipe, {"soil.name": "lete-sand"}).soil == "lete-sand"
    with pytest.raises(InputError, match="soil"):
        recipe_from_dict({**BASE, "soil": {"name": 3}})
    with pytest.raises(InputError, match="soil"):
        recipe_from_dict({**BASE, "soil": {"kind": "sand"}})


def test_study_sim_overrides_the_terrain_body_and_soil():
    assert SimConfig().for_terrain(1.62, "snow").gravity_m_s2 == pytest.approx(1.62)
    assert SimConfig().for_terrain(1.62, "snow").soil == "snow"
    set_by_study = SimConfig(gravity_m_s2=9.81, soil="lete-sand").for_terrain(1.62, "snow")
    assert set_by_study.gravity_m_s2 == 9.81 and set_by_study.soil == "lete-sand"
    assert SimConfig().for_terrain().soil == "lunar-regolith"


def test_study_cells_use_the_terrain_gravity(tmp_path):
    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.study.spec.config import load_study

    def sim_of(plan):  # what drive_terrain gives the World
        recipe = plan.recipe()
        prepared = prepare_terrain(recipe, 1, plan.trial_settings, [])
        return prepared.sim_for(plan.trial_settings.sim)

    path = tmp_path / "s.toml"
    path.write_text('[study]\nname = "g"\nrecipe = "lunar-mare"\nroot_seed = 1\n'
                    '[recipe_overrides]\n"grid.rows" = 65\n"grid.cols" = 65\n[roughness]\nborder_m = 0.5\n'
                    '[grid]\n"sim.gravity_m_s2" = [9.81]\n')
    _, plans = load_study(path)
    assert sim_of(plans[0]).gravity_m_s2 == 9.81
    path.write_text('[study]\nname = "g"\nrecipe = "lunar-mare"\nroot_seed = 1\n'
                    '[recipe_overrides]\n"grid.rows" = 65\n"grid.cols" = 65\n[roughness]\nborder_m = 0.5\n')
    _, plans = load_study(path)
    assert sim_of(plans[0]).gravity_m_s2 == pytest.approx(1.62)


def test_a_png_sidecar_recipe_keeps_its_body_and_soil():
    from offroadbench.bodies import terrain_gravity_and_soil

    data = dict(load_recipe("lunar-mare").data)
    assert terrain_gravity_and_soil(data) == (pytest.approx(1.62), "lunar-regolith")
    assert terrain_gravity_and_soil(dict(load_recipe("paper-d2.3").data)) == (None, None)
    assert terrain_gravity_and_soil(None) == (None, None)
