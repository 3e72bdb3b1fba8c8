"""The 16-bit height convention: 65,535 levels over a terrain's relief (a leaf module: numpy only).

Majhor & Bos (2023, Sec. 2.1-2.2) export each DEM as a 16-bit grayscale PNG and drive Unreal's
vehicle on that landscape, so the terrain the paper's vehicle met is the *quantised* DEM. This module
holds that quantisation once, for the PNG codec (:mod:`offroadbench.io.png16`), the roughness
thresholds' unit (:mod:`offroadbench.analysis.roughness`) and the recipes' default
``[grid] quantise = "png16"`` (:func:`quantise`).

A level ``q`` in ``0..65535`` stands for the height ``z_lo + q * ((z_hi - z_lo) / 65535)``, which is
exactly what :func:`offroadbench.io.png16.read_png16` returns for a PNG whose sidecar says
``z_min_m = z_lo``, ``z_max_m = z_hi``.

Portability. A float64 terrain computed on two x86-64 CPUs can differ in its last bits (numpy's SIMD
transcendental functions, OpenBLAS's and FFTW's kernels are chosen at run time by CPU). The levels
absorb that: a last-bit change moves a level only if the scaled height lies within ~1e-12 of a
half-level, and :func:`portable_range` rounds the range to whole nanometres so that ``z_lo`` and
``z_hi`` do not carry the last bits either. Multiplying and adding float64 numbers is exact IEEE 754
arithmetic on every CPU, so the quantised heights are then the same bits everywhere.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "LEVELS",
    "UE_ZERO_LEVEL",
    "UE_LEVELS_PER_CM",
    "RANGE_DECIMALS",
    "ue_z_range_m",
    "portable_range",
    "encode_levels",
    "decode_levels",
    "quantise",
]

#: the highest 16-bit level; the levels 0..LEVELS split the relief into LEVELS steps
LEVELS = 65535
#: Unreal's 16-bit level at Location.Z, and levels per centimetre at Scale.Z = 1 (LANDSCAPE_ZSCALE = 1/128)
UE_ZERO_LEVEL = 32768
UE_LEVELS_PER_CM = 128
#: the quantised range's ends are rounded to this many decimals of a metre (1 nm)
RANGE_DECIMALS = 9


def ue_z_range_m(z_scale: float) -> float:
    """Height in metres that Unreal spans from level 0 to level 65535 at Landscape ``Scale.Z``.

    ``65535 / 128 * z_scale`` cm: 511.99 m at 100, 3.83994 m at the paper's 0.75. The one place
    the "512 m at Z scale 100" convention lives.
    """
    return LEVELS / UE_LEVELS_PER_CM * z_scale / 100.0


def portable_range(z_min_m: float, z_max_m: float) -> tuple[float, float]:
    """The (z_lo, z_hi) metres that the levels span: the range rounded to whole nanometres.

    ``z_hi`` is then nudged (by at most a few ulps) until ``z_lo + 65535 * ((z_hi - z_lo) / 65535)``
    is ``z_hi`` itself, so a PNG written with this range (``z_max_m`` = its top level's height)
    reads back to the same step and the same bits. A flat map keeps ``z_lo == z_hi``.
    """
    lo = round(float(z_min_m), RANGE_DECIMALS)
    hi = round(float(z_max_m), RANGE_DECIMALS)
    if hi <= lo:
        return lo, lo
    for _ in range(32):
        top = lo + LEVELS * ((hi - lo) / LEVELS)
        if top == hi:
            return lo, hi
        hi = top
    raise ArithmeticError(f"no self-consistent 16-bit range for z in [{z_min_m!r}, {z_max_m!r}]")


def encode_levels(z: np.ndarray, z_lo: float, z_hi: float) -> np.ndarray:
    """uint16 levels of heights ``z`` (metres) over ``z_lo..z_hi``: the nearest level, clipped."""
    span = z_hi - z_lo
    if span <= 0:
        return np.zeros(np.shape(z), dtype=np.uint16)
    q = np.rint((np.asarray(z, dtype=np.float64) - z_lo) / span * LEVELS)
    return np.clip(q, 0, LEVELS).astype(np.uint16)


def decode_levels(q: np.ndarray, z_lo: float, z_hi: float) -> np.ndarray:
    """Heights in metres (float64) of uint16 levels over ``z_lo..z_hi``."""
    return z_lo + np.asarray(q).astype(np.float64) * ((z_hi - z_lo) / LEVELS)


def quantise(z: np.ndarray) -> np.ndarray:
    """Heights snapped to the 16-bit levels over their own (portable) range: what a PNG export holds."""
    z = np.asarray(z, dtype=np.float64)
    lo, hi = portable_range(float(z.min()), float(z.max()))
    if hi == lo:
        return np.full(z.shape, lo)
    return decode_levels(encode_levels(z, lo, hi), lo, hi)
