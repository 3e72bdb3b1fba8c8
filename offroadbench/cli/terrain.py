"""Terrain commands: ``terrains``, ``generate``, ``analyze``, ``roughness-study``.

Each command parses, checks its outputs, calls one library function and formats its result.
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

from offroadbench.cli._common import (
    add_plot_option,
    check_output_dir,
    check_output_file,
    check_recipe_memory,
    crater_diameters,
    created_dirs,
    float_at_least,
    format_table,
    load_heightmap_arg,
    load_recipe_with_sets,
    parse_sets,
    plot_path,
    recipe_meta,
    nonnegative_float,
    positive_float,
    positive_int,
    save_figure,
    seed_arg,
)

log = logging.getLogger(__name__)


#: what ``--seed`` means in the commands that take one terrain (generate, analyze, export)
TERRAIN_SEED_HELP = ("the terrain's OWN seed (default 0): the integer a study's terrains table and drive print as "
                     "'seed N'; terrain j of a root seed s (a study's root_seed, drive --seed s with j = 0) is "
                     "terrain_seed(s, j) (offroadbench.seeding)")


#: what the spire warning recommends where the command has no --clip-percentile (drive)
CLIP_ELSEWHERE = ("to drive a clipped terrain, write it with `offroadbench generate TERRAIN --clip-percentile P "
                  "-o T.png` (heights clipped to the P..100-P percentiles, not in the paper) and drive T.png")


def warn_relief_tails(hm, label: str, remedy: str | None = None) -> None:
    """Log, once, that a few extreme samples hold most of the relief (the paper presets' corner spire,
    offroadbench.analysis.relief), wherever a terrain is generated or read. ``remedy``: what to do
    about it in this command (default: its own ``--clip-percentile P``)."""
    from offroadbench.analysis.relief import tail_report

    tails = tail_report(hm)
    if tails.dominated:
        log.warning("%s: %s", label, tails.message(remedy))


# --------------------------------------------------------------------------- commands
def cmd_terrains(args: argparse.Namespace) -> int:
    from offroadbench import resources
    from offroadbench.terrain.recipe import list_presets
    from offroadbench.terrain.registry import TERRAIN_REGISTRY

    presets = list_presets()  # none found: InputError, exit 2
    print(f"Terrain presets ({', '.join(str(r) for r in resources.roots('terrains'))}):")
    width = max((len(n) for n in presets), default=10)
    for name, desc in presets.items():
        print(f"  {name:<{width}}  {desc}")
    print("\nGenerators and modifiers (use in recipe [layers.NAME] tables):")
    for name, spec in sorted(TERRAIN_REGISTRY.items()):
        print(f"  {name:<14} {spec.kind:<9}  {spec.summary}")
    return 0


def clipped_label(label: str, percentile: float) -> str:
    """A terrain's label with its clip said: ``paper-d2.45 seed 0, clipped to the 0.1..99.9 percentiles``."""
    return f"{label}, clipped to the {percentile:g}..{100 - percentile:g} percentiles"


def cmd_generate(args: argparse.Namespace) -> int:
    from offroadbench.io.png16 import sidecar_path, write_png16
    from offroadbench.terrain.recipe import generate_terrain

    from offroadbench.analysis.relief import check_clip_percentile, clip_percentile

    out = check_output_file(args.output, "-o", suffixes=(".png",))  # fail before the work, not after
    check_clip_percentile(args.clip_percentile)
    recipe = load_recipe_with_sets(args.recipe, args.set)
    check_recipe_memory(recipe, args.force)
    t0 = time.perf_counter()
    hm = generate_terrain(recipe, args.seed)
    dt = time.perf_counter() - t0
    meta = recipe_meta(recipe, args.seed, parse_sets(args.set))
    if args.clip_percentile:
        hm = clip_percentile(hm, args.clip_percentile)
        meta["clip_percentile"] = args.clip_percentile
        meta["label"] = clipped_label(str(meta["label"]), args.clip_percentile)  # the sidecar's label says so too
    label = str(meta["label"])
    warn_relief_tails(hm, label)
    with created_dirs(out.parent):
        meta = write_png16(hm, out, meta=meta)
    print(f"{label}: {hm.rows}x{hm.cols} at {hm.cell_size_m:g} m, relief {hm.relief_m:.3f} m, generated in {dt:.2f} s")
    for layer in recipe.layers:
        if hasattr(layer.config, "describe"):
            print(f"  layer {layer.name}: {layer.config.describe(recipe.grid)}")
    print(f"wrote {out} and {sidecar_path(out)}")
    print(f"Unreal import scale: X {meta['ue_scale_x']:g}  Y {meta['ue_scale_y']:g}  Z {meta['ue_scale_z']:.4g}")
    return 0


def _surface_plot_path(plot: Path) -> Path:
    return plot.with_name(plot.stem + "_surface" + plot.suffix)


def format_terrain_report(rep, label: str) -> str:
    """The text ``analyze`` prints for a :class:`~offroadbench.analysis.describe.TerrainReport`."""
    hm, rcfg, s = rep.heightmap, rep.roughness, rep.surface
    lines = [
        f"{label}: {hm.rows}x{hm.cols} at {hm.cell_size_m:g} m ({hm.width_m:.2f} x {hm.height_m:.2f} m), "
        f"relief {hm.relief_m:.3f} m",
        f"Moore gradient (rise/run): median {rep.gradient_p50:.3f}, 95th pct {rep.gradient_p95:.3f}, max {rep.gradient_max:.3f}",
        f"Roughness classes inside the {rcfg.border_m:g} m border (paper Sec. 2.3-2.4; closing disk r = {rcfg.closing_radius_m:g} m):",
        format_table(rep.classes),
        "Surface (Horn slopes, radially averaged power spectrum): slope median {:.1f} deg, 90th pct {:.1f} deg, "
        "99th pct {:.1f} deg; steeper than 10/20/30 deg: {:.1f} / {:.1f} / {:.1f} %; PSD slope {:.2f} -> D = {:.2f}".format(
            s["slope_p50_deg"], s["slope_p90_deg"], s["slope_p99_deg"],
            100 * s["fraction_steeper_10deg"], 100 * s["fraction_steeper_20deg"],
            100 * s["fraction_steeper_30deg"], s["psd_slope_beta"], s["fractal_dimension"],
        ),
    ]
    dim = s["fractal_dimension"]
    cratered = rep.crater_diameters_m is not None and rep.crater_diameters_m.size > 0
    if cratered or not 2.0 < dim < 3.0:
        lines.append(
            "  caveat: D = 4 - beta/2 holds for a self-affine (fractal) surface only"
            + (f"; {dim:.2f} is outside its range (2, 3)" if not 2.0 < dim < 3.0 else "")
            + ("; craters add power at their own diameters and steepen the spectrum, so on a cratered "
               "terrain the slope measures the craters as much as the base surface" if cratered else "")
        )
    d = rep.crater_diameters_m
    if rep.crater_sfd_slope is not None:
        lines.append(f"Craters placed: {d.size}, D = {d.min():.2f} .. {d.max():.2f} m, "
                     f"fitted cumulative slope k = {rep.crater_sfd_slope:.2f}")
    return "\n".join(lines)


def cmd_analyze(args: argparse.Namespace) -> int:
    from offroadbench.analysis.describe import describe_terrain
    from offroadbench.analysis.relief import check_clip_percentile, clip_percentile
    from offroadbench.analysis.roughness import RoughnessConfig

    rcfg = RoughnessConfig(border_m=args.border_m, closing_radius_m=args.closing_radius_m)
    check_clip_percentile(args.clip_percentile)
    src = Path(args.terrain)
    stem = src.stem if src.suffix.lower() == ".png" else (
        f"{src.stem if src.suffix.lower() == '.toml' else src.name}_seed{args.seed}")
    plot = plot_path(args.plot, f"{stem}_classes.png")
    if plot is not None:
        check_output_file(_surface_plot_path(plot), "--plot")
    hm, label, recipe = load_heightmap_arg(args.terrain, args.seed, args.cell_size_m, args.relief_m, args.set, args.force)
    hm = clip_percentile(hm, args.clip_percentile)  # P = 0 (the default) keeps every height
    label = clipped_label(label, args.clip_percentile) if args.clip_percentile else label
    warn_relief_tails(hm, label)
    rep = describe_terrain(hm, rcfg, crater_diameters_m=crater_diameters(recipe, args.seed))
    print(format_terrain_report(rep, label))
    from offroadbench.terrain.soil_map import soil_map_for

    soil_map = soil_map_for(recipe, hm, args.seed) if recipe is not None else None
    if soil_map is not None:
        print("Soil map: " + ", ".join(f"{s} {100 * f:.1f} %" for s, f in soil_map.fractions().items()))
    if plot is not None:
        from offroadbench.plots.surface import plot_surface_analysis
        from offroadbench.plots.terrain import plot_terrain_classes

        with created_dirs(plot.parent):
            fig = plot_terrain_classes(hm, rep.maps.classes, fractions=rep.maps.fractions, border_m=rcfg.border_m, title=label)
            print(f"wrote {save_figure(fig, plot)}")
            fig = plot_surface_analysis(hm, crater_diameters_m=rep.crater_diameters_m, title=label)
            print(f"wrote {save_figure(fig, _surface_plot_path(plot))}")
            if soil_map is not None:  # the recipe's [[soil.regions]] / raster
                from offroadbench.plots.soil import plot_soil_map

                fig = plot_soil_map(hm, soil_map, title=f"{label}: soil map")
                print(f"wrote {save_figure(fig, plot.with_name(plot.stem + '_soil' + plot.suffix))}")
    return 0


def cmd_roughness_study(args: argparse.Namespace) -> int:
    from offroadbench.analysis.roughness import RoughnessConfig
    from offroadbench.cli._common import bar
    from offroadbench.io.atomic import atomic_path
    from offroadbench.plots.terrain import plot_roughness_study
    from offroadbench.study.roughness import PAPER_FIG5_CHANGES_PP, run_roughness_study

    out = check_output_dir(args.out, "--out")
    # the figure is always written (the study's result); --plot PATH puts it elsewhere
    figure = plot_path(args.plot if args.plot not in (None, True) else True, out / "roughness_study.png")
    recipe = load_recipe_with_sets(args.recipe, args.set)
    check_recipe_memory(recipe, args.force)
    t0 = time.perf_counter()
    with bar("terrains", unit="terrain") as progress:
        res = run_roughness_study(
            recipe, args.dims, args.terrains, args.seed, dim_key=args.dim_key,
            roughness=RoughnessConfig(border_m=args.border_m), progress=progress,
        )
    print(f"Median class areas inside the {args.border_m:g} m border, {args.terrains} terrains per D ({time.perf_counter() - t0:.1f} s):")
    print(format_table(res.summary))
    print("\nPaper (Sec. 3.1), change of the median areas in percentage points:")
    print(format_table(res.paper_changes_pp))
    with created_dirs(out):
        with atomic_path(out / "roughness_terrains.csv") as tmp:
            res.terrains.to_csv(tmp, index=False)
        with atomic_path(out / "roughness_summary.csv") as tmp:
            res.summary.to_csv(tmp, index=False)
        fig = plot_roughness_study(res.summary, PAPER_FIG5_CHANGES_PP if len(args.dims) == 3 else None)
        with created_dirs(figure.parent):
            save_figure(fig, figure)
    print(f"\nwrote {out}/roughness_terrains.csv, roughness_summary.csv, {figure}")
    return 0


# --------------------------------------------------------------------------- parsers
def add_force(p: argparse.ArgumentParser) -> None:
    p.add_argument("--force", action="store_true",
                   help="skip the up-front memory estimate check (also OFFROADBENCH_NO_MEMORY_CHECK=1)")


def register(sub) -> None:
    p = sub.add_parser("terrains", help="list terrain presets and generators")
    p.set_defaults(func=cmd_terrains)

    p = sub.add_parser("generate", help="generate a terrain and write a 16-bit PNG + JSON sidecar")
    p.add_argument("recipe", help="preset name (see `offroadbench terrains`) or path to a recipe .toml")
    p.add_argument("--seed", type=seed_arg, default=0, help=TERRAIN_SEED_HELP)
    p.add_argument("-o", "--output", required=True, help="output .png (NAME.json is written beside it)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a dotted recipe key, e.g. layers.base.D_high=2.6")
    p.add_argument("--clip-percentile", type=float, metavar="P", default=0.0,
                   help="clip heights to the P..100-P percentiles before writing (not in the paper; e.g. 0.1 removes "
                   "the paper presets' corner spire, so the 16-bit step follows the bulk; default 0 = keep every height)")
    add_force(p)
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("analyze", help="roughness classes of a terrain (PNG or preset)")
    p.add_argument("terrain", help="16-bit PNG heightmap, preset name or recipe .toml")
    p.add_argument("--seed", type=seed_arg, default=0, help="when TERRAIN is a preset: " + TERRAIN_SEED_HELP)
    add_plot_option(p, "the figures: hillshade beside the class map (paper Fig. 4a) at PATH, the surface "
                    "statistics at PATH_surface", "TERRAIN_seedN_classes.png (a PNG: its stem) in the working directory")
    p.add_argument("--border-m", type=float_at_least(0, "--border-m"), default=5.0, help="border excluded from the areas, m (default 5)")
    p.add_argument("--closing-radius-m", type=float_at_least(0, "--closing-radius-m"), default=0.25, help="closing disk radius, m (default 0.25)")
    p.add_argument("--clip-percentile", type=float, metavar="P", default=0.0,
                   help="clip heights to the P..100-P percentiles first (not in the paper; default 0 = keep every height)")
    p.add_argument("--cell-size-m", type=positive_float, help="cell size for a PNG without sidecar, m")
    p.add_argument("--relief-m", type=nonnegative_float, help="relief of a PNG without sidecar, m")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a dotted recipe key (presets only)")
    add_force(p)
    p.set_defaults(func=cmd_analyze)

    p = sub.add_parser("roughness-study", help="median class areas vs D (paper Fig. 5)")
    p.add_argument("--dims", type=float, nargs="+", default=[2.3, 2.45, 2.6], help="D values of the high-frequency DEM")
    p.add_argument("--terrains", type=positive_int, default=20, help="terrains per D (default 20, as the paper)")
    p.add_argument("--seed", type=seed_arg, default=0,
                   help="ROOT seed (default 0): terrain j of each D is terrain_seed(seed, j), printed in "
                   "roughness_terrains.csv (generate --seed <it> rebuilds it; offroadbench.seeding)")
    p.add_argument("--recipe", default="paper-d2.45", help="base recipe (default paper-d2.45)")
    p.add_argument("--border-m", type=float_at_least(0, "--border-m"), default=5.0, help="border excluded from the areas, m (default 5)")
    p.add_argument("--dim-key", default="layers.base.D_high", help="dotted recipe key that --dims sets")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a dotted recipe key")
    p.add_argument("--out", default="runs/roughness-study", help="output directory, created if missing (default runs/roughness-study)")
    add_plot_option(p, "the figure (median class areas against D; always written)", "--out/roughness_study.png")
    add_force(p)
    p.set_defaults(func=cmd_roughness_study)


__all__ = ["register", "format_terrain_report"]
