"""Import of existing DEMs so real data can be enhanced (Martin et al. 2014, Sec. IV; Yoshikawa Sec. 3.4).

Formats:

* ``.png``: a 16-bit grayscale PNG, read with :func:`offroadbench.io.png16.read_png16` (cell size
  and height range from the JSON sidecar, or given by the caller). A ``nodata_level`` (e.g. 0)
  marks gaps.
* ``.npy``: a 2-D float array of heights in metres; NaN marks gaps. The cell size comes from a
  sidecar ``NAME.json`` with ``cell_size_m`` or from the caller.
* ``.npz``: a geographic DEM as matplotlib ships its sample ``jacksboro_fault_dem.npz``:
  ``elevation`` (2-D, metres), ``dx`` and ``dy`` (cell size in degrees of longitude and latitude),
  ``xmin`` (longitude of the first column), ``ymin`` (latitude of the first row) and ``ymax``
  (latitude of the last row). The degrees become metres on a sphere of radius 6371008.8 m (the
  IUGG mean Earth radius) at the DEM's middle latitude: a column step of
  ``R dx cos(lat)`` and a row step of ``R dy`` (both in radians), so the cells are **not square**
  (about 74.5 m x 92.7 m for the Jacksboro DEM at 36.6 deg N); :class:`RawDEM` keeps both and the
  ``dem`` generator's bilinear resampling uses each along its own axis. Rows are ordered south
  first (a file whose first row is its northern one is flipped). The local equirectangular
  approximation errs by < 0.1 % over the sample's 0.29 deg of latitude.
* ``.tif`` / ``.tiff``: a GeoTIFF DEM (band 1, heights in the file's units, taken as metres), read
  with rasterio (``pip install 'offroadbench[geo]'``). The cell size comes from the geotransform
  (square pixels, no rotation); nodata samples (and masked ones) become NaN gaps. The first row of
  the result is the raster's southern edge (a north-up raster is flipped), so z[r, c] is at
  x = c * cell, y = r * cell from the south-west sample, as everywhere in offroadbench; this undoes
  the ``geotiff`` export exactly (:mod:`offroadbench.io.export.geotiff`).

The result is a :class:`RawDEM`: heights that may contain NaN (a ``Heightmap`` may not), to be
gap-filled (:func:`offroadbench.terrain.gaps.fill_gaps`) before use.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from offroadbench.errors import InputError

__all__ = ["RawDEM", "read_dem", "DEM_SUFFIXES", "EARTH_RADIUS_M"]

DEM_SUFFIXES = (".png", ".npy", ".npz", ".tif", ".tiff")
#: IUGG mean Earth radius (Moritz 2000, Geodetic Reference System 1980), metres
EARTH_RADIUS_M = 6371008.8


@dataclass(frozen=True, eq=False)
class RawDEM:
    """Heights in metres (NaN = unknown) on a regular grid: ``cell_size_m`` between columns (x),
    ``cell_size_y_m`` between rows (y; None = square cells, the same as ``cell_size_m``).
    ``lon_lat_deg``: longitude and latitude of sample z[0, 0] where the file gives them."""

    z: np.ndarray
    cell_size_m: float
    cell_size_y_m: float | None = None
    lon_lat_deg: tuple[float, float] | None = None

    @property
    def row_step_m(self) -> float:
        """The distance between rows (y), metres."""
        return self.cell_size_m if self.cell_size_y_m is None else self.cell_size_y_m

    @property
    def gap_count(self) -> int:
        return int(np.isnan(self.z).sum())


def _sidecar_cell(path: Path, side: Path | None = None) -> float | None:
    """``cell_size_m`` from the JSON sidecar ``side`` (default ``NAME.json`` beside ``path``), or None."""
    side = path.with_suffix(".json") if side is None else side
    if not side.is_file():
        return None
    try:
        meta = json.loads(side.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{side}: not valid JSON ({exc})") from None
    if not isinstance(meta, dict) or "cell_size_m" not in meta:
        raise InputError(f"{side}: has no cell_size_m")
    cell = meta["cell_size_m"]
    if isinstance(cell, bool) or not isinstance(cell, (int, float)) or not np.isfinite(cell) or not cell > 0:
        raise InputError(f"{side}: cell_size_m = {cell!r} is not allowed; allowed: a finite number > 0 (metres)")
    return float(cell)


def read_dem(
    path: str | Path,
    *,
    cell_size_m: float | None = None,
    relief_m: float | None = None,
    nodata_level: int | None = None,
) -> RawDEM:
    """Read a DEM file (see the module docstring). ``cell_size_m`` overrides a missing sidecar."""
    from offroadbench.io.inputs import check_input_file

    p = check_input_file(path, "DEM file")
    suffix = p.suffix.lower()
    if suffix == ".png":
        from offroadbench.io.png16 import read_png16
        from PIL import Image

        hm = read_png16(p, cell_size_m=cell_size_m, relief_m=relief_m)
        z = np.array(hm.z, dtype=np.float64)
        if nodata_level is not None:
            with Image.open(p) as img:
                q = np.asarray(img).astype(np.int64)
            z[q == int(nodata_level)] = np.nan
        return RawDEM(z=z, cell_size_m=hm.cell_size_m)
    if suffix == ".npy":
        try:
            z = np.load(p, allow_pickle=False)
        except (ValueError, EOFError, OSError) as exc:
            raise InputError(f"{p}: not a plain .npy array ({exc})") from None
        if z.ndim != 2 or not np.issubdtype(z.dtype, np.number):
            raise InputError(f"{p}: must hold a 2-D numeric array of heights, got shape {z.shape} dtype {z.dtype}")
        z = z.astype(np.float64)
        if np.isinf(z).any():
            raise InputError(f"{p}: contains infinite heights; use NaN for gaps")
        cell = _sidecar_cell(p) if cell_size_m is None else float(cell_size_m)
        if cell is None:
            raise InputError(f"{p}: no sidecar {p.with_suffix('.json').name} with cell_size_m; give the cell size (m)")
        if not cell > 0:
            raise InputError(f"{p}: cell_size_m must be > 0, got {cell}")
        return RawDEM(z=z, cell_size_m=cell)
    if suffix == ".npz":
        return _read_geographic_npz(p)
    if suffix in (".tif", ".tiff"):
        return _read_geotiff(p, cell_size_m)
    raise InputError(f"DEM file {p}: unknown format {suffix!r}; known: {', '.join(DEM_SUFFIXES)}")


def _read_geotiff(p: Path, cell_size_m: float | None) -> RawDEM:
    try:
        import rasterio
    except ImportError:
        raise InputError(f"{p}: reading GeoTIFF DEMs needs rasterio; pip install 'offroadbench[geo]'") from None
    import warnings

    from rasterio.errors import NotGeoreferencedWarning, RasterioIOError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NotGeoreferencedWarning)  # handled below: the cell size is asked for
            src = rasterio.open(p)
        with src:
            if src.count < 1:
                raise InputError(f"{p}: has no raster band")
            z = src.read(1, masked=True).astype(np.float64).filled(np.nan)
            t = src.transform
    except RasterioIOError as exc:
        raise InputError(f"{p}: not a readable GeoTIFF ({exc})") from None
    if t.b != 0 or t.d != 0:
        raise InputError(f"{p}: the geotransform is rotated ({t.b}, {t.d}); resample it north-up first (gdalwarp)")
    if t.is_identity:  # no georeference (e.g. the plain tiff export): rows as stored, cell from elsewhere
        cell = _sidecar_cell(p, p.with_name(p.name + ".json")) if cell_size_m is None else float(cell_size_m)
        if cell is None:
            raise InputError(f"{p}: has no geotransform and no sidecar {p.name}.json; give the cell size (m)")
    else:
        if abs(abs(t.a) - abs(t.e)) > 1e-9 * abs(t.a):
            raise InputError(f"{p}: pixels are not square ({abs(t.a)} x {abs(t.e)}); resample to square cells first")
        cell = abs(t.a) if cell_size_m is None else float(cell_size_m)
        if t.e < 0:  # north-up: raster row 0 is the northern edge; ours is the southern one
            z = z[::-1]
        if t.a < 0:
            z = z[:, ::-1]
    if np.isinf(z).any():
        raise InputError(f"{p}: contains infinite heights; set a nodata value for gaps")
    if not cell > 0:
        raise InputError(f"{p}: cell_size_m must be > 0, got {cell}")
    return RawDEM(z=np.ascontiguousarray(z), cell_size_m=cell)


def _read_geographic_npz(p: Path) -> RawDEM:
    """matplotlib's geographic DEM layout (see the module docstring)."""
    try:
        with np.load(p, allow_pickle=False) as data:
            arrays = {k: np.asarray(data[k]) for k in data.files}
    except (ValueError, EOFError, OSError) as exc:
        raise InputError(f"{p}: not a plain .npz archive ({exc})") from None
    missing = [k for k in ("elevation", "dx", "dy", "xmin", "ymin", "ymax") if k not in arrays]
    if missing:
        raise InputError(f"{p}: a geographic .npz DEM needs elevation, dx, dy, xmin, ymin, ymax; missing {', '.join(missing)}")
    z = arrays["elevation"]
    if z.ndim != 2 or not np.issubdtype(z.dtype, np.number) or min(z.shape) < 2:
        raise InputError(f"{p}: elevation must be a 2-D numeric array of at least 2 x 2, got shape {z.shape} dtype {z.dtype}")
    dx, dy, lon0, lat_first, lat_last = (float(arrays[k]) for k in ("dx", "dy", "xmin", "ymin", "ymax"))
    if not (dx > 0 and dy > 0):
        raise InputError(f"{p}: dx = {dx}, dy = {dy} degrees; both must be > 0")
    z = z.astype(np.float64)
    if lat_first > lat_last:  # the first row is the northern one: ours is the southern one
        z = z[::-1]
    lat_south = min(lat_first, lat_last)
    lat_mid = 0.5 * (lat_first + lat_last)
    rad = np.pi / 180.0
    cell_x = EARTH_RADIUS_M * dx * rad * float(np.cos(lat_mid * rad))
    cell_y = EARTH_RADIUS_M * dy * rad
    return RawDEM(z=np.ascontiguousarray(z), cell_size_m=cell_x, cell_size_y_m=cell_y, lon_lat_deg=(lon0, lat_south))
