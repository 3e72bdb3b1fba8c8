"""GeoTIFF: ``NAME.geo.tif``, float32 heights in metres with a geotransform and a CRS.

(Not ``NAME.tif``: that is the plain ``tiff`` export, whose rows are not flipped; exporting both under
one name into one directory must not pair one's pixels with the other's sidecar.)

Layout (GDAL's north-up convention). A GIS draws raster row 0 at the top, i.e. at the largest y,
while our row 0 is y = 0. The raster is therefore written last row first (raster row i is z[rows - 1
- i]) with the geotransform

    x = -cell / 2 + (col + 0.5) * cell,   y = (rows - 0.5) * cell - (row + 0.5) * cell

(origin at the outer corner of the top-left pixel, pixel size = cell size, negative y step), so
the centre of the pixel holding z[r, c] is at (c * cell, r * cell): sample (0, 0) at the origin and
nothing mirrored. ``AREA_OR_POINT=Point`` says the values are point heights at those centres.
The heights are float32 (the only loss, relative 6e-8); the transform is exact in float64.
:func:`offroadbench.io.dem.read_dem` reads the file back (and any north-up GeoTIFF DEM, nodata as
gaps) and undoes the row order, so export -> ``dem`` layer gives back the same heightmap.

CRS: ``meta["crs"]`` (from the recipe's ``[recipe] crs`` key, e.g. ``"IAU_2015:30110"``, the Moon's
equirectangular projection in metres, for the lunar presets) is written when given. Synthetic
Earth-like maps are on no body: they get a local engineering CS in metres (``LOCAL_CS``, no datum),
so a GIS shows metres instead of "unknown" units and places them nowhere on a globe. Needs rasterio (``pip install 'offroadbench[geo]'``).
"""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path
from typing import Any

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import PROVENANCE_KEYS

__all__ = ["LOCAL_METRES_WKT", "geotransform", "write_geotiff", "read_geotiff"]

#: the CS of a map on no particular body: metres east and north of sample (0, 0)
LOCAL_METRES_WKT = 'LOCAL_CS["offroadbench local metres",UNIT["metre",1],AXIS["Easting",EAST],AXIS["Northing",NORTH]]'


def geotransform(hm: Heightmap):
    """The north-up ``affine.Affine`` that puts the pixel of z[r, c] at centre (c * cell, r * cell)."""
    from affine import Affine

    cell = Decimal(repr(hm.cell_size_m))
    return Affine(float(cell), 0.0, float(-cell / 2), 0.0, -float(cell), float((hm.rows - Decimal("0.5")) * cell))


def write_geotiff(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    import rasterio
    from rasterio.crs import CRS
    from rasterio.errors import CRSError

    crs = CRS.from_wkt(LOCAL_METRES_WKT)
    if meta.get("crs"):
        try:
            crs = CRS.from_user_input(meta["crs"])
        except CRSError as exc:
            raise InputError(f"crs {meta['crs']!r} is not a coordinate reference system GDAL/PROJ knows ({exc})") from None
    z32 = np.ascontiguousarray(hm.z[::-1], dtype=np.float32)  # north-up: raster row 0 is the largest y
    profile = dict(
        driver="GTiff", width=hm.cols, height=hm.rows, count=1, dtype="float32", crs=crs,
        transform=geotransform(hm), compress="deflate", predictor=3,
    )
    with rasterio.open(d / f"{name}.geo.tif", "w", **profile) as dst:
        dst.write(z32, 1)
        dst.update_tags(AREA_OR_POINT="Point", units="metres", **{k: str(meta[k]) for k in PROVENANCE_KEYS if k in meta})
        dst.update_tags(1, units="metres")
        dst.set_band_description(1, "height")
        dst.units = ("metre",)
    cast_err = float(np.max(np.abs(z32[::-1].astype(np.float64) - hm.z)))
    where = f"CRS {meta['crs']}" if meta.get("crs") else "a local CS in metres (no body)"
    return [f"GeoTIFF float32, pixel {hm.cell_size_m:g} m, sample (0, 0) at (0, 0), {where}; float32 rounding {cast_err:.2e} m"]


def read_geotiff(d: Path, name: str) -> Heightmap:
    """The export read back through the DEM importer (:func:`offroadbench.io.dem.read_dem`)."""
    from offroadbench.io.dem import read_dem

    raw = read_dem(d / f"{name}.geo.tif")
    if raw.gap_count:
        raise InputError(f"{d / name}.geo.tif: has {raw.gap_count} nodata samples")
    return Heightmap(raw.z, raw.cell_size_m)


EXPORTERS.register(
    "geotiff",
    Exporter(
        name="geotiff",
        summary="GeoTIFF NAME.geo.tif: float32 metres, north-up geotransform (pixel = cell, sample (0, 0) at 0, 0), the recipe's CRS or a local metric one",
        reader="GDAL / rasterio / QGIS; offroadbench's dem layer",
        write=write_geotiff,
        read=read_geotiff,
        precision_m=lambda hm: float(np.finfo(np.float32).eps) / 2 * float(np.abs(hm.z).max()),
        requires=("rasterio",),
        extra="geo",
    ),
)
