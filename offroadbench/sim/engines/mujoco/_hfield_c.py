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


#: the kernels' one signature: (m, d, con addresses, g1, g2, margin, layout tuple) -> contacts
_KERNEL_SIG = types.int32(types.int64, types.int64, types.int64, types.int32, types.int32, types.float64,
                          types.UniTuple(types.int64, 12))


@njit(_KERNEL_SIG, cache=True)
def sphere_hfield(m, d, con, g1, g2, margin, lay):  # pragma: no cover - compiled
    """Contacts of sphere geom ``g2`` with height-field geom ``g1`` into ``con`` (mjPreContact
    array at that address), their number; ``m``, ``d`` the mjModel and mjData addresses, ``lay``
    the layout's offsets and MuJoCo's own functions' addresses (its sphere function is called for
    ``margin != 0``)."""
    if margin != 0.0:
        return _call_collision(lay[L_SPHERE0], m, d, con, g1, g2, margin)
    ng = max(g1, g2) + 1
    xpos = _f64(d, lay[L_XPOS], 3 * ng)
    xmat = _f64(d, lay[L_XMAT], 9 * ng)
    hid = _i32(m, lay[L_DATAID], ng)[g1]
    nrow = _i32(m, lay[L_NROW], hid + 1)[hid]
    ncol = _i32(m, lay[L_NCOL], hid + 1)[hid]
    hsize = _f64(m, lay[L_HSIZE], 4 * hid + 4)
    size0, size1, size2, size3 = hsize[4 * hid], hsize[4 * hid + 1], hsize[4 * hid + 2], hsize[4 * hid + 3]
    adr = _i32(m, lay[L_HADR], hid + 1)[hid]
    hdata = carray(_as_pointer(_pointer_field(m, lay[L_HDATA]) + 4 * adr), (nrow * ncol,), np.float32)
    out = carray(_as_pointer(con), (MAXCONPAIR * PRE,), np.float64)
    p1, m1, p2 = 3 * g1, 9 * g1, 3 * g2
    v0, v1, v2 = xpos[p2] - xpos[p1], xpos[p2 + 1] - xpos[p1 + 1], xpos[p2 + 2] - xpos[p1 + 2]
    mat1 = xmat[m1:m1 + 9]
    pos = np.empty(3)  # the centre in the field's frame (mju_mulMatTVec3)
    pos[0] = mat1[0] * v0 + mat1[3] * v1 + mat1[6] * v2
    pos[1] = mat1[1] * v0 + mat1[4] * v1 + mat1[7] * v2
    pos[2] = mat1[2] * v0 + mat1[5] * v1 + mat1[8] * v2
    radius = _f64(m, lay[L_RBOUND], ng)[g2] + margin
    if (size0 < pos[0] - radius or -size0 > pos[0] + radius or size1 < pos[1] - radius
            or -size1 > pos[1] + radius or size2 < pos[2] - radius or -size3 > pos[2] + radius):
        return 0
    r = _f64(m, lay[L_SIZE], 3 * ng)[3 * g2]
    xmax, xmin = r * 1.0 + pos[0], r * -1.0 + pos[0]  # mjc_sphereSupport along +-x, +-y, +-z
    ymax, ymin = r * 1.0 + pos[1], r * -1.0 + pos[1]
    zmax, zmin = r * 1.0 + pos[2], r * -1.0 + pos[2]
    if (xmin - margin > size0 or xmax + margin < -size0 or ymin - margin > size1 or ymax + margin < -size1
            or zmin - margin > size2 or zmax + margin < -size3):
        return 0
    cmin = max(0, int(math.floor((xmin + size0) / (2.0 * size0) * (ncol - 1))))
    cmax = min(ncol - 1, int(math.ceil((xmax + size0) / (2.0 * size0) * (ncol - 1))))
    rmin = max(0, int(math.floor((ymin + size1) / (2.0 * size1) * (nrow - 1))))
    rmax = min(nrow - 1, int(math.ceil((ymax + size1) / (2.0 * size1) * (nrow - 1))))
    dx = (2.0 * size0) / (ncol - 1)
    dy = (2.0 * size1) / (nrow - 1)
    zb = -size3
    t = np.empty((3, 3))
    res = np.empty(10)
    ncon = 0
    for row in range(rmin, rmax):
        ya, yb = dy * (row + 1) - size1, dy * row - size1  # rows r+1 and r
        ax, az = dx * cmin - size0, hdata[(row + 1) * ncol + cmin] * size2
        bz = hdata[row * ncol + cmin] * size2
        for col in range(cmin + 1, cmax + 1):
            nx_ = dx * col - size0
            naz = hdata[(row + 1) * ncol + col] * size2
            nbz = hdata[row * ncol + col] * size2
            # exact cull: the sphere's lowest point over this cell's footprint
            ddx = ax - pos[0] if pos[0] < ax else (pos[0] - nx_ if pos[0] > nx_ else 0.0)
            ddy = yb - pos[1] if pos[1] < yb else (pos[1] - ya if pos[1] > ya else 0.0)
            dxy2 = ddx * ddx + ddy * ddy
            zlow = pos[2] - math.sqrt(r * r - dxy2) if dxy2 < r * r else 1e300
            for i in range(2):
                if i == 0:  # (r+1, c-1), (r, c-1), (r+1, c)
                    t[0, 0], t[0, 1], t[0, 2] = ax, ya, az
                    t[1, 0], t[1, 1], t[1, 2] = ax, yb, bz
                    t[2, 0], t[2, 1], t[2, 2] = nx_, ya, naz
                else:  # (r, c-1), (r+1, c), (r, c)
                    t[0, 0], t[0, 1], t[0, 2] = ax, yb, bz
                    t[1, 0], t[1, 1], t[1, 2] = nx_, ya, naz
                    t[2, 0], t[2, 1], t[2, 2] = nx_, yb, nbz
                if t[0, 2] < zmin and t[1, 2] < zmin and t[2, 2] < zmin:  # MuJoCo's prism-height test
                    continue
                if t[0, 2] <= zlow and t[1, 2] <= zlow and t[2, 2] <= zlow:
                    continue
                if _sphere_prism(pos, r, t, zb, res):
                    b = PRE * ncon
                    mx = 0.5 * (res[4] + res[7])
                    my = 0.5 * (res[5] + res[8])
                    mz = 0.5 * (res[6] + res[9])
                    out[b] = -res[0]
                    out[b + 1] = mat1[0] * mx + mat1[1] * my + mat1[2] * mz + xpos[p1]
                    out[b + 2] = mat1[3] * mx + mat1[4] * my + mat1[5] * mz + xpos[p1 + 1]
                    out[b + 3] = mat1[6] * mx + mat1[7] * my + mat1[8] * mz + xpos[p1 + 2]
                    out[b + 4] = mat1[0] * res[1] + mat1[1] * res[2] + mat1[2] * res[3]
                    out[b + 5] = mat1[3] * res[1] + mat1[4] * res[2] + mat1[5] * res[3]
                    out[b + 6] = mat1[6] * res[1] + mat1[7] * res[2] + mat1[8] * res[3]
                    out[b + 7] = 0.0
                    out[b + 8] = 0.0
                    out[b + 9] = 0.0
                    ncon += 1
                    if ncon >= MAXCONPAIR:
                        return ncon
            ax, az, bz = nx_, naz, nbz
    return ncon


@njit(_KERNEL_SIG, cache=True)
def box_hfield(m, d, con, g1, g2, margin, lay):  # pragma: no cover - compiled
    """Contacts of box geom ``g2`` with height-field geom ``g1``: 0 when no height sample under the
    box reaches its lowest point, else MuJoCo's own function at ``original`` (arguments as
    :func:`sphere_hfield`)."""
    ng = max(g1, g2) + 1
    xpos = _f64(d, lay[L_XPOS], 3 * ng)
    xmat = _f64(d, lay[L_XMAT], 9 * ng)
    hid = _i32(m, lay[L_DATAID], ng)[g1]
    nrow = _i32(m, lay[L_NROW], hid + 1)[hid]
    ncol = _i32(m, lay[L_NCOL], hid + 1)[hid]
    hsize = _f64(m, lay[L_HSIZE], 4 * hid + 4)
    size0, size1, size2 = hsize[4 * hid], hsize[4 * hid + 1], hsize[4 * hid + 2]
    adr = _i32(m, lay[L_HADR], hid + 1)[hid]
    hdata = carray(_as_pointer(_pointer_field(m, lay[L_HDATA]) + 4 * adr), (nrow * ncol,), np.float32)
    size = _f64(m, lay[L_SIZE], 3 * ng)
    p1, m1, p2, m2 = 3 * g1, 9 * g1, 3 * g2, 9 * g2
    v0, v1, v2 = xpos[p2] - xpos[p1], xpos[p2 + 1] - xpos[p1 + 1], xpos[p2 + 2] - xpos[p1 + 2]
    a = xmat[m1:m1 + 9]
    b = xmat[m2:m2 + 9]
    px = a[0] * v0 + a[3] * v1 + a[6] * v2
    py = a[1] * v0 + a[4] * v1 + a[7] * v2
    pz = a[2] * v0 + a[5] * v1 + a[8] * v2
    ext = np.empty(3)  # the box's half-extents along the field's axes: sum_k |(a^T b)[i, k]| size[k]
    for i in range(3):
        e = 0.0
        for k in range(3):
            e += abs(a[i] * b[k] + a[3 + i] * b[3 + k] + a[6 + i] * b[6 + k]) * size[3 * g2 + k]
        ext[i] = e
    # the lowest corner, less a slack far above the rounding of MuJoCo's own support-point sum
    zmin = pz - ext[2] - (1e-9 + 1e-12 * (abs(pz) + ext[2]))
    cmin = max(0, int(math.floor((px - ext[0] + size0) / (2.0 * size0) * (ncol - 1))) - 1)
    cmax = min(ncol - 1, int(math.ceil((px + ext[0] + size0) / (2.0 * size0) * (ncol - 1))) + 1)
    rmin = max(0, int(math.floor((py - ext[1] + size1) / (2.0 * size1) * (nrow - 1))) - 1)
    rmax = min(nrow - 1, int(math.ceil((py + ext[1] + size1) / (2.0 * size1) * (nrow - 1))) + 1)
    if cmin > cmax or rmin > rmax:
        return _call_collision(lay[L_BOX0], m, d, con, g1, g2, margin)
    hmax = -np.inf
    for row in range(rmin, rmax + 1):
        for col in range(cmin, cmax + 1):
            h = hdata[row * ncol + col]
            if h > hmax:
                hmax = h
    if hmax * size2 + margin < zmin:
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
