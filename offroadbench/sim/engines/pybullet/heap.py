"""Memory around PyBullet's heightfield: an 'empty' heightfield that costs nothing to create, and
glibc's allocator held lean while its heights are replaced (see offroadbench.sim.engines.pybullet.terrain)."""

from __future__ import annotations

import ctypes
import functools
import platform
import sys
from contextlib import contextmanager

import numpy as np


def empty_heights(n: int, z_min_m: float, z_max_m: float) -> np.ndarray:
    """``n`` heights for an 'empty' heightfield with the height range (z_min_m, z_max_m).

    Bullet scans the data for its min and max with ``a < b ? a : b``, which a NaN restarts, so
    ``[+inf, ..., +inf, NaN, z_min, z_max]`` gives the range (z_min, z_max); every triangle made only
    of +inf samples lies above that range and is skipped by the render-mesh walk, so creating the
    shape costs almost nothing. The heights are then written with ``replaceHeightfieldIndex``.
    """
    data = np.full(n, np.inf)
    data[-3:] = (np.nan, z_min_m, z_max_m)
    return data


#: glibc's ``mallopt`` parameter number for the block size from which malloc maps each block on
#: its own (``M_MMAP_THRESHOLD`` in malloc.h); such a block goes back to the OS when freed
_M_MMAP_THRESHOLD = -3


#: the threshold during the replace: every block of 1 MiB or more is mapped on its own
_REPLACE_MMAP_THRESHOLD = 1 << 20


#: the threshold after it: glibc's own ceiling for its adaptive threshold (64-bit), so blocks up
#: to 32 MiB (map-sized numpy arrays) are served from the heap again without a page fault each
_AFTER_MMAP_THRESHOLD = 32 << 20


@functools.cache
def _glibc():
    """The process's C library if it is glibc (whose allocator has mallopt and malloc_trim), else None."""
    if not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc":
        return None
    try:
        libc = ctypes.CDLL(None)
        if not (hasattr(libc, "mallopt") and hasattr(libc, "malloc_trim")):
            return None  # pragma: no cover - a glibc without them
    except OSError:  # pragma: no cover - no symbols of the running process
        return None
    return libc


@contextmanager
def lean_heap():
    """Around the heightfield replace: hand the heap's free memory back to the OS, and map every
    large block on its own so that the replace's growing arrays leave nothing behind in the heap.

    Without this (glibc's adaptive threshold, raised to ~8-32 MiB by the map-sized arrays freed
    before), the replace's intermediate arrays under the threshold land in the heap and stay
    resident after they are freed, on top of its transient: ~35 MiB more peak RSS per worker.
    Afterwards the process keeps a fixed 32 MiB threshold (glibc's adaptive one cannot be
    restored). Results are unchanged (tests/sim/test_world.py drives with and without this).
    Without glibc this does nothing.
    """
    libc = _glibc()
    if libc is None:
        yield
        return
    libc.malloc_trim(0)
    libc.mallopt(_M_MMAP_THRESHOLD, _REPLACE_MMAP_THRESHOLD)
    try:
        yield
    finally:
        libc.mallopt(_M_MMAP_THRESHOLD, _AFTER_MMAP_THRESHOLD)
