"""The ``coulomb`` tyre law as Warp kernels over every world's wheels, run between MuJoCo Warp's
``step1`` and ``step2``: the device form of offroadbench.sim.engines.mujoco._tyres_c (whose
arithmetic it follows operation by operation: CoulombBristles.wheel_force, the Coulomb-bristle
friction of Dahl 1968, with the bristle's stiffness and damping of
offroadbench.sim.tyre_laws.coulomb.bristle_constants).

- :func:`clear_sums` then :func:`read_contacts` (after ``step2``): each wheel's terrain contacts of
  the step just taken summed into its accumulator (normal force, force-weighted point and
  normal), its normal load and the world's deepest wheel penetration (a contact whose frame has no
  normal, which MuJoCo Warp's height-field collision gives now and then at zero depth, is left
  out: its normal sum would be zero and the law's normal undefined); :func:`release_untouched`
  drops the bristle of a wheel with no loaded contact.
- :func:`drop_false_contacts` (between MuJoCo Warp's collision and its constraint rows,
  offroadbench.sim.engines.mujoco_warp.batch.WarpBatch.step1): terrain contacts that cannot be
  the height field's (MuJoCo Warp 4.0's float32 GJK/EPA gives some) taken out of the solver.
- :func:`apply_tyres` (after ``step1``): each touched wheel's friction force from those sums and
  the current velocities, with its moment about the wheel's centre of mass, into
  ``xfrc_applied``; the chassis row gets the pushed force (the vehicle check's drawbar rig).

Precision: MuJoCo Warp's state is float32; the tyre state (sums, bristles, loads) and all the
law's arithmetic are float64, the float32 inputs widened on reading, the forces narrowed on writing.

Order of the sums: :func:`read_contacts` adds each contact into its wheel's sums with atomic adds
in the order of the contact array. On Warp's CPU device a kernel's threads run one after another
in that order and MuJoCo Warp's collision kernels fill the contact array in a fixed order too, so
the sums, and a batch's results, are the same bits run after run. On a GPU neither order is
fixed: results there are reproducible only to float rounding (the contacts would have to be sorted
per wheel first; not done).
"""

from __future__ import annotations

import warp as wp

__all__ = ["ABOVE_TOLERANCE_M", "DOWN_TOLERANCE", "apply_tyres", "clear_sums", "drop_false_contacts", "read_contacts",
           "release_untouched", "reset_worlds", "rotate"]

# per (world, wheel) float64 state columns: the sums (0..6), the bristle (7..9), the load (10)
ACC, BRISTLE, LOAD, NCOL = 0, 7, 10, 11

DOWN_TOLERANCE = 0.01
"""A terrain contact whose unit normal (from the terrain to the other geom) has a vertical component
below ``-DOWN_TOLERANCE`` points into the ground: not a height field's contact."""
ABOVE_TOLERANCE_M = 0.01
"""A terrain contact whose terrain-side witness point lies more than this above every height sample
around it (m) is not on the terrain: not a height field's contact."""

_CONSTRAINT = 1  # mujoco_warp's ContactType.CONSTRAINT bit


@wp.kernel
def drop_false_contacts(nacon: wp.array(dtype=wp.int32), worldid: wp.array(dtype=wp.int32),
                        geom: wp.array(dtype=wp.vec2i), dist: wp.array(dtype=wp.float32),
                        pos: wp.array(dtype=wp.vec3), frame: wp.array(dtype=wp.mat33),
                        ctype: wp.array(dtype=wp.int32), terrain: wp.int32,
                        geom_xpos: wp.array2d(dtype=wp.vec3), geom_dataid: wp.array2d(dtype=wp.int32),
                        hfield_adr: wp.array(dtype=wp.int32), hfield_nrow: wp.array(dtype=wp.int32),
                        hfield_ncol: wp.array(dtype=wp.int32), hfield_size: wp.array(dtype=wp.vec4),
                        hfield_data: wp.array(dtype=wp.float32), dropped: wp.array(dtype=wp.int32)):
    """Take out of the constraint solver (clear ``ContactType.CONSTRAINT``) every terrain contact
    that cannot be one of the height field's, and count it in ``dropped[world]``; run between MuJoCo
    Warp's collision and its constraint rows. A height field is the tops of prisms that reach down
    to its base, and a contact's witness point on it lies on a prism's top or side, so for a body
    above the base (MuJoCo's own ``mjc_ConvexHField`` never gives otherwise):

    - its normal, from the terrain to the other geom, points up or sideways, never down (z below
      ``-DOWN_TOLERANCE``);
    - its terrain-side witness point, ``pos - n dist / 2`` (MuJoCo Warp's ``pos`` is the midpoint
      of the two witness points, ``n`` from the terrain), is no higher than the highest of the 4 x 4
      height samples around it, give or take ``ABOVE_TOLERANCE_M``.

    MuJoCo Warp 4.0's prism-by-prism GJK/EPA (float32, ``collision_convex.ccd_hfield_kernel``) now
    and then breaks both: a contact along a coordinate axis whose depth is the vertical distance
    between a prism's top sample and the far face of the geom (0.23 m under the chassis box with
    normal (0, 0, -1), 0.24 m under a wheel with normal (0, 0, 1), where MuJoCo finds at most 7 mm
    or no contact): single contacts that launched the engines-warp trials that tipped
    (docs/mujoco-warp.md). The terrain geom is not rotated (MuJoCoWorld's MJCF). Grid: the contact
    array."""
    k = wp.tid()
    if k >= nacon[0]:
        return
    g = geom[k]
    f = frame[k]
    n = wp.vec3(f[0, 0], f[0, 1], f[0, 2])
    if g[1] == terrain:
        n = -n
    elif g[0] != terrain:
        return
    w = worldid[k]
    false = n[2] < -wp.float32(DOWN_TOLERANCE)
    if not false:
        hf = geom_dataid[w % geom_dataid.shape[0], terrain]
        size = hfield_size[hf]
        nrow = hfield_nrow[hf]
        ncol = hfield_ncol[hf]
        p = pos[k] - n * (dist[k] * wp.float32(0.5)) - geom_xpos[w, terrain]  # the witness, field frame
        c = int(wp.floor((p[0] + size[0]) * float(ncol - 1) / (wp.float32(2.0) * size[0])))
        r = int(wp.floor((p[1] + size[1]) * float(nrow - 1) / (wp.float32(2.0) * size[1])))
        top = float(-1.0e30)
        for i in range(r - 1, r + 3):
            for j in range(c - 1, c + 3):
                if i >= 0 and i < nrow and j >= 0 and j < ncol:
                    top = wp.max(top, hfield_data[hfield_adr[hf] + i * ncol + j] * size[2])
        false = top > float(-1.0e30) and p[2] > top + wp.float32(ABOVE_TOLERANCE_M)
    if false:
        ctype[k] = ctype[k] - (ctype[k] & _CONSTRAINT)
        wp.atomic_add(dropped, w, 1)


@wp.kernel
def reset_worlds(mask: wp.array(dtype=wp.int32), state: wp.array3d(dtype=wp.float64),
                 touch: wp.array2d(dtype=wp.int32), held: wp.array2d(dtype=wp.int32),
                 pen: wp.array(dtype=wp.float64)):
    """Forget the tyre state of the worlds whose ``mask`` is set (a spawn). Grid: (world, wheel)."""
    w, i = wp.tid()
    if mask[w] == 0:
        return
    for j in range(NCOL):
        state[w, i, j] = wp.float64(0.0)
    touch[w, i] = 0
    held[w, i] = 0
    pen[w] = wp.float64(0.0)


@wp.kernel
def clear_sums(state: wp.array3d(dtype=wp.float64), touch: wp.array2d(dtype=wp.int32),
               pen: wp.array(dtype=wp.float64)):
    """Zero the contact sums, loads, touch flags and penetration before :func:`read_contacts`
    (the bristles stay). Grid: (world, wheel)."""
    w, i = wp.tid()
    for j in range(7):
        state[w, i, ACC + j] = wp.float64(0.0)
    state[w, i, LOAD] = wp.float64(0.0)
    touch[w, i] = 0
    if i == 0:
        pen[w] = wp.float64(0.0)


@wp.kernel
def read_contacts(nacon: wp.array(dtype=wp.int32), worldid: wp.array(dtype=wp.int32),
                  geom: wp.array(dtype=wp.vec2i), dist: wp.array(dtype=wp.float32),
                  pos: wp.array(dtype=wp.vec3), frame: wp.array(dtype=wp.mat33),
                  ctype: wp.array(dtype=wp.int32),
                  efc_address: wp.array2d(dtype=wp.int32), efc_force: wp.array2d(dtype=wp.float32),
                  terrain: wp.int32, geom_slot: wp.array(dtype=wp.int32),
                  state: wp.array3d(dtype=wp.float64), touch: wp.array2d(dtype=wp.int32),
                  pen: wp.array(dtype=wp.float64)):
    """Add contact ``tid`` (if it is a wheel's terrain contact with a positive normal force) into
    its wheel's sums: the Python loop's ``MuJoCoTyres._read_contacts``. A contact taken out of the
    solver (:func:`drop_false_contacts`) is no contact: not in the sums, nor in the penetration.
    Grid: the contact array."""
    k = wp.tid()
    if k >= nacon[0]:
        return
    if (ctype[k] & _CONSTRAINT) == 0:
        return
    g = geom[k]
    slot = int(-1)
    sign = wp.float64(1.0)
    if g[0] == terrain:
        slot = geom_slot[g[1]]
    elif g[1] == terrain:
        slot = geom_slot[g[0]]
        sign = wp.float64(-1.0)
    if slot < 0:
        return
    w = worldid[k]
    depth = -wp.float64(dist[k])
    wp.atomic_max(pen, w, depth)
    adr = efc_address[k, 0]
    if adr < 0:
        return
    fn = wp.float64(efc_force[w, adr])
    if fn <= wp.float64(0.0):
        return
    f = frame[k]
    if f[0, 0] * f[0, 0] + f[0, 1] * f[0, 1] + f[0, 2] * f[0, 2] < 0.25:
        return  # no normal (MuJoCo Warp's height-field collision gives some at zero depth): not a tyre contact
    p = pos[k]
    fs = fn * sign
    wp.atomic_add(state, w, slot, LOAD, fn)
    wp.atomic_add(state, w, slot, ACC, fn)
    wp.atomic_add(state, w, slot, ACC + 1, fn * wp.float64(p[0]))
    wp.atomic_add(state, w, slot, ACC + 2, fn * wp.float64(p[1]))
    wp.atomic_add(state, w, slot, ACC + 3, fn * wp.float64(p[2]))
    wp.atomic_add(state, w, slot, ACC + 4, fs * wp.float64(f[0, 0]))
    wp.atomic_add(state, w, slot, ACC + 5, fs * wp.float64(f[0, 1]))
    wp.atomic_add(state, w, slot, ACC + 6, fs * wp.float64(f[0, 2]))
    touch[w, slot] = 1


@wp.kernel
def release_untouched(touch: wp.array2d(dtype=wp.int32), held: wp.array2d(dtype=wp.int32)):
    """A wheel with no loaded terrain contact in the last step lets its bristle go. Grid: (world, wheel)."""
    w, i = wp.tid()
    if touch[w, i] == 0:
        held[w, i] = 0


@wp.func
def rotate(r: wp.mat33, a: wp.vec3d) -> wp.vec3d:
    """``r a`` with the float32 matrix widened, summed in the compiled loops' order (_tyres_c, _soil_c;
    the soil kernels use it too)."""
    return wp.vec3d(wp.float64(r[0, 0]) * a[0] + wp.float64(r[0, 1]) * a[1] + wp.float64(r[0, 2]) * a[2],
                    wp.float64(r[1, 0]) * a[0] + wp.float64(r[1, 1]) * a[1] + wp.float64(r[1, 2]) * a[2],
                    wp.float64(r[2, 0]) * a[0] + wp.float64(r[2, 1]) * a[1] + wp.float64(r[2, 2]) * a[2])


@wp.kernel
def apply_tyres(qvel: wp.array2d(dtype=wp.float32), xmat: wp.array2d(dtype=wp.mat33),
                xipos: wp.array2d(dtype=wp.vec3), xfrc: wp.array2d(dtype=wp.spatial_vector),
                chassis: wp.int32, wheel_body: wp.array(dtype=wp.int32), wheel_qvel: wp.array(dtype=wp.int32),
                wheel_axis: wp.array(dtype=wp.vec3d), consts: wp.array(dtype=wp.float64),
                push: wp.array(dtype=wp.vec3), state: wp.array3d(dtype=wp.float64),
                touch: wp.array2d(dtype=wp.int32), held: wp.array2d(dtype=wp.int32)):
    """Wheel ``i`` of world ``w``: its tyre force (zero if untouched) and moment about its centre of
    mass into ``xfrc``; wheel 0 also writes the chassis row (the pushed force). ``consts``: (mu,
    bristle step s, stiffness N/m, damping N s/m). _tyres_c.apply_tyres and wheel_force, operation
    for operation. Grid: (world, wheel)."""
    w, i = wp.tid()
    zero = wp.spatial_vector(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if i == 0:
        pf = push[w]
        xfrc[w, chassis] = wp.spatial_vector(pf[0], pf[1], pf[2], 0.0, 0.0, 0.0)
    body = wheel_body[i]
    if touch[w, i] == 0:
        xfrc[w, body] = zero
        return
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
    s = wp.float64(qvel[w, wheel_qvel[i]])
    wx = om[0] + a[0] * s
    wy = om[1] + a[1] * s
    wz = om[2] + a[2] * s
    # CoulombBristles.wheel_force
    fn = state[w, i, ACC]
    px = state[w, i, ACC + 1] / fn
    py = state[w, i, ACC + 2] / fn
    pz = state[w, i, ACC + 3] / fn
    snx = state[w, i, ACC + 4]
    sny = state[w, i, ACC + 5]
    snz = state[w, i, ACC + 6]
    norm = wp.sqrt(snx * snx + sny * sny + snz * snz)
    nx = snx / norm
    ny = sny / norm
    nz = snz / norm
    qx = px - cx
    qy = py - cy
    qz = pz - cz
    ux = vx + wy * qz - wz * qy
    uy = vy + wz * qx - wx * qz
    uz = vz + wx * qy - wy * qx
    un = ux * nx + uy * ny + uz * nz
    sx = ux - un * nx
    sy = uy - un * ny
    sz = uz - un * nz
    dx = wp.float64(0.0)
    dy = wp.float64(0.0)
    dz = wp.float64(0.0)
    if held[w, i] != 0:
        dx = state[w, i, BRISTLE]
        dy = state[w, i, BRISTLE + 1]
        dz = state[w, i, BRISTLE + 2]
        dn = dx * nx + dy * ny + dz * nz
        dx = dx - dn * nx
        dy = dy - dn * ny
        dz = dz - dn * nz
    dt = consts[1]
    k = consts[2]
    cdamp = consts[3]
    dx = dx + sx * dt
    dy = dy + sy * dt
    dz = dz + sz * dt
    fx = -(k * dx + cdamp * sx)
    fy = -(k * dy + cdamp * sy)
    fz = -(k * dz + cdamp * sz)
    fm = wp.sqrt(fx * fx + fy * fy + fz * fz)
    limit = consts[0] * fn
    if fm > limit:
        sc = limit / fm
        fx = fx * sc
        fy = fy * sc
        fz = fz * sc
        dx = -fx / k
        dy = -fy / k
        dz = -fz / k
    state[w, i, BRISTLE] = dx
    state[w, i, BRISTLE + 1] = dy
    state[w, i, BRISTLE + 2] = dz
    held[w, i] = 1
    ox = px - cx
    oy = py - cy
    oz = pz - cz
    xfrc[w, body] = wp.spatial_vector(wp.float32(fx), wp.float32(fy), wp.float32(fz),
                                      wp.float32(oy * fz - oz * fy), wp.float32(oz * fx - ox * fz),
                                      wp.float32(ox * fy - oy * fx))
