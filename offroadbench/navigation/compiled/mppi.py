"""The cosines and sines of the ``mppi`` policy's rollout headings compiled with numba: the same
numbers as its Python pass (offroadbench.navigation.policies.mppi.cos_sin), outside the interpreter.

Both evaluate the C library's scalar double ``cos`` and ``sin`` on each float32 heading widened to
float64 (exact) and round the result to float32 (to nearest). numba compiles ``math.cos`` and
``math.sin`` to calls of the same libm (no ``fastmath``, so no approximation is substituted; LLVM
fuses the pair into glibc's ``sincos``, which runs the code of ``sin`` and ``cos``), hence the same
bits as in the interpreter (tests/navigation/test_mppi.py). One exception: numba with Intel's
SVML (the ``icc_rt`` package) vectorises the loop with SVML's own ``cos``, which has other last bits;
then this module refuses to load and the Python pass runs. It is an accelerator only: without numba
the Python pass runs (``pip install 'offroadbench[fast]'`` installs numba).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit

__all__ = ["cos_sin"]

if numba.config.USING_SVML:  # SVML's vector cos/sin are not the C library's: other last bits
    raise ImportError("numba uses Intel SVML: the mppi headings take the Python pass (C library cos/sin)")


@njit(cache=True, nogil=True)
def _cos_sin(th, c, s):  # pragma: no cover - compiled
    for i in range(th.size):
        a = np.float64(th[i])
        if math.isfinite(a):
            c[i] = math.cos(a)
            s[i] = math.sin(a)
        else:  # as the Python pass (the C library's NaN may carry a sign)
            c[i] = np.nan
            s[i] = np.nan


def cos_sin(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``cos`` and ``sin`` of the float32 angles ``th`` (rad) through the C library in float64, each
    rounded to float32 (arrays of ``th``'s shape)."""
    flat = np.ascontiguousarray(th, dtype=np.float32).ravel()
    c = np.empty(flat.size, dtype=np.float32)
    s = np.empty(flat.size, dtype=np.float32)
    _cos_sin(flat, c, s)
    return c.reshape(np.shape(th)), s.reshape(np.shape(th))
