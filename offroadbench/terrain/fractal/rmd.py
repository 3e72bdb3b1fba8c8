"""Random midpoint displacement (RMD), Martin et al. 2014, Sec. IV.A: diamond-square surfaces and DEM expansion.

A square grid of side ``W = 2^(M+1)`` (+1 samples here, Martin et al. 2014, Eq. 13) is refined level by level:
the *square* phase sets each cell centre to the mean of its four corners, the *diamond* phase
each edge midpoint to the mean of its four neighbours, and every new value is displaced
by a Gaussian of scale S. After each phase the scale is multiplied by
``S_f = 2^(-(3 - F)/2)`` (Martin et al. 2014, Eq. 14), F the fractal dimension, so after one level (two
phases) it has shrunk by ``2^-(3-F) = 2^-H`` as fBm requires (Peitgen & Saupe). The initial scale
is Martin et al. 2014, Eq. (15): ``S = S_f H_s D_r W sqrt(1 - 2^(2(3-F) - 2))`` with H_s the height-range factor
and D_r the horizontal resolution. Border midpoints use their two parents along the border.

Fractal expansion of a DEM (``rmd_expand``, Martin et al. 2014, Sec. IV.A, Eq. 13-16, Fig. 5) uses
the same two phases: each level doubles the resolution. The old samples are copied to the even
pixels of a (2R-1) x (2C-1) grid and the new ones are interpolated in a square phase and a diamond
phase and displaced by Gaussians whose scale shrinks by S_f (Eq. 14) per phase. The original
samples are kept exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.registry import register

__all__ = [
    "DiamondSquareConfig",
    "scale_factor",
    "initial_scale",
    "square_phase",
    "diamond_phase",
    "diamond_square",
    "generate_diamond_square",
    "RMDExpandConfig",
    "estimate_displacement_scale",
    "rmd_expand",
]

#: Largest grid (pixels) an expansion may produce.
MAX_PIXELS = 1 << 26


def scale_factor(dimension: float) -> float:
    """Martin et al. 2014, Eq. (14): S_f = 1 / 2^((3 - F) / 2)."""
    return 1.0 / 2.0 ** ((3.0 - dimension) / 2.0)


def initial_scale(dimension: float, height_scale: float, resolution_m: float, width_px: int) -> float:
    """Martin et al. 2014, Eq. (15): S = S_f H D_r W sqrt(1 - 2^(2(3-F) - 2))."""
    return (
        scale_factor(dimension) * height_scale * resolution_m * width_px
        * math.sqrt(1.0 - 2.0 ** (2.0 * (3.0 - dimension) - 2.0))
    )


def square_phase(z: np.ndarray, step: int, sigma: float, rng: np.random.Generator) -> None:
    """Set every cell centre (spacing ``step``) to the mean of its 4 corners + N(0, sigma^2), in place."""
    h = step // 2
    rows, cols = z.shape
    rs = np.arange(0, rows - 1, step)
    cs = np.arange(0, cols - 1, step)
    mean = 0.25 * (
        z[np.ix_(rs, cs)] + z[np.ix_(rs, cs + step)] + z[np.ix_(rs + step, cs)] + z[np.ix_(rs + step, cs + step)]
    )
    z[np.ix_(rs + h, cs + h)] = mean + sigma * rng.standard_normal(mean.shape)


def _diamond_set(z: np.ndarray, rs: np.ndarray, cs: np.ndarray, h: int, sigma: float, rng, along_rows: bool) -> None:
    """Diamond values at (rs x cs). ``along_rows``: the pair (r, c -+ h) always exists (else (r -+ h, c))."""
    rows, cols = z.shape
    if along_rows:
        pair = z[np.ix_(rs, cs - h)] + z[np.ix_(rs, cs + h)]
        cross_lo, cross_hi = rs - h, rs + h
        ok = (cross_lo >= 0) & (cross_hi < rows)
        cross = np.zeros_like(pair)
        cross[ok, :] = z[np.ix_(cross_lo[ok], cs)] + z[np.ix_(cross_hi[ok], cs)]
        full = np.broadcast_to(ok[:, None], pair.shape)
    else:
        pair = z[np.ix_(rs - h, cs)] + z[np.ix_(rs + h, cs)]
        cross_lo, cross_hi = cs - h, cs + h
        ok = (cross_lo >= 0) & (cross_hi < cols)
        cross = np.zeros_like(pair)
        cross[:, ok] = z[np.ix_(rs, cross_lo[ok])] + z[np.ix_(rs, cross_hi[ok])]
        full = np.broadcast_to(ok[None, :], pair.shape)
    mean = np.where(full, 0.25 * (pair + cross), 0.5 * pair)
    z[np.ix_(rs, cs)] = mean + sigma * rng.standard_normal(mean.shape)


def diamond_phase(z: np.ndarray, step: int, sigma: float, rng: np.random.Generator) -> None:
    """Set every edge midpoint (spacing ``step``) to the mean of its 4 neighbours + N(0, sigma^2).

    A midpoint on the grid's border has no outer neighbour; it uses the mean of its two parents
    along the border instead (Martin et al. 2014, Sec. IV.A: border pixels use the nearest known pixels).
    """
    h = step // 2
    rows, cols = z.shape
    _diamond_set(z, np.arange(0, rows, step), np.arange(h, cols, step), h, sigma, rng, along_rows=True)
    _diamond_set(z, np.arange(h, rows, step), np.arange(0, cols, step), h, sigma, rng, along_rows=False)


def diamond_square(size_px: int, dimension: float, sigma0: float, rng: np.random.Generator) -> np.ndarray:
    """A (size, size) RMD surface; size must be 2^n + 1. Corners are N(0, sigma0^2)."""
    n = size_px - 1
    if n < 2 or n & (n - 1):
        raise InputError(f"diamond-square size = {size_px} px is not allowed; it must be 2^n + 1 (3, 5, 9, 17, ...)")
    sf = scale_factor(dimension)
    z = np.zeros((size_px, size_px))
    z[np.ix_([0, n], [0, n])] = sigma0 * rng.standard_normal((2, 2))
    sigma = sigma0
    step = n
    while step > 1:
        square_phase(z, step, sigma, rng)
        sigma *= sf
        diamond_phase(z, step, sigma, rng)
        sigma *= sf
        step //= 2
    return z


@dataclass(frozen=True, kw_only=True)
class DiamondSquareConfig:
    """A diamond-square RMD surface (Martin et al. 2014, Sec. IV.A), cropped from the next 2^n + 1 square."""

    D: float = 2.2
    """Fractal dimension F in (2, 3) (Martin et al. 2014 uses 2.2 for lunar terrain)."""
    height_scale: float = 0.05
    """H of Martin et al. 2014, Eq. (15), the height-range factor relative to the DEM width."""
    relief_m: float | None = None
    """If set, rescale to min 0 .. relief_m; otherwise heights are Eq. (15)'s metres."""

    def __post_init__(self) -> None:
        check_range(self, "D", self.D, lo=2, hi=3, lo_open=True, hi_open=True)
        check_range(self, "height_scale", self.height_scale, lo=0, lo_open=True)
        if self.relief_m is not None:
            check_range(self, "relief_m", self.relief_m, lo=0, lo_open=True)


@register("diamond_square", DiamondSquareConfig, summary="Diamond-square random midpoint displacement (Martin et al. 2014, Sec. IV.A)")
def generate_diamond_square(cfg: DiamondSquareConfig, grid: GridConfig, rng: np.random.Generator) -> Heightmap:
    """RMD surface of the grid's size (the top-left corner of the enclosing 2^n + 1 square).

    The grid's cell size is D_r of Martin et al. 2014, Eq. (15)."""
    side = max(grid.rows, grid.cols) - 1
    size = 2 ** max(1, math.ceil(math.log2(side))) + 1
    sigma0 = initial_scale(cfg.D, cfg.height_scale, grid.cell_size_m, size - 1)
    z = diamond_square(size, cfg.D, sigma0, rng)[: grid.rows, : grid.cols]
    hm = Heightmap(z=z, cell_size_m=grid.cell_size_m)
    return hm.rescaled(cfg.relief_m) if cfg.relief_m is not None else hm


@dataclass(frozen=True, kw_only=True)
class RMDExpandConfig:
    """Fractal expansion of a DEM by 2^levels with RMD (Martin et al. 2014, Sec. IV.A, Eq. 13-16)."""

    levels: int = 1
    """Number of doublings k: the grid becomes ((R-1) 2^k + 1) x ((C-1) 2^k + 1), cell / 2^k."""
    D: float = 2.2
    """Fractal dimension F of the new detail (Martin et al. 2014, Eq. 14)."""
    displacement_scale_m: float | None = None
    """S_e of Martin et al. 2014, Eq. (16), the scale of the first new square phase, metres. None: estimated from
    the DEM (see :func:`estimate_displacement_scale`), since Eq. (15)'s height factor is unknown
    for real data."""

    def __post_init__(self) -> None:
        check_int(self, "levels", self.levels, lo=1, hi=12)
        check_range(self, "D", self.D, lo=2, hi=3, lo_open=True, hi_open=True)
        if self.displacement_scale_m is not None:
            check_range(self, "displacement_scale_m", self.displacement_scale_m, lo=0)


def estimate_displacement_scale(z: np.ndarray, dimension: float) -> float:
    """S_e for the first new square phase, from the DEM's finest detail.

    The residual of each pixel from the mean of its 4 diagonal neighbours is what the last square
    phase would have added had the DEM been made by RMD; one diamond phase and one square phase
    later (two factors S_f, Martin et al. 2014, Eq. 14) comes the first new phase.
    """
    if min(z.shape) < 3:
        return 0.0
    resid = z[1:-1, 1:-1] - 0.25 * (z[:-2, :-2] + z[:-2, 2:] + z[2:, :-2] + z[2:, 2:])
    return float(resid.std()) * scale_factor(dimension) ** 2


@register(
    "rmd_expand",
    RMDExpandConfig,
    kind="modifier",
    summary="RMD fractal expansion by 2^k keeping the original samples (Martin et al. 2014, Eq. 13-16)",
)
def rmd_expand(cfg: RMDExpandConfig, hm: Heightmap, rng: np.random.Generator) -> Heightmap:
    """Double the resolution ``levels`` times; ``result.z[::2^k, ::2^k] == hm.z`` exactly."""
    rows = (hm.rows - 1) * 2**cfg.levels + 1
    cols = (hm.cols - 1) * 2**cfg.levels + 1
    if rows * cols > MAX_PIXELS:
        raise InputError(
            f"RMDExpandConfig.levels = {cfg.levels} would make a {rows} x {cols} grid (> {MAX_PIXELS} pixels); use fewer levels"
        )
    sf = scale_factor(cfg.D)
    sigma = cfg.displacement_scale_m if cfg.displacement_scale_m is not None else estimate_displacement_scale(hm.z, cfg.D)
    z = np.array(hm.z, dtype=np.float64)
    for _ in range(cfg.levels):
        new = np.zeros((2 * z.shape[0] - 1, 2 * z.shape[1] - 1))
        new[::2, ::2] = z
        square_phase(new, 2, sigma, rng)
        diamond_phase(new, 2, sigma * sf, rng)
        sigma *= sf * sf
        z = new
    return Heightmap(z=z, cell_size_m=hm.cell_size_m / 2**cfg.levels)
