"""The report's header names a terrain's own gravity as such, and gives soft soil in another
gravity than Earth's its caveat (issue 46)."""

from offroadbench.study import study_from_dict
from offroadbench.study.report import held_fixed
from offroadbench.study.report.header import SOFT_SOIL_CAVEAT
from offroadbench.study.runner import study_meta
from offroadbench.study.spec import plan_cells


def _rows(sim: dict, recipe: str = "lunar-mare") -> dict:
    data = {"study": {"name": "g", "recipe": recipe, "root_seed": 1, "terrains_per_cell": 1, "missions_per_terrain": 1},
            "recipe_overrides": {"grid.rows": 65, "grid.cols": 65}, "sim": sim}
    study = study_from_dict(data)
    df = held_fixed(study_meta(study, plan_cells(study), version="test"))
    return dict(zip(df["setting"], df["note"], strict=True))


def test_a_lunar_terrain_gravity_is_its_own_not_a_changed_default():
    notes = _rows({})
    assert notes["gravity (m/s^2)"].startswith("the terrain's own: moon") and "not the default" not in notes["gravity (m/s^2)"]
    # set in the study, it is a change again
    assert _rows({"gravity_m_s2": 3.71})["gravity (m/s^2)"] == "not the default (9.81)"
    assert _rows({}, recipe="paper-d2.45")["gravity (m/s^2)"] == ""


def test_soft_soil_off_earth_carries_its_caveat():
    assert SOFT_SOIL_CAVEAT in _rows({"tyre_model": "terramechanics"})["soil (terramechanics tyres)"]
    assert SOFT_SOIL_CAVEAT not in _rows({"tyre_model": "terramechanics", "gravity_m_s2": 9.81})["soil (terramechanics tyres)"]
