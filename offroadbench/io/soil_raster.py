"""Soil rasters: PNG images of soil indices aligned with a heightmap (issue 47), read for a recipe's
``[soil] raster`` and written as the soil-map sidecar of an export.

A soil raster is a grayscale PNG (8 or 16 bit) with one pixel per heightmap sample: pixel (row r,
col c) is the index of the soil at ``z[r, c]`` (the heightmap's own convention, no flips). The
indices name soils through a list kept beside the raster: the recipe's ``raster_soils``, or, for an
exported raster, its JSON sidecar (``<name>.json``: ``soils``, ``cell_size_m``, ``rows``, ``cols``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

import numpy as np

from offroadbench.errors import InputError
from offroadbench.io.atomic import atomic_path, check_writable

__all__ = ["read_soil_raster", "soil_raster_sidecar", "write_soil_raster"]


def read_soil_raster(path: str | Path) -> np.ndarray:
    """The soil indices of a grayscale PNG, shape (rows, cols), int64 (an InputError naming the file
    for a missing, unreadable or colour image)."""
    from PIL import Image

    p = Path(path)
    if not p.is_file():
        raise InputError(f"soil raster {p}: no such file")
    try:
        with Image.open(p) as img:
            if img.mode not in ("L", "I;16", "I", "P"):
                raise InputError(f"soil raster {p}: mode {img.mode!r}; must be an 8- or 16-bit grayscale PNG of soil "
                                 "indices")
            data = np.asarray(img)
    except InputError:
        raise
    except Exception as exc:  # PIL raises many kinds on a broken file
        raise InputError(f"soil raster {p}: cannot read it as a PNG ({exc})") from None
    return data.astype(np.int64)


def soil_raster_sidecar(png_path: str | Path) -> Path:
    """The JSON beside an exported soil raster: same name, ``.json``."""
    return Path(png_path).with_suffix(".json")


def write_soil_raster(index: np.ndarray, soils: Sequence[str], cell_size_m: float, path: str | Path) -> Path:
    """Write ``index`` (soil indices, shape (rows, cols)) as an 8-bit grayscale PNG at ``path`` and its
    JSON sidecar (``soils``: index -> soil name, ``cell_size_m``, ``rows``, ``cols``), atomically;
    return the PNG's path."""
    from PIL import Image

    png = Path(path)
    idx = np.asarray(index)
    if idx.ndim != 2 or idx.size == 0 or idx.min() < 0 or idx.max() >= len(soils) or len(soils) > 256:
        raise InputError(f"soil raster {png}: indices must lie in 0..{len(soils) - 1} (at most 256 soils)")
    check_writable(png)
    side = soil_raster_sidecar(png)
    meta = {"soils": list(soils), "cell_size_m": float(cell_size_m), "rows": int(idx.shape[0]),
            "cols": int(idx.shape[1]), "convention": "pixel (row r, col c) is the soil index at z[r, c]"}
    with atomic_path(side) as tmp_json, atomic_path(png) as tmp_png:
        Image.fromarray(idx.astype(np.uint8), mode="L").save(tmp_png, format="PNG")
        tmp_json.write_text(json.dumps(meta, indent=2) + "\n")
    return png
