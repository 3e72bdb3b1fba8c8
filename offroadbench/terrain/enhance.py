"""Enhancing DEMs: spectral restoration, RMD fractal expansion, gap filling, DEM import.

* ``spectral_restore`` (Yoshikawa & Nishiguchi Sec. 3.4, Fig. 4): DFT the DEM (a), keep the
  coefficients with wavelength longer than a cutoff (b), replace the rest with random ones that
  follow the fBm law E|a|^2 = S0 / f^(2H+2) (c, Yoshikawa & Nishiguchi 2001, Eq. 5-7) and inverse-DFT (d). S0 is fitted to
  the DEM's own spectrum in the octave below the cutoff, so the synthetic spectrum continues the
  measured one. The kept (low-pass) part is unchanged.
* ``rmd_expand`` (Martin et al. 2014, Sec. IV.A, Eq. 13-16, Fig. 5): each level doubles the
  resolution. The old samples are copied to the even pixels of a (2R-1) x (2C-1) grid and the new
  ones are interpolated in a square phase and a diamond phase and displaced by Gaussians whose
  scale shrinks by S_f (Eq. 14) per phase. The original samples are kept exactly.
* :func:`fill_gaps` (Martin et al. 2014, Sec. IV.B): unknown (NaN) pixels are filled from the outside in.
* ``dem`` generator: import a DEM file (16-bit PNG + sidecar, or .npy), fill its gaps and sample
  it onto the recipe's grid (bilinear), so real data can be layered and enhanced.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.fractal.diamond_square import diamond_phase, scale_factor, square_phase
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.registry import register

log = logging.getLogger(__name__)

__all__ = [
    "SpectralRestoreConfig",
    "spectral_restore",
    "RMDExpandConfig",
    "estimate_displacement_scale",
    "rmd_expand",
    "known_neighbour_count",
    "fill_gaps",
    "DEMConfig",
    "SAMPLE_DEM",
    "generate_dem",
]

#: Largest grid (pixels) an expansion may produce.
MAX_PIXELS = 1 << 26
#: The bundled synthetic sample DEM with gaps (diamond-square + craters; for demos and tests).
SAMPLE_DEM = Path(__file__).resolve().parent.parent.parent / "terrains" / "data" / "sample-dem.npy"


# --------------------------------------------------------------------------- spectral restoration
@dataclass(frozen=True, kw_only=True)
class SpectralRestoreConfig:
    """Spectral restoration of the short wavelengths of a coarse or smoothed DEM (Yoshikawa & Nishiguchi 2001, Sec. 3.4)."""

    cutoff_wavelength_m: float = 1.0
    """Wavelengths shorter than this are replaced by fBm (Yoshikawa & Nishiguchi 2001's r_max, as a length in metres)."""
    H: float = 0.8
    """Hurst exponent of the synthetic part (Yoshikawa & Nishiguchi 2001, Sec. 5.1: H ~ 0.8, D ~ 2.2 for lunar DEMs)."""
    fit_octaves: float = 1.0
    """Width of the band below the cutoff used to fit the amplitude S0, in octaves."""

    def __post_init__(self) -> None:
        check_range(self, "cutoff_wavelength_m", self.cutoff_wavelength_m, lo=0, lo_open=True)
        check_range(self, "H", self.H, lo=0, hi=1, lo_open=True, hi_open=True)
        check_range(self, "fit_octaves", self.fit_octaves, lo=0.1, hi=5)


def _frequency_grid(rows: int, cols: int, cell: float) -> np.ndarray:
    fy = np.fft.fftfreq(rows, d=cell)
    fx = np.fft.rfftfreq(cols, d=cell)
    return np.hypot(fy[:, None], fx[None, :])


@register(
    "spectral_restore",
    SpectralRestoreConfig,
    kind="modifier",
    summary="Keep a DEM's long wavelengths, synthesise the short ones as fBm (Yoshikawa & Nishiguchi Sec. 3.4)",
)
def spectral_restore(cfg: SpectralRestoreConfig, hm: Heightmap, rng: np.random.Generator) -> Heightmap:
    """Yoshikawa & Nishiguchi 2001, Sec. 3.4 steps (a)-(d) on ``hm`` (see the module docstring)."""
    coef = np.fft.rfft2(hm.z)
    f = _frequency_grid(hm.rows, hm.cols, hm.cell_size_m)
    fc = 1.0 / cfg.cutoff_wavelength_m
    high = f > fc
    if not high.any():
        log.info("spectral_restore: cutoff %g m is below the grid's Nyquist wavelength; nothing to restore", cfg.cutoff_wavelength_m)
        return hm
    band = (f > 0) & (f <= fc) & (f >= fc / 2.0**cfg.fit_octaves)
    if not band.any():
        raise InputError(
            f"SpectralRestoreConfig.cutoff_wavelength_m = {cfg.cutoff_wavelength_m:g} m leaves no measured "
            f"wavelengths to fit on a {hm.width_m:g} x {hm.height_m:g} m map; use a shorter cutoff"
        )
    exponent = 2.0 * cfg.H + 2.0
    s0 = float(np.mean(np.abs(coef[band]) ** 2 * f[band] ** exponent))
    amp = np.sqrt(s0 * f[high] ** (-exponent) / 2.0)
    noise = rng.standard_normal(amp.shape) + 1j * rng.standard_normal(amp.shape)
    coef[high] = amp * noise
    return hm.with_z(np.fft.irfft2(coef, s=hm.shape))


# --------------------------------------------------------------------------- RMD expansion
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


# --------------------------------------------------------------------------- gap filling
_DIRECTIONS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def known_neighbour_count(known: np.ndarray) -> np.ndarray:
    """Number of known pixels among the 8 neighbours of every pixel."""
    k = np.pad(known.astype(np.int16), 1)
    rows, cols = known.shape
    total = np.zeros((rows, cols), dtype=np.int16)
    for dr, dc in _DIRECTIONS:
        total += k[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols]
    return total


def _counts_at(known_padded: np.ndarray, rr: np.ndarray, cc: np.ndarray) -> np.ndarray:
    """Known 8-neighbour counts at pixels (rr, cc) of a 1-padded known mask."""
    total = np.zeros(rr.size, dtype=np.int16)
    for dr, dc in _DIRECTIONS:
        total += known_padded[rr + 1 + dr, cc + 1 + dc]
    return total


def _idw_eight_directions(z: np.ndarray, known: np.ndarray, rr: np.ndarray, cc: np.ndarray, reach: int) -> np.ndarray:
    """Inverse-distance weighted mean of the nearest known pixel in each of the 8 directions,
    looking at most ``reach`` pixels along each."""
    rows, cols = z.shape
    t = np.arange(1, reach + 1)
    wsum = np.zeros(rr.size)
    vsum = np.zeros(rr.size)
    for dr, dc in _DIRECTIONS:
        r = rr[:, None] + dr * t[None, :]
        c = cc[:, None] + dc * t[None, :]
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        hit = np.zeros(r.shape, dtype=bool)
        hit[inside] = known[r[inside], c[inside]]
        any_hit = hit.any(axis=1)
        first = np.argmax(hit, axis=1)
        idx = np.flatnonzero(any_hit)
        if idx.size == 0:
            continue
        tt = first[idx]
        w = 1.0 / ((tt + 1) * math.hypot(dr, dc))
        vsum[idx] += w * z[r[idx, tt], c[idx, tt]]
        wsum[idx] += w
    return vsum / wsum


def fill_gaps(
    z: np.ndarray, cell_size_m: float, roughness: float, rng: np.random.Generator, reach_px: int = 64
) -> np.ndarray:
    """Fill NaN pixels from the outside in (Martin et al. 2014, Sec. IV.B); known pixels are never changed.

    Unknown pixels with the most known neighbours are filled first; the counts are then
    recomputed and the next batch filled, until none is left. (Martin et al. 2014 fills one pixel at a time and
    re-sorts; we fill all pixels sharing the current highest count at once, which keeps the
    outside-in order and is much faster.) A pixel's value is the inverse-distance weighted mean of
    the nearest known pixel in each of the 8 directions (looking up to ``reach_px`` pixels) plus
    ``roughness * cell_size_m`` times a unit Gaussian.
    """
    out = np.array(z, dtype=np.float64, copy=True)
    unknown = np.isnan(out)
    if unknown.all():
        raise InputError("fill_gaps: every pixel is unknown (NaN); nothing to fill from")
    if np.isinf(out).any():
        raise InputError("fill_gaps: heights contain inf; only NaN marks a gap")
    known_padded = np.pad(~unknown, 1)
    ur, uc = np.nonzero(unknown)
    while ur.size:
        counts = _counts_at(known_padded, ur, uc)
        pick = counts == counts.max()
        rr, cc = ur[pick], uc[pick]
        vals = _idw_eight_directions(out, known_padded[1:-1, 1:-1], rr, cc, reach_px)
        out[rr, cc] = vals + roughness * cell_size_m * rng.standard_normal(rr.size)
        known_padded[rr + 1, cc + 1] = True
        ur, uc = ur[~pick], uc[~pick]
    return out


# --------------------------------------------------------------------------- DEM import
@dataclass(frozen=True, kw_only=True)
class DEMConfig:
    """An imported DEM sampled onto the recipe's grid (gaps filled first; bilinear resampling
    where the grid's cell size or origin differ from the DEM's)."""

    path: str | None = None
    """A 16-bit PNG (with sidecar), .npy or GeoTIFF DEM (offroadbench.io.dem); None = the bundled synthetic sample with gaps."""
    source_cell_size_m: float | None = None
    """The file's cell size, metres, if it has no sidecar."""
    source_relief_m: float | None = None
    """Height range of a PNG without sidecar, metres."""
    nodata_level: int | None = None
    """PNG level that marks a gap (e.g. 0); .npy files mark gaps with NaN."""
    origin_x_m: float = 0.0
    """x in the DEM (metres from its first column) of the output's first column."""
    origin_y_m: float = 0.0
    """y in the DEM (metres from its first row) of the output's first row."""
    fill_roughness: float = 0.2
    """Gap-fill noise: a unit Gaussian times this times the DEM cell (Martin et al. 2014, Sec. IV.B)."""

    def __post_init__(self) -> None:
        if self.source_cell_size_m is not None:
            check_range(self, "source_cell_size_m", self.source_cell_size_m, lo=0, lo_open=True)
        if self.source_relief_m is not None:
            check_range(self, "source_relief_m", self.source_relief_m, lo=0)
        check_range(self, "origin_x_m", self.origin_x_m, lo=0)
        check_range(self, "origin_y_m", self.origin_y_m, lo=0)
        check_range(self, "fill_roughness", self.fill_roughness, lo=0)


def _resample(z: np.ndarray, src_cell: float, cfg: DEMConfig, grid: GridConfig) -> np.ndarray:
    src_rows, src_cols = z.shape
    x = cfg.origin_x_m + np.arange(grid.cols) * grid.cell_size_m
    y = cfg.origin_y_m + np.arange(grid.rows) * grid.cell_size_m
    tol = 1e-9 * src_cell
    if x[-1] > (src_cols - 1) * src_cell + tol or y[-1] > (src_rows - 1) * src_cell + tol:
        raise InputError(
            f"dem: the grid ({grid.cols} x {grid.rows} at {grid.cell_size_m:g} m from ({cfg.origin_x_m:g}, "
            f"{cfg.origin_y_m:g}) m) reaches beyond the DEM ({(src_cols - 1) * src_cell:g} x "
            f"{(src_rows - 1) * src_cell:g} m at {src_cell:g} m)"
        )
    fc = np.clip(x / src_cell, 0, src_cols - 1)
    fr = np.clip(y / src_cell, 0, src_rows - 1)
    c0 = np.minimum(fc.astype(np.intp), src_cols - 2)
    r0 = np.minimum(fr.astype(np.intp), src_rows - 2)
    tc = (fc - c0)[None, :]
    tr = (fr - r0)[:, None]
    top = z[np.ix_(r0, c0)] * (1 - tc) + z[np.ix_(r0, c0 + 1)] * tc
    bot = z[np.ix_(r0 + 1, c0)] * (1 - tc) + z[np.ix_(r0 + 1, c0 + 1)] * tc
    return top * (1 - tr) + bot * tr


@register("dem", DEMConfig, summary="Imported DEM (16-bit PNG + sidecar, .npy or GeoTIFF), gaps filled, resampled to the grid")
def generate_dem(cfg: DEMConfig, grid: GridConfig, rng: np.random.Generator) -> Heightmap:
    """Read the DEM, fill its gaps (Martin et al. 2014, Sec. IV.B) and sample it onto the grid
    (bilinear where the grid's cells or origin differ from the DEM's)."""
    from offroadbench.io.dem import read_dem

    path = Path(cfg.path) if cfg.path is not None else SAMPLE_DEM
    raw = read_dem(path, cell_size_m=cfg.source_cell_size_m, relief_m=cfg.source_relief_m, nodata_level=cfg.nodata_level)
    z = raw.z
    if raw.gap_count:
        log.info("dem: filling %d gap pixel(s) of %s", raw.gap_count, path)
        z = fill_gaps(z, raw.cell_size_m, cfg.fill_roughness, rng)
    same_grid = (
        math.isclose(raw.cell_size_m, grid.cell_size_m) and cfg.origin_x_m == 0 and cfg.origin_y_m == 0
        and z.shape[0] >= grid.rows and z.shape[1] >= grid.cols
    )
    out = z[: grid.rows, : grid.cols] if same_grid else _resample(z, raw.cell_size_m, cfg, grid)
    return Heightmap(z=out, cell_size_m=grid.cell_size_m)
