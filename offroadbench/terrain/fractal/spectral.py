"""Spectral restoration of a coarse or smoothed DEM (Yoshikawa & Nishiguchi 2001, Sec. 3.4, Fig. 4).

DFT the DEM (a), keep the coefficients with wavelength longer than a cutoff (b), replace the rest
with random ones that follow the fBm law E|a|^2 = S0 / f^(2H+2) (c, Yoshikawa & Nishiguchi 2001,
Eq. 5-7) and inverse-DFT (d). S0 is fitted to the DEM's own spectrum in the octave below the
cutoff, so the synthetic spectrum continues the measured one. The kept (low-pass) part is unchanged.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.registry import register

log = logging.getLogger(__name__)

__all__ = ["SpectralRestoreConfig", "spectral_restore"]


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
