"""Webots: a world file ``NAME.wbt`` with the terrain as an ``ElevationGrid`` (R2022a+ ENU, z up).

Webots places ElevationGrid vertex P[i, j] at ``(xSpacing * i, ySpacing * j, height[i + j *
xDimension])`` in the local frame of its Solid, for 0 <= i < xDimension, 0 <= j < yDimension
(Webots Reference Manual, ElevationGrid; the x-y plane with z up since R2022a, whose worlds are
ENU). With i = column, j = row, xDimension = cols, yDimension = rows and xSpacing = ySpacing = cell,
``height`` is z in row-major order as it is and the Solid sits at the origin: sample (r, c) is at
(c * cell, r * cell, z[r, c]) with no flip. Heights are absolute metres written with their
shortest round-trip text; ``thickness`` (the collision box added below the lowest point) is
max(relief, 0.5 m), as for MuJoCo. The terrain Solid has no Physics node (static) and uses the
grid itself as its ``boundingObject``.

Webots is a desktop application, not a Python package, so the round trip is checked with
:func:`read_wbt`, a small strict reader of the VRML-like ``.wbt`` syntax (nodes, DEF/USE, fields,
lists), not with Webots itself.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import describe, fmt, fmt_list, span_m

__all__ = ["WEBOTS_VERSION", "write_webots", "read_wbt", "read_webots", "Node"]

#: the world-file header: R2023b reads base nodes without EXTERNPROTO lines; ENU is its default
WEBOTS_VERSION = "R2023b"
#: depth (m) of the box Webots adds below the lowest point, at least
THICKNESS_MIN_M = 0.5


def _axis_angle_yaw_pitch(yaw: float, pitch: float) -> tuple[float, float, float, float]:
    """Webots rotation (axis x y z, angle) of a camera turned by ``yaw`` about z, then tilted down by
    ``pitch`` (a Webots camera looks along +x with z up)."""
    qz = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    qy = np.array([np.cos(pitch / 2), 0.0, np.sin(pitch / 2), 0.0])  # +pitch about y turns +x towards -z
    w1, x1, y1, z1 = qz
    w2, x2, y2, z2 = qy
    q = np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                  w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    angle = 2 * np.arccos(np.clip(q[0], -1, 1))
    axis = q[1:] / np.linalg.norm(q[1:])
    return tuple(round(float(v), 4) for v in (*axis, angle))


#: the Viewpoint: looking north (+y) and 36.87 deg down (the eye is 0.8 south and 0.6 above)
_VIEW_ORIENTATION = _axis_angle_yaw_pitch(np.pi / 2, float(np.arctan2(0.6, 0.8)))


def write_webots(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    thickness = max(hm.relief_m, THICKNESS_MIN_M)
    w, h = span_m(hm.cols, hm.cell_size_m), span_m(hm.rows, hm.cell_size_m)
    eye = (w / 2, -0.8 * max(w, h), hm.z_max_m + 0.6 * max(w, h))  # south of the map, looking north and down
    info = describe(hm, name, meta).replace("\\", "/").replace('"', "'")
    rows = "\n".join("        " + " ".join(fmt(v) for v in row) for row in hm.z.tolist())
    text = f"""#VRML_SIM {WEBOTS_VERSION} utf8
# offroadbench terrain {name}: ElevationGrid P[i, j] = (xSpacing i, ySpacing j, height[i + j xDimension]), z up (ENU)
WorldInfo {{
  info [
    "{info}"
  ]
  basicTimeStep 16
  coordinateSystem "ENU"
}}
Viewpoint {{
  orientation {fmt_list(_VIEW_ORIENTATION)}
  position {fmt_list(eye)}
}}
DirectionalLight {{
  direction -0.5 0.5 -1
}}
Solid {{
  translation 0 0 0
  children [
    Shape {{
      appearance PBRAppearance {{
        baseColor 0.55 0.52 0.48
        roughness 1
        metalness 0
      }}
      geometry DEF TERRAIN_GRID ElevationGrid {{
        xDimension {hm.cols}
        xSpacing {fmt(hm.cell_size_m)}
        yDimension {hm.rows}
        ySpacing {fmt(hm.cell_size_m)}
        thickness {fmt(thickness)}
        height [
{rows}
        ]
      }}
    }}
  ]
  name "{name}"
  boundingObject USE TERRAIN_GRID
  locked TRUE
}}
"""
    (d / f"{name}.wbt").write_text(text)
    return [f"Webots world {name}.wbt: ElevationGrid {hm.cols} x {hm.rows} at {fmt(hm.cell_size_m)} m, x 0..{fmt(w)}, y 0..{fmt(h)} m"]


# --------------------------------------------------------------------------- a strict .wbt reader
_TOKEN = re.compile(r'\s*(?:(#[^\n]*)|("(?:[^"\\]|\\.)*")|([\[\]{}])|([^\s\[\]{}"#]+))')
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


class Node:
    """A parsed node: its type, DEF name and fields (name -> list of values; nodes are Nodes)."""

    def __init__(self, type_: str, def_name: str | None) -> None:
        self.type = type_
        self.def_name = def_name
        self.fields: dict[str, list[Any]] = {}

    def __repr__(self) -> str:
        return f"Node({self.type}, {sorted(self.fields)})"


def _tokens(text: str, where: str) -> list[str]:
    out, pos = [], 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None or m.end() == pos:
            if text[pos:].strip() == "":
                break
            raise InputError(f"{where}: cannot read at character {pos}: {text[pos:pos + 20]!r}")
        pos = m.end()
        if m.group(1) is None and m.lastindex is not None:
            out.append(m.group(m.lastindex))
    return out


def read_wbt(path: Path) -> list[Node]:
    """The top-level nodes of a Webots world file; USE resolves to the DEF'd node. Strict: any
    token out of place is an InputError naming it."""
    text = path.read_text()
    if not text.startswith("#VRML_SIM R") or "utf8" not in text.splitlines()[0]:
        raise InputError(f"{path}: no '#VRML_SIM Rxxxx utf8' header")
    toks = _tokens(text, str(path))
    defs: dict[str, Node] = {}
    i = 0

    def peek() -> str | None:
        return toks[i] if i < len(toks) else None

    def take(expected: str | None = None) -> str:
        nonlocal i
        if i >= len(toks):
            raise InputError(f"{path}: unexpected end of file" + (f", expected {expected!r}" if expected else ""))
        t = toks[i]
        if expected is not None and t != expected:
            raise InputError(f"{path}: expected {expected!r}, found {t!r} (token {i})")
        i += 1
        return t

    def node() -> Node:
        def_name = None
        if peek() == "USE":
            take()
            ref = take()
            if ref not in defs:
                raise InputError(f"{path}: USE {ref} before DEF {ref}")
            return defs[ref]
        if peek() == "DEF":
            take()
            def_name = take()
        type_ = take()
        if not _IDENT.match(type_):
            raise InputError(f"{path}: {type_!r} is not a node type")
        n = Node(type_, def_name)
        if def_name:
            defs[def_name] = n
        take("{")
        while peek() != "}":
            fname = take()
            if not _IDENT.match(fname):
                raise InputError(f"{path}: {fname!r} is not a field name (in {type_})")
            n.fields[fname] = value()
        take("}")
        return n

    def scalar(t: str) -> Any:
        if _NUMBER.match(t):
            return float(t) if any(ch in t for ch in ".eE") else int(t)
        if t in ("TRUE", "FALSE"):
            return t == "TRUE"
        if t.startswith('"'):
            return t[1:-1]
        raise InputError(f"{path}: {t!r} is not a value")

    def starts_node() -> bool:
        t = peek()
        return t in ("DEF", "USE") or (t is not None and _IDENT.match(t) and i + 1 < len(toks) and toks[i + 1] == "{")

    def value() -> list[Any]:
        if peek() == "[":
            take()
            items: list[Any] = []
            while peek() != "]":
                items.append(node() if starts_node() else scalar(take()))
            take("]")
            return items
        if starts_node():
            return [node()]
        if peek() == "NULL":
            take()
            return [None]
        vals = [scalar(take())]
        while peek() is not None and (_NUMBER.match(peek()) or peek() in ("TRUE", "FALSE") or peek().startswith('"')):
            vals.append(scalar(take()))
        return vals

    nodes = []
    while peek() is not None:
        nodes.append(node())
    return nodes


def _find(nodes: list[Any], type_: str) -> list[Node]:
    """Every node of ``type_`` in ``nodes`` and below, once each (a USE is the DEF'd node)."""
    found: dict[int, Node] = {}
    for n in nodes:
        if isinstance(n, Node):
            if n.type == type_:
                found[id(n)] = n
            for vals in n.fields.values():
                found.update((id(m), m) for m in _find(vals, type_))
    return list(found.values())


def read_webots(d: Path, name: str) -> Heightmap:
    """The ElevationGrid of the Solid named ``name`` in ``NAME.wbt``, placed as Webots places it."""
    path = d / f"{name}.wbt"
    nodes = read_wbt(path)
    info = _find(nodes, "WorldInfo")
    if not info or info[0].fields.get("coordinateSystem", ["ENU"]) != ["ENU"]:
        raise InputError(f"{path}: WorldInfo is missing or not ENU")
    solids = [s for s in _find(nodes, "Solid") if s.fields.get("name") == [name]]
    grids = _find(solids, "ElevationGrid")
    if len(solids) != 1 or len(grids) != 1:
        raise InputError(f"{path}: expected one Solid {name!r} with one ElevationGrid")
    g, solid = grids[0].fields, solids[0].fields
    if solid.get("boundingObject") != [grids[0]]:
        raise InputError(f"{path}: the Solid's boundingObject is not its ElevationGrid")
    nx, ny = g["xDimension"][0], g["yDimension"][0]
    dx, dy = g["xSpacing"][0], g["ySpacing"][0]
    heights = np.array(g["height"], dtype=np.float64)
    if heights.size != nx * ny or dx != dy:
        raise InputError(f"{path}: height[] has {heights.size} values for {nx} x {ny}, spacing {dx} x {dy}")
    tx, ty, tz = solid.get("translation", [0, 0, 0])
    if (tx, ty) != (0, 0) or "rotation" in solid:
        raise InputError(f"{path}: the terrain Solid is moved in x, y or rotated")
    return Heightmap(heights.reshape(ny, nx) + tz, float(dx))


EXPORTERS.register(
    "webots",
    Exporter(
        name="webots",
        summary="Webots world NAME.wbt: a static Solid with an ElevationGrid (ENU, z up) as shape and bounding object",
        reader="Webots R2022a+ (checked with offroadbench's strict .wbt reader; Webots is not a Python package)",
        write=write_webots,
        read=read_webots,
        precision_m=lambda hm: 0.0,
    ),
)
