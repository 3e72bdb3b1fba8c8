import numpy as np
import pytest

from offroadbench.heightmap import Heightmap


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def small_paper_recipe():
    """The D = 2.45 paper preset on a 161 x 161 grid (8 m at 5 cm): fast, same physics of roughness."""
    from offroadbench.terrain.recipe import apply_overrides, load_recipe

    return apply_overrides(load_recipe("paper-d2.45"), {"grid.rows": 161, "grid.cols": 161})


@pytest.fixture
def flat_map():
    return Heightmap.flat(21, 31, 0.1, z_m=1.5)
