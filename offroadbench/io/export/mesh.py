"""Wavefront OBJ: ``NAME.obj``, a triangle mesh in metres, z up, whose vertices are the samples.

Vertex ``v x y z`` for every kept sample (x = c cell, y = r cell, z = z[r, c], written with Python's
shortest round-trip float text, so they read back exactly), row by row; two triangles per grid
cell, counter-clockwise seen from +z so normals point up. OBJ has no units or up axis: these are
metres with z up (e.g. Blender's importer: Forward Y, Up Z). ``stride`` keeps every stride-th row
and column and always the last ones, so the extent is unchanged.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import describe, fmt, grid_triangles

__all__ = ["write_obj", "read_obj"]

_CHUNK = 1 << 17  # faces per write: bounded memory on big maps


def _keep_indices(n: int, stride: int) -> np.ndarray:
    idx = np.arange(0, n, stride)
    return idx if idx[-1] == n - 1 else np.append(idx, n - 1)


def write_obj(hm: Heightmap, d: Path, name: str, meta: dict[str, Any], stride: int = 1) -> list[str]:
    if isinstance(stride, bool) or not isinstance(stride, (int, np.integer)) or stride < 1:
        raise InputError(f"obj stride must be an integer >= 1, got {stride!r}")
    rows = _keep_indices(hm.rows, int(stride))
    cols = _keep_indices(hm.cols, int(stride))
    nr, nc = len(rows), len(cols)
    xs = [fmt(v) for v in cols * hm.cell_size_m]
    ys = [fmt(v) for v in rows * hm.cell_size_m]
    sub = hm.z[np.ix_(rows, cols)]
    tri = grid_triangles(nr, nc) + 1  # OBJ indices start at 1
    n_tri = len(tri)
    with (d / f"{name}.obj").open("w") as fh:
        fh.write(
            f"# {describe(hm, name, meta)}\n"
            f"# stride {stride} -> {nr}x{nc} vertices, {n_tri} triangles; vertex (row r, col c) = (c * cell, r * cell, z[r, c]), rows in order\n"
            f"o {name}\n"
        )
        for i in range(nr):
            y = ys[i]
            fh.write("".join(f"v {xs[j]} {y} {fmt(z)}\n" for j, z in enumerate(sub[i].tolist())))
        for k in range(0, n_tri, _CHUNK):
            fh.write("".join(f"f {p} {q} {s}\n" for p, q, s in tri[k : k + _CHUNK].tolist()))
    return [f"OBJ mesh: {nr * nc} vertices, {n_tri} triangles (stride {stride})"]


def read_obj(d: Path, name: str) -> Heightmap:
    """The vertex grid of ``NAME.obj`` (as written: rows of equal y, x increasing) as a Heightmap."""
    path = d / f"{name}.obj"
    verts = []
    with path.open() as fh:
        for line in fh:
            if line.startswith("v "):
                verts.append([float(t) for t in line.split()[1:4]])
    v = np.array(verts)
    if v.size == 0:
        raise InputError(f"{path}: no vertices")
    ncol = int(np.count_nonzero(v[:, 1] == v[0, 1]))
    if ncol < 2 or len(v) % ncol:
        raise InputError(f"{path}: vertices are not a regular grid")
    grid = v.reshape(-1, ncol, 3)
    cell = grid[0, 1, 0] - grid[0, 0, 0]
    return Heightmap(grid[:, :, 2], cell)


EXPORTERS.register(
    "obj",
    Exporter(
        name="obj",
        summary="Wavefront OBJ triangle mesh NAME.obj in metres, z up; vertices are the samples (--stride N decimates)",
        reader="any mesh tool (Blender, trimesh, Isaac Sim's mesh importer)",
        write=write_obj,
        read=read_obj,
        precision_m=lambda hm: 0.0,
        options=("stride",),
    ),
)
