"""Surface statistics for cratered and fractal terrain (Martin et al. 2014, Sec. V.E).

* Slopes by Horn's method (the 3x3 weighted finite difference of Martin et al. 2014, Fig. 11-13) and the
  cumulative slope distribution: the fraction of the area steeper than each angle.
* The radially averaged power spectrum (Martin et al. 2014, Fig. 14) and a fractal-dimension estimate from
  its slope: for an fBm surface the 2-D spectral density falls as ``f^-beta`` with
  ``beta = 2H + 2`` (Yoshikawa & Nishiguchi 2001, Eq. 3), and ``D = 3 - H = 4 - beta / 2``.
* A crater size-frequency check: the power-law slope k of a placed population
  (N_cum ~ D^-k, Martin et al. 2014, Eq. 12), by maximum likelihood for a power law truncated to
  [D_min, D_max].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

__all__ = [
    "horn_slope_deg",
    "cumulative_slope_distribution",
    "RadialSpectrum",
    "radial_power_spectrum",
    "SpectralFit",
    "fit_spectral_slope",
    "fractal_dimension",
    "fit_sfd_slope",
    "cumulative_counts",
    "surface_summary",
]

SLOPE_PERCENTILES = (50, 90, 99)


def horn_slope_deg(hm: Heightmap) -> np.ndarray:
    """Slope angle in degrees at every pixel by Horn's method (edges replicated).

    With the 3x3 neighbourhood a b c / d e f / g h i (rows of increasing y):
    dz/dx = ((c + 2f + i) - (a + 2d + g)) / (8 cell), dz/dy = ((g + 2h + i) - (a + 2b + c)) / (8 cell).
    """
    z = np.pad(hm.z, 1, mode="edge")
    a, b, c = z[:-2, :-2], z[:-2, 1:-1], z[:-2, 2:]
    d, f = z[1:-1, :-2], z[1:-1, 2:]
    g, h, i = z[2:, :-2], z[2:, 1:-1], z[2:, 2:]
    cell = hm.cell_size_m
    dzdx = ((c + 2 * f + i) - (a + 2 * d + g)) / (8.0 * cell)
    dzdy = ((g + 2 * h + i) - (a + 2 * b + c)) / (8.0 * cell)
    return np.degrees(np.arctan(np.hypot(dzdx, dzdy)))


def cumulative_slope_distribution(slope_deg: np.ndarray, angles_deg=None) -> tuple[np.ndarray, np.ndarray]:
    """(angles, fraction of pixels with slope > angle), as Martin et al. 2014, Fig. 11 (in fractions, not %)."""
    s = np.sort(np.asarray(slope_deg, dtype=float).ravel())
    if angles_deg is None:
        angles_deg = np.arange(0.0, 90.5, 0.5)
    angles = np.asarray(angles_deg, dtype=float)
    frac = 1.0 - np.searchsorted(s, angles, side="right") / s.size
    return angles, frac


@dataclass(frozen=True)
class RadialSpectrum:
    """Radially averaged power spectral density: frequency (cycles/m) and mean power per bin."""

    frequency_per_m: np.ndarray
    power: np.ndarray
    counts: np.ndarray
    """Number of Fourier coefficients averaged in each bin."""


def radial_power_spectrum(hm: Heightmap, bins: int = 40) -> RadialSpectrum:
    """Radially averaged 2-D power spectrum (Martin et al. 2014, Fig. 14).

    A least-squares plane is removed and a 2-D Hann window applied before the FFT, so the
    map's edges do not leak power (which would flatten the spectrum towards f^-2). Power is
    averaged over log-spaced annuli from the lowest non-zero frequency to Nyquist.
    """
    z = hm.z - _plane(hm.z)
    wy = np.hanning(hm.rows)
    wx = np.hanning(hm.cols)
    zw = z * wy[:, None] * wx[None, :]
    p = np.abs(np.fft.rfft2(zw)) ** 2
    fy = np.fft.fftfreq(hm.rows, d=hm.cell_size_m)
    fx = np.fft.rfftfreq(hm.cols, d=hm.cell_size_m)
    f = np.hypot(fy[:, None], fx[None, :])
    f_lo = 1.0 / (max(hm.rows, hm.cols) * hm.cell_size_m)
    f_hi = 0.5 / hm.cell_size_m
    edges = np.geomspace(f_lo, f_hi, bins + 1)
    idx = np.digitize(f.ravel(), edges) - 1
    ok = (idx >= 0) & (idx < bins)
    sums = np.bincount(idx[ok], weights=p.ravel()[ok], minlength=bins)
    counts = np.bincount(idx[ok], weights=None, minlength=bins)
    fsum = np.bincount(idx[ok], weights=f.ravel()[ok], minlength=bins)
    have = counts > 0
    return RadialSpectrum(
        frequency_per_m=fsum[have] / counts[have], power=sums[have] / counts[have], counts=counts[have]
    )


def _plane(z: np.ndarray) -> np.ndarray:
    rows, cols = z.shape
    yy, xx = np.mgrid[0:rows, 0:cols]
    a = np.column_stack([np.ones(z.size), xx.ravel(), yy.ravel()])
    coef, *_ = np.linalg.lstsq(a, z.ravel(), rcond=None)
    return (a @ coef).reshape(z.shape)


@dataclass(frozen=True)
class SpectralFit:
    """log10 P = intercept - beta log10 f over [f_min, f_max]; D = 4 - beta / 2."""

    beta: float
    intercept: float
    f_min_per_m: float
    f_max_per_m: float
    dimension: float


def fit_spectral_slope(spec: RadialSpectrum, f_min_per_m: float | None = None, f_max_per_m: float | None = None) -> SpectralFit:
    """Least-squares power-law fit to the radial spectrum.

    Default band: from 4x the lowest frequency (the window smears the first few) to half of
    Nyquist (the window and aliasing bend the top octave). Bins are weighted by the square
    root of their number of coefficients.
    """
    f, p = spec.frequency_per_m, spec.power
    lo = f_min_per_m if f_min_per_m is not None else 4.0 * f.min()
    hi = f_max_per_m if f_max_per_m is not None else 0.5 * f.max()
    sel = (f >= lo) & (f <= hi) & (p > 0)
    if sel.sum() < 3:
        raise InputError(f"spectral fit: fewer than 3 frequency bins in [{lo:g}, {hi:g}] cycles/m; use a larger map")
    # a bin mean of n periodogram values has a relative error ~ 1/sqrt(n): weight by sqrt(n)
    w = np.sqrt(spec.counts[sel])
    slope, intercept = np.polyfit(np.log10(f[sel]), np.log10(p[sel]), 1, w=w)
    beta = -float(slope)
    return SpectralFit(beta=beta, intercept=float(intercept), f_min_per_m=float(lo), f_max_per_m=float(hi), dimension=4.0 - beta / 2.0)


def fractal_dimension(hm: Heightmap) -> float:
    """Fractal dimension estimated from the radially averaged spectrum: D = 4 - beta / 2."""
    return fit_spectral_slope(radial_power_spectrum(hm)).dimension


def fit_sfd_slope(diameters_m, d_min_m: float | None = None, d_max_m: float | None = None) -> float:
    """Maximum-likelihood slope k of N_cum(D) ~ D^-k for diameters in [d_min, d_max].

    The pdf is k D^-(k+1) / (d_min^-k - d_max^-k). With r = d_max / d_min the likelihood equation
    ``1/k - mean(ln(D / d_min)) - ln(r) r^-k / (1 - r^-k) = 0`` is solved by bisection. With
    d_max = inf it is the Hill estimator k = n / sum ln(D / d_min).
    """
    d = np.asarray(diameters_m, dtype=float)
    lo = float(d.min()) if d_min_m is None else float(d_min_m)
    hi = float(d.max()) if d_max_m is None else float(d_max_m)
    d = d[(d >= lo) & (d <= hi)]
    if d.size < 2:
        raise InputError(f"crater SFD fit needs at least 2 craters in [{lo:g}, {hi:g}] m, got {d.size}")
    mean_log = float(np.mean(np.log(d / lo)))
    if not np.isfinite(hi) or hi <= lo:
        return 1.0 / mean_log
    r = hi / lo

    def score(k: float) -> float:  # d/dk of the mean log-likelihood
        return 1.0 / k - mean_log - np.log(r) * r ** (-k) / (1.0 - r ** (-k))

    a, b = 1e-6, 50.0
    if score(b) > 0:
        return b
    for _ in range(200):
        m = 0.5 * (a + b)
        if score(m) > 0:
            a = m
        else:
            b = m
    return 0.5 * (a + b)


def cumulative_counts(diameters_m) -> tuple[np.ndarray, np.ndarray]:
    """(sorted diameters descending, number of craters >= each): the empirical N_cum curve."""
    d = np.sort(np.asarray(diameters_m, dtype=float))[::-1]
    return d, np.arange(1, d.size + 1)


def surface_summary(hm: Heightmap) -> dict:
    """Slope percentiles (Horn), the spectral slope beta and the estimated fractal dimension.

    D = 4 - beta/2 assumes an fBm-like surface; a cratered map, whose spectrum is dominated by
    the crater shapes, can give values outside (2, 3): read it as a spectral-slope summary.
    """
    slope = horn_slope_deg(hm)
    out = {f"slope_p{q}_deg": float(np.percentile(slope, q)) for q in SLOPE_PERCENTILES}
    out["slope_mean_deg"] = float(slope.mean())
    for angle in (10, 20, 30):
        out[f"fraction_steeper_{angle}deg"] = float((slope > angle).mean())
    fit = fit_spectral_slope(radial_power_spectrum(hm))
    out["psd_slope_beta"] = fit.beta
    out["fractal_dimension"] = fit.dimension
    return out
