"""MuJoCo: MJCF ``NAME.xml`` with an ``<hfield>`` read from ``NAME.hfield`` and a geom placing it.

MuJoCo spans a height field over [-radius_x, radius_x] x [-radius_y, radius_y] around its geom,
column c at x = c * 2 radius_x / (ncol - 1) - radius_x and row r at y = r * 2 radius_y / (nrow - 1)
- radius_y; the data are normalised to [0, 1] and scaled by elevation_z; base_z is the depth of a
box below the lowest point (MuJoCo XML reference, asset/hfield; engine_collision_convex.c). So the
hfield size is (half width, half height, relief, max(relief, 0.5 m)) and the geom sits at
(width / 2, height / 2, z_min): sample (r, c) lands at (c cell, r cell, z), exactly the map's
extent (computed in decimal from the cell size).

The elevation goes in MuJoCo's custom binary format, ``int32 nrow, int32 ncol, float32
data[nrow * ncol]`` row-major, copied as is (mjCHField::LoadCustom): row r is at -radius_y + r dy,
i.e. our row order, with no flip. (A PNG hfield would be flipped by MuJoCo's loader and decoded to
8 bits: 256 levels, 15 mm steps on a 3.84 m relief; the binary file keeps float32.)
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import describe, fmt_list, half_span_m

__all__ = ["MUJOCO_BASE_MIN_M", "mujoco_hfield_size", "write_mujoco", "read_mujoco"]

#: depth (m) of the box MuJoCo adds under the lowest point of a height field (hfield size[3])
MUJOCO_BASE_MIN_M = 0.5


def mujoco_hfield_size(hm: Heightmap) -> tuple[float, float, float, float]:
    """MuJoCo hfield ``size`` = (radius_x, radius_y, elevation_z, base_z) for ``hm``."""
    relief = hm.relief_m
    return (
        half_span_m(hm.cols, hm.cell_size_m),
        half_span_m(hm.rows, hm.cell_size_m),
        relief if relief > 0 else 1.0,
        max(relief, MUJOCO_BASE_MIN_M),
    )


def write_mujoco(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    rx, ry, ez, base = mujoco_hfield_size(hm)
    data = (hm.z - hm.z_min_m).astype("<f4")
    fname = f"{name}.hfield"
    with (d / fname).open("wb") as fh:
        fh.write(np.array([hm.rows, hm.cols], dtype="<i4").tobytes())
        fh.write(data.tobytes(order="C"))
    pos = (rx, ry, hm.z_min_m)
    root = ET.Element("mujoco", model=name)
    root.append(ET.Comment(" " + describe(hm, name, meta).replace("--", "- -") + " "))
    asset = ET.SubElement(root, "asset")
    ET.SubElement(
        asset, "hfield", name=name, file=fname, content_type="image/vnd.mujoco.hfield", size=fmt_list((rx, ry, ez, base))
    )
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "geom", name=f"{name}_terrain", type="hfield", hfield=name, pos=fmt_list(pos))
    ET.indent(root, space="  ")
    (d / f"{name}.xml").write_text(ET.tostring(root, encoding="unicode") + "\n")
    return [f"MuJoCo hfield size {fmt_list((rx, ry, ez, base))}, geom pos {fmt_list(pos)}"]


def read_mujoco(d: Path, name: str) -> Heightmap:
    """Heights MuJoCo builds from ``NAME.xml`` (normalised data times elevation, at the geom's pos)."""
    xml = d / f"{name}.xml"
    try:
        root = ET.parse(xml).getroot()
        hf = root.find("asset/hfield")
        geom = root.find("worldbody/geom")
        rx, ry, ez, _ = (float(v) for v in hf.get("size").split())
        pz = float(geom.get("pos").split()[2])
        raw = (d / hf.get("file")).read_bytes()
    except (OSError, ET.ParseError, AttributeError, ValueError) as exc:
        raise InputError(f"{xml}: not an offroadbench MuJoCo height field ({exc})") from None
    nrow, ncol = (int(v) for v in np.frombuffer(raw[:8], dtype="<i4"))
    data = np.frombuffer(raw[8:], dtype="<f4").reshape(nrow, ncol).astype(np.float64)
    lo, hi = data.min(), data.max()
    norm = (data - lo) / (hi - lo) if hi > lo else np.zeros_like(data)
    if not np.isclose(2 * rx / (ncol - 1), 2 * ry / (nrow - 1), rtol=1e-12):
        raise InputError(f"{xml}: cells are not square ({2 * rx / (ncol - 1)} x {2 * ry / (nrow - 1)} m)")
    return Heightmap(pz + norm * ez, 2 * rx / (ncol - 1))


EXPORTERS.register(
    "mujoco",
    Exporter(
        name="mujoco",
        summary="MJCF NAME.xml: <hfield> from NAME.hfield (float32 binary) + a geom placing it",
        reader="MuJoCo (mujoco.MjModel.from_xml_path)",
        write=write_mujoco,
        read=read_mujoco,
        # float32 data, then MuJoCo's normalisation: a few float32 roundings of the relief
        precision_m=lambda hm: 4 * float(np.finfo(np.float32).eps) * max(hm.relief_m, 1e-300) + 1e-12 * max(1.0, abs(hm.z_min_m)),
    ),
)
