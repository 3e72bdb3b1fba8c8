"""Fractional Brownian motion (fBm) surfaces by Fourier filtering, Yoshikawa & Nishiguchi Sec. 3.

The spectral density of an fBm surface with Hurst exponent H (0 < H < 1) is isotropic,
Yoshikawa & Nishiguchi 2001, Eq. (3): ``S(u, v) = S0 / (u^2 + v^2)^(H+1)``, and the fractal dimension is
``D = E + 1 - H = 3 - H`` for a surface (Yoshikawa & Nishiguchi 2001, Sec. 3.2). Eq. (4)-(7): the DFT coefficients are
``a_kl = r e^(i theta)`` with theta uniform in [0, 2 pi) and r Rayleigh distributed with
``E[r^2] = 1 / (k^2 + l^2)^(H+1)``; the inverse DFT gives the surface. Coefficients of a real
surface must be conjugate-symmetric: we fill the half-plane of a real inverse FFT (``irfft2``),
which imposes the symmetry. A complex Gaussian coefficient has exactly the Rayleigh modulus and
uniform phase of Eq. (6)-(7).

For a rectangular grid the wave number is the physical one, ``f = sqrt((k/Lx)^2 + (l/Ly)^2)``,
so the surface is isotropic in metres. The surface is periodic (it tiles).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.registry import register

__all__ = ["FBMConfig", "hurst_from_dimension", "fbm_coefficients", "fbm_surface", "generate_fbm"]

DEFAULT_D = 2.2


def hurst_from_dimension(dimension: float) -> float:
    """H = 3 - D for a surface (Yoshikawa & Nishiguchi 2001, Sec. 3.2, D = E + 1 - H with E = 2)."""
    return 3.0 - dimension


@dataclass(frozen=True, kw_only=True)
class FBMConfig:
    """An fBm surface. Give the fractal dimension D or the Hurst exponent H (not both)."""

    D: float | None = None
    """Fractal dimension in (2, 3); 2.2 if neither D nor H is given (lunar DEMs, Yoshikawa & Nishiguchi 2001, Sec. 5.1)."""
    H: float | None = None
    """Hurst exponent in (0, 1); D = 3 - H."""
    relief_m: float = 1.0
    """The surface is shifted to min 0 and scaled to this relief (max - min), metres."""

    def __post_init__(self) -> None:
        if self.D is not None and self.H is not None:
            raise InputError(f"FBMConfig: give D or H, not both (got D = {self.D}, H = {self.H})")
        if self.D is not None:
            check_range(self, "D", self.D, lo=2, hi=3, lo_open=True, hi_open=True)
        if self.H is not None:
            check_range(self, "H", self.H, lo=0, hi=1, lo_open=True, hi_open=True)
        check_range(self, "relief_m", self.relief_m, lo=0, lo_open=True)

    @property
    def hurst(self) -> float:
        """The Hurst exponent H used."""
        if self.H is not None:
            return self.H
        return hurst_from_dimension(self.D if self.D is not None else DEFAULT_D)


def _radial_frequency(rows: int, cols: int) -> np.ndarray:
    """|f| in cycles per map side for the rfft2 half-plane, scaled so the shorter side has integer k."""
    side = min(rows, cols)
    fy = np.fft.fftfreq(rows) * rows * side / rows
    fx = np.fft.rfftfreq(cols) * cols * side / cols
    return np.hypot(fy[:, None], fx[None, :])


def fbm_coefficients(rows: int, cols: int, hurst: float, rng: np.random.Generator) -> np.ndarray:
    """Random half-plane DFT coefficients with E|a|^2 = 1 / f^(2H+2) (Yoshikawa & Nishiguchi 2001, Eq. 5-7); a_00 = 0."""
    f = _radial_frequency(rows, cols)
    power = np.zeros_like(f)
    nz = f > 0
    power[nz] = f[nz] ** (-2.0 * (hurst + 1.0))
    noise = rng.standard_normal(f.shape) + 1j * rng.standard_normal(f.shape)
    return noise * np.sqrt(power / 2.0)


def fbm_surface(rows: int, cols: int, hurst: float, rng: np.random.Generator) -> np.ndarray:
    """A zero-mean, unit-standard-deviation fBm surface of shape (rows, cols), Yoshikawa & Nishiguchi 2001, Eq. (3)-(7)."""
    z = np.fft.irfft2(fbm_coefficients(rows, cols, hurst, rng), s=(rows, cols))
    z -= z.mean()
    std = z.std()
    return z / std if std > 0 else z


@register("fbm", FBMConfig, summary="fBm surface by Fourier filtering, given D or H (Yoshikawa & Nishiguchi Eq. 3-7)")
def generate_fbm(cfg: FBMConfig, grid: GridConfig, rng: np.random.Generator) -> Heightmap:
    """An fBm Heightmap on ``grid`` scaled to ``relief_m``."""
    z = fbm_surface(grid.rows, grid.cols, cfg.hurst, rng)
    return Heightmap(z=z, cell_size_m=grid.cell_size_m).rescaled(cfg.relief_m)
