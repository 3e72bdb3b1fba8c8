"""Import of existing DEMs so real data can be enhanced (Martin et al. 2014, Sec. IV; Yoshikawa Sec. 3.4).

Formats:

* ``.png``: a 16-bit grayscale PNG, read with :func:`offroadbench.io.png16.read_png16` (cell size
  and height range from the JSON sidecar, or given by the caller). A ``nodata_level`` (e.g. 0)
  marks gaps.
* ``.npy``: a 2-D float array of heights in metres; NaN marks gaps. The cell size comes from a
  sidecar ``NAME.json`` with ``cell_size_m`` or from the caller.

The result is a :class:`RawDEM`: heights that may contain NaN (a ``Heightmap`` may not), to be
gap-filled (:func:`offroadbench.terrain.enhance.fill_gaps`) before use.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from offroadbench.errors import InputError

__all__ = ["RawDEM", "read_dem", "DEM_SUFFIXES"]

DEM_SUFFIXES = (".png", ".npy")


@dataclass(frozen=True, eq=False)
class RawDEM:
    """Heights in metres (NaN = unknown) on a regular grid of ``cell_size_m``."""

    z: np.ndarray
    cell_size_m: float

    @property
    def gap_count(self) -> int:
        return int(np.isnan(self.z).sum())


def _sidecar_cell(path: Path) -> float | None:
    side = path.with_suffix(".json")
    if not side.is_file():
        return None
    try:
        meta = json.loads(side.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{side}: not valid JSON ({exc})") from None
    if "cell_size_m" not in meta:
        raise InputError(f"{side}: has no cell_size_m")
    return float(meta["cell_size_m"])


def read_dem(
    path: str | Path,
    *,
    cell_size_m: float | None = None,
    relief_m: float | None = None,
    nodata_level: int | None = None,
) -> RawDEM:
    """Read a DEM file (see the module docstring). ``cell_size_m`` overrides a missing sidecar."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"DEM file {p} does not exist")
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
        except ValueError as exc:
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
    raise InputError(f"DEM file {p}: unknown format {suffix!r}; known: {', '.join(DEM_SUFFIXES)}")
