"""The ``coulomb`` tyre loop of the MuJoCo world compiled with numba: the same forces as the Python
loop, outside the interpreter.

What it computes
----------------
Exactly what offroadbench.sim.engines.mujoco.world does in Python with offroadbench.sim.tyre_laws.coulomb.
CoulombBristles at each MuJoCo step:

- :func:`read_contacts` (after ``mj_step2``): each wheel's terrain contacts of the step just taken,
  summed into the bristles' accumulator (normal force, force-weighted point and normal), the wheels'
  normal loads and the deepest wheel penetration;
- :func:`apply_tyres` (after ``mj_step1``): each touched wheel's Coulomb-bristle friction force
  (Dahl 1968; the law of CoulombBristles.wheel_force) from those sums and the current velocities,
  written with its moment about the wheel's centre of mass into ``xfrc_applied``.

The arithmetic is the Python loop's, operation by operation and in the same order, on IEEE float64
scalars; numba compiles without ``fastmath``, so LLVM neither reassociates nor fuses a multiply and
an add into an FMA, and the only library call is ``sqrt`` (correctly rounded by IEEE 754). The
forces are therefore those of the Python loop to the last bit on any x86-64 CPU, whatever SIMD
it has (tests/sim/test_tyres_compiled.py checks random contact states and a drive against the
Python loop; benchmarks/RESULTS.md, 'Issue 35', records the cost).

State
-----
A loop's state lives in two flat arrays made by :func:`new_state` (no Python object is touched
inside the kernels): ``f`` (float64) holds, for ``n`` wheels, the accumulator (``7 n``), the
bristle deflections (``3 n``), the wheel loads (``n``), the wheel axes in the chassis frame
(``3 n``), then the constants and the step's scalars at ``F_*`` offsets past ``14 n``; ``i``
(int64) holds the touch and held flags (``n`` each), the wheel bodies and their spin dofs' qvel
addresses (``n`` each), then the terrain geom, the chassis body and each geom's wheel slot
(``-1``: not a wheel) at ``I_*`` offsets past ``4 n``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import carray, njit, types

from offroadbench.sim.engines.mujoco._cabi import as_pointer, call_step, int_at, pointer_at, swap_entry

__all__ = ["APPLY", "READ", "STEP", "apply_tyres", "step_trial", "check_types", "loads", "new_state", "penetration", "read_contacts", "reset_state",
           "wheel_force"]

# offsets past 14 n in the float state
F_MU, F_DT, F_K, F_C, F_PEN, F_PUSH_X, F_PUSH_Y, F_PUSH_Z, F_PUSHED = range(9)
N_F = 9
# offsets past 4 n in the int state
I_TERRAIN, I_CHASSIS, I_GEOM_SLOT = range(3)


def new_state(n_wheels: int, mu: float, dt_s: float, stiffness_n_m: float, damping_n_s_m: float,
              wheel_bodies, wheel_qvel, wheel_axes, terrain_geom: int, chassis_body: int,
              geom_slot) -> tuple[np.ndarray, np.ndarray]:
    """The (float, int) state arrays of one loop: ``n_wheels`` wheels, tyre-terrain friction
    coefficient ``mu``, bristle integration step ``dt_s`` (s), bristle stiffness (N/m) and damping
    (N s/m); each wheel's body id, spin dof's qvel address and spin axis in the chassis frame; the
    terrain geom, the chassis body, and each geom's wheel slot (``-1``: not a wheel)."""
    n = n_wheels
    f = np.zeros(14 * n + N_F)
    f[11 * n:14 * n] = np.asarray(wheel_axes, dtype=np.float64).ravel()
    base = 14 * n
    f[base + F_MU], f[base + F_DT], f[base + F_K], f[base + F_C] = mu, dt_s, stiffness_n_m, damping_n_s_m
    i = np.zeros(4 * n + 2 + len(geom_slot), dtype=np.int64)
    i[2 * n:3 * n] = wheel_bodies
    i[3 * n:4 * n] = wheel_qvel
    i[4 * n + I_TERRAIN] = terrain_geom
    i[4 * n + I_CHASSIS] = chassis_body
    i[4 * n + I_GEOM_SLOT:] = geom_slot
    return f, i


def reset_state(f: np.ndarray, i: np.ndarray, n: int) -> None:
    """Forget the bristles, the contact sums, the loads and the penetration (before a spawn)."""
    f[0:11 * n] = 0.0
    f[14 * n + F_PEN] = 0.0
    i[0:2 * n] = 0


def loads(f: np.ndarray, n: int) -> tuple[float, ...]:
    """Each wheel's summed normal force from the terrain in the last step, N."""
    return tuple(f[10 * n:11 * n].tolist())


def penetration(f: np.ndarray, n: int) -> float:
    """Deepest wheel penetration of the last step, m."""
    return float(f[14 * n + F_PEN])


#: the kernels' signatures, compiled at import (or loaded from numba's cache): MuJoCo's arrays as
#: any-layout views (``d.contact``'s fields are strided), the state arrays contiguous
_READ_SIG = "void(int32[:, :], float64[:], float64[:, :], float64[:, :], int32[:], float64[:], float64[::1], int64[::1])"
_APPLY_SIG = "void(float64[:], float64[:, :], float64[:, :], float64[:, :], float64[::1], int64[::1])"


@njit(_READ_SIG, cache=True)
def read_contacts(geom, dist, pos, frame, efc_address, efc_force, f, st):  # pragma: no cover - compiled
    """Sum the wheels' terrain contacts of the step just taken (``d.contact`` fields of its
    ``ncon`` contacts and ``d.efc_force``) into the state: the Python loop's ``_read_contacts``."""
    n = (f.shape[0] - N_F) // 14
    base_i = 4 * n
    terrain = st[base_i + I_TERRAIN]
    for j in range(11 * n):
        if j < 7 * n or j >= 10 * n:  # the sums and the loads; the bristles (7n..10n) stay
            f[j] = 0.0
    for j in range(n):
        st[j] = 0
    deepest = 0.0
    for k in range(dist.shape[0]):
        g1 = geom[k, 0]
        g2 = geom[k, 1]
        if g1 == terrain:
            slot = st[base_i + I_GEOM_SLOT + g2]
            sign = 1.0
        elif g2 == terrain:
            slot = st[base_i + I_GEOM_SLOT + g1]
            sign = -1.0
        else:
            continue
        if slot < 0:
            continue
        if -dist[k] > deepest:
            deepest = -dist[k]
        adr = efc_address[k]
        if adr < 0:
            continue
        fn = efc_force[adr]
        if fn <= 0.0:
            continue
        f[10 * n + slot] += fn
        b = 7 * slot
        st[slot] = 1
        f[b] += fn
        f[b + 1] += fn * pos[k, 0]
        f[b + 2] += fn * pos[k, 1]
        f[b + 3] += fn * pos[k, 2]
        fs = fn * sign
        f[b + 4] += fs * frame[k, 0]
        f[b + 5] += fs * frame[k, 1]
        f[b + 6] += fs * frame[k, 2]
    f[14 * n + F_PEN] = deepest
    for j in range(n):  # release the bristles of the wheels not touched
        if st[j] == 0:
            st[n + j] = 0


@njit(cache=True)
def _n_wheels(f):  # pragma: no cover - compiled
    return (f.shape[0] - N_F) // 14


@njit(cache=True)
def wheel_force(f, st, i, cx, cy, cz, vx, vy, vz, wx, wy, wz):  # pragma: no cover - compiled
    """(force x, y, z in N; point x, y, z in m) of touched wheel ``i``, its centre of mass at (cx,
    cy, cz) moving at (vx, vy, vz) and turning at (wx, wy, wz) (world frame); updates its bristle.
    CoulombBristles.wheel_force, operation for operation."""
    n = _n_wheels(f)
    base = 14 * n
    b = 7 * i
    fn = f[b]
    px = f[b + 1] / fn
    py = f[b + 2] / fn
    pz = f[b + 3] / fn
    snx = f[b + 4]
    sny = f[b + 5]
    snz = f[b + 6]
    norm = math.sqrt(snx * snx + sny * sny + snz * snz)
    nx = snx / norm
    ny = sny / norm
    nz = snz / norm
    rx = px - cx
    ry = py - cy
    rz = pz - cz
    ux = vx + wy * rz - wz * ry
    uy = vy + wz * rx - wx * rz
    uz = vz + wx * ry - wy * rx
    un = ux * nx + uy * ny + uz * nz
    sx = ux - un * nx
    sy = uy - un * ny
    sz = uz - un * nz
    j = 7 * n + 3 * i
    if st[n + i] != 0:
        dx = f[j]
        dy = f[j + 1]
        dz = f[j + 2]
        dn = dx * nx + dy * ny + dz * nz
        dx = dx - dn * nx
        dy = dy - dn * ny
        dz = dz - dn * nz
    else:
        dx = 0.0
        dy = 0.0
        dz = 0.0
    dt = f[base + F_DT]
    k = f[base + F_K]
    cdamp = f[base + F_C]
    dx = dx + sx * dt
    dy = dy + sy * dt
    dz = dz + sz * dt
    fx = -(k * dx + cdamp * sx)
    fy = -(k * dy + cdamp * sy)
    fz = -(k * dz + cdamp * sz)
    fm = math.sqrt(fx * fx + fy * fy + fz * fz)
    limit = f[base + F_MU] * fn
    if fm > limit:
        s = limit / fm
        fx = fx * s
        fy = fy * s
        fz = fz * s
        dx = -fx / k
        dy = -fy / k
        dz = -fz / k
    f[j] = dx
    f[j + 1] = dy
    f[j + 2] = dz
    st[n + i] = 1
    return fx, fy, fz, px, py, pz


@njit(_APPLY_SIG, cache=True)
def apply_tyres(qvel, xmat, xipos, xfrc, f, st):  # pragma: no cover - compiled
    """Write the touched wheels' tyre forces, and moments about their centres of mass, into
    ``xfrc`` (``d.xfrc_applied``; every other row zero, the chassis row the pushed force if any),
    from ``d.qvel``, ``d.xmat`` and ``d.xipos`` after ``mj_step1``: the Python loop's ``_apply_tyres``."""
    n = _n_wheels(f)
    base = 14 * n
    chassis = st[4 * n + I_CHASSIS]
    xfrc[:, :] = 0.0
    if f[base + F_PUSHED] != 0.0:
        xfrc[chassis, 0] = f[base + F_PUSH_X]
        xfrc[chassis, 1] = f[base + F_PUSH_Y]
        xfrc[chassis, 2] = f[base + F_PUSH_Z]
    touched = False
    for j in range(n):
        if st[j] != 0:
            touched = True
    if not touched:
        return
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
        if st[i] == 0:
            continue
        body = st[2 * n + i]
        c0 = xipos[body, 0]
        c1 = xipos[body, 1]
        c2 = xipos[body, 2]
        rx = c0 - c00
        ry = c1 - c01
        rz = c2 - c02
        lx = v0 + w1 * rz - w2 * ry
        ly = v1 + w2 * rx - w0 * rz
        lz = v2 + w0 * ry - w1 * rx
        ax = 11 * n + 3 * i
        a0 = r[0] * f[ax] + r[1] * f[ax + 1] + r[2] * f[ax + 2]
        a1 = r[3] * f[ax] + r[4] * f[ax + 1] + r[5] * f[ax + 2]
        a2 = r[6] * f[ax] + r[7] * f[ax + 1] + r[8] * f[ax + 2]
        s = qvel[st[3 * n + i]]
        fx, fy, fz, px, py, pz = wheel_force(f, st, i, c0, c1, c2, lx, ly, lz, w0 + a0 * s, w1 + a1 * s, w2 + a2 * s)
        ox = px - c0
        oy = py - c1
        oz = pz - c2
        xfrc[body, 0] = fx
        xfrc[body, 1] = fy
        xfrc[body, 2] = fz
        xfrc[body, 3] = oy * fz - oz * fy
        xfrc[body, 4] = oz * fx - ox * fz
        xfrc[body, 5] = ox * fy - oy * fx


def _entry(kernel):
    """``kernel``'s compiled entry point for its one signature: the call skips numba's type dispatch
    (about 0.5 us of 1 per call; the arguments are unboxed as the signature says, so the caller
    passes exactly those types: :func:`check_types` once per world). Falls back to the dispatcher
    where numba keeps its compiled overloads elsewhere."""
    try:
        (result,) = kernel.overloads.values()
        return result.entry_point
    except (AttributeError, ValueError):
        return kernel


# indices into the layout tuple of :func:`step_trial` (offroadbench.sim.engines.mujoco._layout.StepLayout)
S_NCON, S_NEFC, S_CONTACT, S_EFC_FORCE, S_SIZE, S_DIST, S_POS, S_FRAME, S_GEOM, S_EFC_ADDRESS = range(10)
_STEP_SIG = types.void(types.int64, types.int64, types.UniTuple(types.int64, 3), types.UniTuple(types.int64, 10),
                       types.UniTuple(types.int64, 4), types.float64[:], types.float64[:, :], types.float64[:, :], types.float64[:, :],
                       types.float64[::1], types.int64[::1], types.int64, types.boolean)


@njit(_STEP_SIG, cache=True)
def step_trial(m, d, fns, lay, table, qvel, xmat, xipos, xfrc, f, st, substeps, each):  # pragma: no cover - compiled
    """One trial step of the MuJoCo world with the compiled tyre loop, wholly outside the interpreter:
    ``substeps`` times MuJoCo's ``mj_step1``, :func:`apply_tyres`, ``mj_step2`` and :func:`read_contacts`
    (``each``), or (``each`` False) that once and then plain ``mj_step`` with the forces held, the
    contacts read after the last. ``m``, ``d``: the mjModel and mjData addresses; ``fns``: the
    addresses of ``mj_step``, ``mj_step1``, ``mj_step2``; ``lay``: where the contacts are
    (offroadbench.sim.engines.mujoco._layout.StepLayout.as_tuple); ``table``: (entry, function) x 2,
    the world's height-field collision functions, written into MuJoCo's collision table for these
    calls and the entries' old values put back after them (a function 0: the entry left alone;
    offroadbench.sim.engines.mujoco._hfield_c.HFieldCollision.entries); the arrays as for the two
    kernels. The same calls in the same order as MuJoCoTyres._step_compiled, so the same bits."""
    old0 = swap_entry(table[0], table[1])
    old1 = swap_entry(table[2], table[3])
    last = substeps - 1
    for k in range(substeps):
        if each or k == 0:
            call_step(fns[1], m, d)
            apply_tyres(qvel, xmat, xipos, xfrc, f, st)
            call_step(fns[2], m, d)
        else:
            call_step(fns[0], m, d)
        if each or k == last:
            ncon = int_at(d, lay[S_NCON])
            nefc = int_at(d, lay[S_NEFC])
            buf = as_pointer(pointer_at(d, lay[S_CONTACT]))
            size = lay[S_SIZE]
            fv = carray(buf, (ncon, size // 8), np.float64)
            iv = carray(buf, (ncon, size // 4), np.int32)
            efc = carray(as_pointer(pointer_at(d, lay[S_EFC_FORCE])), (nefc,), np.float64)
            od, op, of = lay[S_DIST] // 8, lay[S_POS] // 8, lay[S_FRAME] // 8
            og, oe = lay[S_GEOM] // 4, lay[S_EFC_ADDRESS] // 4
            read_contacts(iv[:, og:og + 2], fv[:, od], fv[:, op:op + 3], fv[:, of:of + 9], iv[:, oe], efc, f, st)
    if table[1] != 0:
        swap_entry(table[0], old0)
    if table[3] != 0:
        swap_entry(table[2], old1)


#: :func:`read_contacts`, :func:`apply_tyres` and :func:`step_trial` without numba's per-call type dispatch
READ = _entry(read_contacts)
APPLY = _entry(apply_tyres)
STEP = _entry(step_trial)


def check_types(qvel, xmat, xipos, xfrc, contact, efc_force) -> None:
    """Call both kernels once through numba's dispatcher with a world's arrays (``d.qvel``,
    ``d.xmat``, ``d.xipos``, ``d.xfrc_applied``, ``d.contact``, ``d.efc_force``) on a throw-away state,
    which raises TypeError if their types are not the compiled signatures' (another MuJoCo version),
    before :data:`READ` and :data:`APPLY` are used without that check."""
    f, st = new_state(0, 0.0, 0.0, 0.0, 0.0, [], [], np.zeros((0, 3)), -1, 0, [-1] * xfrc.shape[0])
    scratch = np.zeros_like(xfrc)
    apply_tyres(qvel, xmat, xipos, scratch, f, st)
    c = contact
    read_contacts(c.geom, c.dist, c.pos, c.frame, c.efc_address, efc_force, f, st)
