"""Terrain export for other simulators and tools: a registry of formats, each writing a set of files.

``export_heightmap(hm, "gazebo", out_dir, name="t")`` writes every file of one format into
``out_dir`` as one transaction (:mod:`offroadbench.io.export._staging`): the files appear together
or, on any error, not at all. Where they may go is the one output-path policy of
:mod:`offroadbench.io.outputs`. ``read_export(out_dir, "gazebo", name="t")`` reads them back the way
the target tool would (its documented mapping from file to world), as a Heightmap.

Placement convention (shared/DESIGN.md): ``z[r, c]`` is the height in metres at
``x = c * cell``, ``y = r * cell``. Every exporter puts sample (0, 0) at x = y = 0 and the far sample
``(rows - 1, cols - 1)`` at ``(width_m, height_m)``, heights in metres, z up, in the target's own
frame and units. Where a tool reads image rows in the other direction the exporter says so and
compensates; the terrain itself is never mirrored. Numbers in text files are written with the
shortest text that reads back as the same float64, and extents are computed in decimal from the
cell size (:func:`offroadbench.io.export._common.span_m`), so 200 samples at 0.05 m span "9.95".

The formats are the entries of :data:`EXPORTERS` (``offroadbench export --list``); one module per
format: ``unreal``, ``gazebo``, ``mujoco``, ``mesh`` (obj), ``grid`` (tiff, npy), ``geotiff``,
``usd`` and ``webots``. Installed packages add formats through the entry-point group
``offroadbench.exporters`` (the entry point names an :class:`Exporter`).
"""

from __future__ import annotations

import importlib
import logging
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.export._staging import staged_dir
from offroadbench.io.outputs import check_output_dir
from offroadbench.registry import Registry

__all__ = ["EXPORTERS", "Exporter", "ExportResult", "check_name", "check_output_dir", "export_heightmap", "read_export", "staged_dir"]

log = logging.getLogger(__name__)

_BUILTIN_MODULES = ("unreal", "gazebo", "mujoco", "mesh", "grid", "geotiff", "usd", "webots")

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote: the final file paths and one human-readable line per key fact."""

    files: tuple[Path, ...]
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, kw_only=True)
class Exporter:
    """One export format."""

    name: str
    """Format name (``--format``)."""
    summary: str
    """One line: the files written."""
    reader: str
    """The tool that reads the files (README Export table, ``--list``)."""
    write: Callable[..., list[str]]
    """``write(hm, directory, name, meta, **options) -> notes``: write every file into ``directory``."""
    read: Callable[[Path, str], Heightmap]
    """``read(directory, name) -> Heightmap``: the terrain as the target tool places it (metres, our grid)."""
    precision_m: Callable[[Heightmap], float]
    """Largest height error of a write-read round trip of ``hm``, metres (0 for bit-exact formats)."""
    options: tuple[str, ...] = ()
    """Keyword options ``write`` accepts (e.g. ``stride`` for obj)."""
    requires: tuple[str, ...] = field(default=())
    """Importable modules the format needs beyond the core dependencies (e.g. ``rasterio``)."""
    extra: str | None = None
    """The pip extra that installs ``requires`` (``pip install offroadbench[geo]``)."""

    def check_available(self) -> None:
        """InputError naming the extra to install if a required module is missing."""
        for module in self.requires:
            try:
                importlib.import_module(module)
            except ImportError:
                hint = f"pip install 'offroadbench[{self.extra}]'" if self.extra else f"install {module}"
                raise InputError(f"export format {self.name!r} needs the {module} package; {hint}") from None


def _load_builtin() -> None:
    for module in _BUILTIN_MODULES:
        importlib.import_module(f"{__name__}.{module}")


def _adapt_plugin(name: str, obj: object) -> Exporter:
    if not isinstance(obj, Exporter):
        raise TypeError(f"entry point {name!r} must name an offroadbench.io.export.Exporter, got {type(obj).__name__}")
    return obj


EXPORTERS: Registry[Exporter] = Registry(
    "export format", entry_point_group="offroadbench.exporters", loader=_load_builtin, adapt=_adapt_plugin
)


def check_name(name: str) -> str:
    """A file-name stem for the exported files: letters, digits, '.', '_', '-'; no path separators."""
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise InputError(
            f"export name {name!r} is not allowed; use letters, digits, '.', '_' and '-' (starting with a letter or digit)"
        )
    return name


def export_heightmap(
    hm: Heightmap,
    fmt: str,
    out_dir: str | Path,
    *,
    name: str = "terrain",
    meta: Mapping[str, Any] | None = None,
    soil_map: Any = None,
    **options: Any,
) -> ExportResult:
    """Write ``hm`` in format ``fmt`` into ``out_dir`` (created with its missing parents).

    ``name`` is the stem of the written files, ``meta`` extra keys for sidecars (recipe, seed, crs,
    ...), ``options`` format options (``stride`` for obj). All or nothing: on any error no file is
    left (nor a parent directory created for it). The heights are exported as they are; whether a
    spike dominates the relief (and so the 16-bit step of the image formats) is
    offroadbench.analysis.relief's question, which ``offroadbench export`` asks and reports.

    A ``soil_map`` (offroadbench.terrain.soil_map.SoilMap: ``index`` aligned with ``hm``, ``soils``)
    travels as a sidecar raster in every format: ``<name>_soil.png`` (8-bit soil indices, pixel (r, c)
    at ``z[r, c]``) and ``<name>_soil.json`` (the soils by index; offroadbench.io.soil_raster).
    """
    exporter = EXPORTERS.get(fmt)
    check_name(name)
    unknown = sorted(set(options) - set(exporter.options))
    if unknown:
        allowed = ", ".join(exporter.options) or "none"
        raise InputError(f"export format {fmt!r} takes no option {', '.join(unknown)}; its options: {allowed}")
    exporter.check_available()
    if soil_map is not None and tuple(soil_map.index.shape) != hm.shape:
        raise InputError(f"soil map of {soil_map.index.shape[0]} x {soil_map.index.shape[1]} samples; the terrain is "
                         f"{hm.rows} x {hm.cols}")
    out = Path(out_dir)
    with staged_dir(out) as stage:
        notes = exporter.write(hm, stage, name, dict(meta or {}), **options)
        if soil_map is not None:
            from offroadbench.io.soil_raster import write_soil_raster

            write_soil_raster(soil_map.index, soil_map.soils, hm.cell_size_m, stage / f"{name}_soil.png")
            notes = [*notes, f"soil map: {name}_soil.png with {name}_soil.json ({len(soil_map.soils)} soils)"]
        rel = sorted(p.relative_to(stage) for p in stage.rglob("*") if p.is_file())
    files = tuple(out / p for p in rel)
    log.info("export %s: wrote %d file(s) to %s", fmt, len(files), out)
    return ExportResult(files=files, notes=tuple(notes))


def read_export(directory: str | Path, fmt: str, *, name: str = "terrain") -> Heightmap:
    """The terrain that format ``fmt``'s files ``name`` in ``directory`` describe, placed as the target
    tool places it (see each format's module for the mapping it follows)."""
    exporter = EXPORTERS.get(fmt)
    exporter.check_available()
    return exporter.read(Path(directory), check_name(name))
