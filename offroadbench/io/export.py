"""Terrain export for other simulators: a registry of exporters, each writing a set of files.

``export_heightmap(hm, "gazebo", out_dir, name="t")`` writes every file of one format into
``out_dir`` atomically: the files are written into a hidden staging directory first and moved into
place only when all of them are complete, so an error never leaves a partial export behind.

Placement convention (shared/DESIGN.md): ``z[r, c]`` is the height in metres at
``x = c * cell``, ``y = r * cell``. Every exporter puts sample (0, 0) at x = y = 0 and the far sample
``(rows - 1, cols - 1)`` at ``(width_m, height_m)``, with heights ``z_min_m .. z_max_m``, in the target
simulator's own frame and units. Where a simulator reads image rows in the other direction the
exporter says so and compensates; the terrain itself is never mirrored.

Formats (``EXPORTERS``; ``offroadbench export --list``):

========  ====================================================================================
unreal    16-bit PNG + JSON sidecar (:func:`offroadbench.io.png16.write_png16`) and
          ``NAME_unreal.txt`` with the Landscape import scale and location.
gazebo    a model directory ``NAME/`` (model.config, model.sdf with a ``<heightmap>``, 16-bit PNG
          resampled to a square (2^n)+1 grid).
mujoco    ``NAME.xml`` (MJCF ``<hfield>`` + geom) and ``NAME.hfield`` (MuJoCo's float32 binary).
obj       ``NAME.obj``: a Wavefront triangle mesh in metres, z up; vertices are the samples.
tiff      ``NAME.tif``: 32-bit float heights in metres (Pillow mode "F") + ``NAME.tif.json`` sidecar.
npy       ``NAME.npy``: float64 heights in metres + ``NAME.npy.json`` sidecar.
========  ====================================================================================

:func:`read_grid` reads a TIFF or NPY export back into a :class:`~offroadbench.heightmap.Heightmap`.
The grid sidecars are ``NAME.tif.json`` / ``NAME.npy.json`` (not ``NAME.json``) so that several formats
exported under one name into one directory never overwrite each other's metadata (``NAME.json`` is
the unreal PNG's sidecar).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.atomic import current_umask

__all__ = [
    "EXPORTERS",
    "Exporter",
    "ExportResult",
    "GRID_FORMAT",
    "UE_RECOMMENDED_SIZES",
    "check_name",
    "check_output_dir",
    "export_heightmap",
    "gazebo_grid_size",
    "gazebo_placement",
    "get_exporter",
    "grid_metadata",
    "mujoco_hfield_size",
    "read_grid",
    "resample_bilinear",
    "unreal_import_settings",
]

log = logging.getLogger(__name__)

GRID_FORMAT = "offroadbench-grid/1"

#: Square Landscape sizes (vertices per side) from Unreal's "Recommended Landscape Sizes" table,
#: Landscape Technical Guide (https://docs.unrealengine.com/5.0/en-US/landscape-technical-guide-in-unreal-engine/):
#: these fill whole components exactly, so the import is 1:1 with no padding or cropping.
UE_RECOMMENDED_SIZES = (127, 253, 505, 1009, 2017, 4033, 8129)

#: Unreal maps 16-bit level v to (v - 32768) / 128 * Z scale (cm), i.e. -256..+256 m at Z scale 100
#: (Landscape Technical Guide: Z scale = height in cm * 1/512; Unreal forum "How heightmaps for landscape
#: are scaled?", forums.unrealengine.com/t/479315; the same 512 m as png16.py).
UE_LEVELS_PER_Z_SCALE_UNIT = 128.0
UE_ZERO_LEVEL = 32768

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


# --------------------------------------------------------------------------- registry
@dataclass(frozen=True)
class ExportResult:
    """What an export wrote: the final file paths and one human-readable line per key fact."""

    files: tuple[Path, ...]
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class Exporter:
    """One export format: ``write(hm, directory, name, meta, **options)`` writes files into
    ``directory`` and returns notes; ``options`` names the keyword options it accepts."""

    name: str
    summary: str
    write: Callable[..., list[str]]
    options: tuple[str, ...] = ()


EXPORTERS: dict[str, Exporter] = {}


def _register(name: str, summary: str, options: tuple[str, ...] = ()):
    def deco(fn):
        EXPORTERS[name] = Exporter(name=name, summary=summary, write=fn, options=options)
        return fn

    return deco


def get_exporter(name: str) -> Exporter:
    """The exporter registered as ``name``; an unknown name is an InputError listing the known ones."""
    try:
        return EXPORTERS[name]
    except KeyError:
        raise InputError(f"export format {name!r} is unknown; known formats: {', '.join(sorted(EXPORTERS))}") from None


def check_name(name: str) -> str:
    """A file-name stem for the exported files: letters, digits, '.', '_', '-'; no path separators."""
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise InputError(
            f"export name {name!r} is not allowed; use letters, digits, '.', '_' and '-' (starting with a letter or digit)"
        )
    return name


# --------------------------------------------------------------------------- atomic directory output
def check_output_dir(out_dir: str | Path) -> Path:
    """``out_dir`` if it is a writable directory, or can be created in a writable existing parent."""
    d = Path(out_dir)
    if d.exists():
        if not d.is_dir():
            raise InputError(f"output directory {d}: exists and is not a directory")
        if not os.access(d, os.W_OK | os.X_OK):
            raise InputError(f"output directory {d}: is not writable")
        return d
    parent = d.parent if str(d.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"output directory {d}: parent {parent} does not exist or is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"output directory {d}: parent {parent} is not writable")
    return d


@contextlib.contextmanager
def _staged_dir(out_dir: Path) -> Iterator[Path]:
    """Yield an empty staging directory; on success its contents appear in ``out_dir``.

    A new ``out_dir`` is staged beside it and renamed into place in one step. An existing ``out_dir``
    gets a hidden staging directory inside it whose files are then moved in (renames on one file
    system); files they replace are kept aside until every move has succeeded, and put back if one
    fails. On any error the staging directory is deleted and ``out_dir`` is as it was.
    """
    out_dir = check_output_dir(out_dir)
    fresh = not out_dir.exists()
    parent = out_dir.parent if fresh else out_dir
    try:
        stage = Path(tempfile.mkdtemp(prefix=f".{out_dir.name or 'export'}.", suffix=".tmp", dir=parent))
    except OSError as exc:
        raise InputError(f"output directory {out_dir}: cannot write there ({exc.strerror})") from None
    try:
        yield stage
        if fresh:
            os.chmod(stage, 0o777 & ~current_umask())  # mkdtemp makes 0700; give the usual directory mode
            os.rename(stage, out_dir)
        else:
            _merge_into(stage, out_dir)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _check_merge(stage: Path, out_dir: Path) -> None:
    """InputError if an existing path in ``out_dir`` has the wrong kind (file vs directory)."""
    for src in stage.rglob("*"):
        dst = out_dir / src.relative_to(stage)
        if dst.exists() and src.is_dir() != dst.is_dir():
            kind = "a directory" if dst.is_dir() else "a file"
            raise InputError(f"output {dst}: is {kind} already; remove it or choose another --name or directory")


def _merge_into(stage: Path, out_dir: Path) -> None:
    _check_merge(stage, out_dir)
    backup = Path(tempfile.mkdtemp(prefix=".export-replaced.", suffix=".tmp", dir=out_dir))
    created: list[Path] = []
    replaced: list[tuple[Path, Path]] = []  # (target, its previous version in backup)
    try:
        for src in sorted(stage.rglob("*")):
            rel = src.relative_to(stage)
            dst = out_dir / rel
            if src.is_dir():
                if not dst.is_dir():
                    dst.mkdir()
                    created.append(dst)
                continue
            if dst.exists():
                old = backup / rel
                old.parent.mkdir(parents=True, exist_ok=True)
                os.replace(dst, old)
                replaced.append((dst, old))
            os.replace(src, dst)
            created.append(dst)
    except BaseException:
        for p in reversed(created):
            with contextlib.suppress(OSError):
                p.rmdir() if p.is_dir() else p.unlink()
        for dst, old in replaced:
            with contextlib.suppress(OSError):
                os.replace(old, dst)
        raise
    finally:
        shutil.rmtree(backup, ignore_errors=True)


def export_heightmap(
    hm: Heightmap,
    fmt: str,
    out_dir: str | Path,
    *,
    name: str = "terrain",
    meta: Mapping[str, Any] | None = None,
    **options: Any,
) -> ExportResult:
    """Write ``hm`` in format ``fmt`` into ``out_dir`` (created if missing; its parent must exist).

    ``name`` is the stem of the written files, ``meta`` extra keys for sidecars (recipe, seed, ...),
    ``options`` format options (``stride`` for obj). All or nothing: on any error no file is left.
    """
    exporter = get_exporter(fmt)
    check_name(name)
    unknown = sorted(set(options) - set(exporter.options))
    if unknown:
        allowed = ", ".join(exporter.options) or "none"
        raise InputError(f"export format {fmt!r} takes no option {', '.join(unknown)}; its options: {allowed}")
    out = Path(out_dir)
    with _staged_dir(out) as stage:
        notes = exporter.write(hm, stage, name, dict(meta or {}), **options)
        rel = sorted(p.relative_to(stage) for p in stage.rglob("*") if p.is_file())
    files = tuple(out / p for p in rel)
    log.info("export %s: wrote %d file(s) to %s", fmt, len(files), out)
    return ExportResult(files=files, notes=tuple(notes))


# --------------------------------------------------------------------------- shared helpers
def grid_metadata(hm: Heightmap, dtype: str, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Sidecar keys for a float grid export (TIFF, NPY): enough to rebuild the Heightmap."""
    from offroadbench import __version__

    meta: dict[str, Any] = {
        "format": GRID_FORMAT,
        "dtype": dtype,
        "units": "metres",
        "layout": "z[r, c] is the height at x = c * cell_size_m, y = r * cell_size_m (row 0 first, no flips)",
        "rows": hm.rows,
        "cols": hm.cols,
        "cell_size_m": hm.cell_size_m,
        "z_min_m": hm.z_min_m,
        "z_max_m": hm.z_max_m,
        "relief_m": hm.relief_m,
        "offroadbench_version": __version__,
    }
    meta.update(extra or {})
    return meta


def _grid_sidecar(path: Path) -> Path:
    """``NAME.tif.json`` beside ``NAME.tif`` (``NAME.npy.json`` beside ``NAME.npy``)."""
    return path.with_name(path.name + ".json")


def _write_json(path: Path, data: Mapping[str, Any]) -> None:
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")


def resample_bilinear(hm: Heightmap, rows: int, cols: int) -> np.ndarray:
    """Heights on a ``rows x cols`` grid spanning the same extent (first to last sample), bilinear.

    Corner samples are kept exactly; an unchanged shape returns a copy of ``hm.z``.
    """
    if (rows, cols) == hm.shape:
        return np.array(hm.z)
    x = np.linspace(0.0, hm.width_m, cols)
    y = np.linspace(0.0, hm.height_m, rows)
    xx, yy = np.meshgrid(x, y)
    return np.asarray(hm.height_at(xx, yy), dtype=np.float64)


def _fmt(v: float) -> str:
    """Shortest text that reads back as the same float64 (no trailing '.0' noise for integers)."""
    return repr(float(v)).removesuffix(".0") if float(v).is_integer() else repr(float(v))


def _save_png16_levels(q: np.ndarray, path: Path) -> None:
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(q, dtype=np.uint16)).save(path, format="PNG")


# --------------------------------------------------------------------------- unreal
def unreal_import_settings(hm: Heightmap) -> dict[str, float]:
    """Landscape import scale and location (cm) that reproduce ``hm`` in Unreal Engine.

    Unreal places landscape vertex (col c, row r) at actor location + (c * Scale X, r * Scale Y) cm
    (the actor's origin is the first vertex, not the centre: UE4 wiki "Landscape - Sizes and Height
    Guide"), and 16-bit level v at Z + (v - 32768) / 128 * Scale Z cm (the -256..+256 m range at
    Z scale 100). With the png16 encoding (level 0 = z_min, 65535 = z_max):

    * Scale X = Scale Y = cell size in cm; Scale Z = relief in cm / 512 (as in the png16 sidecar);
    * Location = (0, 0, (z_min + relief / 2) * 100) cm, so level 0 lands on z_min.

    The 512 vs 65535/128 rounding shrinks heights by 1/65536: at most one 16-bit step at the top.
    """
    relief_cm = hm.relief_m * 100.0
    scale_z = relief_cm / (65536.0 / UE_LEVELS_PER_Z_SCALE_UNIT)  # = relief_cm / 512
    return {
        "scale_x": hm.cell_size_m * 100.0,
        "scale_y": hm.cell_size_m * 100.0,
        "scale_z": scale_z,
        "location_x_cm": 0.0,
        "location_y_cm": 0.0,
        "location_z_cm": hm.z_min_m * 100.0 + UE_ZERO_LEVEL / UE_LEVELS_PER_Z_SCALE_UNIT * scale_z,
    }


def _ue_size_note(hm: Heightmap) -> str | None:
    if hm.rows == hm.cols and hm.rows in UE_RECOMMENDED_SIZES:
        return None
    return (
        f"{hm.rows}x{hm.cols} is not one of Unreal's recommended Landscape sizes "
        f"({', '.join(f'{n}x{n}' for n in UE_RECOMMENDED_SIZES)}); Unreal will fit components to it "
        "and may pad or crop the edge: generate at a recommended size for an exact 1:1 import"
    )


@_register("unreal", "Unreal Engine Landscape: 16-bit PNG + JSON sidecar + NAME_unreal.txt (import scale, location)")
def _export_unreal(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    from offroadbench import __version__
    from offroadbench.io.png16 import write_png16

    s = unreal_import_settings(hm)
    write_png16(hm, d / f"{name}.png", meta=meta)
    size_note = _ue_size_note(hm)
    if size_note:
        log.warning("unreal: %s", size_note)
    lines = [
        f"Unreal Engine Landscape import for {name}.png (offroadbench {__version__})",
        "",
        f"Heightmap: {name}.png, 16-bit grayscale, {hm.cols} x {hm.rows} pixels (width = columns along X, height = rows along Y);",
        f"  level 0 = {hm.z_min_m:.6g} m, level 65535 = {hm.z_max_m:.6g} m (relief {hm.relief_m:.6g} m); metadata in {name}.json.",
        "",
        "Landscape mode > Manage > Import from File, then set on the Landscape actor:",
        f"  Location (cm):  X {_fmt(s['location_x_cm'])}   Y {_fmt(s['location_y_cm'])}   Z {s['location_z_cm']:.6f}",
        "  Rotation:       0 0 0",
        f"  Scale:          X {_fmt(s['scale_x'])}   Y {_fmt(s['scale_y'])}   Z {s['scale_z']:.8f}",
        "",
        f"Then pixel (row r, col c) lies at X = c * {_fmt(s['scale_x'])} cm, Y = r * {_fmt(s['scale_y'])} cm, the terrain spans",
        f"X 0 .. {hm.width_m * 100:.6g} cm, Y 0 .. {hm.height_m * 100:.6g} cm, Z {hm.z_min_m * 100:.6g} .. {hm.z_max_m * 100:.6g} cm:",
        "the same numbers as offroadbench's x = c * cell, y = r * cell, in centimetres.",
        "Z: Unreal maps level v to Location Z + (v - 32768) / 128 * Scale Z cm (512 m over 16 bits at Scale Z 100).",
        "Unreal's frame is left-handed (X forward, Y right, Z up): a right-handed tool shows the same x, y mirrored.",
        "",
        "Recommended Landscape sizes (vertices per side): " + ", ".join(str(n) for n in UE_RECOMMENDED_SIZES) + ".",
        (f"This map: {size_note}." if size_note else f"This map ({hm.rows} x {hm.cols}) is one of them."),
    ]
    (d / f"{name}_unreal.txt").write_text("\n".join(lines) + "\n")
    notes = [
        f"Unreal import: Scale X {_fmt(s['scale_x'])} Y {_fmt(s['scale_y'])} Z {s['scale_z']:.6g}, "
        f"Location (0, 0, {s['location_z_cm']:.4f}) cm"
    ]
    if size_note:
        notes.append("warning: " + size_note)
    return notes


# --------------------------------------------------------------------------- gazebo
def gazebo_grid_size(rows: int, cols: int) -> int:
    """Smallest (2^n)+1 >= max(rows, cols): Gazebo heightmap images must be square with that side."""
    n = max(rows, cols)
    side = 2
    while side + 1 < n:
        side *= 2
    return side + 1


def gazebo_placement(hm: Heightmap, z_min_m: float, relief_m: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(``<size>``, ``<pos>``) of an SDF ``<heightmap>`` that puts the samples where ``hm`` says.

    Gazebo centres the heightmap on ``<pos>`` x, y, stretches it over ``<size>`` x, y (first to last
    pixel) and maps pixel level / 65535 to pos.z + level / 65535 * size.z (gz-common
    ImageHeightmap::FillHeightMap; SDFormat ``<heightmap>``: "size: the size of the heightmap in
    world units", "pos: a position offset"). So size = (width, height, relief) and
    pos = (width / 2, height / 2, z_min). A flat map gets size.z = 1 (all levels are 0).
    """
    size = (hm.width_m, hm.height_m, relief_m if relief_m > 0 else 1.0)
    pos = (hm.width_m / 2.0, hm.height_m / 2.0, z_min_m)
    return size, pos


@_register("gazebo", "Gazebo (classic and gz-sim) model directory NAME/: model.config, model.sdf, square (2^n)+1 16-bit PNG")
def _export_gazebo(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    """Gazebo needs square images of (2^n)+1 pixels (Gazebo terrain tutorial; gz-common asserts a
    square image), so the map is resampled (bilinear, same extent) to the next such size unless it
    already is one. Gazebo reads image rows towards -y: the top image row is at +y ("depth goes in
    -y because traditionally images are read from top row to bottom row", DART HeightmapShape, used
    by gz-physics with flipY = false; classic Gazebo flips rows into a +y grid). The PNG is therefore
    written bottom row first, so that z[0, 0] lands at world (0, 0) and no mirroring happens.
    Caveats of the simulators, not of the file: Gazebo versions stretch the image over ``<size>`` with
    N - 1, N or 2N - 1 intervals (gz-physics DART: size / N; classic ODE: size / (2N - 1) at
    subsampling 2), up to a 1/N (0.1 % at N = 1025) shrink we cannot compensate in a file shared with
    the renderer; and classic Gazebo's Ogre terrain renders a square of side size.x, so a map whose
    extent is not square is logged with a warning (its collision shape is still right).
    """
    from offroadbench import __version__
    from offroadbench.io.png16 import encode_png16

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
        how += f"; the extent {hm.width_m:g} x {hm.height_m:g} m is not square: classic Gazebo renders it as a square of side size.x"
        log.warning("gazebo: %s x %s m extent is not square; classic Gazebo renders a square of side size.x", f"{hm.width_m:g}", f"{hm.height_m:g}")
    model = d / name
    tex = model / "materials" / "textures"
    tex.mkdir(parents=True)
    png_name = f"{name}_heightmap.png"
    _save_png16_levels(encode_png16(grid)[::-1], tex / png_name)
    uri = f"model://{name}/materials/textures/{png_name}"
    size_s = " ".join(_fmt(v) for v in size)
    pos_s = " ".join(_fmt(v) for v in pos)
    description = (
        f"offroadbench {__version__} terrain {name}: {hm.rows}x{hm.cols} samples at {hm.cell_size_m:g} m, "
        f"x 0..{hm.width_m:g} m, y 0..{hm.height_m:g} m, z {grid.z_min_m:.6g}..{grid.z_max_m:.6g} m; {how}. "
        "Image row 0 is the +y edge (Gazebo's convention), so sample (0, 0) is at world (0, 0). "
        f"Put the directory containing {name}/ on GAZEBO_MODEL_PATH (classic) or GZ_SIM_RESOURCE_PATH (gz-sim)."
    )
    for k in ("recipe_name", "seed", "terrain_id"):
        if k in meta:
            description += f" {k}: {meta[k]}."
    config = (
        '<?xml version="1.0"?>\n<model>\n'
        f"  <name>{escape(name)}</name>\n  <version>1.0</version>\n"
        '  <sdf version="1.6">model.sdf</sdf>\n'
        "  <author><name>offroadbench</name><email>none</email></author>\n"
        f"  <description>{escape(description)}</description>\n</model>\n"
    )
    heightmap = f"<uri>{escape(uri)}</uri>\n            <size>{size_s}</size>\n            <pos>{pos_s}</pos>"
    sdf = (
        '<?xml version="1.0"?>\n<sdf version="1.6">\n'
        f"  <model name={quoteattr(name)}>\n    <static>true</static>\n"
        '    <link name="terrain">\n'
        '      <collision name="collision">\n        <geometry>\n          <heightmap>\n'
        f"            {heightmap}\n          </heightmap>\n        </geometry>\n      </collision>\n"
        '      <visual name="visual">\n        <geometry>\n          <heightmap>\n'
        "            <use_terrain_paging>false</use_terrain_paging>\n"
        f"            {heightmap}\n          </heightmap>\n        </geometry>\n      </visual>\n"
        "    </link>\n  </model>\n</sdf>\n"
    )
    (model / "model.config").write_text(config)
    (model / "model.sdf").write_text(sdf)
    return [f"Gazebo model {name}/: {how}; <size> {size_s}, <pos> {pos_s}"]


# --------------------------------------------------------------------------- mujoco
#: depth (m) of the box MuJoCo adds under the lowest point of a height field (hfield size[3])
MUJOCO_BASE_MIN_M = 0.5


def mujoco_hfield_size(hm: Heightmap) -> tuple[float, float, float, float]:
    """MuJoCo hfield ``size`` = (radius_x, radius_y, elevation_z, base_z) for ``hm``.

    MuJoCo spans the field over [-radius_x, radius_x] x [-radius_y, radius_y] around its geom, with
    column c at x = c * 2 radius_x / (ncol - 1) - radius_x and row r at y = r * 2 radius_y / (nrow - 1)
    - radius_y; data are normalised to [0, 1] and scaled by elevation_z; base_z is the depth of a box
    below the lowest point (MuJoCo XML reference, asset/hfield; engine_collision_convex.c). So
    radius = half extent, elevation_z = relief (1 for a flat map: all data are 0), base_z =
    max(relief, 0.5 m).
    """
    relief = hm.relief_m
    return (hm.width_m / 2.0, hm.height_m / 2.0, relief if relief > 0 else 1.0, max(relief, MUJOCO_BASE_MIN_M))


@_register("mujoco", "MuJoCo MJCF NAME.xml: <hfield> from NAME.hfield (float32 binary) + a geom placing it")
def _export_mujoco(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    """The elevation goes in MuJoCo's custom binary format, ``int32 nrow, int32 ncol, float32
    data[nrow * ncol]`` row-major, copied as is (mjCHField::LoadCustom): row r is at -radius_y + r dy,
    i.e. our row order, with no flip. (A PNG hfield would be flipped by MuJoCo's loader and decoded to
    8 bits: 256 levels, 15 mm steps on a 3.84 m relief; the binary file keeps float32.)
    The geom sits at (width / 2, height / 2, z_min), so sample (r, c) lands at (c cell, r cell, z).
    """
    from offroadbench import __version__

    rx, ry, ez, base = mujoco_hfield_size(hm)
    data = (hm.z - hm.z_min_m).astype("<f4")
    header = np.array([hm.rows, hm.cols], dtype="<i4")
    fname = f"{name}.hfield"
    with (d / fname).open("wb") as fh:
        fh.write(header.tobytes())
        fh.write(data.tobytes(order="C"))
    pos = (hm.width_m / 2.0, hm.height_m / 2.0, hm.z_min_m)
    size_s = " ".join(_fmt(v) for v in (rx, ry, ez, base))
    pos_s = " ".join(_fmt(v) for v in pos)
    comment = (
        f"offroadbench {__version__} terrain {name}: {hm.rows}x{hm.cols} samples at {hm.cell_size_m:g} m; "
        f"sample (row r, col c) is at x = c * {hm.cell_size_m:g}, y = r * {hm.cell_size_m:g}, "
        f"z from {hm.z_min_m:.6g} to {hm.z_max_m:.6g} m."
    )
    for k in ("recipe_name", "seed", "terrain_id"):
        if k in meta:
            comment += f" {k}: {meta[k]}."
    xml = (
        f"<mujoco model={quoteattr(name)}>\n"
        f"  <!-- {escape(comment).replace('--', '- -')} -->\n"
        "  <asset>\n"
        f'    <hfield name={quoteattr(name)} file={quoteattr(fname)} content_type="image/vnd.mujoco.hfield" size="{size_s}"/>\n'
        "  </asset>\n"
        "  <worldbody>\n"
        f'    <geom name={quoteattr(name + "_terrain")} type="hfield" hfield={quoteattr(name)} pos="{pos_s}"/>\n'
        "  </worldbody>\n"
        "</mujoco>\n"
    )
    (d / f"{name}.xml").write_text(xml)
    return [f"MuJoCo hfield size {size_s}, geom pos {pos_s}"]


# --------------------------------------------------------------------------- obj
def _keep_indices(n: int, stride: int) -> np.ndarray:
    idx = np.arange(0, n, stride)
    return idx if idx[-1] == n - 1 else np.append(idx, n - 1)


@_register("obj", "Wavefront OBJ triangle mesh NAME.obj in metres, z up; vertices are the samples (--stride N decimates)", ("stride",))
def _export_obj(hm: Heightmap, d: Path, name: str, meta: dict[str, Any], stride: int = 1) -> list[str]:
    """Vertex ``v x y z`` for every kept sample (x = c cell, y = r cell, z = z[r, c], written with
    Python's shortest round-trip float text, so they read back exactly), row by row; two triangles
    per grid cell, counter-clockwise seen from +z so normals point up. OBJ has no units or up axis:
    these are metres with z up (e.g. Blender's importer: Forward Y, Up Z). ``stride`` keeps every
    stride-th row and column and always the last ones, so the extent is unchanged.
    """
    if isinstance(stride, bool) or not isinstance(stride, (int, np.integer)) or stride < 1:
        raise InputError(f"obj stride must be an integer >= 1, got {stride!r}")
    from offroadbench import __version__

    rows = _keep_indices(hm.rows, int(stride))
    cols = _keep_indices(hm.cols, int(stride))
    nr, nc = len(rows), len(cols)
    xs = [repr(float(v)) for v in cols * hm.cell_size_m]
    ys = [repr(float(v)) for v in rows * hm.cell_size_m]
    sub = hm.z[np.ix_(rows, cols)]
    idx = np.arange(nr * nc).reshape(nr, nc) + 1  # OBJ indices start at 1
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()  # (r, c), (r, c+1)
    c_, e = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()  # (r+1, c+1), (r+1, c)
    n_tri = 2 * a.size
    with (d / f"{name}.obj").open("w") as fh:
        fh.write(
            f"# offroadbench {__version__} terrain {name}: {hm.rows}x{hm.cols} samples at {hm.cell_size_m:g} m, "
            f"stride {stride} -> {nr}x{nc} vertices, {n_tri} triangles\n"
            "# units: metres; z up; vertex (row r, col c) = (c * cell, r * cell, z[r, c]), rows in order\n"
            f"o {name}\n"
        )
        for i in range(nr):
            y = ys[i]
            fh.write("".join(f"v {xs[j]} {y} {z!r}\n" for j, z in enumerate(sub[i].tolist())))
        tri = np.empty((n_tri, 3), dtype=np.int64)
        tri[0::2] = np.stack([a, b, c_], axis=1)
        tri[1::2] = np.stack([a, c_, e], axis=1)
        for k in range(0, n_tri, 1 << 17):  # in chunks: bounded memory on big maps
            fh.write("".join(f"f {p} {q} {s}\n" for p, q, s in tri[k : k + (1 << 17)].tolist()))
    return [f"OBJ mesh: {nr * nc} vertices, {n_tri} triangles (stride {stride})"]


# --------------------------------------------------------------------------- tiff / npy
@_register("tiff", "32-bit float TIFF NAME.tif of z in metres (Pillow mode F, deflate) + NAME.tif.json sidecar")
def _export_tiff(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    """Row 0 of the image is row 0 of z (no flip). Lossless for the float32 values it stores: the
    only change is the cast float64 -> float32 (relative error <= 6e-8, 6 um at 100 m); use npy for
    bit-exact float64."""
    from PIL import Image

    z32 = hm.z.astype(np.float32)
    img = Image.fromarray(z32)  # float32 -> mode "F"
    img.save(d / f"{name}.tif", format="TIFF", compression="tiff_adobe_deflate")
    cast_err = float(np.max(np.abs(z32.astype(np.float64) - hm.z)))
    _write_json(_grid_sidecar(d / f"{name}.tif"), grid_metadata(hm, "float32", {"file": f"{name}.tif", **meta}))
    return [f"TIFF float32: largest float64 -> float32 rounding {cast_err:.2e} m"]


@_register("npy", "NumPy NAME.npy of z in metres (float64, bit-exact) + NAME.npy.json sidecar")
def _export_npy(hm: Heightmap, d: Path, name: str, meta: dict[str, Any]) -> list[str]:
    """``np.load`` gives back ``hm.z`` exactly."""
    np.save(d / f"{name}.npy", np.ascontiguousarray(hm.z, dtype=np.float64), allow_pickle=False)
    _write_json(_grid_sidecar(d / f"{name}.npy"), grid_metadata(hm, "float64", {"file": f"{name}.npy", **meta}))
    return ["NPY float64: bit-exact"]


def read_grid(path: str | Path) -> Heightmap:
    """Read a ``tiff`` or ``npy`` export (``NAME.tif`` / ``NAME.npy`` with its ``.json`` sidecar) as a Heightmap."""
    p = Path(path)
    side = _grid_sidecar(p)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    if not side.is_file():
        raise InputError(f"{p}: no sidecar {side.name} with the cell size")
    try:
        meta = json.loads(side.read_text())
        cell = float(meta["cell_size_m"])
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{side}: not an offroadbench grid sidecar ({exc})") from None
    suffix = p.suffix.lower()
    if suffix in (".tif", ".tiff"):
        from PIL import Image

        with Image.open(p) as img:
            if img.mode != "F":
                raise InputError(f"{p}: is a mode {img.mode} TIFF, expected 32-bit float (mode F)")
            z = np.asarray(img, dtype=np.float32)
    elif suffix == ".npy":
        z = np.load(p, allow_pickle=False)
    else:
        raise InputError(f"{p}: unknown grid file type {suffix!r}; expected .tif, .tiff or .npy")
    if z.shape != (meta.get("rows", z.shape[0]), meta.get("cols", z.shape[1])):
        raise InputError(f"{p}: shape {z.shape} does not match the sidecar's {meta.get('rows')}x{meta.get('cols')}")
    return Heightmap(z.astype(np.float64), cell)
