"""The PyBullet world's terrain: the map's heightfield tiles built in a client, and vertical rays on them.

:func:`build_terrain` is what offroadbench.sim.engines.pybullet.world.World builds once per World
(its ``_build_terrain``); :func:`heightfield_ray_height` answers its ``ray_height``. Facts the build relies on
(measured, shared/DESIGN.md):

- Bullet centres a heightfield on the middle of its x/y grid and at (min + max) / 2 in z, so
  a heightfield of samples (r0..r1, c0..c1) is placed at ((c0 + c1)/2 * cell, (r0 + r1)/2 * cell,
  (z_min + z_max)/2) to put sample (r, c) at (c * cell, r * cell, z[r, c]). ``numHeightfieldRows`` is the number of x samples (cols) and
  the data is ``z.ravel()`` (index c + r * cols).
- ``createMultiBody`` gets a tiny dummy visual shape; without one PyBullet builds a render mesh
  (seconds and hundreds of MB per 1009^2 terrain).
- Heightfields are never removed and recreated (that leaks ~600 MB per terrain): one World, one
  terrain; closing the World disconnects the client, which frees everything.
- Building a heightfield from data walks every triangle into a render mesh that the shape keeps
  (about 2-3 s and 600 MB for 1009^2, even in DIRECT mode). The walk skips triangles outside the
  shape's height range, so the shape is first created empty with the map's height range
  (:func:`empty_heights`: almost no walk), and the heights are then written in place with
  ``replaceHeightfieldIndex``, whose walk is freed at once (about 1 s, nothing kept). Replacing
  never updates a shape's height range, so the range is set at creation. The shape, and so
  every result, is bit for bit the one built from the data directly.
- The replace's transient is ~700 MiB for one 1009^2 heightfield whatever the arguments
  (pybullet 3.2.7, PhysicsServerCommandProcessor.cpp): its walk visits every triangle
  overlapping the shape's own AABB (identity transform, fixed height range and scale, margin 0
  that ``changeDynamics`` can only raise), and the heights are written before the walk, so the
  final write visits all 2.03 M triangles. Per triangle it appends 3 ``GLInstanceVertex`` (36 B)
  and 3 int indices to arrays that double in capacity, and Bullet's allocator zero-fills every
  allocation (capacity, not size, is resident); then one position and one normal ``btVector3``
  (32 B, double precision) per vertex: 288 + 32 + 186 + 186 MiB, plus an 8 MiB copy of the
  heights. :func:`lean_heap` keeps glibc's heap from adding its freed blocks to that peak.
- So the map is built as tiles (``SimConfig.heightfield_tile_cells``, :func:`tile_spans`), one
  heightfield body each, written one after the other: the transient is one tile's (~45 MiB for
  the default 256-cell tiles of a 1009^2 map: peak RSS of a build 0.24 GB instead of 0.88 GB, in
  the same time). Neighbouring tiles share their edge samples and all tiles share the map's height
  range, so every vertex is where the single heightfield puts it (to the last bit in z, to
  rounding of the tile centre in x and y) and vertical rays hit the same heights. What changes is
  the contact bookkeeping on a seam: a wheel there touches two shapes, so Bullet keeps two
  contact manifolds (up to 4 points each) where one heightfield gives one. The forces are those
  of the same triangles, but the solver sees other point sets, so trajectories differ in the
  last digits and then, on rough ground, chaotically (like any other change of rounding);
  ``heightfield_tile_cells = 0`` rebuilds the single heightfield and its results bit for bit.
- Reusing one World for another terrain (replacing its heights) was measured and rejected: the
  results then differ in the last digits from a fresh World (solver and contact state carried
  over), and it would save only ~0.2 s per terrain once the build above is cheap.
"""

from __future__ import annotations

import math

import numpy as np
from offroadbench.sim.engines.pybullet._pb import pb

from offroadbench.heightmap import Heightmap
from offroadbench.sim.config import SimConfig, tile_spans
from offroadbench.sim.engines.pybullet.heap import empty_heights, lean_heap

__all__ = ["build_terrain", "heightfield_ray_height", "heightfield_shape"]


def build_terrain(cid: int, hm: Heightmap, sim: SimConfig) -> tuple[int, ...]:
    """One static body per heightfield tile (:func:`tile_spans`) of ``hm`` in client ``cid``, all
    with the map's height range (m) and ``sim.terrain_friction``; their body ids."""
    tile = sim.heightfield_tile_cells
    rows, cols = tile_spans(hm.rows - 1, tile), tile_spans(hm.cols - 1, tile)
    dummy_visual = pb.createVisualShape(pb.GEOM_SPHERE, radius=1e-3, physicsClientId=cid)
    z_centre = (hm.z_min_m + hm.z_max_m) / 2.0
    bodies = []
    for r0, r1 in rows:
        for c0, c1 in cols:
            z = hm.z[r0 : r1 + 1, c0 : c1 + 1]
            shape = heightfield_shape(cid, hm.cell_size_m, empty_heights(z.size, hm.z_min_m, hm.z_max_m), z.shape)
            with lean_heap():
                heightfield_shape(cid, hm.cell_size_m, z.ravel(), z.shape, replace=shape)
            centre = [(c0 + c1) / 2.0 * hm.cell_size_m, (r0 + r1) / 2.0 * hm.cell_size_m, z_centre]
            body = pb.createMultiBody(0, shape, dummy_visual, basePosition=centre, physicsClientId=cid)
            pb.changeDynamics(body, -1, lateralFriction=sim.terrain_friction, physicsClientId=cid)
            lo, hi = pb.getAABB(body, physicsClientId=cid)
            # Bullet keeps the range in float32: a few ulps of the heights (2e-5 m at a DEM's 320 m)
            tol_m = max(1e-5, 8 * float(np.finfo(np.float32).eps) * max(abs(hm.z_min_m), abs(hm.z_max_m)))
            if abs(lo[2] - hm.z_min_m) > tol_m or abs(hi[2] - hm.z_max_m) > tol_m:  # pragma: no cover - a pybullet change
                raise RuntimeError(f"heightfield height range {lo[2]:.6g}..{hi[2]:.6g} m is not the map's "
                                   f"{hm.z_min_m:.6g}..{hm.z_max_m:.6g} m (pybullet {pb.getAPIVersion()})")
            bodies.append(body)
    return tuple(bodies)


def heightfield_shape(cid: int, cell_size_m: float, data: np.ndarray, shape: tuple[int, int], replace: int = -1) -> int:
    """A heightfield collision shape of ``shape`` = (rows, cols) samples ``cell_size_m`` apart from
    row-major ``data`` (heights, m) in client ``cid``; ``replace``: the shape whose heights to write."""
    return pb.createCollisionShape(
        pb.GEOM_HEIGHTFIELD,
        meshScale=[cell_size_m, cell_size_m, 1.0],
        heightfieldData=data,
        numHeightfieldRows=shape[1],
        numHeightfieldColumns=shape[0],
        replaceHeightfieldIndex=replace,
        physicsClientId=cid,
    )


def heightfield_ray_height(cid: int, hm: Heightmap, terrain: frozenset[int], x_m: float, y_m: float) -> float:
    """Height of the terrain collision surface (bodies ``terrain``) at (x, y) by a vertical ray, metres
    (NaN off the map).

    Bullet's heightfield ray test leaves out a shape's outer edge, so a ray exactly on a tile
    seam misses both tiles; such a ray is cast again 1 nm towards the map's centre."""
    for nudge_m in (0.0, 1e-9):
        x = x_m + math.copysign(nudge_m, hm.width_m / 2.0 - x_m)
        y = y_m + math.copysign(nudge_m, hm.height_m / 2.0 - y_m)
        hit = pb.rayTest([x, y, hm.z_max_m + 1.0], [x, y, hm.z_min_m - 1.0], physicsClientId=cid)[0]
        if hit[0] in terrain:
            return float(hit[3][2])
    return float("nan")
