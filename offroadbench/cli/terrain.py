"""Terrain commands: ``terrains``, ``generate``, ``analyze``, ``roughness-study``."""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np
import pandas as pd

from offroadbench.cli._args import positive_int, seed_arg
from offroadbench.config import parse_set_value
from offroadbench.errors import InputError

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- shared helpers
def parse_sets(pairs: list[str] | None) -> dict[str, object]:
    """``["a.b=1", "c=x"]`` -> ``{"a.b": 1, "c": "x"}`` (values parsed as TOML)."""
    out: dict[str, object] = {}
    for item in pairs or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--set {item!r}: expected KEY=VALUE with a dotted TOML key, e.g. layers.base.D_high=2.6")
        out[key.strip()] = parse_set_value(value.strip())
    return out


def load_recipe_with_sets(name: str, sets: list[str] | None):
    from offroadbench.terrain.recipe import apply_overrides, load_recipe

    recipe = load_recipe(name)
    overrides = parse_sets(sets)
    return apply_overrides(recipe, overrides) if overrides else recipe


def save_figure(fig, path: str | Path) -> Path:
    """Save a matplotlib figure atomically (PNG, 150 dpi)."""
    from offroadbench.io.atomic import atomic_path

    p = Path(path)
    with atomic_path(p) as tmp:
        fig.savefig(tmp, dpi=150, format=p.suffix.lstrip(".") or "png")
    return p


def load_heightmap_arg(
    source: str, seed: int, cell_size_m: float | None = None, relief_m: float | None = None, sets: list[str] | None = None
):
    """(Heightmap, label, recipe or None) from a PNG path (16-bit, with sidecar) or a preset / recipe."""
    if source.lower().endswith(".png"):
        from offroadbench.io.png16 import read_png16

        if sets:
            raise InputError("--set applies to presets and recipes, not to a PNG heightmap")
        return read_png16(source, cell_size_m=cell_size_m, relief_m=relief_m), Path(source).stem, None
    from offroadbench.terrain.recipe import generate_terrain

    recipe = load_recipe_with_sets(source, sets)
    return generate_terrain(recipe, seed), f"{recipe.name} seed {seed}", recipe


def format_table(df: pd.DataFrame, floatfmt: str = "{:.2f}") -> str:
    return df.to_string(index=False, float_format=lambda v: floatfmt.format(v))


# --------------------------------------------------------------------------- commands
def cmd_terrains(args: argparse.Namespace) -> int:
    from offroadbench.terrain.recipe import list_presets, presets_dir
    from offroadbench.terrain.registry import TERRAIN_REGISTRY, get_spec

    presets = list_presets()
    print(f"Terrain presets ({presets_dir()}):")
    width = max((len(n) for n in presets), default=10)
    for name, desc in presets.items():
        print(f"  {name:<{width}}  {desc}")
    get_spec("wm")  # make sure every generator is registered
    print("\nGenerators and modifiers (use in recipe [layers.NAME] tables):")
    for name, spec in sorted(TERRAIN_REGISTRY.items()):
        print(f"  {name:<14} {spec.kind:<9}  {spec.summary}")
    return 0


def cmd_generate(args: argparse.Namespace) -> int:
    from offroadbench.io.png16 import sidecar_path, write_png16
    from offroadbench.terrain.recipe import generate_terrain

    recipe = load_recipe_with_sets(args.recipe, args.set)
    out = Path(args.output)
    from offroadbench.io.atomic import check_writable

    check_writable(out)  # fail before the work, not after
    t0 = time.perf_counter()
    hm = generate_terrain(recipe, args.seed)
    dt = time.perf_counter() - t0
    meta = write_png16(
        hm,
        out,
        meta={"recipe_name": recipe.name, "seed": args.seed, "terrain_id": recipe.terrain_id(args.seed), "recipe": dict(recipe.data)},
    )
    print(f"{recipe.name} seed {args.seed}: {hm.rows}x{hm.cols} at {hm.cell_size_m:g} m, relief {hm.relief_m:.3f} m, generated in {dt:.2f} s")
    for layer in recipe.layers:
        if hasattr(layer.config, "describe"):
            print(f"  layer {layer.name}: {layer.config.describe()}")
    print(f"wrote {out} and {sidecar_path(out)}")
    print(
        f"Unreal import scale: X {meta['ue_scale_x']:g}  Y {meta['ue_scale_y']:g}  Z {meta['ue_scale_z']:.4g}"
    )
    return 0


def cmd_analyze(args: argparse.Namespace) -> int:
    from offroadbench.analysis.roughness import (
        CLASS_NAMES,
        RoughnessConfig,
        class_fractions,
        classify_terrain,
        gradient_map,
    )

    if args.plot:
        from offroadbench.io.atomic import check_writable

        check_writable(args.plot)
    hm, label, recipe = load_heightmap_arg(args.terrain, args.seed, args.cell_size_m, args.relief_m, args.set)
    rcfg = RoughnessConfig(border_m=args.border_m, closing_radius_m=args.closing_radius_m)
    grad = gradient_map(hm)
    maps = classify_terrain(hm, rcfg)
    classes = maps.classes
    inside, closed_frac = maps.fractions, maps.closed_fractions
    whole = class_fractions(classes, hm.cell_size_m, 0.0)
    cell_area = hm.cell_size_m**2
    table = pd.DataFrame(
        {
            "class": CLASS_NAMES,
            "max_slope": [f"<= {rcfg.low_max_slope:.3f}", f"<= {rcfg.semi_max_slope:.3f}", f"> {rcfg.semi_max_slope:.3f}"],
            "area_pct": [100 * inside[c] for c in CLASS_NAMES],
            "area_m2": [inside[c] * _inside_cells(hm, rcfg.border_m) * cell_area for c in CLASS_NAMES],
            "whole_map_pct": [100 * whole[c] for c in CLASS_NAMES],
            "after_closing_pct": [100 * closed_frac[c] for c in CLASS_NAMES],
        }
    )
    print(f"{label}: {hm.rows}x{hm.cols} at {hm.cell_size_m:g} m ({hm.width_m:.2f} x {hm.height_m:.2f} m), "
          f"relief {hm.relief_m:.3f} m")
    print(f"Moore gradient (rise/run): median {np.median(grad):.3f}, 95th pct {np.percentile(grad, 95):.3f}, max {grad.max():.3f}")
    print(f"Roughness classes inside the {rcfg.border_m:g} m border (paper Sec. 2.3-2.4; closing disk r = {rcfg.closing_radius_m:g} m):")
    print(format_table(table))
    from offroadbench.analysis.surface import surface_summary

    surf = surface_summary(hm)
    print(
        "Surface (Horn slopes, radially averaged power spectrum): slope median {:.1f} deg, 90th pct {:.1f} deg, "
        "99th pct {:.1f} deg; steeper than 10/20/30 deg: {:.1f} / {:.1f} / {:.1f} %; PSD slope {:.2f} -> D = {:.2f}".format(
            surf["slope_p50_deg"], surf["slope_p90_deg"], surf["slope_p99_deg"],
            100 * surf["fraction_steeper_10deg"], 100 * surf["fraction_steeper_20deg"],
            100 * surf["fraction_steeper_30deg"], surf["psd_slope_beta"], surf["fractal_dimension"],
        )
    )
    diameters = _crater_diameters(recipe, args.seed)
    if diameters is not None:
        from offroadbench.analysis.surface import fit_sfd_slope

        if diameters.size >= 2:
            print(f"Craters placed: {diameters.size}, D = {diameters.min():.2f} .. {diameters.max():.2f} m, "
                  f"fitted cumulative slope k = {fit_sfd_slope(diameters):.2f}")
    if args.plot:
        from offroadbench.plots.terrain import plot_terrain_classes
        from offroadbench.plots.surface import plot_surface_analysis

        fig = plot_terrain_classes(hm, classes, fractions=inside, border_m=rcfg.border_m, title=label)
        print(f"wrote {save_figure(fig, args.plot)}")
        surf_path = Path(args.plot).with_name(Path(args.plot).stem + "_surface" + Path(args.plot).suffix)
        fig = plot_surface_analysis(hm, crater_diameters_m=diameters, title=label)
        print(f"wrote {save_figure(fig, surf_path)}")
    return 0


def _crater_diameters(recipe, seed: int):
    """Diameters (m) of the craters a recipe places, or None for a PNG or a crater-free recipe."""
    if recipe is None:
        return None
    from offroadbench.terrain.craters import recipe_craters

    tables = recipe_craters(recipe, seed)
    if not tables:
        return None
    return np.concatenate([np.asarray(t.diameter_m) for t in tables.values()])


def _inside_cells(hm, border_m: float) -> int:
    from offroadbench.analysis.roughness import border_mask

    return int(border_mask(hm.shape, border_m, hm.cell_size_m).sum())


def cmd_roughness_study(args: argparse.Namespace) -> int:
    from offroadbench.plots.terrain import plot_roughness_study
    from offroadbench.analysis.roughness import RoughnessConfig
    from offroadbench.study.roughness import (
        PAPER_FIG5_CHANGES_PP,
        roughness_study,
        summarise_roughness_study,
    )
    from offroadbench.cli._progress import bar
    from offroadbench.io.atomic import atomic_path

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory")
    recipe = load_recipe_with_sets(args.recipe, args.set)
    t0 = time.perf_counter()
    with bar("terrains", unit="terrain") as progress:
        table = roughness_study(
            recipe, args.dims, args.terrains, args.seed, dim_key=args.dim_key,
            roughness=RoughnessConfig(border_m=args.border_m), progress=progress,
        )
    summary = summarise_roughness_study(table)
    print(f"Median class areas inside the {args.border_m:g} m border, {args.terrains} terrains per D ({time.perf_counter() - t0:.1f} s):")
    print(format_table(summary))
    paper = pd.DataFrame(
        {"class": list(PAPER_FIG5_CHANGES_PP), "paper_2.3_to_2.45_pp": [v[0] for v in PAPER_FIG5_CHANGES_PP.values()],
         "paper_2.45_to_2.6_pp": [v[1] for v in PAPER_FIG5_CHANGES_PP.values()]}
    )
    print("\nPaper (Sec. 3.1), change of the median areas in percentage points:")
    print(format_table(paper))
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out {out}: cannot create directory ({exc.strerror})") from None
    with atomic_path(out / "roughness_terrains.csv") as tmp:
        table.to_csv(tmp, index=False)
    with atomic_path(out / "roughness_summary.csv") as tmp:
        summary.to_csv(tmp, index=False)
    fig = plot_roughness_study(summary, PAPER_FIG5_CHANGES_PP if len(args.dims) == 3 else None)
    save_figure(fig, out / "roughness_study.png")
    print(f"\nwrote {out}/roughness_terrains.csv, roughness_summary.csv, roughness_study.png")
    return 0


# --------------------------------------------------------------------------- parsers
def register(sub) -> None:
    p = sub.add_parser("terrains", help="list terrain presets and generators")
    p.set_defaults(func=cmd_terrains)

    p = sub.add_parser("generate", help="generate a terrain and write a 16-bit PNG + JSON sidecar")
    p.add_argument("recipe", help="preset name (see `offroadbench terrains`) or path to a recipe .toml")
    p.add_argument("--seed", type=seed_arg, default=0, help="random seed (default 0)")
    p.add_argument("-o", "--output", required=True, help="output .png (NAME.json is written beside it)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a dotted recipe key, e.g. layers.base.D_high=2.6")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("analyze", help="roughness classes of a terrain (PNG or preset)")
    p.add_argument("terrain", help="16-bit PNG heightmap, preset name or recipe .toml")
    p.add_argument("--seed", type=seed_arg, default=0, help="seed when TERRAIN is a preset (default 0)")
    p.add_argument("--plot", help="write a figure: hillshade beside the class map (paper Fig. 4a)")
    p.add_argument("--border-m", type=float, default=5.0, help="border excluded from the areas, m (default 5)")
    p.add_argument("--closing-radius-m", type=float, default=0.25, help="closing disk radius, m (default 0.25)")
    p.add_argument("--cell-size-m", type=float, help="cell size for a PNG without sidecar, m")
    p.add_argument("--relief-m", type=float, help="relief of a PNG without sidecar, m")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a dotted recipe key (presets only)")
    p.set_defaults(func=cmd_analyze)

    p = sub.add_parser("roughness-study", help="median class areas vs D (paper Fig. 5)")
    p.add_argument("--dims", type=float, nargs="+", default=[2.3, 2.45, 2.6], help="D values of the high-frequency DEM")
    p.add_argument("--terrains", type=positive_int, default=20, help="terrains per D (default 20, as the paper)")
    p.add_argument("--seed", type=seed_arg, default=0, help="root seed (default 0)")
    p.add_argument("--recipe", default="paper-d2.45", help="base recipe (default paper-d2.45)")
    p.add_argument("--border-m", type=float, default=5.0, help="border excluded from the areas, m (default 5)")
    p.add_argument("--dim-key", default="layers.base.D_high", help="dotted recipe key that --dims sets")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a dotted recipe key")
    p.add_argument("--out", default="runs/roughness-study", help="output directory (default runs/roughness-study)")
    p.set_defaults(func=cmd_roughness_study)


__all__ = ["register", "parse_sets", "save_figure", "load_heightmap_arg", "load_recipe_with_sets", "format_table"]

