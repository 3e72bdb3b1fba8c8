"""Surface statistics: Horn slopes, cumulative slope distribution, radial PSD and D, crater SFD fit."""

import math

import numpy as np
import pytest

from offroadbench.terrain.grid import GridConfig
from offroadbench.analysis.surface import (
    cumulative_counts,
    cumulative_slope_distribution,
    fit_sfd_slope,
    fit_spectral_slope,
    horn_slope_deg,
    radial_power_spectrum,
    surface_summary,
)
from offroadbench.plots.surface import plot_surface_analysis
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.fractal.fbm import FBMConfig, generate_fbm


def test_horn_slope_of_a_plane_is_exact():
    y, x = np.mgrid[0:20, 0:30] * 0.1
    hm = Heightmap(0.3 * x - 0.4 * y, 0.1)
    s = horn_slope_deg(hm)
    assert s[1:-1, 1:-1] == pytest.approx(math.degrees(math.atan(0.5)))


def test_cumulative_slope_distribution_counts_steeper_pixels():
    angles, frac = cumulative_slope_distribution(np.array([1.0, 5.0, 5.0, 20.0]), [0.0, 5.0, 10.0, 30.0])
    np.testing.assert_allclose(frac, [1.0, 0.25, 0.25, 0.0])
    _, f = cumulative_slope_distribution(np.linspace(0, 40, 1000))
    assert np.all(np.diff(f) <= 0) and f[0] <= 1.0


def test_spectral_fit_recovers_a_known_power_law():
    hm = generate_fbm(FBMConfig(H=0.5), GridConfig(rows=256, cols=256), np.random.default_rng(0))
    fit = fit_spectral_slope(radial_power_spectrum(hm))
    assert fit.beta == pytest.approx(3.0, abs=0.15)  # 2H + 2 (Yoshikawa & Nishiguchi 2001, Eq. 3)
    assert fit.dimension == pytest.approx(4.0 - fit.beta / 2.0)


def test_spectral_fit_needs_enough_bins():
    hm = Heightmap.flat(8, 8, 1.0).with_z(np.arange(64.0).reshape(8, 8) ** 1.5)
    with pytest.raises(InputError, match="frequency bins"):
        fit_spectral_slope(radial_power_spectrum(hm, bins=4))


def test_sfd_fit_on_an_exact_power_law_sample():
    # deterministic quantiles of a power law with k = 1.8 truncated to [0.3, 10]
    u = (np.arange(20000) + 0.5) / 20000
    lo, hi, k = 0.3, 10.0, 1.8
    d = ((hi**-k - lo**-k) * u + lo**-k) ** (-1 / k)
    assert fit_sfd_slope(d, lo, hi) == pytest.approx(k, abs=0.01)
    assert fit_sfd_slope(d[d < 1.0], lo, 1.0) == pytest.approx(k, abs=0.02)
    with pytest.raises(InputError):
        fit_sfd_slope([1.0], 0.5, 2.0)
    dd, n = cumulative_counts([1.0, 3.0, 2.0])
    np.testing.assert_array_equal(dd, [3.0, 2.0, 1.0])
    np.testing.assert_array_equal(n, [1, 2, 3])


def test_surface_summary_and_figure():
    hm = generate_fbm(FBMConfig(D=2.3, relief_m=0.5), GridConfig(rows=128, cols=128, cell_size_m=0.05), np.random.default_rng(1))
    s = surface_summary(hm)
    assert {"slope_p50_deg", "slope_p90_deg", "slope_p99_deg", "psd_slope_beta", "fractal_dimension"} <= set(s)
    assert s["slope_p50_deg"] <= s["slope_p90_deg"] <= s["slope_p99_deg"]
    assert 2.0 < s["fractal_dimension"] < 3.0
    fig = plot_surface_analysis(hm, crater_diameters_m=[0.5, 0.7, 1.0, 2.0, 0.4])
    assert len(fig.axes) == 3
    fig2 = plot_surface_analysis(hm)
    assert len(fig2.axes) == 2
