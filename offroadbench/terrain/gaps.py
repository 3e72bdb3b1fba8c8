"""Filling the gaps (unknown pixels) of a DEM from the outside in, Martin et al. 2014, Sec. IV.B."""

from __future__ import annotations

import math

import numpy as np

from offroadbench.errors import InputError

__all__ = ["known_neighbour_count", "fill_gaps"]

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
