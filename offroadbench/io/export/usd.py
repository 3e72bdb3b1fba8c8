"""Isaac Sim / Omniverse: a USD stage ``NAME.usd`` with the terrain as a collision mesh.

The stage has ``upAxis = "Z"`` and ``metersPerUnit = 1`` and one prim ``/World/terrain``, a
``UsdGeom.Mesh`` whose vertices are the samples (row by row, two triangles per cell,
counter-clockwise from +z as in the obj export) with ``UsdPhysics.CollisionAPI`` and
``UsdPhysics.MeshCollisionAPI`` (approximation ``none``: the triangle mesh itself, the right
collider for static terrain in PhysX) applied. Points are float32 (USD's ``point3f[]``); to keep
their precision on maps far from z = 0 they hold ``z - z_min`` and the prim carries a double
``xformOp:translate`` of (0, 0, z_min). So vertex (r, c) is at (c * cell, r * cell, z[r, c]) in
metres, within float32 rounding (relative 6e-8). The grid shape and cell size are kept in the
prim's ``customData`` (``offroadbench``) for an exact read-back. Needs usd-core
(``pip install 'offroadbench[usd]'``); Isaac Sim ships its own USD.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import describe, grid_triangles

__all__ = ["write_usd", "read_usd"]

PRIM_PATH = "/World/terrain"


def write_usd(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    from pxr import Gf, Usd, UsdGeom, UsdPhysics, Vt

    path = d / f"{name}.usd"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    stage.GetRootLayer().documentation = describe(hm, name, meta)

    xx, yy = np.meshgrid(hm.x_coords_m(), hm.y_coords_m())
    pts = np.stack([xx, yy, hm.z - hm.z_min_m], axis=-1).reshape(-1, 3).astype(np.float32)
    tri = grid_triangles(hm.rows, hm.cols)
    mesh = UsdGeom.Mesh.Define(stage, PRIM_PATH)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(tri), 3, dtype=np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(tri.ravel()))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*pts.min(axis=0).tolist()), Gf.Vec3f(*pts.max(axis=0).tolist())]))
    mesh.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(0.0, 0.0, hm.z_min_m))
    prim = mesh.GetPrim()
    UsdPhysics.CollisionAPI.Apply(prim)
    UsdPhysics.MeshCollisionAPI.Apply(prim).CreateApproximationAttr(UsdPhysics.Tokens.none)
    prim.SetCustomDataByKey("offroadbench:rows", hm.rows)
    prim.SetCustomDataByKey("offroadbench:cols", hm.cols)
    prim.SetCustomDataByKey("offroadbench:cell_size_m", hm.cell_size_m)
    stage.GetRootLayer().Save()
    return [f"USD stage {name}.usd: {PRIM_PATH} mesh, {hm.rows * hm.cols} points, {len(tri)} triangles, z up, 1 m per unit, collision mesh"]


def read_usd(d: Path, name: str) -> Heightmap:
    """World-space vertex heights of ``/World/terrain`` in ``NAME.usd`` on the grid the prim records."""
    from pxr import Usd, UsdGeom

    path = d / f"{name}.usd"
    stage = Usd.Stage.Open(str(path))
    if stage is None or not stage.GetPrimAtPath(PRIM_PATH):
        raise InputError(f"{path}: no {PRIM_PATH} prim")
    prim = stage.GetPrimAtPath(PRIM_PATH)
    if UsdGeom.GetStageUpAxis(stage) != UsdGeom.Tokens.z or UsdGeom.GetStageMetersPerUnit(stage) != 1.0:
        raise InputError(f"{path}: not z up in metres")
    rows, cols, cell = (prim.GetCustomDataByKey(f"offroadbench:{k}") for k in ("rows", "cols", "cell_size_m"))
    if None in (rows, cols, cell):
        raise InputError(f"{path}: {PRIM_PATH} has no offroadbench grid customData")
    pts = np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get(), dtype=np.float64).reshape(rows, cols, 3)
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))  # row-vector convention
    world = pts @ m[:3, :3] + m[3, :3]
    return Heightmap(world[:, :, 2], cell)


EXPORTERS.register(
    "usd",
    Exporter(
        name="usd",
        summary="USD stage NAME.usd: /World/terrain UsdGeom.Mesh (metres, z up) with UsdPhysics collision APIs",
        reader="NVIDIA Isaac Sim / Omniverse (usd-core: pxr.Usd)",
        write=write_usd,
        read=read_usd,
        precision_m=lambda hm: float(np.finfo(np.float32).eps) * max(hm.relief_m, 1e-300) + 1e-12 * max(1.0, abs(hm.z_min_m)),
        requires=("pxr",),
        extra="usd",
    ),
)
