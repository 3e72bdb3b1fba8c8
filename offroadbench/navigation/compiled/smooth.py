"""The Gaussian filter of offroadbench.navigation.perception.seen_map compiled with numba: the
numbers of ``scipy.ndimage.gaussian_filter(a, sigma, mode="nearest")`` on a 2-D float64 array,
outside scipy's per-line loop.

scipy filters along axis 0, then along axis 1, each pass the symmetric correlation of its C loop
(``NI_Correlate1D``): with the kernel's weights ``w`` (length ``2 R + 1``, ``w[R]`` the centre)
and the line extended by its edge values,
``out[l] = x[l] w[R]``, then for ``j = R, R-1, ..., 1``: ``out[l] += (x[l-j] + x[l+j]) w[R-j]``.
:func:`gaussian_nearest` does those operations on the same float64 numbers in the same order for
every output element; it only runs them for a whole row of elements at a time (axis 1 as the rows
of the transposed intermediate) (numba compiles
without ``fastmath``, so nothing is reassociated or fused into an FMA), so each result is scipy's to
the last bit (tests/navigation/test_smooth_compiled.py). The weights are scipy's own, read back from
its filter of a unit impulse (:func:`kernel`). It is an accelerator only: without numba
perception.seen_map calls scipy (``pip install 'offroadbench[fast]'`` installs numba).
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

__all__ = ["gaussian_nearest", "kernel"]


@functools.lru_cache(maxsize=8)
def kernel(sigma: float, truncate: float = 4.0) -> np.ndarray:
    """scipy.ndimage.gaussian_filter1d's weights for ``sigma`` (cells) and ``truncate``, exactly: its
    output for a unit impulse at the centre of ``2 R + 1`` zeros (each output element is then one
    weight plus exact zeros). Read-only."""
    from scipy.ndimage import gaussian_filter1d

    radius = int(truncate * float(sigma) + 0.5)
    impulse = np.zeros(2 * radius + 1)
    impulse[radius] = 1.0
    w = gaussian_filter1d(impulse, sigma, mode="constant", cval=0.0, truncate=truncate)
    if not np.array_equal(w, w[::-1]):  # scipy's symmetric loop (the one replicated) needs it
        raise RuntimeError("gaussian kernel not symmetric")
    w.setflags(write=False)
    return w


@njit(cache=True, nogil=True)
def _along_rows(a, w, out):  # pragma: no cover - compiled
    """The correlation along axis 0 (each column a line), edge values beyond the ends; the inner
    loop runs along a row, element by element independent (vectorised), each element's terms in
    scipy's order."""
    n, m = a.shape
    rad = (w.shape[0] - 1) // 2
    wc = w[rad]
    for i in range(n):
        for c in range(m):
            out[i, c] = a[i, c] * wc
        for j in range(rad, 0, -1):
            lo = max(i - j, 0)
            hi = min(i + j, n - 1)
            wj = w[rad - j]
            for c in range(m):
                out[i, c] += (a[lo, c] + a[hi, c]) * wj


def gaussian_nearest(a: np.ndarray, sigma: float, truncate: float = 4.0) -> np.ndarray:
    """``scipy.ndimage.gaussian_filter(a, sigma, mode="nearest", truncate=truncate)`` of the 2-D
    array ``a`` (float64) with one ``sigma`` (cells) on both axes, to the bit (module docstring)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    w = kernel(float(sigma), float(truncate))
    mid = np.empty_like(a)
    _along_rows(a, w, mid)
    mid = np.ascontiguousarray(mid.T)  # axis 1 as rows: the same pass, on contiguous rows
    out = np.empty_like(mid)
    _along_rows(mid, w, out)
    return np.ascontiguousarray(out.T)
