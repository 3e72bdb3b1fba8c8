"""describe_terrain: the analyze command's numbers as one result object."""

import numpy as np

from offroadbench.analysis.describe import describe_terrain
from offroadbench.analysis.roughness import RoughnessConfig, class_fractions, classify
from offroadbench.heightmap import Heightmap


def test_plane_of_known_slope_is_one_class_and_areas_add_up():
    # a plane rising 0.5 m per metre: Moore gradient 0.5 everywhere (semi: between 0.293 and 0.820)
    cell = 0.05
    x = np.arange(121) * cell
    hm = Heightmap(np.tile(0.5 * x, (121, 1)), cell)
    rep = describe_terrain(hm, RoughnessConfig(border_m=1.0))
    assert abs(rep.gradient_p50 - 0.5) < 1e-9 and abs(rep.gradient_max - 0.5) < 1e-9
    row = rep.classes.set_index("class")
    assert row.loc["semi", "area_pct"] == 100.0 and row.loc["low", "area_pct"] == 0.0
    inside_side_m = (120 * cell - 2 * 1.0) + cell  # cells from 1 m to 5 m inclusive
    assert abs(row["area_m2"].sum() - inside_side_m**2) < 1e-9
    assert rep.crater_sfd_slope is None


def test_fractions_match_the_pipeline(small_paper_recipe):
    from offroadbench.terrain.recipe import generate_terrain

    hm = generate_terrain(small_paper_recipe, 1)
    rcfg = RoughnessConfig(border_m=0.5)
    rep = describe_terrain(hm, rcfg, crater_diameters_m=[1.0, 2.0, 4.0, 8.0])
    frac = class_fractions(classify(hm, rcfg), hm.cell_size_m, 0.5)
    assert np.allclose(rep.classes["area_pct"], [100 * frac[c] for c in ("low", "semi", "high")])
    assert np.isclose(rep.classes["area_pct"].sum(), 100.0)
    assert rep.crater_sfd_slope is not None and rep.crater_sfd_slope > 0
