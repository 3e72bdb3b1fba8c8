"""The ``terramechanics`` soil loop of the MuJoCo world compiled with numba: the same forces as the
Python loop, outside the interpreter.

What it computes
----------------
Exactly what offroadbench.sim.engines.mujoco.tyres (``_soil_forces``) does in Python with
offroadbench.sim.tyre_laws.soil_wheels.SoilWheels at each MuJoCo step, after ``mj_step1``: for each
wheel its centre, axle and velocities from the chassis' rigid motion and the wheel's spin, the
bilinear ground patch under it and the rim's lowest point (two passes), the penetration, the
relaxed longitudinal and lateral slips (Pacejka's transient slip on Wong's slip), the Wong-Reece
forces from the soil tables (bilinear in penetration and slip, trilinear with the lateral slip;
the tables themselves, slip-sinkage included, are offroadbench.sim.tyre_laws.terramechanics.
build_tables, built once in numpy), and the force and torque at the wheel centre written into
``xfrc_applied``. The wheels do not collide with the terrain under this model (the soil carries
them), so no MuJoCo contact is read for them: their contact loads stay zero, as in Python.

The arithmetic is the Python loop's, operation by operation and in the same order, on IEEE
float64 scalars; numba compiles without ``fastmath`` (no reassociation, no FMA contraction), the
only library calls are ``sqrt`` and ``fabs`` (exact), and Python's ``min``/``max`` are written out
with their comparison order (:func:`_max`, :func:`_min`), so NaN and signed zeros come out as
Python's. The forces are those of the Python loop to the last bit
(tests/sim/test_soil_compiled.py; benchmarks/RESULTS.md, 'Issue 35', records the cost).

State
-----
Three arrays made by :func:`new_state`: ``f`` (float64) holds, for ``n`` wheels, the slip
displacements (``2 n``), the last step's (sinkage, slip, penetration) per wheel (``3 n``), the
wheel axes in the chassis frame (``3 n``), then constants and the pushed force at ``F_*`` offsets
past ``8 n``; ``i`` (int64) holds the in-contact flags (``n``), the wheel bodies and their spin
dofs' qvel addresses (``n`` each), then the chassis body and the table and map sizes at ``I_*``
offsets past ``3 n``; ``tab`` (float64) holds the terrain's heights (row-major) and the soil tables
(sinkage, F_z, F_x, T, F_y) one after the other.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["APPLY", "apply_soil", "check_types", "new_state", "outside", "penetration", "reset_state", "slip",
           "wheel_force"]

# offsets past 8 n in the float state
(F_R, F_DT, F_C, F_SX, F_SY, F_CELL, F_DELTA_MAX, F_K_SERIES, F_LAMBDA_SCALE, F_MAX_LAT, F_FADE,
 F_PUSH_X, F_PUSH_Y, F_PUSH_Z, F_PUSHED) = range(15)
N_F = 15
# offsets past 3 n in the int state
I_CHASSIS, I_ROWS, I_COLS, I_N_DELTA, I_N_SLIP, I_N_LAT, I_N = range(7)
N_I = 7


def new_state(soil, hm, wheel_bodies, wheel_qvel, wheel_axes, chassis_body: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The (float, int, table) state arrays of one loop from the Python loop's ``soil``
    (offroadbench.sim.tyre_laws.soil_wheels.SoilWheels: its tables, radius, step, damping and
    relaxation lengths), the terrain ``hm`` and each wheel's body id, spin dof's qvel address and
    spin axis in the chassis frame, and the chassis body."""
    from offroadbench.sim.tyre_laws.soil_wheels import MAX_LATERAL_SLIP, RESISTANCE_FADE_M_S
    from offroadbench.sim.tyre_laws.terramechanics import LAMBDA_SCALE

    n = len(wheel_bodies)
    t = soil.tables
    f = np.zeros(8 * n + N_F)
    f[5 * n:8 * n] = np.asarray(wheel_axes, dtype=np.float64).ravel()
    base = 8 * n
    consts = {F_R: soil._r, F_DT: soil._dt, F_C: soil._c, F_SX: soil._sx, F_SY: soil._sy, F_CELL: soil._cell,
              F_DELTA_MAX: t.delta_max_m, F_K_SERIES: t.k_series_n_m, F_LAMBDA_SCALE: LAMBDA_SCALE,
              F_MAX_LAT: MAX_LATERAL_SLIP, F_FADE: RESISTANCE_FADE_M_S}
    for k, v in consts.items():
        f[base + k] = float(v)
    i = np.zeros(3 * n + N_I, dtype=np.int64)
    i[n:2 * n] = wheel_bodies
    i[2 * n:3 * n] = wheel_qvel
    i[3 * n + I_CHASSIS] = chassis_body
    i[3 * n + I_ROWS], i[3 * n + I_COLS] = hm.rows, hm.cols
    i[3 * n + I_N_DELTA], i[3 * n + I_N_SLIP], i[3 * n + I_N_LAT] = t.n_delta, t.n_slip, t.n_lat
    i[3 * n + I_N] = n
    tab = np.concatenate([np.asarray(soil._z, dtype=np.float64).ravel(),
                          *(np.asarray(a, dtype=np.float64) for a in (t.sinkage, t.fz, t.fx, t.torque, t.fy))])
    return f, i, np.ascontiguousarray(tab)


def reset_state(f: np.ndarray, i: np.ndarray, n: int) -> None:
    """Forget the slip states and the last step's contacts (before a spawn)."""
    f[0:5 * n] = 0.0
    i[0:n] = 0


def penetration(f: np.ndarray, i: np.ndarray, n: int) -> float:
    """The deepest soil sinkage of the last step's wheels on the soil (0 if none), m: the Python
    world's ``max(sinkage over soil.last, default=0)``, in its order."""
    sinks = [float(f[2 * n + 3 * k]) for k in range(n) if i[k]]
    return max(sinks, default=0.0)


def outside(f: np.ndarray, i: np.ndarray, n: int) -> bool:
    """True when a wheel on the soil in the last step had its penetration past the tables' top (it
    bottomed out: SoilWheels.outside_model)."""
    top = float(f[8 * n + F_DELTA_MAX])
    return any(bool(i[k]) and float(f[2 * n + 3 * k + 2]) > top for k in range(n))


def slip(f: np.ndarray, i: np.ndarray, n: int) -> float | None:
    """Mean slip of the last step's wheels on the soil (None if none): the Python world's sum over
    ``soil.last`` in its order, over their count."""
    slips = [float(f[2 * n + 3 * k + 1]) for k in range(n) if i[k]]
    if not slips:
        return None
    return sum(slips) / len(slips)


@njit(cache=True)
def _max(a, b):  # pragma: no cover - compiled
    """Python's ``max(a, b)``: ``b`` only if ``b > a``."""
    return b if b > a else a


@njit(cache=True)
def _min(a, b):  # pragma: no cover - compiled
    """Python's ``min(a, b)``: ``b`` only if ``b < a``."""
    return b if b < a else a


@njit(cache=True)
def _surface(tab, rows, cols, cell, x, y):  # pragma: no cover - compiled
    """(on the map, height, dz/dx, dz/dy) of the bilinear surface at (x, y): SoilWheels._surface."""
    u = x / cell
    v = y / cell
    if not (0.0 <= u <= cols - 1 and 0.0 <= v <= rows - 1):
        return False, 0.0, 0.0, 0.0
    c0 = min(int(u), cols - 2)
    r0 = min(int(v), rows - 2)
    fx = u - c0
    fy = v - r0
    a = r0 * cols + c0
    z00 = tab[a]
    z01 = tab[a + 1]
    z10 = tab[a + cols]
    z11 = tab[a + cols + 1]
    h = (z00 * (1.0 - fx) + z01 * fx) * (1.0 - fy) + (z10 * (1.0 - fx) + z11 * fx) * fy
    gx = ((z01 - z00) * (1.0 - fy) + (z11 - z10) * fy) / cell
    gy = ((z10 - z00) * (1.0 - fx) + (z11 - z01) * fx) / cell
    return True, h, gx, gy


@njit(cache=True)
def _cell(f, st, delta, s):  # pragma: no cover - compiled
    """SoilTables._cell: (i, fi, j, fj) of penetration ``delta`` and slip ``s``."""
    n = st[st.shape[0] - N_I + I_N]
    base = 8 * n
    nd = st[3 * n + I_N_DELTA]
    ns = st[3 * n + I_N_SLIP]
    u = math.sqrt(delta / f[base + F_DELTA_MAX]) * nd if delta > 0.0 else 0.0
    i = int(u)
    if i >= nd:
        i = nd - 1
        fi = 1.0
    else:
        fi = u - i
    v = (_min(1.0, _max(-1.0, s)) + 1.0) * 0.5 * (ns - 1)
    j = int(v)
    if j >= ns - 1:
        j = ns - 2
    return i, fi, j, v - j


@njit(cache=True)
def _lookup(f, st, tab, off, size, delta, s):  # pragma: no cover - compiled
    """SoilTables.lookup: (sinkage, F_z, F_x, T) at penetration ``delta`` and slip ``s``; the tables
    start at ``off`` in ``tab``, ``size`` entries each."""
    n = st[st.shape[0] - N_I + I_N]
    ns = st[3 * n + I_N_SLIP]
    i, fi, j, fj = _cell(f, st, delta, s)
    a = i * ns + j
    b = (i + 1) * ns + j
    w00 = (1.0 - fi) * (1.0 - fj)
    w01 = (1.0 - fi) * fj
    w10 = fi * (1.0 - fj)
    w11 = fi * fj
    t = off
    sink = tab[t + a] * w00 + tab[t + a + 1] * w01 + tab[t + b] * w10 + tab[t + b + 1] * w11
    t = off + size
    fz = tab[t + a] * w00 + tab[t + a + 1] * w01 + tab[t + b] * w10 + tab[t + b + 1] * w11
    t = off + 2 * size
    fx = tab[t + a] * w00 + tab[t + a + 1] * w01 + tab[t + b] * w10 + tab[t + b + 1] * w11
    t = off + 3 * size
    torque = tab[t + a] * w00 + tab[t + a + 1] * w01 + tab[t + b] * w10 + tab[t + b + 1] * w11
    extra = delta - f[8 * n + F_DELTA_MAX]
    if extra > 0.0:
        fz = fz + f[8 * n + F_K_SERIES] * extra
    return sink, fz, fx, torque


@njit(cache=True)
def _lateral(f, st, tab, off, delta, s, lam):  # pragma: no cover - compiled
    """SoilTables.lateral: the side-shear force at penetration, slip and lateral slip ratio; the
    F_y table starts at ``off`` in ``tab``."""
    n = st[st.shape[0] - N_I + I_N]
    ns = st[3 * n + I_N_SLIP]
    nl = st[3 * n + I_N_LAT]
    i, fi, j, fj = _cell(f, st, delta, s)
    w = lam / (lam + f[8 * n + F_LAMBDA_SCALE]) * (nl - 1)
    k = int(w)
    if k >= nl - 1:
        k = nl - 2
    fk = w - k
    total = 0.0
    for di in range(2):
        wi = 1.0 - fi if di == 0 else fi
        for dj in range(2):
            wj = 1.0 - fj if dj == 0 else fj
            b = off + ((i + di) * ns + j + dj) * nl + k
            total = total + wi * wj * (tab[b] * (1.0 - fk) + tab[b + 1] * fk)
    return total


@njit(cache=True)
def wheel_force(f, st, tab, i, cx, cy, cz, ax, ay, az, vx, vy, vz, wx, wy, wz):  # pragma: no cover - compiled
    """SoilWheels.wheel_force, operation for operation: (touches, force x, y, z N, torque x, y, z
    N m) on wheel ``i`` whose centre is at (cx, cy, cz) with unit axle (ax, ay, az), moving at
    (vx, vy, vz) and turning at (wx, wy, wz) (world frame); updates its slip state and its entry of
    the last step (sinkage, slip, penetration) with its in-contact flag."""
    n = st[st.shape[0] - N_I + I_N]
    base = 8 * n
    rows = st[3 * n + I_ROWS]
    cols = st[3 * n + I_COLS]
    cell = f[base + F_CELL]
    r = f[base + F_R]
    # SoilWheels._contact: the plane under the centre, then under the rim's lowest point
    qx = cx
    qy = cy
    ok = True
    h = ex = ey = nx = ny = nz = rx = ry = rz = 0.0
    for _ in range(2):
        ok, h, gx, gy = _surface(tab, rows, cols, cell, qx, qy)
        if not ok:
            break
        ex = qx
        ey = qy
        norm = math.sqrt(gx * gx + gy * gy + 1.0)
        nx = -gx / norm
        ny = -gy / norm
        nz = 1.0 / norm
        na = nx * ax + ny * ay + nz * az
        px = nx - na * ax
        py = ny - na * ay
        pz = nz - na * az
        pn = math.sqrt(px * px + py * py + pz * pz)
        if pn < 1e-6:
            ok = False
            break
        rx = cx - r * px / pn
        ry = cy - r * py / pn
        rz = cz - r * pz / pn
        qx = rx
        qy = ry
    delta = 0.0
    if ok:
        delta = -((rx - ex) * nx + (ry - ey) * ny + (rz - h) * nz)
    if not ok or delta <= 0.0:
        f[2 * i] = 0.0
        f[2 * i + 1] = 0.0
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    fx_ = ay * nz - az * ny
    fy_ = az * nx - ax * nz
    fz_ = ax * ny - ay * nx
    fn = math.sqrt(fx_ * fx_ + fy_ * fy_ + fz_ * fz_)
    fx_ = fx_ / fn
    fy_ = fy_ / fn
    fz_ = fz_ / fn
    lx = ny * fz_ - nz * fy_
    ly = nz * fx_ - nx * fz_
    lz = nx * fy_ - ny * fx_
    v_f = vx * fx_ + vy * fy_ + vz * fz_
    v_l = vx * lx + vy * ly + vz * lz
    v_n = vx * nx + vy * ny + vz * nz
    u_roll = r * (wx * ax + wy * ay + wz * az)
    vref = _max(abs(u_roll), abs(v_f))
    dt = f[base + F_DT]
    sx = f[base + F_SX]
    sy = f[base + F_SY]
    ux = (f[2 * i] + dt * (u_roll - v_f)) / (1.0 + dt * vref / sx)
    ux = _min(sx, _max(-sx, ux))
    uy = (f[2 * i + 1] - dt * v_l) / (1.0 + dt * vref / sy)
    lat = f[base + F_MAX_LAT]
    uy = _min(lat * sy, _max(-lat * sy, uy))
    f[2 * i] = ux
    f[2 * i + 1] = uy
    sl = ux / sx
    lam = abs(uy) / sy
    direction = 1.0 if (u_roll if abs(u_roll) >= abs(v_f) else v_f) >= 0.0 else -1.0
    s_m = direction * sl
    rows_d = st[3 * n + I_N_DELTA] + 1
    size = rows_d * st[3 * n + I_N_SLIP]
    off = rows * cols
    sink, f_n, f_x, torque = _lookup(f, st, tab, off, size, delta, s_m)
    _, _, f_x0, torque0 = _lookup(f, st, tab, off, size, delta, 0.0)
    fade = 1.0 - _min(1.0, abs(v_f) / f[base + F_FADE])
    f_x = direction * (f_x - fade * f_x0)
    torque = direction * (torque - fade * torque0)
    f_y = _lateral(f, st, tab, off + 4 * size, delta, s_m, lam)
    if uy < 0.0:
        f_y = -f_y
    f_n = _max(0.0, f_n - f[base + F_C] * v_n)
    st[i] = 1
    k = 2 * n + 3 * i
    f[k] = sink
    f[k + 1] = s_m
    f[k + 2] = delta
    return (True, f_n * nx + f_x * fx_ + f_y * lx, f_n * ny + f_x * fy_ + f_y * ly, f_n * nz + f_x * fz_ + f_y * lz,
            -torque * ax, -torque * ay, -torque * az)


#: the kernel's signature, compiled at import (or loaded from numba's cache): MuJoCo's arrays as
#: any-layout views, the state arrays contiguous
_APPLY_SIG = "void(float64[:], float64[:, :], float64[:, :], float64[:, :], float64[::1], int64[::1], float64[::1])"


@njit(_APPLY_SIG, cache=True)
def apply_soil(qvel, xmat, xipos, xfrc, f, st, tab):  # pragma: no cover - compiled
    """Write the soil's force and torque on each wheel into ``xfrc`` (``d.xfrc_applied``; every
    other row zero, the chassis row the pushed force if any), from ``d.qvel``, ``d.xmat`` and
    ``d.xipos`` after ``mj_step1``: the Python loop's ``_apply_tyres`` with ``_soil_forces``."""
    n = st[st.shape[0] - N_I + I_N]
    base = 8 * n
    chassis = st[3 * n + I_CHASSIS]
    xfrc[:, :] = 0.0
    if f[base + F_PUSHED] != 0.0:
        xfrc[chassis, 0] = f[base + F_PUSH_X]
        xfrc[chassis, 1] = f[base + F_PUSH_Y]
        xfrc[chassis, 2] = f[base + F_PUSH_Z]
    for j in range(n):  # SoilWheels.begin: forget the last step's contacts
        st[j] = 0
    v0 = qvel[0]
    v1 = qvel[1]
    v2 = qvel[2]
    wb0 = qvel[3]
    wb1 = qvel[4]
    wb2 = qvel[5]
    r = xmat[chassis]
    w0 = r[0] * wb0 + r[1] * wb1 + r[2] * wb2
    w1 = r[3] * wb0 + r[4] * wb1 + r[5] * wb2
    w2 = r[6] * wb0 + r[7] * wb1 + r[8] * wb2
    c00 = xipos[chassis, 0]
    c01 = xipos[chassis, 1]
    c02 = xipos[chassis, 2]
    for i in range(n):
        body = st[n + i]
        c0 = xipos[body, 0]
        c1 = xipos[body, 1]
        c2 = xipos[body, 2]
        rx = c0 - c00
        ry = c1 - c01
        rz = c2 - c02
        lx = v0 + w1 * rz - w2 * ry
        ly = v1 + w2 * rx - w0 * rz
        lz = v2 + w0 * ry - w1 * rx
        ax = 5 * n + 3 * i
        a0 = r[0] * f[ax] + r[1] * f[ax + 1] + r[2] * f[ax + 2]
        a1 = r[3] * f[ax] + r[4] * f[ax + 1] + r[5] * f[ax + 2]
        a2 = r[6] * f[ax] + r[7] * f[ax + 1] + r[8] * f[ax + 2]
        s = qvel[st[2 * n + i]]
        hit, fx, fy, fz, tx, ty, tz = wheel_force(f, st, tab, i, c0, c1, c2, a0, a1, a2, lx, ly, lz,
                                                  w0 + a0 * s, w1 + a1 * s, w2 + a2 * s)
        if hit:
            xfrc[body, 0] = fx
            xfrc[body, 1] = fy
            xfrc[body, 2] = fz
            xfrc[body, 3] = tx
            xfrc[body, 4] = ty
            xfrc[body, 5] = tz


def _entry(kernel):
    """``kernel``'s compiled entry point for its one signature, without numba's per-call type
    dispatch (as offroadbench.sim.engines.mujoco._tyres_c does; :func:`check_types` once per world);
    the dispatcher where numba keeps its compiled overloads elsewhere."""
    try:
        (result,) = kernel.overloads.values()
        return result.entry_point
    except (AttributeError, ValueError):
        return kernel


#: :func:`apply_soil` without numba's per-call type dispatch
APPLY = _entry(apply_soil)


def check_types(qvel, xmat, xipos, xfrc) -> None:
    """Call the kernel once through numba's dispatcher with a world's arrays (``d.qvel``,
    ``d.xmat``, ``d.xipos``, ``d.xfrc_applied``) on a throw-away state with no wheel, which raises
    TypeError if their types are not the compiled signature's (another MuJoCo version), before
    :data:`APPLY` is used without that check."""
    f = np.zeros(N_F)
    st = np.zeros(N_I, dtype=np.int64)
    apply_soil(qvel, xmat, xipos, np.zeros_like(xfrc), f, st, np.zeros(1))
