"""Float grids of heights in metres with a JSON sidecar: 32-bit TIFF and NumPy ``.npy``.

Row 0 of the file is row 0 of z (no flip). The sidecars are ``NAME.tif.json`` / ``NAME.npy.json``
(not ``NAME.json``) so that several formats exported under one name into one directory never
overwrite each other's metadata (``NAME.json`` is the unreal PNG's sidecar). :func:`read_grid`
reads either back. For a georeferenced TIFF that GIS tools place, use the ``geotiff`` format.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import write_json

__all__ = ["GRID_FORMAT", "grid_metadata", "read_grid", "write_tiff", "write_npy"]

GRID_FORMAT = "offroadbench-grid/1"


def grid_metadata(hm: Heightmap, dtype: str, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Sidecar keys for a float grid export (TIFF, NPY): enough to rebuild the Heightmap."""
    from offroadbench import __version__

    meta: dict[str, Any] = {
        "format": GRID_FORMAT,
        "dtype": dtype,
        "units": "metres",
        "layout": "z[r, c] is the height at x = c * cell_size_m, y = r * cell_size_m (row 0 first, no flips)",
        "rows": hm.rows,
        "cols": hm.cols,
        "cell_size_m": hm.cell_size_m,
        "z_min_m": hm.z_min_m,
        "z_max_m": hm.z_max_m,
        "relief_m": hm.relief_m,
        "offroadbench_version": __version__,
    }
    meta.update(extra or {})
    return meta


def _sidecar(path: Path) -> Path:
    """``NAME.tif.json`` beside ``NAME.tif`` (``NAME.npy.json`` beside ``NAME.npy``)."""
    return path.with_name(path.name + ".json")


def write_tiff(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    """Lossless for the float32 values it stores: the only change is the cast float64 -> float32
    (relative error <= 6e-8, 6 um at 100 m); use npy for bit-exact float64."""
    from PIL import Image

    z32 = hm.z.astype(np.float32)
    Image.fromarray(z32).save(d / f"{name}.tif", format="TIFF", compression="tiff_adobe_deflate")  # mode "F"
    cast_err = float(np.max(np.abs(z32.astype(np.float64) - hm.z)))
    write_json(_sidecar(d / f"{name}.tif"), grid_metadata(hm, "float32", {"file": f"{name}.tif", **meta}))
    return [f"TIFF float32: largest float64 -> float32 rounding {cast_err:.2e} m"]


def write_npy(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    """``np.load`` gives back ``hm.z`` exactly."""
    np.save(d / f"{name}.npy", np.ascontiguousarray(hm.z, dtype=np.float64), allow_pickle=False)
    write_json(_sidecar(d / f"{name}.npy"), grid_metadata(hm, "float64", {"file": f"{name}.npy", **meta}))
    return ["NPY float64: bit-exact"]


def read_grid(path: str | Path) -> Heightmap:
    """Read a ``tiff`` or ``npy`` export (``NAME.tif`` / ``NAME.npy`` with its ``.json`` sidecar) as a Heightmap."""
    p = Path(path)
    side = _sidecar(p)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    if not side.is_file():
        raise InputError(f"{p}: no sidecar {side.name} with the cell size")
    try:
        meta = json.loads(side.read_text())
        cell = float(meta["cell_size_m"])
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{side}: not an offroadbench grid sidecar ({exc})") from None
    suffix = p.suffix.lower()
    if suffix in (".tif", ".tiff"):
        from PIL import Image

        with Image.open(p) as img:
            if img.mode != "F":
                raise InputError(f"{p}: is a mode {img.mode} TIFF, expected 32-bit float (mode F)")
            z = np.asarray(img, dtype=np.float32)
    elif suffix == ".npy":
        z = np.load(p, allow_pickle=False)
    else:
        raise InputError(f"{p}: unknown grid file type {suffix!r}; expected .tif, .tiff or .npy")
    if z.shape != (meta.get("rows", z.shape[0]), meta.get("cols", z.shape[1])):
        raise InputError(f"{p}: shape {z.shape} does not match the sidecar's {meta.get('rows')}x{meta.get('cols')}")
    return Heightmap(z.astype(np.float64), cell)


def _float32_precision(hm: Heightmap) -> float:
    return float(np.finfo(np.float32).eps) / 2 * float(np.abs(hm.z).max())


EXPORTERS.register(
    "tiff",
    Exporter(
        name="tiff",
        summary="32-bit float TIFF NAME.tif of z in metres (no georeference) + NAME.tif.json sidecar",
        reader="Pillow, tifffile, image tools (offroadbench.io.export.grid.read_grid)",
        write=write_tiff,
        read=lambda d, name: read_grid(d / f"{name}.tif"),
        precision_m=_float32_precision,
    ),
)
EXPORTERS.register(
    "npy",
    Exporter(
        name="npy",
        summary="NumPy NAME.npy of z in metres (float64, bit-exact) + NAME.npy.json sidecar",
        reader="NumPy (numpy.load; offroadbench.io.export.grid.read_grid)",
        write=write_npy,
        read=lambda d, name: read_grid(d / f"{name}.npy"),
        precision_m=lambda hm: 0.0,
    ),
)
