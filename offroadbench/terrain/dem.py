"""The ``dem`` generator: an imported DEM, its gaps filled, sampled onto the recipe's grid.

The generator never reads a file: a recipe names the file (``path``, or none for the bundled
sample) and :mod:`offroadbench.terrain.recipe` reads it through :func:`offroadbench.io.dem.read_dem`
when the recipe is loaded, handing the :class:`~offroadbench.io.dem.RawDEM` to this layer.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.dem import RawDEM
from offroadbench.terrain.gaps import fill_gaps
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.registry import register

log = logging.getLogger(__name__)

__all__ = ["DEMConfig", "generate_dem"]


@dataclass(frozen=True, kw_only=True)
class DEMConfig:
    """An imported DEM sampled onto the recipe's grid (gaps filled first; bilinear resampling
    where the grid's cell size or origin differ from the DEM's).

    In a recipe the layer names its file with ``path`` (a 16-bit PNG with sidecar, .npy, a
    geographic .npz or GeoTIFF; ``"matplotlib:NAME"`` = a sample file shipped with matplotlib, such
    as ``matplotlib:jacksboro_fault_dem.npz``; none = the bundled synthetic sample with gaps) and, for files that do not carry
    them, ``source_cell_size_m``, ``source_relief_m`` (PNG height range) and ``nodata_level``
    (PNG level of a gap); the recipe loader reads the file into ``dem``.
    """

    dem: RawDEM
    """The DEM: heights in metres, NaN where unknown, on its own cell size."""
    origin_x_m: float = 0.0
    """x in the DEM (metres from its first column) of the output's first column."""
    origin_y_m: float = 0.0
    """y in the DEM (metres from its first row) of the output's first row."""
    fill_roughness: float = 0.2
    """Gap-fill noise: a unit Gaussian times this times the DEM cell (Martin et al. 2014, Sec. IV.B)."""

    def __post_init__(self) -> None:
        if not isinstance(self.dem, RawDEM):
            raise InputError(f"DEMConfig.dem must be a RawDEM (read by offroadbench.io.dem.read_dem), got {type(self.dem).__name__}")
        check_range(self, "origin_x_m", self.origin_x_m, lo=0)
        check_range(self, "origin_y_m", self.origin_y_m, lo=0)
        check_range(self, "fill_roughness", self.fill_roughness, lo=0)


def _resample(z: np.ndarray, src_cell: float, cfg: DEMConfig, grid: GridConfig, src_cell_y: float | None = None) -> np.ndarray:
    """Bilinear samples of ``z`` (columns ``src_cell`` apart, rows ``src_cell_y``, default the
    same) at the grid's points; each axis is interpolated on its own spacing, so non-square DEM
    cells (a geographic DEM's degrees) land on square output cells."""
    src_rows, src_cols = z.shape
    cy = src_cell if src_cell_y is None else src_cell_y
    x = cfg.origin_x_m + np.arange(grid.cols) * grid.cell_size_m
    y = cfg.origin_y_m + np.arange(grid.rows) * grid.cell_size_m
    tol = 1e-9 * max(src_cell, cy)
    if x[-1] > (src_cols - 1) * src_cell + tol or y[-1] > (src_rows - 1) * cy + tol:
        cells = f"{src_cell:g} m" if cy == src_cell else f"{src_cell:g} x {cy:g} m"
        raise InputError(
            f"dem: the grid ({grid.cols} x {grid.rows} at {grid.cell_size_m:g} m from ({cfg.origin_x_m:g}, "
            f"{cfg.origin_y_m:g}) m) reaches beyond the DEM ({(src_cols - 1) * src_cell:g} x "
            f"{(src_rows - 1) * cy:g} m at {cells})"
        )
    fc = np.clip(x / src_cell, 0, src_cols - 1)
    fr = np.clip(y / cy, 0, src_rows - 1)
    c0 = np.minimum(fc.astype(np.intp), src_cols - 2)
    r0 = np.minimum(fr.astype(np.intp), src_rows - 2)
    tc = (fc - c0)[None, :]
    tr = (fr - r0)[:, None]
    top = z[np.ix_(r0, c0)] * (1 - tc) + z[np.ix_(r0, c0 + 1)] * tc
    bot = z[np.ix_(r0 + 1, c0)] * (1 - tc) + z[np.ix_(r0 + 1, c0 + 1)] * tc
    return top * (1 - tr) + bot * tr


@register("dem", DEMConfig, summary="Imported DEM (16-bit PNG + sidecar, .npy or GeoTIFF), gaps filled, resampled to the grid")
def generate_dem(cfg: DEMConfig, grid: GridConfig, rng: np.random.Generator) -> Heightmap:
    """Fill the DEM's gaps (Martin et al. 2014, Sec. IV.B) and sample it onto the grid
    (bilinear where the grid's cells or origin differ from the DEM's)."""
    raw = cfg.dem
    z = raw.z
    if raw.gap_count:
        log.info("dem: filling %d gap pixel(s)", raw.gap_count)
        z = fill_gaps(z, raw.cell_size_m, cfg.fill_roughness, rng)
    same_grid = (
        math.isclose(raw.cell_size_m, grid.cell_size_m) and math.isclose(raw.row_step_m, grid.cell_size_m)
        and cfg.origin_x_m == 0 and cfg.origin_y_m == 0
        and z.shape[0] >= grid.rows and z.shape[1] >= grid.cols
    )
    out = z[: grid.rows, : grid.cols] if same_grid else _resample(z, raw.cell_size_m, cfg, grid, raw.row_step_m)
    return Heightmap(z=out, cell_size_m=grid.cell_size_m)
