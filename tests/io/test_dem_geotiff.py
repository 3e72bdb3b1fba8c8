"""GeoTIFF DEMs in: the cell size from the geotransform, nodata as gaps, north-up rows undone, and
an offroadbench ``geotiff`` export read back by ``generate``'s DEM layer as the same heightmap."""

import numpy as np
import pytest

from offroadbench import Heightmap, InputError
from offroadbench.io.dem import read_dem
from offroadbench.io.export import export_heightmap

rasterio = pytest.importorskip("rasterio")
from affine import Affine  # noqa: E402  (rasterio's dependency)


@pytest.fixture
def hm():
    rng = np.random.default_rng(5)
    z = rng.normal(size=(19, 26)) * 0.5 - 1735.0  # a lunar datum: far below zero
    z[15, 3] = -1731.0
    return Heightmap(z.astype(np.float32).astype(np.float64), 0.25)  # float32 values: the file holds them exactly


def _write(path, z, transform, nodata=None, crs=None):
    with rasterio.open(path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype=z.dtype.name,
                       transform=transform, nodata=nodata, crs=crs) as dst:
        dst.write(z, 1)


def test_export_then_dem_layer_gives_the_same_heightmap(hm, tmp_path):
    from offroadbench.terrain.recipe import apply_overrides, generate_terrain, recipe_from_dict

    export_heightmap(hm, "geotiff", tmp_path, name="site", meta={"crs": "IAU_2015:30110"})
    raw = read_dem(tmp_path / "site.geo.tif")
    assert raw.cell_size_m == hm.cell_size_m and raw.gap_count == 0
    assert np.array_equal(raw.z, hm.z)
    recipe = recipe_from_dict({
        "recipe": {"name": "site"},
        "grid": {"rows": hm.rows, "cols": hm.cols, "cell_size_m": hm.cell_size_m, "quantise": "none"},
        "layers": {"base": {"generator": "dem", "path": str(tmp_path / "site.geo.tif")}},
    })
    out = generate_terrain(recipe, 0)
    assert out.cell_size_m == hm.cell_size_m and np.array_equal(out.z, hm.z)
    levels = generate_terrain(apply_overrides(recipe, {"grid.quantise": "png16"}), 0)  # the default
    assert np.max(np.abs(levels.z - hm.z)) <= hm.relief_m / 65535 / 2 * (1 + 1e-6)


def test_foreign_north_up_dem_with_nodata(tmp_path):
    # a raster as GIS tools write it: row 0 is the north edge, 2 m pixels, origin far from 0, nodata -9999
    north_up = np.arange(4 * 5, dtype=np.float32).reshape(4, 5)
    north_up[1, 2] = -9999.0
    _write(tmp_path / "dtm.tif", north_up, Affine(2.0, 0, 500000.0, 0, -2.0, 4000.0), nodata=-9999.0)
    raw = read_dem(tmp_path / "dtm.tif")
    assert raw.cell_size_m == 2.0 and raw.gap_count == 1
    assert np.isnan(raw.z[2, 2])  # raster row 1 from the top is row 2 from the south edge
    expected = north_up[::-1].astype(np.float64)
    expected[2, 2] = np.nan
    assert np.array_equal(raw.z, expected, equal_nan=True)


def test_unusable_geotiffs_are_input_errors(tmp_path):
    z = np.zeros((4, 4), dtype=np.float32)
    _write(tmp_path / "rect.tif", z, Affine(2.0, 0, 0, 0, -1.0, 4))
    with pytest.raises(InputError, match="not square"):
        read_dem(tmp_path / "rect.tif")
    _write(tmp_path / "rot.tif", z, Affine(2.0, 0.5, 0, 0.5, -2.0, 4))
    with pytest.raises(InputError, match="rotated"):
        read_dem(tmp_path / "rot.tif")
    (tmp_path / "junk.tif").write_text("not a tiff")
    with pytest.raises(InputError, match="not a readable GeoTIFF"):
        read_dem(tmp_path / "junk.tif")


def test_plain_tiff_export_reads_with_its_sidecar(hm, tmp_path):
    export_heightmap(hm, "tiff", tmp_path, name="t")
    raw = read_dem(tmp_path / "t.tif")
    assert raw.cell_size_m == hm.cell_size_m and np.array_equal(raw.z, hm.z)


def test_cli_exports_a_lunar_preset_with_its_crs(tmp_path, capsys):
    from offroadbench.cli import main

    code = main(["export", "lunar-mare", "--format", "geotiff", "-o", str(tmp_path), "--name", "m",
                 "--set", "grid.rows=33", "--set", "grid.cols=33"])
    assert code == 0, capsys.readouterr().err
    with rasterio.open(tmp_path / "m.geo.tif") as src:
        assert "Moon" in src.crs.to_wkt() and src.res == (0.05, 0.05)
        assert src.tags()["recipe_name"] == "lunar-mare"


def test_a_coarse_lunar_dtm_with_gaps_is_enhanced_and_driveable_terrain(tmp_path):
    """A real-DTM workflow: a 1 m GeoTIFF with nodata gaps -> dem layer (gaps filled, resampled to
    0.25 m) -> spectral restoration of the wavelengths below 2 m. The long wavelengths stay the DTM's."""
    from offroadbench.terrain.recipe import generate_terrain, recipe_from_dict

    y, x = np.mgrid[0:33, 0:33].astype(float)
    dtm = (-1700.0 + 2.0 * np.sin(x / 6.0) + 1.5 * np.cos(y / 5.0)).astype(np.float32)
    dtm[10:12, 20:23] = -32768.0  # a void, as in LOLA/Kaguya products
    _write(tmp_path / "dtm.tif", dtm[::-1].copy(), Affine(1.0, 0, 1000.0, 0, -1.0, 2032.5), nodata=-32768.0,
           crs="IAU_2015:30110")
    recipe = recipe_from_dict({
        "recipe": {"name": "site", "crs": "IAU_2015:30110"},
        "grid": {"rows": 121, "cols": 121, "cell_size_m": 0.25},
        "layers": {
            "base": {"generator": "dem", "path": str(tmp_path / "dtm.tif")},
            "fine": {"generator": "spectral_restore", "cutoff_wavelength_m": 2.0},
        },
    })
    a, b = generate_terrain(recipe, 1), generate_terrain(recipe, 1)
    assert np.array_equal(a.z, b.z) and np.isfinite(a.z).all()
    # the DTM's shape survives: compare at its own 1 m samples, away from the void
    coarse = a.z[::4, ::4]
    ref = dtm[:31, :31].astype(np.float64)
    ok = np.ones_like(ref, dtype=bool)
    ok[8:14, 18:25] = False
    assert np.corrcoef(coarse[ok], ref[ok])[0, 1] > 0.95
    assert np.abs(coarse[ok] - ref[ok]).mean() < 0.5
