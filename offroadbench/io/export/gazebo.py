"""Gazebo (classic and gz-sim): a model directory ``NAME/`` with model.config, model.sdf and a
square (2^n)+1 16-bit PNG heightmap.

Gazebo centres the heightmap on ``<pos>`` x, y, stretches it over ``<size>`` x, y (first to last
pixel) and maps pixel level / 65535 to pos.z + level / 65535 * size.z (gz-common
ImageHeightmap::FillHeightMap; SDFormat ``<heightmap>``: "size: the size of the heightmap in world
units", "pos: a position offset"). So size = (width, height, relief) and pos = (width / 2,
height / 2, z_min), both computed in decimal from the cell size so the extent is exact. A flat map
gets size.z = 1 (all levels are 0).

Gazebo needs square images of (2^n)+1 pixels (Gazebo terrain tutorial; gz-common asserts a square
image), so the map is resampled (bilinear, same extent) to the next such size unless it already is
one. Gazebo reads image rows towards -y: the top image row is at +y ("depth goes in -y because
traditionally images are read from top row to bottom row", DART HeightmapShape, used by gz-physics
with flipY = false; classic Gazebo flips rows into a +y grid). The PNG is therefore written bottom
row first, so that z[0, 0] lands at world (0, 0) and no mirroring happens.

Caveats of the simulators, not of the file: Gazebo versions stretch the image over ``<size>`` with
N - 1, N or 2N - 1 intervals (gz-physics DART: size / N; classic ODE: size / (2N - 1) at
subsampling 2), up to a 1/N (0.1 % at N = 1025) shrink we cannot compensate in a file shared with
the renderer; and classic Gazebo's Ogre terrain renders a square of side size.x, so a map whose
extent is not square is logged with a warning (its collision shape is still right).
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import (
    describe,
    fmt,
    fmt_list,
    half_span_m,
    load_png16_levels,
    resample_bilinear,
    save_png16_levels,
    span_m,
)
from offroadbench.io.png16 import LEVELS, encode_png16

__all__ = ["gazebo_grid_size", "gazebo_placement", "write_gazebo", "read_gazebo"]

log = logging.getLogger(__name__)


def gazebo_grid_size(rows: int, cols: int) -> int:
    """Smallest (2^n)+1 >= max(rows, cols): Gazebo heightmap images must be square with that side."""
    n = max(rows, cols)
    side = 2
    while side + 1 < n:
        side *= 2
    return side + 1


def gazebo_placement(hm: Heightmap, z_min_m: float, relief_m: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(``<size>``, ``<pos>``) of an SDF ``<heightmap>`` that puts the samples where ``hm`` says."""
    size = (span_m(hm.cols, hm.cell_size_m), span_m(hm.rows, hm.cell_size_m), relief_m if relief_m > 0 else 1.0)
    pos = (half_span_m(hm.cols, hm.cell_size_m), half_span_m(hm.rows, hm.cell_size_m), z_min_m)
    return size, pos


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib: str) -> ET.Element:
    el = ET.SubElement(parent, tag, attrib)
    if text is not None:
        el.text = text
    return el


def _write_xml(root: ET.Element, path: Path) -> None:
    ET.indent(root, space="  ")
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    with path.open("a") as fh:
        fh.write("\n")


def _heightmap_element(parent: ET.Element, uri: str, size: tuple, pos: tuple, visual: bool) -> None:
    hmap = _sub(_sub(parent, "geometry"), "heightmap")
    if visual:
        _sub(hmap, "use_terrain_paging", "false")
    _sub(hmap, "uri", uri)
    _sub(hmap, "size", fmt_list(size))
    _sub(hmap, "pos", fmt_list(pos))


def write_gazebo(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    side = gazebo_grid_size(hm.rows, hm.cols)
    z = resample_bilinear(hm, side, side)
    if (side, side) != hm.shape:
        how = f"resampled {hm.rows}x{hm.cols} -> {side}x{side} (bilinear, same extent) because Gazebo needs square (2^n)+1 images"
        log.info("gazebo: %s", how)
    else:
        how = f"{side}x{side} samples, used as they are"
    grid = Heightmap(z, hm.cell_size_m)  # only its heights are used; the cell size is not square here
    size, pos = gazebo_placement(hm, grid.z_min_m, grid.relief_m)
    if hm.rows != hm.cols:
        how += f"; the extent {fmt(size[0])} x {fmt(size[1])} m is not square: classic Gazebo renders it as a square of side size.x"
        log.warning("gazebo: %s x %s m extent is not square; classic Gazebo renders a square of side size.x", fmt(size[0]), fmt(size[1]))
    model = d / name
    tex = model / "materials" / "textures"
    tex.mkdir(parents=True)
    png_name = f"{name}_heightmap.png"
    save_png16_levels(encode_png16(grid)[::-1], tex / png_name)  # bottom row first: image row 0 is +y
    uri = f"model://{name}/materials/textures/{png_name}"
    description = (
        describe(hm, name, meta) + f" {how}. Image row 0 is the +y edge (Gazebo's convention), so sample (0, 0) is "
        f"at world (0, 0). Put the directory containing {name}/ on GAZEBO_MODEL_PATH (classic) or "
        "GZ_SIM_RESOURCE_PATH (gz-sim)."
    )

    config = ET.Element("model")
    _sub(config, "name", name)
    _sub(config, "version", "1.0")
    _sub(config, "sdf", "model.sdf", version="1.6")
    author = _sub(config, "author")
    _sub(author, "name", "offroadbench")
    _sub(author, "email", "none")
    _sub(config, "description", description)
    _write_xml(config, model / "model.config")

    sdf = ET.Element("sdf", version="1.6")
    mdl = _sub(sdf, "model", name=name)
    _sub(mdl, "static", "true")
    link = _sub(mdl, "link", name="terrain")
    _heightmap_element(_sub(link, "collision", name="collision"), uri, size, pos, visual=False)
    _heightmap_element(_sub(link, "visual", name="visual"), uri, size, pos, visual=True)
    _write_xml(sdf, model / "model.sdf")
    return [f"Gazebo model {name}/: {how}; <size> {fmt_list(size)}, <pos> {fmt_list(pos)}"]


def read_gazebo(d: Path, name: str) -> Heightmap:
    """The collision heightmap of ``NAME/model.sdf`` placed as Gazebo places it (square extents only)."""
    model = d / name
    try:
        hmap = ET.parse(model / "model.sdf").getroot().find("model/link/collision/geometry/heightmap")
        uri = hmap.find("uri").text
        size = [float(v) for v in hmap.find("size").text.split()]
        pos = [float(v) for v in hmap.find("pos").text.split()]
    except (OSError, ET.ParseError, AttributeError, ValueError) as exc:
        raise InputError(f"{model / 'model.sdf'}: not a Gazebo heightmap model ({exc})") from None
    prefix = f"model://{name}/"
    if not uri.startswith(prefix):
        raise InputError(f"{model / 'model.sdf'}: heightmap uri {uri!r} is not inside model {name}")
    q = load_png16_levels(model / uri[len(prefix):])
    n = q.shape[0]
    if size[0] != size[1]:
        raise InputError(f"{model}: extent {size[0]} x {size[1]} m is not square; its cells are not square either")
    z = pos[2] + q[::-1] / LEVELS * size[2]  # image row 0 is the +y edge
    return Heightmap(z, size[0] / (n - 1))


EXPORTERS.register(
    "gazebo",
    Exporter(
        name="gazebo",
        summary="model directory NAME/: model.config, model.sdf (<heightmap>), square (2^n)+1 16-bit PNG",
        reader="Gazebo classic and gz-sim (<heightmap> in SDF 1.6)",
        write=write_gazebo,
        read=read_gazebo,
        precision_m=lambda hm: hm.relief_m / LEVELS / 2 + 1e-12 * max(1.0, float(abs(hm.z).max())),
    ),
)
