"""``offroadbench export``: write a terrain (PNG or preset) for another simulator."""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

from offroadbench.errors import InputError

log = logging.getLogger(__name__)


def cmd_export(args: argparse.Namespace) -> int:
    from offroadbench.analysis.relief import check_clip_percentile, clip_percentile, tail_report
    from offroadbench.cli._common import check_output_dir, load_heightmap_arg
    from offroadbench.io.export import EXPORTERS, check_name, export_heightmap

    if args.list:
        print("Export formats (offroadbench export TERRAIN --format NAME -o DIR):")
        width = max(len(n) for n in EXPORTERS)
        for name, exp in EXPORTERS.items():
            needs = f" [needs pip install 'offroadbench[{exp.extra}]']" if exp.extra else ""
            print(f"  {name:<{width}}  {exp.summary}; read by {exp.reader}{needs}")
        return 0
    missing = [flag for flag, v in (("TERRAIN", args.terrain), ("--format", args.format), ("-o DIR", args.output)) if v is None]
    if missing:
        raise InputError(f"export: missing {', '.join(missing)} (or use --list to see the formats)")
    exporter = EXPORTERS.get(args.format)  # fail on a bad format, name, option or directory before the work
    exporter.check_available()
    options = {} if args.stride is None else {"stride": args.stride}
    if options and "stride" not in exporter.options:
        raise InputError(f"--stride applies to the obj format only, not to {args.format!r}")
    if args.name is not None:
        check_name(args.name)
    check_clip_percentile(args.clip_percentile)
    out = check_output_dir(args.output, "-o")

    t0 = time.perf_counter()
    hm, label, recipe = load_heightmap_arg(args.terrain, args.seed, args.cell_size_m, args.relief_m, args.set, args.force)
    soil_map = None
    if recipe is not None:
        from offroadbench.terrain.soil_map import soil_map_for

        soil_map = soil_map_for(recipe, hm, args.seed)  # the recipe's [[soil.regions]]: a sidecar raster
    if args.clip_percentile:
        hm = clip_percentile(hm, args.clip_percentile)
    if recipe is not None:
        from offroadbench.cli._common import parse_sets, recipe_meta

        meta = recipe_meta(recipe, args.seed, parse_sets(args.set))
        name = args.name or f"{recipe.name}_seed{args.seed}"
    else:
        from offroadbench.io.png16 import read_png16_metadata

        meta = {"source": str(args.terrain)}
        side = read_png16_metadata(args.terrain)
        crs = side.get("crs") or ((side.get("recipe") or {}).get("recipe") or {}).get("crs")
        if crs:  # the generating recipe's CRS (the lunar presets' Moon CRS), kept in a GeoTIFF
            meta["crs"] = crs
        name = args.name or Path(args.terrain).stem  # the PNG's stem (the label also names its recipe)
    if args.clip_percentile:
        meta["clip_percentile"] = args.clip_percentile
    tails = tail_report(hm)  # a spike that sets the 16-bit step of the image formats: exported as it is, said here
    if tails.dominated:
        log.warning("export %s: %s", args.format, tails.message())
    result = export_heightmap(hm, args.format, out, name=check_name(name), meta=meta, soil_map=soil_map, **options)
    print(
        f"{label}: {hm.rows}x{hm.cols} at {hm.cell_size_m:g} m, relief {hm.relief_m:.3f} m -> {args.format} "
        f"({time.perf_counter() - t0:.2f} s)"
    )
    for note in result.notes:  # the spire warning was logged above: printed once
        if not note.startswith("warning: "):  # an exporter logs each warning it returns as a note
            print(f"  {note}")
    for path in result.files:
        print(f"wrote {path}")
    return 0


def register(sub) -> None:
    from offroadbench.cli._common import int_at_least, seed_arg
    from offroadbench.cli.terrain import TERRAIN_SEED_HELP

    p = sub.add_parser(
        "export",
        help="export a terrain for another simulator or tool (see --list)",
        description="Write a terrain (16-bit PNG with sidecar, preset or recipe) in another simulator's format. "
        "All files appear together or not at all.",
    )
    p.add_argument("terrain", nargs="?", help="16-bit PNG heightmap, preset name or recipe .toml")
    p.add_argument("--format", help="export format (see --list)")
    p.add_argument("-o", "--output", "--out", dest="output",
                   help="output directory (created with its missing parents); --out as in the other commands")
    p.add_argument("--list", action="store_true", help="list the export formats and exit")
    p.add_argument("--seed", type=seed_arg, default=0, help="when TERRAIN is a preset: " + TERRAIN_SEED_HELP)
    p.add_argument("--name", help="file name stem (default: PRESET_seedN, or the PNG's stem)")
    p.add_argument("--stride", type=int_at_least(1, "stride"), help="obj only: keep every N-th row and column (default 1)")
    p.add_argument("--clip-percentile", type=float, metavar="P", default=0.0,
                   help="clip heights to the P..100-P percentiles before export (not in the paper; e.g. 0.1 removes "
                   "the paper presets' corner spire; default 0 = keep every height)")
    p.add_argument("--cell-size-m", type=float, help="cell size for a PNG without sidecar, m")
    p.add_argument("--relief-m", type=float, help="relief of a PNG without sidecar, m")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a dotted recipe key (presets only)")
    p.add_argument("--force", action="store_true",
                   help="skip the up-front memory estimate check (also OFFROADBENCH_NO_MEMORY_CHECK=1)")
    p.set_defaults(func=cmd_export)


__all__ = ["register", "cmd_export"]
