"""The residual pass of offroadbench.navigation.costmap._patch_planes compiled with numba: the same
numbers as the numpy pass, outside the interpreter and without its temporary arrays.

For each planning cell the numpy pass forms the plane's heights over the disk round the cell's
centre pixel, ``(a x + b y) + c``, subtracts them from the terrain, and takes the largest absolute
difference inside the disk. :func:`plane_residuals` does those operations on the same float64
scalars in the same order (numba compiles without ``fastmath``, so nothing is reassociated or fused
into an FMA; ``abs`` and the maximum are exact), so each residual is the numpy pass's to the last bit
(tests/navigation/test_planes_compiled.py). It is an accelerator only: without numba the numpy pass
runs (``pip install 'offroadbench[fast]'`` installs numba).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["plane_residuals"]


@njit(cache=True, nogil=True)
def _residuals(zp, disk, xx, yy, a, b, c, f, c0, out):  # pragma: no cover - compiled
    rows, cols = out.shape
    kr, kc = disk.shape
    for r in range(rows):
        for q in range(cols):
            ar, br, cr = a[r, q], b[r, q], c[r, q]
            r0, q0 = c0 + r * f, c0 + q * f
            top = 0.0
            nan = False
            for i in range(kr):
                for j in range(kc):
                    if disk[i, j]:
                        v = abs(zp[r0 + i, q0 + j] - (ar * xx[i, j] + br * yy[i, j] + cr))
                        if v > top:
                            top = v
                        elif v != v:
                            nan = True
            out[r, q] = np.nan if nan else top


def plane_residuals(zp: np.ndarray, disk: np.ndarray, xx: np.ndarray, yy: np.ndarray, a: np.ndarray, b: np.ndarray,
                    c: np.ndarray, f: int, c0: int) -> np.ndarray:
    """Largest ``|z - ((a x + b y) + c)|`` over ``disk`` (bool, odd square; offsets ``xx``, ``yy`` in m)
    round pixel ``(c0 + r f, c0 + q f)`` of the padded map ``zp`` (its window's corner), for every
    planning cell ``(r, q)`` of ``a``'s shape, m."""
    out = np.empty(a.shape)
    _residuals(np.ascontiguousarray(zp, dtype=np.float64), np.ascontiguousarray(disk, dtype=np.bool_),
               np.ascontiguousarray(xx, dtype=np.float64), np.ascontiguousarray(yy, dtype=np.float64),
               np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64),
               np.ascontiguousarray(c, dtype=np.float64), int(f), int(c0), out)
    return out
