"""Helpers shared by the exporters: exact numbers in text files, extents, provenance."""

from __future__ import annotations

import json
from decimal import Decimal
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench.heightmap import Heightmap

__all__ = ["fmt", "fmt_list", "span_m", "half_span_m", "describe", "grid_triangles", "write_json", "resample_bilinear", "save_png16_levels", "load_png16_levels"]

#: meta keys copied into the description of a model file (SDF, MJCF, USD, Webots world)
PROVENANCE_KEYS = ("recipe_name", "seed", "overrides", "terrain_id", "source")


def fmt(v: float) -> str:
    """Shortest text that reads back as the same float64 (``repr``), without a trailing ``.0``.

    ``fmt(9.95) == "9.95"``, ``fmt(3.0) == "3"``, ``fmt(-0.0) == "0"``, ``fmt(1e-05) == "1e-05"``.
    """
    x = float(v)
    if x == 0:
        return "0"
    s = repr(x)
    return s[:-2] if s.endswith(".0") else s


def fmt_list(values) -> str:
    """Numbers separated by single spaces (SDF vectors, MJCF attributes, VRML fields)."""
    return " ".join(fmt(v) for v in values)


def span_m(n_samples: int, cell_size_m: float) -> float:
    """(n - 1) * cell computed in decimal from the cell size's shortest text, then rounded once.

    ``span_m(200, 0.05) == 9.95`` where ``199 * 0.05 == 9.950000000000001`` in float64: both are
    within one ulp of the true extent, but the decimal product is the number the user meant and
    prints without float noise. Use it for every extent written into a file.
    """
    return float(Decimal(repr(float(cell_size_m))) * (n_samples - 1))


def half_span_m(n_samples: int, cell_size_m: float) -> float:
    """Half of :func:`span_m`, also in decimal (MuJoCo radii, Gazebo/MuJoCo centres)."""
    return float(Decimal(repr(float(cell_size_m))) * (n_samples - 1) / 2)


def describe(hm: Heightmap, name: str, meta: Mapping[str, Any]) -> str:
    """One paragraph for a model file's description: size, placement, heights, provenance."""
    from offroadbench import __version__

    text = (
        f"offroadbench {__version__} terrain {name}: {hm.rows}x{hm.cols} samples at {fmt(hm.cell_size_m)} m; "
        f"sample (row r, col c) is at x = c * {fmt(hm.cell_size_m)} m, y = r * {fmt(hm.cell_size_m)} m "
        f"(x 0..{fmt(span_m(hm.cols, hm.cell_size_m))}, y 0..{fmt(span_m(hm.rows, hm.cell_size_m))}), "
        f"z {fmt(hm.z_min_m)}..{fmt(hm.z_max_m)} m, z up."
    )
    for k in PROVENANCE_KEYS:
        if k in meta:
            text += f" {k}: {meta[k]}."
    return text


def grid_triangles(rows: int, cols: int) -> np.ndarray:
    """(2 (rows-1)(cols-1), 3) 0-based vertex indices of a row-major vertex grid: two triangles per
    cell, (r, c) (r, c+1) (r+1, c+1) and (r, c) (r+1, c+1) (r+1, c), counter-clockwise seen from +z."""
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, e = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tri = np.empty((2 * a.size, 3), dtype=np.int32 if rows * cols < 2**31 else np.int64)
    tri[0::2] = np.stack([a, b, c], axis=1)
    tri[1::2] = np.stack([a, c, e], axis=1)
    return tri


def write_json(path: Path, data: Mapping[str, Any]) -> None:
    """JSON with sorted keys; floats are written by ``json`` with their shortest round-trip text."""
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")


def resample_bilinear(hm: Heightmap, rows: int, cols: int) -> np.ndarray:
    """Heights on a ``rows x cols`` grid spanning the same extent (first to last sample), bilinear.

    Corner samples are kept exactly; an unchanged shape returns a copy of ``hm.z``.
    """
    if (rows, cols) == hm.shape:
        return np.array(hm.z)
    x = np.linspace(0.0, hm.width_m, cols)
    y = np.linspace(0.0, hm.height_m, rows)
    xx, yy = np.meshgrid(x, y)
    return np.asarray(hm.height_at(xx, yy), dtype=np.float64)


def save_png16_levels(q: np.ndarray, path: Path) -> None:
    """A uint16 array as a 16-bit grayscale PNG (no metadata)."""
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(q, dtype=np.uint16)).save(path, format="PNG")


def load_png16_levels(path: Path) -> np.ndarray:
    """The levels of a 16-bit grayscale PNG as float64."""
    from PIL import Image

    with Image.open(path) as img:
        return np.asarray(img).astype(np.float64)
