"""The mast sensor's radial sweep (offroadbench.navigation.sensor, the viewshed) compiled with numba:
the numbers of the numpy sweep, ray by ray, without its (A, R) work arrays and scipy's
interpolation call.

Along each ray the numpy sweep takes every sample ``x = x_s + r cos(phi)``, ``col = x / cell`` (and
so for y), up to the first one off the map (``0 <= col <= cols - 1`` and so for rows); at each such
sample the bilinear height of ``scipy.ndimage.map_coordinates(order=1, mode="nearest")``, the
tangent ``(z - z_s) / r`` and whether it is at least the largest tangent before it minus 1e-12.
:func:`sweep` does the same float64 operations in the same order. The interpolation is scipy's
C loop for a point inside the map (NI_GeometricTransform with the order-1 spline weights of
ni_splines.c): ``t = x - floor(x)``, weights ``w0 = 1 - t`` and ``w1 = 1 - w0``, the upper
neighbour mirrored to ``n - 2`` on the last grid line, and the sum ``0 + z00 w0r w0c + z01 w0r w1c
+ z10 w1r w0c + z11 w1r w1c`` (each product left to right). numba compiles without ``fastmath``, so
nothing is reassociated, fused into an FMA or simplified (``0 + x`` keeps its sign of zero): each
result is the numpy sweep's to the last bit (tests/navigation/test_mast_floats.py). It is an
accelerator only: without numba the numpy sweep runs (``pip install 'offroadbench[fast]'``).
"""

from __future__ import annotations

import math

import numpy as np

from numba import njit

__all__ = ["deposit", "sweep"]


@njit(cache=True, nogil=True)
def sweep(z, cell, xs, ys, zs, r, ray_x, ray_y, out_x, out_y, out_z, out_r):  # pragma: no cover - compiled
    """The visible samples of the sensor at ``(xs, ys, zs)`` (m) over the heights ``z`` (rows, cols)
    of grid spacing ``cell`` (m), with the ranges ``r`` (R,) and offsets ``ray_x``, ``ray_y`` (A, R):
    their x, y, true height and range written to the front of ``out_*``; returns how many."""
    rows, cols = z.shape
    n_a, n_r = ray_x.shape
    n = 0
    for a in range(n_a):
        top = -math.inf
        for k in range(n_r):
            x = xs + ray_x[a, k]
            y = ys + ray_y[a, k]
            col = x / cell
            row = y / cell
            if not (col >= 0 and col <= cols - 1 and row >= 0 and row <= rows - 1):
                break  # off the map: blocks the rest of the ray
            r0f = math.floor(row)
            c0f = math.floor(col)
            wr0 = 1.0 - (row - r0f)
            wc0 = 1.0 - (col - c0f)
            wr1 = 1.0 - wr0
            wc1 = 1.0 - wc0
            r0 = int(r0f)
            c0 = int(c0f)
            r1 = r0 + 1 if r0 + 1 < rows else rows - 2
            c1 = c0 + 1 if c0 + 1 < cols else cols - 2
            h = 0.0
            h += z[r0, c0] * wr0 * wc0
            h += z[r0, c1] * wr0 * wc1
            h += z[r1, c0] * wr1 * wc0
            h += z[r1, c1] * wr1 * wc1
            tan = (h - zs) / r[k]
            if k == 0 or tan >= top - 1e-12:
                out_x[n] = x
                out_y[n] = y
                out_z[n] = h
                out_r[n] = r[k]
                n += 1
            if tan > top:
                top = tan
    return n


@njit(cache=True, nogil=True)
def deposit(x, y, z, r, noise, k, tx, ty, bx, by, c, s, cell, new, rows, cols, sums, counts, touched):  # pragma: no cover - compiled
    """The mast sensor's scan after the sweep (MastSensor._scan's numpy form, the same operations in
    the same order): each visible sample's height ``z + (k r) n``, its believed position ``(b_x + c
    dx) - s dy``, ``(b_y + s dx) + c dy`` with ``d = (x, y) - (t_x, t_y)``, the cell it rounds to,
    and into every cell hit (``new``, the flat map) the mean of its samples, summed from 0 in their
    order (as numpy's bincount). ``sums``, ``counts`` (zeros, the flat map's size) and ``touched``
    are work arrays, left zero; returns how many cells were written."""
    m = 0
    for i in range(z.shape[0]):
        h = z[i] + k * r[i] * noise[i]
        dx = x[i] - tx
        dy = y[i] - ty
        qx = bx + c * dx - s * dy
        qy = by + s * dx + c * dy
        col = np.int64(np.rint(qx / cell))
        row = np.int64(np.rint(qy / cell))
        if col >= 0 and col < cols and row >= 0 and row < rows:
            f = row * cols + col
            if counts[f] == 0:
                touched[m] = f
                m += 1
            sums[f] += h
            counts[f] += 1
    for j in range(m):
        f = touched[j]
        new[f] = sums[f] / counts[f]
        sums[f] = 0.0
        counts[f] = 0
    return m
