"""The ``terramechanics`` soil law as Warp kernels over every world's wheels, run between MuJoCo Warp's
``step1`` and ``step2``: the device form of offroadbench.sim.engines.mujoco._soil_c.apply_soil (the
MuJoCo engine's compiled soil loop), whose arithmetic it follows operation by operation and in the
same order: offroadbench.sim.tyre_laws.soil_wheels.SoilWheels.wheel_force (the ground plane under the
wheel from the bilinear height patch, taken twice, under the centre and under the rim's lowest
point; the penetration; the relaxed slips, Pacejka's transient slip on Wong's slip; the Wong-Reece
forces of the soil tables, offroadbench.sim.tyre_laws.terramechanics.build_tables: bilinear in
penetration and slip, Wong and Reece 1967, with the lateral force trilinear in the lateral slip,
Ishigami et al. 2007 Eq. 9-10; the compaction resistance faded in over the first
``RESISTANCE_FADE_M_S`` of speed).

- :func:`apply_soil` (after ``step1``, grid (world, wheel)): wheel ``i`` of world ``w`` reads its
  centre and velocities from the chassis' rigid motion and its spin, the heights of its world's
  terrain (``heights[terrain_of[w]]``, the terrain's own float64 heights, not the float32 height
  field) and the batch's soil tables, updates its slip state and last-step record, and writes
  its force and torque at the wheel's centre into ``xfrc_applied`` (zero off the soil); wheel 0
  also writes the chassis row (the pushed force). The wheels do not collide with the terrain under
  this model (the soil carries them: the MuJoCo engine's MJCF), so no contact is read and no sum
  is taken: each thread writes its own wheel's rows only, and a world's forces do not depend on
  the order threads run in, on any device.
- :func:`reset_soil` forgets the slip states and last-step records of the worlds being spawned.

State, per (world, wheel), float64 columns: the slip displacements (``UX``, ``UY``, m), the last
step's sinkage, signed slip and penetration (``SINK``, ``SLIP``, ``DELTA``) and the force and
torque written (``FORCE``..``FORCE + 5``, N and N m, float64 before the narrowing to
``xfrc_applied``'s float32). ``on[w, i]``: the wheel was on the soil in the last step.

Precision: MuJoCo Warp's state is float32; all the law's arithmetic is float64, the float32
inputs widened on reading. The host readers (:func:`penetration`, :func:`slip`, :func:`outside`)
are _soil_c's, over one world's rows.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from offroadbench.sim.engines.mujoco_warp.kernels import rotate

__all__ = ["CONSTS", "NCOL", "apply_soil", "outside", "penetrations", "reset_soil", "slip"]

# per (world, wheel) float64 state columns
UX, UY, SINK, SLIP, DELTA, FORCE, NCOL = 0, 1, 2, 3, 4, 5, 11
#: the float64 constants' order in ``consts`` (m, s, N s/m, m, m, m, m, N/m, 1, 1, m/s)
CONSTS = ("radius_m", "dt_s", "damping_n_s_m", "relaxation_m", "lateral_relaxation_m", "cell_m", "delta_max_m",
          "k_series_n_m", "lambda_scale", "max_lateral_slip", "fade_m_s")
(C_R, C_DT, C_C, C_SX, C_SY, C_CELL, C_DMAX, C_KS, C_LAM, C_MAXLAT, C_FADE) = range(len(CONSTS))
# the int constants' order in ``ints``: grid rows and columns, table sizes
I_ROWS, I_COLS, I_ND, I_NS, I_NL = range(5)


@wp.kernel
def reset_soil(mask: wp.array(dtype=wp.int32), soil: wp.array3d(dtype=wp.float64), on: wp.array2d(dtype=wp.int32)):
    """Forget the soil state of the worlds whose ``mask`` is set (a spawn; _soil_c.reset_state).
    Grid: (world, wheel)."""
    w, i = wp.tid()
    if mask[w] == 0:
        return
    for j in range(NCOL):
        soil[w, i, j] = wp.float64(0.0)
    on[w, i] = 0


@wp.func
def _fmax(a: wp.float64, b: wp.float64) -> wp.float64:
    """Python's ``max(a, b)``: ``b`` only if ``b > a``."""
    if b > a:
        return b
    return a


@wp.func
def _fmin(a: wp.float64, b: wp.float64) -> wp.float64:
    """Python's ``min(a, b)``: ``b`` only if ``b < a``."""
    if b < a:
        return b
    return a


@wp.func
def _surface(heights: wp.array2d(dtype=wp.float64), t: int, rows: int, cols: int, cell: wp.float64,
             x: wp.float64, y: wp.float64) -> wp.vec4d:
    """(on the map 1/0, height, dz/dx, dz/dy) of terrain ``t``'s bilinear surface at (x, y) m:
    _soil_c._surface."""
    one = wp.float64(1.0)
    u = x / cell
    v = y / cell
    if not (u >= wp.float64(0.0) and u <= wp.float64(cols - 1) and v >= wp.float64(0.0)
            and v <= wp.float64(rows - 1)):
        return wp.vec4d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))
    c0 = wp.min(int(u), cols - 2)
    r0 = wp.min(int(v), rows - 2)
    fx = u - wp.float64(c0)
    fy = v - wp.float64(r0)
    a = r0 * cols + c0
    z00 = heights[t, a]
    z01 = heights[t, a + 1]
    z10 = heights[t, a + cols]
    z11 = heights[t, a + cols + 1]
    h = (z00 * (one - fx) + z01 * fx) * (one - fy) + (z10 * (one - fx) + z11 * fx) * fy
    gx = ((z01 - z00) * (one - fy) + (z11 - z10) * fy) / cell
    gy = ((z10 - z00) * (one - fx) + (z11 - z01) * fx) / cell
    return wp.vec4d(one, h, gx, gy)


@wp.func
def _cell(consts: wp.array(dtype=wp.float64), ints: wp.array(dtype=wp.int32), delta: wp.float64,
          s: wp.float64) -> wp.vec4d:
    """(i, fi, j, fj) of penetration ``delta`` m and slip ``s`` in the tables: _soil_c._cell (i, j
    whole numbers held as float64)."""
    one = wp.float64(1.0)
    nd = ints[I_ND]
    ns = ints[I_NS]
    u = wp.float64(0.0)
    if delta > wp.float64(0.0):
        u = wp.sqrt(delta / consts[C_DMAX]) * wp.float64(nd)
    i = int(u)
    fi = wp.float64(0.0)
    if i >= nd:
        i = nd - 1
        fi = one
    else:
        fi = u - wp.float64(i)
    v = (_fmin(one, _fmax(-one, s)) + one) * wp.float64(0.5) * wp.float64(ns - 1)
    j = int(v)
    if j >= ns - 1:
        j = ns - 2
    return wp.vec4d(wp.float64(i), fi, wp.float64(j), v - wp.float64(j))


@wp.func
def _lookup(consts: wp.array(dtype=wp.float64), ints: wp.array(dtype=wp.int32), tab: wp.array(dtype=wp.float64),
            size: int, delta: wp.float64, s: wp.float64) -> wp.vec4d:
    """(sinkage m, F_z N, F_x N, T N m) at penetration ``delta`` and slip ``s``: _soil_c._lookup, the
    tables (sinkage, F_z, F_x, T) at 0, ``size``, ``2 size``, ``3 size`` in ``tab``."""
    one = wp.float64(1.0)
    ns = ints[I_NS]
    c = _cell(consts, ints, delta, s)
    i = int(c[0])
    fi = c[1]
    j = int(c[2])
    fj = c[3]
    a = i * ns + j
    b = (i + 1) * ns + j
    w00 = (one - fi) * (one - fj)
    w01 = (one - fi) * fj
    w10 = fi * (one - fj)
    w11 = fi * fj
    sink = tab[a] * w00 + tab[a + 1] * w01 + tab[b] * w10 + tab[b + 1] * w11
    t = size
    fz = tab[t + a] * w00 + tab[t + a + 1] * w01 + tab[t + b] * w10 + tab[t + b + 1] * w11
    t = 2 * size
    fx = tab[t + a] * w00 + tab[t + a + 1] * w01 + tab[t + b] * w10 + tab[t + b + 1] * w11
    t = 3 * size
    torque = tab[t + a] * w00 + tab[t + a + 1] * w01 + tab[t + b] * w10 + tab[t + b + 1] * w11
    extra = delta - consts[C_DMAX]
    if extra > wp.float64(0.0):
        fz = fz + consts[C_KS] * extra
    return wp.vec4d(sink, fz, fx, torque)


@wp.func
def _lateral(consts: wp.array(dtype=wp.float64), ints: wp.array(dtype=wp.int32), tab: wp.array(dtype=wp.float64),
             off: int, delta: wp.float64, s: wp.float64, lam: wp.float64) -> wp.float64:
    """The side-shear force N at penetration, slip and lateral slip ratio: _soil_c._lateral, the F_y
    table at ``off`` in ``tab``."""
    one = wp.float64(1.0)
    ns = ints[I_NS]
    nl = ints[I_NL]
    c = _cell(consts, ints, delta, s)
    i = int(c[0])
    fi = c[1]
    j = int(c[2])
    fj = c[3]
    w = lam / (lam + consts[C_LAM]) * wp.float64(nl - 1)
    k = int(w)
    if k >= nl - 1:
        k = nl - 2
    fk = w - wp.float64(k)
    total = wp.float64(0.0)
    for di in range(2):
        wi = fi
        if di == 0:
            wi = one - fi
        for dj in range(2):
            wj = fj
            if dj == 0:
                wj = one - fj
            b = off + ((i + di) * ns + j + dj) * nl + k
            total = total + wi * wj * (tab[b] * (one - fk) + tab[b + 1] * fk)
    return total


@wp.kernel
def apply_soil(qvel: wp.array2d(dtype=wp.float32), xmat: wp.array2d(dtype=wp.mat33),
               xipos: wp.array2d(dtype=wp.vec3), xfrc: wp.array2d(dtype=wp.spatial_vector),
               chassis: wp.int32, wheel_body: wp.array(dtype=wp.int32), wheel_qvel: wp.array(dtype=wp.int32),
               wheel_axis: wp.array(dtype=wp.vec3d), consts: wp.array(dtype=wp.float64),
               ints: wp.array(dtype=wp.int32), tab: wp.array(dtype=wp.float64),
               heights: wp.array2d(dtype=wp.float64), terrain_of: wp.array(dtype=wp.int32),
               push: wp.array(dtype=wp.vec3), soil: wp.array3d(dtype=wp.float64), on: wp.array2d(dtype=wp.int32)):
    """Wheel ``i`` of world ``w``: the soil's force and torque at its centre into ``xfrc`` (zero off
    the soil); wheel 0 also writes the chassis row (the pushed force). _soil_c.apply_soil and
    wheel_force, operation for operation. Grid: (world, wheel)."""
    w, i = wp.tid()
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    if i == 0:
        pf = push[w]
        xfrc[w, chassis] = wp.spatial_vector(pf[0], pf[1], pf[2], 0.0, 0.0, 0.0)
    body = wheel_body[i]
    on[w, i] = 0
    r = xmat[w, chassis]
    wb = wp.vec3d(wp.float64(qvel[w, 3]), wp.float64(qvel[w, 4]), wp.float64(qvel[w, 5]))
    om = rotate(r, wb)
    c0 = xipos[w, chassis]
    cw = xipos[w, body]
    cx = wp.float64(cw[0])
    cy = wp.float64(cw[1])
    cz = wp.float64(cw[2])
    rx = cx - wp.float64(c0[0])
    ry = cy - wp.float64(c0[1])
    rz = cz - wp.float64(c0[2])
    vx = wp.float64(qvel[w, 0]) + om[1] * rz - om[2] * ry
    vy = wp.float64(qvel[w, 1]) + om[2] * rx - om[0] * rz
    vz = wp.float64(qvel[w, 2]) + om[0] * ry - om[1] * rx
    a = rotate(r, wheel_axis[i])
    ax = a[0]
    ay = a[1]
    az = a[2]
    s = wp.float64(qvel[w, wheel_qvel[i]])
    wx = om[0] + ax * s
    wy = om[1] + ay * s
    wz = om[2] + az * s
    # SoilWheels._contact: the plane under the centre, then under the rim's lowest point
    t = terrain_of[w]
    rows = ints[I_ROWS]
    cols = ints[I_COLS]
    cell = consts[C_CELL]
    rad = consts[C_R]
    qx = cx
    qy = cy
    ok = int(1)
    h = zero
    ex = zero
    ey = zero
    nx = zero
    ny = zero
    nz = zero
    px_ = zero
    py_ = zero
    pz_ = zero
    for _ in range(2):
        if ok == 1:
            g = _surface(heights, t, rows, cols, cell, qx, qy)
            if g[0] == zero:
                ok = 0
            else:
                h = g[1]
                ex = qx
                ey = qy
                norm = wp.sqrt(g[2] * g[2] + g[3] * g[3] + one)
                nx = -g[2] / norm
                ny = -g[3] / norm
                nz = one / norm
                na = nx * ax + ny * ay + nz * az
                px = nx - na * ax
                py = ny - na * ay
                pz = nz - na * az
                pn = wp.sqrt(px * px + py * py + pz * pz)
                if pn < wp.float64(1e-6):
                    ok = 0
                else:
                    px_ = cx - rad * px / pn
                    py_ = cy - rad * py / pn
                    pz_ = cz - rad * pz / pn
                    qx = px_
                    qy = py_
    delta = zero
    if ok == 1:
        delta = -((px_ - ex) * nx + (py_ - ey) * ny + (pz_ - h) * nz)
    if ok == 0 or delta <= zero:
        soil[w, i, UX] = zero
        soil[w, i, UY] = zero
        for j in range(6):
            soil[w, i, FORCE + j] = zero
        xfrc[w, body] = wp.spatial_vector(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        return
    fx_ = ay * nz - az * ny
    fy_ = az * nx - ax * nz
    fz_ = ax * ny - ay * nx
    fn = wp.sqrt(fx_ * fx_ + fy_ * fy_ + fz_ * fz_)
    fx_ = fx_ / fn
    fy_ = fy_ / fn
    fz_ = fz_ / fn
    lx = ny * fz_ - nz * fy_
    ly = nz * fx_ - nx * fz_
    lz = nx * fy_ - ny * fx_
    v_f = vx * fx_ + vy * fy_ + vz * fz_
    v_l = vx * lx + vy * ly + vz * lz
    v_n = vx * nx + vy * ny + vz * nz
    u_roll = rad * (wx * ax + wy * ay + wz * az)
    vref = _fmax(wp.abs(u_roll), wp.abs(v_f))
    dt = consts[C_DT]
    sx = consts[C_SX]
    sy = consts[C_SY]
    ux = (soil[w, i, UX] + dt * (u_roll - v_f)) / (one + dt * vref / sx)
    ux = _fmin(sx, _fmax(-sx, ux))
    uy = (soil[w, i, UY] - dt * v_l) / (one + dt * vref / sy)
    lat = consts[C_MAXLAT]
    uy = _fmin(lat * sy, _fmax(-lat * sy, uy))
    soil[w, i, UX] = ux
    soil[w, i, UY] = uy
    sl = ux / sx
    lam = wp.abs(uy) / sy
    lead = v_f
    if wp.abs(u_roll) >= wp.abs(v_f):
        lead = u_roll
    direction = -one
    if lead >= zero:
        direction = one
    s_m = direction * sl
    size = (ints[I_ND] + 1) * ints[I_NS]
    look = _lookup(consts, ints, tab, size, delta, s_m)
    look0 = _lookup(consts, ints, tab, size, delta, zero)
    fade = one - _fmin(one, wp.abs(v_f) / consts[C_FADE])
    f_x = direction * (look[2] - fade * look0[2])
    torque = direction * (look[3] - fade * look0[3])
    f_y = _lateral(consts, ints, tab, 4 * size, delta, s_m, lam)
    if uy < zero:
        f_y = -f_y
    f_n = _fmax(zero, look[1] - consts[C_C] * v_n)
    on[w, i] = 1
    soil[w, i, SINK] = look[0]
    soil[w, i, SLIP] = s_m
    soil[w, i, DELTA] = delta
    ffx = f_n * nx + f_x * fx_ + f_y * lx
    ffy = f_n * ny + f_x * fy_ + f_y * ly
    ffz = f_n * nz + f_x * fz_ + f_y * lz
    tx = -torque * ax
    ty = -torque * ay
    tz = -torque * az
    soil[w, i, FORCE] = ffx
    soil[w, i, FORCE + 1] = ffy
    soil[w, i, FORCE + 2] = ffz
    soil[w, i, FORCE + 3] = tx
    soil[w, i, FORCE + 4] = ty
    soil[w, i, FORCE + 5] = tz
    xfrc[w, body] = wp.spatial_vector(wp.float32(ffx), wp.float32(ffy), wp.float32(ffz),
                                      wp.float32(tx), wp.float32(ty), wp.float32(tz))


# ---------------------------------------------------------------------------- host readers
def penetrations(soil: np.ndarray, on: np.ndarray) -> np.ndarray:
    """Every world's deepest soil sinkage of its wheels on the soil in the last step (0 where none),
    m: _soil_c.penetration, over ``soil`` (nworld, nwheel, state; host) and ``on`` (nworld, nwheel
    flags). A maximum is exact, so the same value as one world's scalar maximum."""
    on = on.astype(bool)
    deepest = np.where(on, soil[:, :, SINK], -np.inf).max(axis=1, initial=-np.inf)
    return np.where(on.any(axis=1), deepest, 0.0)


def slip(rows, on) -> float | None:
    """Mean slip of one world's wheels on the soil in the last step (None if none): _soil_c.slip."""
    slips = [float(rows[k][SLIP]) for k in range(len(on)) if on[k]]
    if not slips:
        return None
    return sum(slips) / len(slips)


def outside(rows, on, delta_max_m: float) -> bool:
    """True when a wheel on the soil in the last step had its penetration past the tables' top
    ``delta_max_m`` (it bottomed out): _soil_c.outside."""
    return any(bool(on[k]) and float(rows[k][DELTA]) > delta_max_m for k in range(len(on)))
