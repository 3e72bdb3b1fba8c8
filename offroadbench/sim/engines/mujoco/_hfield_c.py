"""Height-field collision functions for sphere wheels and a box chassis, compiled with numba and
installed into MuJoCo's collision table around one world's own steps (``[sim.mujoco]
hfield_collision``, offroadbench.sim.engines.mujoco.settings).

Why
---
MuJoCo collides a convex geom with a height field (``mjc_ConvexHField``, ``engine_collision_convex.c``)
by walking the grid cells under the geom's bounding box, two triangular prisms per cell, and running
its general convex solver (GJK/EPA, ``mjc_penetration``) on every prism whose top reaches the geom's
lowest point. A sphere wheel so gets ~50 solver calls per step of which ~1.4 touch, and the chassis
box walks ~770 prisms that are almost always all rejected (issue 41's profile: collision is 24 of
30 us of a 1/120 s step on the paper maps).

What
----
- :func:`box_hfield` (modes ``exact`` and ``closed_form``): the box's contacts are MuJoCo's own, to
  the bit. If no height sample under the box's bounding box (widened by a cell each way) reaches the
  box's lowest point, MuJoCo's prism-height test would reject every prism, so it returns 0 contacts
  at once; otherwise it calls MuJoCo's own function, unchanged. It never writes to the model.
- :func:`sphere_hfield` (mode ``closed_form``): the sphere's contacts of ``mjc_ConvexHField``: the
  same sub-grid, the same prisms in the same order (``addPrismVert``: triangles (r+1, c-1), (r, c-1),
  (r+1, c) and (r, c-1), (r+1, c), (r, c)), the same prism-height test and contact cap
  (``mjMAXCONPAIR``), one contact per penetrating prism; the penetration of the sphere into a prism is
  computed in closed form (the signed distance of its centre to the convex prism: the deepest face if
  inside, else the closest point on the surface, Ericson, *Real-Time Collision Detection* 2005,
  5.1.5) instead of by GJK/EPA, and written in ``mjc_penetration``'s convention: ``dist`` = minus the
  depth, ``pos`` = the midpoint of the witness points (on the prism's surface and on the sphere),
  ``normal`` = from the height field (geom 1) to the sphere (geom 2), ``tangent`` = 0, rotated into
  the world by the field's frame. Equal to MuJoCo's within its convex solver's tolerance, not to the
  bit (tests/sim/test_hfield_collision.py states the tolerances). A cheap exact cull skips, without
  the closed form, prisms whose vertices all lie below the sphere's lowest point over their cell.
  A non-zero contact margin falls back to MuJoCo's own function.

How it is installed
-------------------
The kernels are cached ``njit`` functions taking MuJoCo's struct offsets (offroadbench.sim.engines.
mujoco._layout) and MuJoCo's original function's address as arguments; thin ``cfunc`` wrappers with
the MuJoCo C signature (``mjfCollision``: ``int (const mjModel*, mjData*, mjPreContact*, int, int,
mjtNum)``) bind those per process. :class:`HFieldCollision` writes the wrappers' addresses into the
table entries ``mjCOLLISIONFUNC[mjGEOM_HFIELD][mjGEOM_SPHERE / mjGEOM_BOX]`` before a world's MuJoCo
calls and writes back what was there after them, so a second world, or any other MuJoCo user in the
process, sees MuJoCo's own functions between those calls. The table is process-global: a MuJoCo step
of another thread running at the same time as this world's would see them too (the study runs one
world per process).
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
from numba import carray, cfunc, njit, types

from offroadbench.sim.engines.mujoco import _layout
from offroadbench.sim.engines.mujoco._cabi import as_address as _as_address
from offroadbench.sim.engines.mujoco._cabi import as_pointer as _as_pointer
from offroadbench.sim.engines.mujoco._cabi import call_collision as _call_collision
from offroadbench.sim.engines.mujoco._cabi import f64_field as _f64
from offroadbench.sim.engines.mujoco._cabi import i32_field as _i32
from offroadbench.sim.engines.mujoco._cabi import pointer_at as _pointer_field

__all__ = ["HFieldCollision", "MODES", "box_hfield", "sphere_hfield"]

#: values of MuJoCoConfig.hfield_collision
MODES = ("mujoco", "exact", "closed_form")
MAXCONPAIR = 50  # mjMAXCONPAIR (mjmodel.h): contacts per geom pair
PRE = 10  # mjtNum per mjPreContact: dist, pos[3], normal[3], tangent[3]

# indices into the layout tuple handed to the kernels
# (the struct offsets, then the addresses of MuJoCo's own sphere and box functions)
(L_DATAID, L_SIZE, L_RBOUND, L_HSIZE, L_NROW, L_NCOL, L_HADR, L_HDATA, L_XPOS, L_XMAT, L_SPHERE0, L_BOX0) = range(12)


# ---------------------------------------------------------------------------- geometry
@njit(cache=True)
def _closest_on_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):  # pragma: no cover - compiled
    """The point of triangle abc closest to p (Ericson 2005, 5.1.5, ClosestPtPointTriangle)."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bx, by, bz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return ax + v * abx, ay + v * aby, az + v * abz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cx, cy, cz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return ax + w * acx, ay + w * acy, az + w * acz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return bx + w * (cx - bx), by + w * (cy - by), bz + w * (cz - bz)
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w


@njit(cache=True)
def _wall(cx, cy, r, orient, a0, a1, b0, b1):  # pragma: no cover - compiled
    """(signed distance of (cx, cy) to the vertical wall over edge a->b, outward unit normal x, y)."""
    wx, wy = orient * (b1 - a1), -orient * (b0 - a0)
    lw = math.sqrt(wx * wx + wy * wy)
    wx, wy = wx / lw, wy / lw
    return (cx - a0) * wx + (cy - a1) * wy, wx, wy


@njit(cache=True)
def _sphere_prism(c, r, t, zb, out):  # pragma: no cover - compiled
    """Penetration of the sphere (centre ``c``, radius ``r``, m) into the prism over triangle ``t``
    (3x3, its top vertices) down to ``zb`` (m), all in the height field's frame. Returns False if
    they do not overlap; else True with ``out`` = (depth, normal xyz from the prism to the sphere,
    witness point on the prism xyz, witness point on the sphere xyz)."""
    e1x, e1y, e1z = t[1, 0] - t[0, 0], t[1, 1] - t[0, 1], t[1, 2] - t[0, 2]
    e2x, e2y, e2z = t[2, 0] - t[0, 0], t[2, 1] - t[0, 1], t[2, 2] - t[0, 2]
    nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    orient = 1.0 if nz >= 0.0 else -1.0  # the triangle's turn in the xy plane
    ln = math.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx * orient / ln, ny * orient / ln, nz * orient / ln
    # signed distances of the centre to the five face planes (outward normals): top, 3 walls, bottom
    best = (c[0] - t[0, 0]) * nx + (c[1] - t[0, 1]) * ny + (c[2] - t[0, 2]) * nz
    if best >= r:
        return False
    inside = best <= 0.0
    fx, fy, fz = nx, ny, nz
    for k in range(3):
        j = (k + 1) % 3
        s, wx, wy = _wall(c[0], c[1], r, orient, t[k, 0], t[k, 1], t[j, 0], t[j, 1])
        if s >= r:
            return False
        if s > 0.0:
            inside = False
        if s > best:
            best, fx, fy, fz = s, wx, wy, 0.0
    s = zb - c[2]
    if s >= r:
        return False
    if s > 0.0:
        inside = False
    if s > best:
        best, fx, fy, fz = s, 0.0, 0.0, -1.0
    if inside:  # the centre is in the prism: out through the nearest face
        out[0] = r - best
        out[1], out[2], out[3] = fx, fy, fz
        out[4], out[5], out[6] = c[0] - best * fx, c[1] - best * fy, c[2] - best * fz
        out[7], out[8], out[9] = c[0] - r * fx, c[1] - r * fy, c[2] - r * fz
        return True
    # outside: the closest point on the prism's surface (top, the walls as two triangles each, bottom)
    best2 = 1e300
    q0 = q1 = q2 = 0.0
    for f in range(8):
        if f == 0:
            p = _closest_on_triangle(c[0], c[1], c[2], t[0, 0], t[0, 1], t[0, 2], t[1, 0], t[1, 1], t[1, 2],
                                     t[2, 0], t[2, 1], t[2, 2])
        elif f < 7:
            k = (f - 1) // 2
            j = (k + 1) % 3
            a0, a1, a2 = t[k, 0], t[k, 1], t[k, 2]
            b0, b1, b2 = t[j, 0], t[j, 1], t[j, 2]
            if (f - 1) % 2 == 0:
                p = _closest_on_triangle(c[0], c[1], c[2], a0, a1, a2, b0, b1, b2, b0, b1, zb)
            else:
                p = _closest_on_triangle(c[0], c[1], c[2], a0, a1, a2, b0, b1, zb, a0, a1, zb)
        else:
            if not c[2] < zb + r:
                continue
            p = _closest_on_triangle(c[0], c[1], c[2], t[0, 0], t[0, 1], zb, t[1, 0], t[1, 1], zb,
                                     t[2, 0], t[2, 1], zb)
        dx, dy, dz = c[0] - p[0], c[1] - p[1], c[2] - p[2]
        d2 = dx * dx + dy * dy + dz * dz
        if d2 < best2:
            best2 = d2
            q0, q1, q2 = p[0], p[1], p[2]
    dist = math.sqrt(best2)
    if dist >= r or dist <= 0.0:
        return False
    n0, n1, n2 = (c[0] - q0) / dist, (c[1] - q1) / dist, (c[2] - q2) / dist
    out[0] = r - dist
    out[1], out[2], out[3] = n0, n1, n2
    out[4], out[5], out[6] = q0, q1, q2
    out[7], out[8], out[9] = c[0] - r * n0, c[1] - r * n1, c[2] - r * n2
    return True


@njit(cache=True)
def _field(m, d, g1, g2, lay):  # pragma: no cover - compiled
    """Height-field geom ``g1`` and geom ``g2`` as MuJoCo holds them: (the field's samples (float32,
    row-major), nrow, ncol, hfield_size (x, y half-extents, elevation scale, base depth; m), geom
    ``g2``'s centre in the field's frame xyz (mju_mulMatTVec3), d->geom_xpos, d->geom_xmat)."""
    ng = max(g1, g2) + 1
    xpos = _f64(d, lay[L_XPOS], 3 * ng)
    xmat = _f64(d, lay[L_XMAT], 9 * ng)
    hid = _i32(m, lay[L_DATAID], ng)[g1]
    nrow = _i32(m, lay[L_NROW], hid + 1)[hid]
    ncol = _i32(m, lay[L_NCOL], hid + 1)[hid]
    size = _f64(m, lay[L_HSIZE], 4 * hid + 4)[4 * hid:4 * hid + 4]
    adr = _i32(m, lay[L_HADR], hid + 1)[hid]
    hdata = carray(_as_pointer(_pointer_field(m, lay[L_HDATA]) + 4 * adr), (nrow * ncol,), np.float32)
    p1, m1, p2 = 3 * g1, 9 * g1, 3 * g2
    v0, v1, v2 = xpos[p2] - xpos[p1], xpos[p2 + 1] - xpos[p1 + 1], xpos[p2 + 2] - xpos[p1 + 2]
    a = xmat[m1:m1 + 9]
    px = a[0] * v0 + a[3] * v1 + a[6] * v2
    py = a[1] * v0 + a[4] * v1 + a[7] * v2
    pz = a[2] * v0 + a[5] * v1 + a[8] * v2
    return hdata, nrow, ncol, size, px, py, pz, xpos, xmat


@njit(cache=True)
def _lowest_over_cell(px, py, pz, r, x0, x1, y0, y1):  # pragma: no cover - compiled
    """Height of the sphere's (centre (px, py, pz), radius r) lowest point over the cell [x0, x1] x
    [y0, y1], m; +inf if the sphere does not reach over it. A prism whose vertices all lie at or
    below it cannot overlap the sphere (its top is their convex hull)."""
    ddx = x0 - px if px < x0 else (px - x1 if px > x1 else 0.0)
    ddy = y0 - py if py < y0 else (py - y1 if py > y1 else 0.0)
    dxy2 = ddx * ddx + ddy * ddy
    return pz - math.sqrt(r * r - dxy2) if dxy2 < r * r else np.inf


@njit(cache=True)
def _write_contact(out, n, res, a, ox, oy, oz):  # pragma: no cover - compiled
    """mjPreContact ``n`` of ``out`` from :func:`_sphere_prism`'s ``res`` (the field's frame), in the
    world: dist = -depth, pos = the witness points' midpoint, normal, tangent 0 (``mjc_penetration``),
    rotated by the field's xmat ``a`` and moved by its origin (ox, oy, oz)."""
    b = PRE * n
    mx, my, mz = 0.5 * (res[4] + res[7]), 0.5 * (res[5] + res[8]), 0.5 * (res[6] + res[9])
    out[b] = -res[0]
    out[b + 1] = a[0] * mx + a[1] * my + a[2] * mz + ox
    out[b + 2] = a[3] * mx + a[4] * my + a[5] * mz + oy
    out[b + 3] = a[6] * mx + a[7] * my + a[8] * mz + oz
    out[b + 4] = a[0] * res[1] + a[1] * res[2] + a[2] * res[3]
    out[b + 5] = a[3] * res[1] + a[4] * res[2] + a[5] * res[3]
    out[b + 6] = a[6] * res[1] + a[7] * res[2] + a[8] * res[3]
    out[b + 7] = 0.0
    out[b + 8] = 0.0
    out[b + 9] = 0.0


@njit(cache=True)
def _set_prism(t, i, x0, x1, y0, y1, z00, z01, z10, z11):  # pragma: no cover - compiled
    """Prism ``i`` of the cell with corners (x0|x1, y0|y1) at heights z(row, col) into ``t``, as
    ``addPrismVert`` orders them: 0: (r+1, c-1), (r, c-1), (r+1, c); 1: (r, c-1), (r+1, c), (r, c)."""
    if i == 0:
        t[0, 0], t[0, 1], t[0, 2] = x0, y1, z10
        t[1, 0], t[1, 1], t[1, 2] = x0, y0, z00
        t[2, 0], t[2, 1], t[2, 2] = x1, y1, z11
    else:
        t[0, 0], t[0, 1], t[0, 2] = x0, y0, z00
        t[1, 0], t[1, 1], t[1, 2] = x1, y1, z11
        t[2, 0], t[2, 1], t[2, 2] = x1, y0, z01


#: the kernels' one signature: (m, d, con addresses, g1, g2, margin, layout tuple) -> contacts
_KERNEL_SIG = types.int32(types.int64, types.int64, types.int64, types.int32, types.int32, types.float64,
                          types.UniTuple(types.int64, 12))


@njit(_KERNEL_SIG, cache=True)
def sphere_hfield(m, d, con, g1, g2, margin, lay):  # pragma: no cover - compiled
    """Contacts of sphere geom ``g2`` with height-field geom ``g1`` into ``con`` (mjPreContact
    array at that address), their number; ``m``, ``d`` the mjModel and mjData addresses, ``lay``
    the layout's offsets and MuJoCo's own functions' addresses (its sphere function is called for
    ``margin != 0``). The tests and the sub-grid of ``mjc_ConvexHField``, operation for operation."""
    if margin != 0.0:
        return _call_collision(lay[L_SPHERE0], m, d, con, g1, g2, margin)
    hdata, nrow, ncol, size, px, py, pz, xpos, xmat = _field(m, d, g1, g2, lay)
    size0, size1, size2, size3 = size[0], size[1], size[2], size[3]
    radius = _f64(m, lay[L_RBOUND], g2 + 1)[g2] + margin
    if (size0 < px - radius or -size0 > px + radius or size1 < py - radius
            or -size1 > py + radius or size2 < pz - radius or -size3 > pz + radius):
        return 0
    r = _f64(m, lay[L_SIZE], 3 * g2 + 3)[3 * g2]
    xmax, xmin = r * 1.0 + px, r * -1.0 + px  # mjc_sphereSupport along +-x, +-y, +-z
    ymax, ymin = r * 1.0 + py, r * -1.0 + py
    zmax, zmin = r * 1.0 + pz, r * -1.0 + pz
    if (xmin - margin > size0 or xmax + margin < -size0 or ymin - margin > size1 or ymax + margin < -size1
            or zmin - margin > size2 or zmax + margin < -size3):
        return 0
    cmin = max(0, int(math.floor((xmin + size0) / (2.0 * size0) * (ncol - 1))))
    cmax = min(ncol - 1, int(math.ceil((xmax + size0) / (2.0 * size0) * (ncol - 1))))
    rmin = max(0, int(math.floor((ymin + size1) / (2.0 * size1) * (nrow - 1))))
    rmax = min(nrow - 1, int(math.ceil((ymax + size1) / (2.0 * size1) * (nrow - 1))))
    dx = (2.0 * size0) / (ncol - 1)
    dy = (2.0 * size1) / (nrow - 1)
    out = carray(_as_pointer(con), (MAXCONPAIR * PRE,), np.float64)
    a = xmat[9 * g1:9 * g1 + 9]
    centre = np.array((px, py, pz))
    t = np.empty((3, 3))
    res = np.empty(10)
    ncon = 0
    for row in range(rmin, rmax):
        y0, y1 = dy * row - size1, dy * (row + 1) - size1
        x0, z00, z10 = dx * cmin - size0, hdata[row * ncol + cmin] * size2, hdata[(row + 1) * ncol + cmin] * size2
        for col in range(cmin + 1, cmax + 1):
            x1 = dx * col - size0
            z01, z11 = hdata[row * ncol + col] * size2, hdata[(row + 1) * ncol + col] * size2
            # MuJoCo's prism-height test: prism 0 spans z10, z00, z11; prism 1 z00, z11, z01
            if z00 < zmin and z11 < zmin and z10 < zmin and z01 < zmin:
                x0, z00, z10 = x1, z01, z11
                continue
            zlow = _lowest_over_cell(px, py, pz, r, x0, x1, y0, y1)
            for i in range(2):
                _set_prism(t, i, x0, x1, y0, y1, z00, z01, z10, z11)
                if t[0, 2] < zmin and t[1, 2] < zmin and t[2, 2] < zmin:  # MuJoCo's prism-height test
                    continue
                if t[0, 2] <= zlow and t[1, 2] <= zlow and t[2, 2] <= zlow:  # the exact cull
                    continue
                if _sphere_prism(centre, r, t, -size3, res):
                    _write_contact(out, ncon, res, a, xpos[3 * g1], xpos[3 * g1 + 1], xpos[3 * g1 + 2])
                    ncon += 1
                    if ncon >= MAXCONPAIR:
                        return ncon
            x0, z00, z10 = x1, z01, z11
    return ncon


@njit(_KERNEL_SIG, cache=True)
def box_hfield(m, d, con, g1, g2, margin, lay):  # pragma: no cover - compiled
    """Contacts of box geom ``g2`` with height-field geom ``g1``: 0 when no height sample under the
    box (its bounding box in the field's frame, widened by a cell each way) reaches its lowest
    point, else MuJoCo's own function (arguments as :func:`sphere_hfield`)."""
    hdata, nrow, ncol, size, px, py, pz, xpos, xmat = _field(m, d, g1, g2, lay)
    half = _f64(m, lay[L_SIZE], 3 * g2 + 3)[3 * g2:3 * g2 + 3]
    a = xmat[9 * g1:9 * g1 + 9]
    b = xmat[9 * g2:9 * g2 + 9]
    ext = np.zeros(3)  # the box's half-extents along the field's axes: sum_k |(a^T b)[i, k]| half[k]
    for i in range(3):
        for k in range(3):
            ext[i] += abs(a[i] * b[k] + a[3 + i] * b[3 + k] + a[6 + i] * b[6 + k]) * half[k]
    # the lowest corner, less a slack far above the rounding of MuJoCo's own support-point sum
    zmin = pz - ext[2] - (1e-9 + 1e-12 * (abs(pz) + ext[2]))
    cmin = max(0, int(math.floor((px - ext[0] + size[0]) / (2.0 * size[0]) * (ncol - 1))) - 1)
    cmax = min(ncol - 1, int(math.ceil((px + ext[0] + size[0]) / (2.0 * size[0]) * (ncol - 1))) + 1)
    rmin = max(0, int(math.floor((py - ext[1] + size[1]) / (2.0 * size[1]) * (nrow - 1))) - 1)
    rmax = min(nrow - 1, int(math.ceil((py + ext[1] + size[1]) / (2.0 * size[1]) * (nrow - 1))) + 1)
    if cmin > cmax or rmin > rmax:
        return _call_collision(lay[L_BOX0], m, d, con, g1, g2, margin)
    hmax = -np.inf
    for row in range(rmin, rmax + 1):
        for col in range(cmin, cmax + 1):
            hmax = max(hmax, hdata[row * ncol + col])
    if hmax * size[2] + margin < zmin:
        return 0
    return _call_collision(lay[L_BOX0], m, d, con, g1, g2, margin)


# ---------------------------------------------------------------------------- installing
_SIG = types.intc(types.voidptr, types.voidptr, types.voidptr, types.intc, types.intc, types.float64)
_WRAPPERS: dict = {}  # (layout offsets, original sphere, original box) -> (sphere cfunc, box cfunc)


def _wrappers(lay: tuple, sphere_original: int, box_original: int):
    """The ``cfunc`` wrappers (C function pointers of MuJoCo's ``mjfCollision`` type) that bind this
    process's layout and MuJoCo's original functions to the cached kernels (compiled once per
    process, a fraction of a second; the kernels come from numba's cache)."""
    consts = (*lay, sphere_original, box_original)  # one UniTuple(int64): the kernels' cached signature
    if consts not in _WRAPPERS:
        @cfunc(_SIG)
        def sphere(m, d, con, g1, g2, margin):  # pragma: no cover - compiled
            return sphere_hfield(_as_address(m), _as_address(d), _as_address(con), g1, g2, margin, consts)

        @cfunc(_SIG)
        def box(m, d, con, g1, g2, margin):  # pragma: no cover - compiled
            return box_hfield(_as_address(m), _as_address(d), _as_address(con), g1, g2, margin, consts)

        _WRAPPERS[consts] = (sphere, box)
    return _WRAPPERS[consts]


class HFieldCollision:
    """One world's height-field collision functions: :meth:`install` before its MuJoCo calls,
    :meth:`restore` after them. Build with :meth:`for_world`."""

    def __init__(self, slots: tuple[int, int], functions: tuple[int | None, int | None]) -> None:
        self._slots = [ctypes.c_void_p.from_address(a) for a in slots]
        self._ours = functions
        self._saved = [None, None]

    @classmethod
    def for_world(cls, mode: str, model, data) -> HFieldCollision | None:
        """The functions of ``mode`` (``exact``: the box's early-out; ``closed_form``: that and the
        sphere's closed form) for ``model`` and its ``data``; None for ``mujoco`` or where MuJoCo's
        struct layout does not check out (offroadbench.sim.engines.mujoco._layout)."""
        if mode == "mujoco":
            return None
        layout = _layout.layout_for(model, data)
        if layout is None:
            return None
        import mujoco

        g = mujoco.mjtGeom
        slots = _layout.table_slot_addresses(((g.mjGEOM_HFIELD, g.mjGEOM_SPHERE), (g.mjGEOM_HFIELD, g.mjGEOM_BOX)))
        sphere0, box0 = (ctypes.c_void_p.from_address(a).value for a in slots)
        mo, da = layout.model, layout.data
        lay = (mo["geom_dataid"], mo["geom_size"], mo["geom_rbound"], mo["hfield_size"], mo["hfield_nrow"],
               mo["hfield_ncol"], mo["hfield_adr"], mo["hfield_data"], da["geom_xpos"], da["geom_xmat"])
        sphere, box = _wrappers(lay, sphere0, box0)
        return cls(slots, (sphere.address if mode == "closed_form" else None, box.address))

    def entries(self) -> tuple[int, int, int, int]:
        """(table entry address, this world's function address or 0) for the sphere and the box:
        for a compiled trial step that writes them itself (offroadbench.sim.engines.mujoco._tyres_c.
        step_trial)."""
        ours = [0 if f is None else int(f) for f in self._ours]
        return ctypes.addressof(self._slots[0]), ours[0], ctypes.addressof(self._slots[1]), ours[1]

    def install(self) -> None:
        """Point the table's hfield-sphere and hfield-box entries at this world's functions."""
        for k, slot in enumerate(self._slots):
            if self._ours[k] is not None:
                self._saved[k] = slot.value
                slot.value = self._ours[k]

    def restore(self) -> None:
        """Put back what the entries held before :meth:`install`."""
        for k, slot in enumerate(self._slots):
            if self._ours[k] is not None:
                slot.value = self._saved[k]
