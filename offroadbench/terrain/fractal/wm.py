"""3D Weierstrass-Mandelbrot (W-M) surfaces, Majhor & Bos 2023, Eq. (1)-(2).

Eq. (1)::

    z(x, y) = A sum_{m=1..M} sum_{n=1..n_max} gamma^((D-3) n)
              [ cos(phi_mn) - cos( 2 pi gamma^n r / L * cos(atan(y/x) - pi m / M) + phi_mn ) ]

with ``r = sqrt(x^2 + y^2)`` and Eq. (2) ``A = L (G/L)^(D-2) (ln(gamma)/M)^(1/2)``.

Fast evaluation. ``r cos(atan(y/x) - pi m/M) = x cos(pi m/M) + y sin(pi m/M)``, so each (m, n)
term is a plane wave ``cos(u x + v y + phi)`` with ``u = k cos(theta_m)``, ``v = k sin(theta_m)``,
``k = 2 pi gamma^n / L``. On a grid ``x_c = c dx``, ``y_r = r dy`` the whole sum is

    z = A [ sum_j a_j cos(phi_j) - Re( E_y  diag(a e^{i phi})  E_x^T ) ],
    E_x[c, j] = exp(i u_j x_c),  E_y[r, j] = exp(i v_j y_r),

one real matrix product of inner size 2J (J kept terms). The exponential tables are built from
two short tables per term (``c = B q + s``), so only about ``2 sqrt(N)`` sines and cosines are
evaluated per term instead of N. This is ``method = "gemm"``, the reference.

``method = "nufft"`` (the default) evaluates the same sum as a type-1 non-uniform FFT (the ``finufft``
package): the terms are non-uniform "points" ``(u_j dx mod 2 pi, v_j dy mod 2 pi)`` with
strengths ``a_j e^{i phi_j}`` and the grid is the uniform set of output "modes". Its cost is one
FFT of a slightly enlarged grid plus a short kernel per term, instead of rows x cols x 2J for the
product; it agrees with "gemm" to about 1e-9 of the surface's range (the tolerance the finufft
call asks for, and the phase rounding of the fastest terms, which both methods share in kind).
See :func:`wm_surface_nufft`. It is the default because it is 5-10x faster on the paper's
1009^2 layers (benchmarks/RESULTS.md) and no less exact: both are checked against the literal
term-by-term Eq. (1) (tests/terrain/test_wm.py); "gemm" remains selectable, and the presets'
terrains under each method are pinned bit for bit (tests/terrain/test_bit_identical.py).

Terms whose amplitude ``gamma^((D-3)(n - n_min))`` is below ``amplitude_tol`` of the first term
are dropped (:func:`kept_harmonics`). Terms above the grid's Nyquist frequency alias; they are
kept unless ``band_limited = true``, because the paper's roughness depends on them.

Coordinate convention (what x and y are measured in) is the ``coordinates`` field; see
:data:`COORDINATES` and ``docs`` in README ("Interpretation choices").
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_choice, check_int, check_range
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.registry import register

log = logging.getLogger(__name__)

__all__ = [
    "WMConfig",
    "COORDINATES",
    "wm_amplitude",
    "n_max_effective",
    "kept_harmonics",
    "draw_phases",
    "grid_coordinates",
    "METHODS",
    "wm_surface",
    "wm_surface_nufft",
    "wm_surface_direct",
    "generate_wm",
]

#: How grid indices map to the x, y of Eq. (1):
#:  - ``pixels``: x = column index, y = row index (the paper's n_max = "length in pixels"
#:    reading; with L = 100.9 the first harmonic has a wavelength of 67 px).
#:  - ``metres``: x = column * cell_size_m.
#:  - ``span_L``: the grid's longer side spans L, x = column * L / max(rows, cols)
#:    (with 1009 px and L = 100.9 that is 0.1 units per pixel).
COORDINATES = ("pixels", "metres", "span_L")

_BLOCK = 32  # size of the short exponential tables (c = _BLOCK * q + s)
_CHUNK_TERMS = 2048  # terms per matrix product, to bound memory
_ROW_BLOCK = 128  # fixed row partition of the product: the bits do not depend on the thread count

#: How the sum of Eq. (1) is evaluated on the grid (WMConfig.method).
METHODS = ("gemm", "nufft")

_NUFFT_BANDS = 4  # fixed row bands of the NUFFT (two per transform): bits do not depend on threads
_NUFFT_EPS = 1e-9  # finufft's requested relative accuracy
_NUFFT_UPSAMPLING = 1.25  # finufft's fine-grid factor: the smaller FFT wins at this accuracy


@dataclass(frozen=True, kw_only=True)
class WMConfig:
    """One 3D W-M surface. Defaults are Majhor & Bos 2023, Table 1, high-frequency DEM at D = 2.45."""

    M: int = 64
    """Number of ridges (angular directions), Eq. (1)."""
    n_max: int | None = None
    """Highest frequency index; None means the grid length in pixels, as the paper (1009)."""
    n_min: int = 1
    """Lowest frequency index (the paper sums from n = 1)."""
    gamma: float = 1.5
    """Frequency density, > 1."""
    D: float = 2.45
    """Fractal dimension, in (2, 3)."""
    L: float = 100.9
    """Sampling length, in the units of the coordinate convention."""
    G: float = 1e-8
    """Elevation scaling coefficient of Eq. (2)."""
    phase_min: float = 0.0
    """Lower end of the uniform random phases, radians (paper: 0)."""
    phase_max: float = math.pi
    """Upper end of the uniform random phases, radians (paper: pi)."""
    coordinates: str = "pixels"
    """What x, y of Eq. (1) are measured in: one of COORDINATES."""
    amplitude_tol: float = 1e-6
    """Drop terms with gamma^((D-3)(n-n_min)) below this fraction of the first term; 0 keeps all."""
    band_limited: bool = False
    """If true, also drop terms above the grid's Nyquist frequency (an anti-aliased surface)."""
    smoothing_sigma_px: float = 0.0
    """Gaussian low-pass sigma in pixels applied to the surface; 0 = none."""
    origin_offset_px: float = 0.0
    """Put the origin of Eq. (1) this many pixels outside the grid's first corner, along both
    axes (the first sample is at x = y = offset). 0 = the paper's reading (origin on the corner).
    Not in the paper: with phases in [0, pi] the terms of Eq. (1) add coherently near the origin
    and the surface has its extreme there; an offset of a few hundred pixels moves that outside."""
    method: str = "nufft"
    """How the sum is evaluated, one of METHODS: "nufft" (non-uniform FFT, the default) or "gemm"
    (separable matrix product, the reference, 5-10x slower); they agree to ~1e-9 of the range
    (1e-6 on layers whose fastest terms float64 cannot phase)."""

    def __post_init__(self) -> None:
        check_int(self, "M", self.M, lo=1)
        check_int(self, "n_min", self.n_min, lo=0)
        if self.n_max is not None:
            check_int(self, "n_max", self.n_max, lo=max(1, self.n_min))
        check_range(self, "gamma", self.gamma, lo=1, lo_open=True)
        check_range(self, "D", self.D, lo=2, hi=3, lo_open=True, hi_open=True)
        check_range(self, "L", self.L, lo=0, lo_open=True)
        check_range(self, "G", self.G, lo=0, lo_open=True)
        check_range(self, "phase_min", self.phase_min)
        check_range(self, "phase_max", self.phase_max, lo=self.phase_min)
        check_choice(self, "coordinates", self.coordinates, COORDINATES)
        check_range(self, "amplitude_tol", self.amplitude_tol, lo=0, hi=1, hi_open=True)
        check_range(self, "smoothing_sigma_px", self.smoothing_sigma_px, lo=0)
        check_range(self, "origin_offset_px", self.origin_offset_px, lo=0)
        check_choice(self, "method", self.method, METHODS)

    def describe(self, grid: GridConfig) -> str:
        """One line on the terms evaluated on ``grid``, e.g. for the CLI."""
        n = kept_harmonics(self, grid)
        total = n_max_effective(self, grid) - self.n_min + 1
        return f"W-M D={self.D:g}: {n.size} of {total} harmonics x M={self.M} = {n.size * self.M} terms kept"


def n_max_effective(cfg: WMConfig, grid: GridConfig) -> int:
    """n_max, or the grid length in pixels when n_max is None (Majhor & Bos 2023, Sec. 2.1)."""
    return cfg.n_max if cfg.n_max is not None else max(grid.rows, grid.cols)


def wm_amplitude(cfg: WMConfig) -> float:
    """Eq. (2): A = L (G/L)^(D-2) (ln(gamma)/M)^(1/2)."""
    return cfg.L * (cfg.G / cfg.L) ** (cfg.D - 2.0) * math.sqrt(math.log(cfg.gamma) / cfg.M)


def grid_step(cfg: WMConfig, grid: GridConfig) -> float:
    """Distance between neighbouring samples in the units of Eq. (1)."""
    if cfg.coordinates == "pixels":
        return 1.0
    if cfg.coordinates == "metres":
        return grid.cell_size_m
    return cfg.L / max(grid.rows, grid.cols)  # span_L


def grid_coordinates(cfg: WMConfig, grid: GridConfig) -> tuple[np.ndarray, np.ndarray]:
    """(x of each column, y of each row) in the units of Eq. (1); both start at the origin offset."""
    step = grid_step(cfg, grid)
    x0 = cfg.origin_offset_px * step
    return x0 + np.arange(grid.cols) * step, x0 + np.arange(grid.rows) * step


def _powers(base: float, exponents) -> np.ndarray:
    """``base ** e`` for each exponent, by the C library's ``pow`` one at a time (float64).

    Not ``np.power``: numpy's SIMD ``power`` loops differ between CPUs in the last bit, and the
    frequency ``gamma^n`` of a high harmonic (up to ~1e60 for D_high near 3) multiplies every
    coordinate before the cosine, so one ulp of it becomes a different phase: the D_high = 2.9
    surface then differed by 2e-3 of its range between an AVX-512 and a baseline x86-64 CPU.
    """
    return np.array([math.pow(float(base), float(e)) for e in np.asarray(exponents, dtype=float).ravel()])


def kept_harmonics(cfg: WMConfig, grid: GridConfig) -> np.ndarray:
    """The frequency indices n that are evaluated on ``grid``, after the tolerance and band-limit cuts."""
    n = np.arange(cfg.n_min, n_max_effective(cfg, grid) + 1)
    if cfg.amplitude_tol > 0:
        rel = _powers(cfg.gamma, (cfg.D - 3.0) * (n - cfg.n_min))
        n = n[rel >= cfg.amplitude_tol]
    if cfg.band_limited:
        # spatial frequency gamma^n / L cycles per unit; Nyquist is 1 / (2 step)
        nyquist = 0.5 / grid_step(cfg, grid)
        n = n[_powers(cfg.gamma, n) / cfg.L <= nyquist]
    return n


def draw_phases(cfg: WMConfig, grid: GridConfig, rng: np.random.Generator) -> np.ndarray:
    """Uniform random phases phi[m-1, n-n_min] for every (m, n) of Eq. (1), shape (M, n_count).

    All phases are drawn, kept or not, so the tolerance never changes the phases of kept terms.
    """
    count = n_max_effective(cfg, grid) - cfg.n_min + 1
    return rng.uniform(cfg.phase_min, cfg.phase_max, size=(cfg.M, count))


def _term_table(cfg: WMConfig, grid: GridConfig, phases: np.ndarray):
    """Flattened per-term (u, v, amplitude, phase) for the kept (m, n)."""
    n = kept_harmonics(cfg, grid)
    m = np.arange(1, cfg.M + 1)
    theta = np.pi * m / cfg.M
    k = 2.0 * np.pi * _powers(cfg.gamma, n) / cfg.L
    u = np.outer(np.cos(theta), k).ravel()
    v = np.outer(np.sin(theta), k).ravel()
    amp = np.tile(_powers(cfg.gamma, (cfg.D - 3.0) * n), cfg.M)
    phi = phases[:, n - cfg.n_min].ravel()
    return u, v, amp, phi


def _exp_table(freq: np.ndarray, count: int, step: float) -> np.ndarray:
    """exp(i * freq_j * step * idx) for idx = 0..count-1, shape (count, J), from short tables."""
    q = np.arange(-(-count // _BLOCK))
    s = np.arange(_BLOCK)
    coarse = np.exp(1j * np.outer(q * (_BLOCK * step), freq))  # (Q, J)
    fine = np.exp(1j * np.outer(s * step, freq))  # (B, J)
    full = (coarse[:, None, :] * fine[None, :, :]).reshape(-1, freq.size)
    return full[:count]


def wm_surface(cfg: WMConfig, grid: GridConfig, phases: np.ndarray) -> np.ndarray:
    """Eq. (1) on the grid, by ``cfg.method``; heights in Eq. (1)'s units.

    Returns z[r, c] at x = c * step, y = r * step (see :func:`grid_coordinates`).
    """
    if cfg.method == "nufft":
        return wm_surface_nufft(cfg, grid, phases)
    return _wm_surface_gemm(cfg, grid, phases)


def _wm_surface_gemm(cfg: WMConfig, grid: GridConfig, phases: np.ndarray) -> np.ndarray:
    """Eq. (1) by the separable matrix product (module docstring)."""
    u, v, amp, phi = _term_table(cfg, grid, phases)
    step = grid_step(cfg, grid)
    x0 = cfg.origin_offset_px * step
    z = np.zeros((grid.rows, grid.cols))
    const = 0.0
    blocks = [slice(r, r + _ROW_BLOCK) for r in range(0, grid.rows, _ROW_BLOCK)]
    with _single_threaded_blas(), ThreadPoolExecutor(max_workers=_threads()) as pool:
        for lo in range(0, u.size, _CHUNK_TERMS):
            sl = slice(lo, lo + _CHUNK_TERMS)
            # the origin offset x0 shifts every plane wave's phase by u x0 + v x0
            w = amp[sl] * np.exp(1j * (phi[sl] + (u[sl] + v[sl]) * x0))
            ex = _exp_table(u[sl], grid.cols, step) * w  # (cols, j)
            ey = _exp_table(v[sl], grid.rows, step)  # (rows, j)
            left = np.concatenate([ey.real, -ey.imag], axis=1)
            right_t = np.ascontiguousarray(np.concatenate([ex.real, ex.imag], axis=1).T)

            def block_product(rows: slice, left=left, right_t=right_t) -> None:
                z[rows] -= left[rows] @ right_t

            list(pool.map(block_product, blocks))
            const += float(np.sum(amp[sl] * np.cos(phi[sl])))
    z += const
    return wm_amplitude(cfg) * z


def wm_surface_nufft(cfg: WMConfig, grid: GridConfig, phases: np.ndarray) -> np.ndarray:
    """Eq. (1) on the grid by a type-1 non-uniform FFT (finufft); heights in Eq. (1)'s units.

    With ``alpha_j = u_j dx`` and ``beta_j = v_j dy`` reduced to [-pi, pi), the oscillating part
    of Eq. (1) at sample (r, c) is ``Re sum_j w_j exp(i (alpha_j c + beta_j r))``: a type-1 NUFFT
    whose output modes are the grid indices (shifted by the transform's centred mode range, which
    multiplies each strength by a phase). Only the real part is wanted, so two bands of rows share
    one complex transform: ``Re F = (F + conj F) / 2`` is a transform with the points at
    ``+-(alpha, beta)`` and conjugate strengths, real on every mode; a second band, times ``i``,
    fills the imaginary part. The rows are cut into a fixed number of bands and every transform is
    single-threaded, so the bits do not depend on the thread count (transforms run in parallel).
    """
    try:
        import finufft
    except ImportError:  # pragma: no cover - finufft is a dependency
        raise ImportError("WMConfig.method = 'nufft' needs the finufft package (pip install finufft)") from None
    u, v, amp, phi = _term_table(cfg, grid, phases)
    step = grid_step(cfg, grid)
    x0 = cfg.origin_offset_px * step
    w = amp * np.exp(1j * (phi + (u + v) * x0))
    alpha = np.mod(u * step + np.pi, 2.0 * np.pi) - np.pi
    beta = np.mod(v * step + np.pi, 2.0 * np.pi) - np.pi
    band = -(-grid.rows // _NUFFT_BANDS)
    # mode k of a transform of n modes is output index k + n // 2 (finufft's centred order)
    w = w * np.exp(1j * (alpha * (grid.cols // 2) + beta * (band // 2)))
    xs = np.concatenate([alpha, -alpha])
    ys = np.concatenate([beta, -beta])
    starts = list(range(0, grid.rows, band))
    z = np.empty((grid.rows, grid.cols))

    def transform(pair: int) -> None:
        lo, hi = starts[2 * pair], starts[2 * pair + 1] if 2 * pair + 1 < len(starts) else None
        wr = w * np.exp(1j * beta * lo)
        wi = w * np.exp(1j * beta * hi) if hi is not None else np.zeros_like(w)
        strengths = np.concatenate([wr + 1j * wi, np.conj(wr) + 1j * np.conj(wi)]) / 2.0
        f = finufft.nufft2d1(
            ys, xs, strengths, (band, grid.cols), eps=_NUFFT_EPS, isign=1, nthreads=1,
            upsampfac=_NUFFT_UPSAMPLING, modeord=0,
        )
        z[lo : lo + band] = f.real[: grid.rows - lo]
        if hi is not None:
            z[hi : hi + band] = f.imag[: grid.rows - hi]

    with ThreadPoolExecutor(max_workers=_threads()) as pool:
        list(pool.map(transform, range(-(-len(starts) // 2))))
    return wm_amplitude(cfg) * (float(np.sum(amp * np.cos(phi))) - z)


def _threads() -> int:
    return max(1, min(8, os.cpu_count() or 1))


@contextlib.contextmanager
def _single_threaded_blas():
    """Run BLAS single-threaded: a multi-threaded GEMM sums in an order that depends on the
    thread count, which would make the same seed give other bits on another worker count.
    Parallelism comes instead from a fixed partition of the rows over Python threads."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def wm_surface_direct(cfg: WMConfig, grid: GridConfig, phases: np.ndarray) -> np.ndarray:
    """Eq. (1) evaluated literally, term by term (slow; for tests and the benchmark).

    ``atan(y/x)`` is evaluated as ``arctan2(y, x)``, equal for x > 0 and defined at x = 0.
    """
    x, y = grid_coordinates(cfg, grid)
    xx, yy = np.meshgrid(x, y)
    r = np.hypot(xx, yy)
    ang = np.arctan2(yy, xx)
    z = np.zeros_like(xx)
    for n in kept_harmonics(cfg, grid):
        a = float(cfg.gamma) ** ((cfg.D - 3.0) * n)
        kr = 2.0 * np.pi * float(cfg.gamma) ** float(n) * r / cfg.L
        for m in range(1, cfg.M + 1):
            p = phases[m - 1, n - cfg.n_min]
            z += a * (np.cos(p) - np.cos(kr * np.cos(ang - np.pi * m / cfg.M) + p))
    return wm_amplitude(cfg) * z


def gaussian_smooth(z: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian low-pass with sigma in pixels; sigma 0 returns z unchanged.

    The kernel is (2 ceil(2 sigma) + 1) pixels wide and edges are replicated, as MATLAB's
    ``imgaussfilt`` does (the paper gives no filter size; see MultifractalConfig).
    """
    if sigma_px <= 0:
        return z
    from scipy.ndimage import gaussian_filter

    return gaussian_filter(z, sigma=sigma_px, mode="nearest", radius=int(math.ceil(2.0 * sigma_px)))


@register("wm", WMConfig, summary="3D Weierstrass-Mandelbrot surface (Majhor & Bos 2023, Eq. 1-2)")
def generate_wm(cfg: WMConfig, grid: GridConfig, rng: np.random.Generator) -> Heightmap:
    """One W-M surface as a Heightmap. Heights are Eq. (1)'s values taken as metres.

    Eq. (1) gives heights in the units of L; a recipe usually rescales to a relief.
    """
    phases = draw_phases(cfg, grid, rng)
    log.info(cfg.describe(grid))
    z = gaussian_smooth(wm_surface(cfg, grid, phases), cfg.smoothing_sigma_px)
    return Heightmap(z=z, cell_size_m=grid.cell_size_m)
