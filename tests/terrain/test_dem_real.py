"""A real DEM at rover scale: matplotlib's Jacksboro DEM through ``dem`` + ``spectral_restore``
(terrains/jacksboro-rover.toml; issue 33, Deliver 2)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from offroadbench.io.dem import EARTH_RADIUS_M, read_dem
from offroadbench.resources import matplotlib_sample
from offroadbench.terrain.recipe import apply_overrides, generate_terrain, load_recipe, recipe_from_dict

SOURCE = "jacksboro_fault_dem.npz"


@pytest.fixture(scope="module")
def raw():
    return read_dem(matplotlib_sample(SOURCE))


@pytest.fixture(scope="module")
def npz():
    with np.load(matplotlib_sample(SOURCE)) as d:
        return {k: np.asarray(d[k]) for k in d.files}


def _dem_only(recipe, **overrides):
    """The recipe without its spectral_restore layer, float64 heights, with ``overrides``."""
    data = copy.deepcopy(dict(recipe.data))
    data["layers"] = {k: v for k, v in data["layers"].items() if v["generator"] == "dem"}
    data["grid"]["quantise"] = "none"
    return apply_overrides(recipe_from_dict(data, "test"), overrides)


def test_the_geographic_npz_is_read_with_its_non_square_cells_and_south_first(raw, npz):
    lat_mid = 0.5 * (float(npz["ymin"]) + float(npz["ymax"]))
    deg = np.pi / 180
    assert raw.cell_size_m == pytest.approx(EARTH_RADIUS_M * float(npz["dx"]) * deg * np.cos(lat_mid * deg))
    assert raw.row_step_m == pytest.approx(EARTH_RADIUS_M * float(npz["dy"]) * deg)
    assert 74.0 < raw.cell_size_m < 75.0 and 92.0 < raw.row_step_m < 93.0  # "about 92 m x 74 m", not square
    # matplotlib's first row is the northern one (ymin = 36.73 > ymax = 36.45): ours is the southern one
    assert float(npz["ymin"]) > float(npz["ymax"])
    np.testing.assert_array_equal(raw.z, npz["elevation"][::-1].astype(float))
    assert raw.lon_lat_deg == (pytest.approx(float(npz["xmin"])), pytest.approx(float(npz["ymax"])))


def test_the_preset_imports_and_keeps_a_crs_at_its_window(raw, npz):
    recipe = load_recipe("jacksboro-rover")
    assert recipe.grid.cell_size_m == 0.25 and [ly.generator for ly in recipe.layers] == ["dem", "spectral_restore"]
    base = recipe.layers[0].config
    # the CRS's origin is the window's south-west sample, in the same local equirectangular metres
    crs = dict(p.lstrip("+").split("=") for p in recipe.data["recipe"]["crs"].split() if "=" in p)
    lon0, lat0 = raw.lon_lat_deg
    deg = np.pi / 180
    lat_mid = 0.5 * (float(npz["ymin"]) + float(npz["ymax"]))  # where the reader measures the column step
    assert float(crs["lon_0"]) == pytest.approx(lon0 + base.origin_x_m / (EARTH_RADIUS_M * deg * np.cos(lat_mid * deg)), abs=1e-6)
    assert float(crs["lat_0"]) == pytest.approx(lat0 + base.origin_y_m / (EARTH_RADIUS_M * deg), abs=1e-6)
    crs_cls = pytest.importorskip("rasterio.crs").CRS  # the [geo]/[readers] extra, as the GeoTIFF export
    assert crs_cls.from_user_input(recipe.data["recipe"]["crs"]).is_projected  # a CRS PROJ knows


def test_resampling_is_bilinear_on_each_axis_of_the_source_heights(raw):
    recipe = load_recipe("jacksboro-rover")
    cx, cy = raw.cell_size_m, raw.row_step_m
    i, j = 180, 240  # a window starting on a source sample
    rec = _dem_only(recipe, **{"grid.rows": 81, "grid.cols": 97, "grid.cell_size_m": 7.3,
                               "layers.base.origin_x_m": j * cx, "layers.base.origin_y_m": i * cy})
    hm = generate_terrain(rec, 0)
    assert hm.z[0, 0] == pytest.approx(raw.z[i, j], abs=1e-9)  # on a sample: the sample itself
    ys = i * cy + np.arange(hm.rows) * hm.cell_size_m
    xs = j * cx + np.arange(hm.cols) * hm.cell_size_m
    ref = RegularGridInterpolator((np.arange(raw.z.shape[0]) * cy, np.arange(raw.z.shape[1]) * cx), raw.z)
    yy, xx = np.meshgrid(ys, xs, indexing="ij")
    np.testing.assert_allclose(hm.z, ref((yy, xx)), atol=1e-9)
    # the rover-scale preset's real part stays within the source heights of its window
    hm = generate_terrain(_dem_only(recipe), 0)
    base = recipe.layers[0].config
    win = raw.z[int(base.origin_y_m // cy): int((base.origin_y_m + hm.height_m) // cy) + 2,
                int(base.origin_x_m // cx): int((base.origin_x_m + hm.width_m) // cx) + 2]
    assert win.min() <= hm.z.min() and hm.z.max() <= win.max()


def _psd(z, dx, dy, edges):
    """Mean periodogram density (m^2 m^2) of ``z`` in the radial frequency bins ``edges`` (cycles/m)."""
    z = z - z.mean()
    p = np.abs(np.fft.fft2(z)) ** 2 * dx * dy / z.size
    f = np.hypot(np.fft.fftfreq(z.shape[0], dy)[:, None], np.fft.fftfreq(z.shape[1], dx)[None, :])
    k = np.digitize(f.ravel(), edges)
    return np.array([p.ravel()[k == b].mean() for b in range(1, len(edges))])


def test_the_restored_spectrum_follows_the_source_below_the_cutoff_and_fbm_above(raw):
    """A 10 km window at 25 m (the preset's layers, a coarser grid so that many wavelengths lie
    below the 185 m cut-off): below it the spectrum is the source's own (bilinear interpolation
    only damps it near the source's Nyquist wavelength); above it, the fBm law f^-(2H+2)."""
    recipe = load_recipe("jacksboro-rover")
    restore = recipe.layers[1].config
    cx, cy = raw.cell_size_m, raw.row_step_m
    ox = oy = 5000.0
    over = {"grid.rows": 400, "grid.cols": 400, "grid.cell_size_m": 25.0,
            "layers.base.origin_x_m": ox, "layers.base.origin_y_m": oy, "grid.quantise": "none"}
    hm = generate_terrain(apply_overrides(recipe, over), 0)
    plain = generate_terrain(_dem_only(recipe, **{k: v for k, v in over.items() if k != "grid.quantise"}), 0)
    width = 400 * 25.0
    src = raw.z[int(round(oy / cy)): int(round(oy / cy)) + int(width / cy), int(round(ox / cx)): int(round(ox / cx)) + int(width / cx)]
    fc = 1.0 / restore.cutoff_wavelength_m

    # below the cut-off the restored map keeps the resampled DEM's Fourier coefficients exactly
    f = np.hypot(np.fft.fftfreq(400, 25.0)[:, None], np.fft.rfftfreq(400, 25.0)[None, :])
    np.testing.assert_allclose(np.fft.rfft2(hm.z)[f <= fc], np.fft.rfft2(plain.z)[f <= fc], rtol=1e-9, atol=1e-6)

    # ... and its spectrum is the source's (same window, on the source's own 74 x 93 m cells)
    edges = np.geomspace(2.0 / width, fc, 8)
    ratio = _psd(hm.z, 25.0, 25.0, edges) / _psd(src, cx, cy, edges)
    wavelengths = 1.0 / np.sqrt(edges[1:] * edges[:-1])
    assert np.all((ratio > 0.5) & (ratio < 1.5)), ratio
    long = wavelengths > 750.0  # far from the source's Nyquist wavelength: no interpolation damping
    assert np.all(np.abs(np.log(ratio[long])) < np.log(1.3)), ratio

    # above the cut-off: fBm with the preset's H, i.e. P ~ f^-(2H + 2) (Yoshikawa & Nishiguchi Eq. 5-7)
    edges = np.geomspace(fc, 1.0 / 55.0, 6)
    p = _psd(hm.z, 25.0, 25.0, edges)
    slope = np.polyfit(np.log(np.sqrt(edges[1:] * edges[:-1])), np.log(p), 1)[0]
    assert slope == pytest.approx(-(2 * restore.H + 2), abs=0.35)
