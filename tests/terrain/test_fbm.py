"""fBm by Fourier filtering (Yoshikawa & Nishiguchi 2001, Eq. 3-7) and diamond-square RMD (Martin et al. 2014, Sec. IV.A, Eq. 13-15)."""

import math

import numpy as np
import pytest

from offroadbench.terrain.grid import GridConfig
from offroadbench.analysis.surface import fractal_dimension
from offroadbench.errors import InputError
from offroadbench.terrain.fractal.rmd import (
    DiamondSquareConfig,
    diamond_square,
    generate_diamond_square,
    initial_scale,
    scale_factor,
)
from offroadbench.terrain.fractal.fbm import FBMConfig, fbm_surface, generate_fbm


@pytest.mark.parametrize("D", [2.2, 2.5])
def test_fbm_comes_back_with_the_requested_fractal_dimension(D):
    est = [fractal_dimension(generate_fbm(FBMConfig(D=D), GridConfig(rows=257, cols=257), np.random.default_rng(s))) for s in range(4)]
    assert np.mean(est) == pytest.approx(D, abs=0.05)


def test_fbm_given_H_equals_fbm_given_D():
    a = generate_fbm(FBMConfig(H=0.7), GridConfig(rows=64, cols=80), np.random.default_rng(3))
    b = generate_fbm(FBMConfig(D=2.3), GridConfig(rows=64, cols=80), np.random.default_rng(3))
    np.testing.assert_allclose(a.z, b.z, atol=1e-12)


def test_fbm_relief_and_unit_surface():
    hm = generate_fbm(FBMConfig(relief_m=2.5), GridConfig(rows=50, cols=70, cell_size_m=0.1), np.random.default_rng(0))
    assert hm.shape == (50, 70) and hm.cell_size_m == 0.1
    assert hm.z_min_m == pytest.approx(0.0) and hm.relief_m == pytest.approx(2.5)
    z = fbm_surface(40, 40, 0.8, np.random.default_rng(0))
    assert z.mean() == pytest.approx(0.0, abs=1e-12) and z.std() == pytest.approx(1.0)


def test_rougher_fbm_has_more_short_wavelength_relief():
    def mean_slope(D):
        hm = generate_fbm(FBMConfig(D=D), GridConfig(rows=128, cols=128), np.random.default_rng(1))
        return np.abs(np.diff(hm.z, axis=1)).mean()

    assert mean_slope(2.2) < mean_slope(2.5) < mean_slope(2.8)


@pytest.mark.parametrize(
    "kw, match",
    [({"D": 3.0}, "D"), ({"H": 0.0}, "H"), ({"D": 2.2, "H": 0.8}, "not both"), ({"relief_m": 0.0}, "relief_m")],
)
def test_fbm_config_errors(kw, match):
    with pytest.raises(InputError, match=match):
        FBMConfig(**kw)


def test_diamond_square_scale_factors_follow_eq14_eq15():
    assert scale_factor(2.2) == pytest.approx(2 ** -0.4)
    s = initial_scale(2.2, 0.05, 0.05, 1024)
    assert s == pytest.approx(2 ** -0.4 * 0.05 * 0.05 * 1024 * math.sqrt(1 - 2 ** (2 * 0.8 - 2)))


def test_diamond_square_keeps_the_lattice_and_interpolates_without_noise():
    # with zero displacement every new point is the mean of its parents: a bilinear plane stays a plane
    rng = np.random.default_rng(0)
    z = diamond_square(17, 2.2, 0.0, rng)
    assert np.all(z == 0.0)
    with pytest.raises(ValueError):
        diamond_square(16, 2.2, 1.0, rng)


def test_diamond_square_roughness_grows_with_D():
    def mean_step(D):
        hm = generate_diamond_square(DiamondSquareConfig(D=D, relief_m=1.0), GridConfig(rows=257, cols=257), np.random.default_rng(2))
        return np.abs(np.diff(hm.z, axis=0)).mean()

    assert mean_step(2.1) < mean_step(2.5) < mean_step(2.9)


def test_diamond_square_crops_non_square_grids():
    hm = generate_diamond_square(DiamondSquareConfig(), GridConfig(rows=70, cols=40, cell_size_m=0.2), np.random.default_rng(0))
    assert hm.shape == (70, 40) and hm.cell_size_m == 0.2
