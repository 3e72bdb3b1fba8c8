"""Import of existing DEMs so real data can be enhanced (Martin et al. 2014, Sec. IV; Yoshikawa Sec. 3.4).

Formats:

* ``.png``: a 16-bit grayscale PNG, read with :func:`offroadbench.io.png16.read_png16` (cell size
  and height range from the JSON sidecar, or given by the caller). A ``nodata_level`` (e.g. 0)
  marks gaps.
* ``.npy``: a 2-D float array of heights in metres; NaN marks gaps. The cell size comes from a
  sidecar ``NAME.json`` with ``cell_size_m`` or from the caller.
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

__all__ = ["RawDEM", "read_dem", "DEM_SUFFIXES"]

DEM_SUFFIXES = (".png", ".npy", ".tif", ".tiff")


@dataclass(frozen=True, eq=False)
class RawDEM:
    """Heights in metres (NaN = unknown) on a regular grid of ``cell_size_m``."""

    z: np.ndarray
    cell_size_m: float

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
