"""Terrain generation speed: the paper's 1009^2 multifractal DEM (W-M by GEMM and by NUFFT, side
by side), the 60-terrain roughness study with each method, and the straightforward W-M.

Prints figures; record them in benchmarks/RESULTS.md. Not a test: nothing here asserts a time.

The straightforward evaluation is Eq. (1) term by term with numpy (one cos over the grid per
(m, n) term, as a direct transcription would do). On the full grid it would take minutes, so it
is timed on a smaller grid and a subset of terms and scaled by (grid cells x terms), which is how
its cost grows; the fast form is timed on the full problem.

The two W-M methods are timed alternately in one run (``gemm, nufft, gemm, nufft, ...``; best of
``--repeats`` each), so machine load hits both alike: compare their ratio.

Usage:  python benchmarks/bench_terrain.py [--repeats 3] [--study-terrains 20] [--smoke]

``--smoke`` runs every step once on 129^2 grids with one terrain per D (seconds; CI runs it so the
script cannot rot); its figures mean nothing.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time
from pathlib import Path

import numpy as np
from _timing import best_of

from offroadbench.analysis.roughness import classify
from offroadbench.study.roughness import roughness_study
from offroadbench.terrain.recipe import apply_overrides, load_recipe
from offroadbench.terrain.fractal.multifractal import MultifractalConfig, generate_multifractal, layer_configs
from offroadbench.terrain.fractal.wm import draw_phases, kept_harmonics, n_max_effective, wm_surface, wm_surface_direct
from offroadbench.terrain.grid import GridConfig

PAPER = GridConfig()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--study-terrains", type=int, default=20, help="terrains per D of the roughness study (0: skip)")
    ap.add_argument("--smoke", action="store_true", help="every step once on 129^2 grids, 1 terrain per D (CI)")
    args = ap.parse_args()
    grid = GridConfig(rows=129, cols=129) if args.smoke else PAPER
    if args.smoke:
        args.repeats, args.study_terrains = 1, 1
    side = grid.rows

    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}, {os.cpu_count()} cores, "
          f"python {platform.python_version()}, numpy {np.__version__}, load average {os.getloadavg()[0]:.1f}")
    results = {}
    for d in (2.3, 2.45, 2.6):
        cfg = MultifractalConfig(D_high=d)
        terms = sum(kept_harmonics(c, grid).size * c.M for c in layer_configs(cfg))
        best = {"gemm": float("inf"), "nufft": float("inf")}
        for _ in range(args.repeats):
            for method in best:
                c = dataclasses.replace(cfg, wm=dataclasses.replace(cfg.wm, method=method))
                best[method] = min(best[method], best_of(lambda c=c: generate_multifractal(c, grid, np.random.default_rng(0)), 1))
        results[d] = (best["gemm"], terms)
        print(f"multifractal {side}^2, D_high={d} ({terms} W-M terms kept): gemm {best['gemm']:.3f} s, "
              f"nufft {best['nufft']:.3f} s, ratio {best['gemm'] / best['nufft']:.1f}x")

    hm = generate_multifractal(MultifractalConfig(), grid, np.random.default_rng(0))
    t_cls = best_of(lambda: classify(hm), args.repeats)
    print(f"roughness classes {side}^2: {t_cls * 1000:.1f} ms")

    if args.study_terrains:
        recipe = load_recipe(Path(__file__).resolve().parents[1] / "terrains" / "paper-d2.45.toml")
        n = 3 * args.study_terrains
        for method in ("gemm", "nufft"):
            sets = {"layers.base.wm.method": method}
            if args.smoke:
                sets |= {"grid.rows": 257, "grid.cols": 257}  # 12.8 m: the 5 m border leaves 2.8 m
            rec = apply_overrides(recipe, sets)
            t0 = time.perf_counter()
            roughness_study(rec, (2.3, 2.45, 2.6), args.study_terrains, 0)
            wall = time.perf_counter() - t0
            print(f"roughness study, {n} terrains, method {method}: {wall:.1f} s ({wall / n * 1000:.0f} ms per terrain)")

    # straightforward per-term evaluation, timed on 1009 x 101 rows and scaled up by grid cells x terms
    cfg = MultifractalConfig(D_high=2.45)
    t_direct_full = 0.0
    strip = GridConfig(rows=max(side // 10, 3), cols=side)
    for c in layer_configs(cfg):
        n_terms = kept_harmonics(c, grid).size * c.M
        # time a slice of harmonics, then scale by the number of terms
        sub_few = dataclasses.replace(c, n_max=min(8, n_max_effective(c, grid)))
        few_terms = kept_harmonics(sub_few, strip).size * c.M
        ph = draw_phases(sub_few, strip, np.random.default_rng(0))
        t = best_of(lambda sub_few=sub_few, ph=ph: wm_surface_direct(sub_few, strip, ph), 1)
        t_direct_full += t * (n_terms / few_terms) * (side / strip.rows)
    t_fast = results[2.45][0]
    print(f"straightforward per-term numpy, scaled to {side}^2 and all kept terms: {t_direct_full:.1f} s")
    print(f"speed-up of the gemm multifractal over straightforward: {t_direct_full / t_fast:.0f}x")

    # a direct measured ratio on one W-M layer at a size that finishes
    c = dataclasses.replace(layer_configs(cfg)[0], n_max=None)
    small = GridConfig(rows=65, cols=65) if args.smoke else GridConfig(rows=201, cols=201)
    ph = draw_phases(c, small, np.random.default_rng(1))
    t_fast_small = best_of(lambda: wm_surface(c, small, ph), args.repeats)
    t_slow_small = best_of(lambda: wm_surface_direct(c, small, ph), 1)
    print(
        f"measured on {small.rows}^2, M=16, {kept_harmonics(c, small).size * 16} terms: fast {t_fast_small * 1000:.1f} ms, "
        f"straightforward {t_slow_small:.2f} s, ratio {t_slow_small / t_fast_small:.0f}x"
    )


if __name__ == "__main__":
    main()
