"""DEM enhancement: RMD expansion (Martin et al. 2014, Eq. 13-16), spectral restoration (Yoshikawa & Nishiguchi 2001, Sec. 3.4), gap filling
(Martin et al. 2014, Sec. IV.B), DEM import and the ``dem`` layer."""

import json

import numpy as np
import pytest

from offroadbench.terrain.grid import GridConfig
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.dem import read_dem
from offroadbench.io.png16 import write_png16
from offroadbench.terrain.recipe import generate_terrain, recipe_from_dict
from offroadbench.terrain.dem import DEMConfig, generate_dem
from offroadbench.terrain.fractal.rmd import RMDExpandConfig, rmd_expand
from offroadbench.terrain.fractal.spectral import SpectralRestoreConfig, spectral_restore
from offroadbench.terrain.gaps import fill_gaps, known_neighbour_count
from offroadbench.terrain.fractal.fbm import FBMConfig, generate_fbm


def coarse(n=33, cell=1.0, seed=0):
    return generate_fbm(FBMConfig(D=2.2, relief_m=5.0), GridConfig(rows=n, cols=n, cell_size_m=cell), np.random.default_rng(seed))


@pytest.mark.parametrize("levels", [1, 3])
def test_rmd_expansion_keeps_the_original_samples(levels):
    base = coarse()
    out = rmd_expand(RMDExpandConfig(levels=levels), base, np.random.default_rng(1))
    f = 2**levels
    assert out.shape == ((base.rows - 1) * f + 1, (base.cols - 1) * f + 1)
    assert out.cell_size_m == pytest.approx(base.cell_size_m / f)
    np.testing.assert_array_equal(out.z[::f, ::f], base.z)
    # new detail was added between the samples: the centres are not the mean of their corners
    corners = 0.25 * (out.z[:-1:2, :-1:2] + out.z[:-1:2, 2::2] + out.z[2::2, :-1:2] + out.z[2::2, 2::2])
    assert np.abs(out.z[1::2, 1::2] - corners).mean() > 0


def test_rmd_expansion_with_zero_scale_interpolates_by_square_and_diamond_means():
    base = Heightmap(np.array([[0.0, 2.0, 4.0], [2.0, 4.0, 6.0], [4.0, 6.0, 8.0]]), 1.0)
    out = rmd_expand(RMDExpandConfig(displacement_scale_m=0.0), base, np.random.default_rng(0))
    y, x = np.mgrid[0:5, 0:5]
    np.testing.assert_allclose(out.z, x + y)  # a plane stays a plane


def test_rmd_expansion_refuses_huge_grids():
    with pytest.raises(InputError, match="levels"):
        rmd_expand(RMDExpandConfig(levels=12), coarse(), np.random.default_rng(0))


def _lowpass(z, cell, wavelength):
    c = np.fft.rfft2(z)
    f = np.hypot(np.fft.fftfreq(z.shape[0], d=cell)[:, None], np.fft.rfftfreq(z.shape[1], d=cell)[None, :])
    c[f > 1.0 / wavelength] = 0
    return np.fft.irfft2(c, s=z.shape)


def test_spectral_restoration_keeps_the_low_pass_and_restores_the_spectrum():
    # a smooth DEM (wavelengths < 4 m removed) gets fBm detail back above the cutoff
    n, cell, cutoff = 256, 0.25, 4.0
    truth = generate_fbm(FBMConfig(H=0.8, relief_m=3.0), GridConfig(rows=n, cols=n, cell_size_m=cell), np.random.default_rng(4))
    smooth = truth.with_z(_lowpass(truth.z, cell, cutoff))
    out = spectral_restore(SpectralRestoreConfig(cutoff_wavelength_m=cutoff, H=0.8), smooth, np.random.default_rng(9))
    np.testing.assert_allclose(_lowpass(out.z, cell, cutoff), smooth.z, atol=1e-9)
    added = out.z - smooth.z
    lost = truth.z - smooth.z
    assert added.std() == pytest.approx(lost.std(), rel=0.3)


def test_spectral_restoration_with_a_cutoff_below_nyquist_changes_nothing():
    hm = coarse(cell=0.5)
    out = spectral_restore(SpectralRestoreConfig(cutoff_wavelength_m=0.5), hm, np.random.default_rng(0))
    assert out is hm
    with pytest.raises(InputError, match="cutoff"):
        spectral_restore(SpectralRestoreConfig(cutoff_wavelength_m=1e6), hm, np.random.default_rng(0))


def with_holes(z):
    z = z.copy()
    y, x = np.mgrid[0 : z.shape[0], 0 : z.shape[1]]
    z[(x - 20) ** 2 + (y - 14) ** 2 < 36] = np.nan
    z[2:4, 5:30] = np.nan
    z[0, 0] = np.nan
    return z


def test_gap_filling_never_changes_a_known_pixel_and_fills_every_gap():
    base = coarse()
    holes = with_holes(base.z)
    out = fill_gaps(holes, base.cell_size_m, 0.3, np.random.default_rng(2))
    known = ~np.isnan(holes)
    np.testing.assert_array_equal(out[known], base.z[known])
    assert np.isfinite(out).all()
    # the fill is close to the surface it replaces (smooth interpolation plus small noise)
    assert np.abs(out - base.z)[~known].mean() < 0.5 * base.relief_m


def test_gap_filling_without_noise_reproduces_a_plane():
    y, x = np.mgrid[0:30, 0:40]
    plane = 0.1 * x + 0.05 * y
    out = fill_gaps(with_holes(plane), 1.0, 0.0, np.random.default_rng(0))
    # the inverse-distance mean of the 8 rays is exact on a plane only where the rays are symmetric;
    # elsewhere it stays within about one pixel's rise (0.1 here)
    assert np.abs(out - plane).max() < 0.15


def test_gap_filling_goes_from_the_outside_in():
    z = np.zeros((9, 9))
    z[2:7, 2:7] = np.nan
    counts = known_neighbour_count(~np.isnan(z))
    assert counts[2, 2] == 5 and counts[2, 4] == 3 and counts[4, 4] == 0
    with pytest.raises(InputError, match="every pixel"):
        fill_gaps(np.full((4, 4), np.nan), 1.0, 0.1, np.random.default_rng(0))


def test_dem_import_npy_with_sidecar_fills_gaps_and_resamples(tmp_path):
    base = coarse(n=33, cell=1.0)
    p = tmp_path / "dem.npy"
    np.save(p, with_holes(base.z))
    (tmp_path / "dem.json").write_text(json.dumps({"cell_size_m": 1.0}))
    raw = read_dem(p)
    assert raw.cell_size_m == 1.0 and raw.gap_count > 0
    hm = generate_dem(DEMConfig(dem=raw), GridConfig(rows=65, cols=65, cell_size_m=0.5), np.random.default_rng(0))
    known = ~np.isnan(with_holes(base.z))
    np.testing.assert_allclose(hm.z[::2, ::2][known], base.z[known], atol=1e-12)
    same = generate_dem(DEMConfig(dem=raw), GridConfig(rows=33, cols=20, cell_size_m=1.0), np.random.default_rng(0))
    np.testing.assert_array_equal(same.z[known[:, :20]], base.z[:, :20][known[:, :20]])
    with pytest.raises(InputError, match="beyond the DEM"):
        generate_dem(DEMConfig(dem=raw), GridConfig(rows=40, cols=40, cell_size_m=1.0), np.random.default_rng(0))
    # the recipe names the file; loading the recipe reads it
    recipe = recipe_from_dict(
        {"grid": {"rows": 65, "cols": 65, "cell_size_m": 0.5, "quantise": "none"},
         "layers": {"base": {"generator": "dem", "path": str(p)}}}
    )
    np.testing.assert_array_equal(generate_terrain(recipe, 0).z[::2, ::2][known], base.z[known])


def test_dem_import_png16_round_trip(tmp_path):
    base = coarse(n=21, cell=0.5)
    write_png16(base, tmp_path / "d.png")
    raw = read_dem(tmp_path / "d.png")
    assert raw.cell_size_m == 0.5
    np.testing.assert_allclose(raw.z, base.z, atol=base.relief_m / 65535)


@pytest.mark.parametrize(
    "setup, match",
    [
        (lambda d: (d / "x.npy", np.save(d / "x.npy", np.zeros((4, 4)))), "cell_size_m"),
        (lambda d: (d / "y.npy", np.save(d / "y.npy", np.zeros(4))), "2-D"),
        (lambda d: (d / "z.xyz", (d / "z.xyz").write_text("x")), "unknown format"),
        (lambda d: (d / "missing.npy", None), "no such file"),
    ],
)
def test_dem_import_errors(tmp_path, setup, match):
    path, _ = setup(tmp_path)
    with pytest.raises(InputError, match=match):
        read_dem(path)


def test_recipe_layers_an_imported_dem_with_restoration_and_craters():
    recipe = recipe_from_dict(
        {
            "grid": {"rows": 129, "cols": 129, "cell_size_m": 0.125},
            "layers": {
                "base": {"generator": "dem"},  # the bundled sample DEM (0.5 m, with gaps)
                "detail": {"generator": "spectral_restore", "cutoff_wavelength_m": 1.0},
                "craters": {"generator": "craters", "population": {"c": 0.05, "d_min_m": 0.5, "d_max_m": 3.0}},
            },
        }
    )
    a = generate_terrain(recipe, 3)
    b = generate_terrain(recipe, 3)
    assert a.shape == (129, 129) and np.array_equal(a.z, b.z)


def test_generation_reads_no_file_the_recipe_loader_reads_them(tmp_path, monkeypatch):
    """Generators are pure: the DEM and the crater CSV are read when the recipe is built, never after."""
    import builtins
    import io as stdlib_io
    import pathlib

    from offroadbench.io.craters_csv import write_craters
    from offroadbench.terrain.craters import CraterTable

    craters = CraterTable(x_m=[5.0], y_m=[6.0], diameter_m=[3.0], age=[0.5], degradation=[np.nan], profile=("martin2014",))
    path = write_craters(craters, tmp_path / "c.csv")
    recipe = recipe_from_dict(
        {
            "grid": {"rows": 65, "cols": 65, "cell_size_m": 0.25},
            "layers": {"base": {"generator": "dem"}, "cr": {"generator": "craters", "crater_file": str(path)}},
        }
    )
    assert recipe.layers[1].config.craters.diameter_m.tolist() == [3.0]

    def no_files(*args, **kwargs):
        raise AssertionError("a generator opened a file")

    monkeypatch.setattr(builtins, "open", no_files)
    monkeypatch.setattr(stdlib_io, "open", no_files)
    monkeypatch.setattr(pathlib.Path, "open", no_files)
    monkeypatch.setattr(np, "load", no_files)
    hm = generate_terrain(recipe, 1)
    assert hm.shape == (65, 65) and np.isfinite(hm.z).all()


@pytest.mark.parametrize(
    "layer, match",
    [
        ({"generator": "dem", "path": 3}, r"layers\.base\.path must be a path string"),
        ({"generator": "dem", "source_cell_size_m": -1.0}, r"layers\.base\.source_cell_size_m = -1\.0 is out of range"),
        ({"generator": "dem", "path": "/no/such/dem.npy"}, "no such file"),
        ({"generator": "dem", "dem": 1}, r"layers\.base\.dem cannot be written in a recipe"),
    ],
)
def test_bad_dem_layers_name_the_key(layer, match):
    with pytest.raises(InputError, match=match):
        recipe_from_dict({"grid": {"rows": 9, "cols": 9, "cell_size_m": 0.5}, "layers": {"base": layer}})
