"""Unreal Engine Landscape: 16-bit PNG + JSON sidecar + ``NAME_unreal.txt`` with the import settings.

The PNG is :func:`offroadbench.io.png16.write_png16`'s (pixel (row r, col c) = z[r, c], level 0 =
z_min, 65535 = z_max); the Z scale and location come from
:func:`offroadbench.io.png16.ue_landscape_settings`, which follows Unreal's exact 16-bit mapping, so
Unreal's heights equal the PNG's decoded heights (within half a 16-bit step of ``hm``).
Unreal places vertex (col c, row r) at Location + (c * Scale.X, r * Scale.Y) cm (the actor's origin
is the first vertex: UE4 wiki "Landscape - Sizes and Height Guide").
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export import EXPORTERS, Exporter
from offroadbench.io.export._common import fmt, load_png16_levels, span_m
from offroadbench.io.png16 import LEVELS, ue_heights_m, ue_landscape_settings, ue_z_range_m, write_png16

__all__ = ["UE_RECOMMENDED_SIZES", "write_unreal", "read_unreal"]

log = logging.getLogger(__name__)

#: Square Landscape sizes (vertices per side) from Unreal's "Recommended Landscape Sizes" table,
#: Landscape Technical Guide (https://docs.unrealengine.com/5.0/en-US/landscape-technical-guide-in-unreal-engine/):
#: these fill whole components exactly, so the import is 1:1 with no padding or cropping.
UE_RECOMMENDED_SIZES = (127, 253, 505, 1009, 2017, 4033, 8129)


def _size_note(hm: Heightmap) -> str | None:
    if hm.rows == hm.cols and hm.rows in UE_RECOMMENDED_SIZES:
        return None
    return (
        f"{hm.rows}x{hm.cols} is not one of Unreal's recommended Landscape sizes "
        f"({', '.join(f'{n}x{n}' for n in UE_RECOMMENDED_SIZES)}); Unreal will fit components to it "
        "and may pad or crop the edge: generate at a recommended size for an exact 1:1 import"
    )


def write_unreal(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    from offroadbench import __version__

    s = ue_landscape_settings(hm)
    write_png16(hm, d / f"{name}.png", meta=meta)
    size_note = _size_note(hm)
    if size_note:
        log.warning("unreal: %s", size_note)
    lines = [
        f"Unreal Engine Landscape import for {name}.png (offroadbench {__version__})",
        "",
        f"Heightmap: {name}.png, 16-bit grayscale, {hm.cols} x {hm.rows} pixels (width = columns along X, height = rows along Y);",
        f"  level 0 = {fmt(hm.z_min_m)} m, level 65535 = {fmt(hm.z_max_m)} m (relief {fmt(hm.relief_m)} m); metadata in {name}.json.",
        "",
        "Landscape mode > Manage > Import from File, then set on the Landscape actor:",
        f"  Location (cm):  X {fmt(s['location_x_cm'])}   Y {fmt(s['location_y_cm'])}   Z {fmt(s['location_z_cm'])}",
        "  Rotation:       0 0 0",
        f"  Scale:          X {fmt(s['scale_x'])}   Y {fmt(s['scale_y'])}   Z {fmt(s['scale_z'])}",
        "",
        f"Then pixel (row r, col c) lies at X = c * {fmt(s['scale_x'])} cm, Y = r * {fmt(s['scale_y'])} cm; the terrain spans",
        f"X 0 .. {fmt(span_m(hm.cols, s['scale_x']))} cm, Y 0 .. {fmt(span_m(hm.rows, s['scale_y']))} cm, "
        f"Z {fmt(hm.z_min_m * 100)} .. {fmt(hm.z_max_m * 100)} cm:",
        "the same numbers as offroadbench's x = c * cell, y = r * cell, in centimetres.",
        "Z: Unreal maps level v to Location Z + (v - 32768) / 128 * Scale Z cm (65535 levels span",
        f"65535 / 128 * Scale Z cm = {fmt(ue_z_range_m(s['scale_z']))} m here), so Scale Z = relief_cm * 128 / 65535 puts every level",
        f"where the PNG's own quantisation puts it: within half a step ({fmt(hm.relief_m / LEVELS / 2)} m) of the generated heights.",
        "Unreal's frame is left-handed (X forward, Y right, Z up): a right-handed tool shows the same x, y mirrored.",
        "",
        "Recommended Landscape sizes (vertices per side): " + ", ".join(str(n) for n in UE_RECOMMENDED_SIZES) + ".",
        (f"This map: {size_note}." if size_note else f"This map ({hm.rows} x {hm.cols}) is one of them."),
    ]
    (d / f"{name}_unreal.txt").write_text("\n".join(lines) + "\n")
    notes = [
        f"Unreal import: Scale X {fmt(s['scale_x'])} Y {fmt(s['scale_y'])} Z {fmt(s['scale_z'])}, "
        f"Location (0, 0, {fmt(s['location_z_cm'])}) cm"
    ]
    if size_note:
        notes.append("warning: " + size_note)
    return notes


def read_unreal(d: Path, name: str) -> Heightmap:
    """Heights Unreal builds from ``NAME.png`` with the sidecar's Scale and Location."""
    side = d / f"{name}.json"
    try:
        meta = json.loads(side.read_text())
        scale_x, scale_z, loc_z = (float(meta[k]) for k in ("ue_scale_x", "ue_scale_z", "ue_location_z_cm"))
    except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{side}: no Unreal import settings ({exc})") from None
    return Heightmap(ue_heights_m(load_png16_levels(d / f"{name}.png"), scale_z, loc_z), scale_x / 100.0)


EXPORTERS.register(
    "unreal",
    Exporter(
        name="unreal",
        summary="16-bit PNG + JSON sidecar + NAME_unreal.txt (Landscape import scale and location)",
        reader="Unreal Engine Landscape (Import from File)",
        write=write_unreal,
        read=read_unreal,
        precision_m=lambda hm: hm.relief_m / LEVELS / 2 + 1e-12 * max(1.0, float(abs(hm.z).max())),
    ),
)
