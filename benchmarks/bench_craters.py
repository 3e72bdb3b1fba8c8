"""Crater stamping speed: 10,000 craters on a 1009^2 map (target <= 5 s), and the enhancement steps.

Prints figures; record them in benchmarks/RESULTS.md. Not a test: nothing here asserts a time.

The population is 10,000 martin2014 craters with diameters 0.3-10 m drawn from the k = 1.8 power
law (Li et al. 2022, Eq. 21), uniform positions, random degradation, oldest first, on a 1009^2 map at 5 cm.

Usage:  python benchmarks/bench_craters.py [--repeats 3] [--count 10000] [--smoke]

``--smoke`` runs every step once on a 129^2 map with 200 craters (seconds; CI runs it so the script
cannot rot); its figures mean nothing.
"""

from __future__ import annotations

import argparse

import numpy as np
from _timing import best_of

from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.craters import CraterTable, StampOptions, inverse_cdf_diameters, stamp_craters
from offroadbench.terrain.fractal.rmd import DiamondSquareConfig, generate_diamond_square
from offroadbench.terrain.fractal.rmd import RMDExpandConfig, rmd_expand
from offroadbench.terrain.fractal.spectral import SpectralRestoreConfig, spectral_restore
from offroadbench.terrain.gaps import fill_gaps
from offroadbench.terrain.fractal.fbm import FBMConfig, generate_fbm


def population(count: int, profile: str, rng: np.random.Generator, side_m: float = 50.4) -> CraterTable:
    d = inverse_cdf_diameters(rng.random(count), 0.3, 10.0, 1.8)
    return CraterTable(
        x_m=rng.uniform(0, side_m, count), y_m=rng.uniform(0, side_m, count), diameter_m=d,
        age=rng.random(count), degradation=rng.random(count), profile=(profile,) * count,
    ).oldest_first()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--count", type=int, default=10_000)
    ap.add_argument("--smoke", action="store_true", help="every step once on a 129^2 map, 200 craters (CI)")
    args = ap.parse_args()
    n = 129 if args.smoke else 1009
    if args.smoke:
        args.count, args.repeats = 200, 1
    grid = GridConfig(rows=n, cols=n)
    side_m = n * grid.cell_size_m
    rng = np.random.default_rng(0)
    base = generate_fbm(FBMConfig(D=2.2, relief_m=0.8), grid, rng)

    rows = []
    for profile in ("martin2014", "yoshikawa", "li_fresh"):
        table = population(args.count, profile, np.random.default_rng(1), side_m)
        t = best_of(lambda table=table: stamp_craters(base, table, np.random.default_rng(2)), args.repeats)
        rows.append((f"{args.count} {profile} craters on {n}^2 (0.3-10 m, k = 1.8)", f"{t:.2f} s"))
    table = population(args.count, "martin2014", np.random.default_rng(1), side_m)
    opts = StampOptions(rim_irregularity=0.05, roughness=0.05)
    t = best_of(lambda: stamp_craters(base, table, np.random.default_rng(2), opts), args.repeats)
    rows.append((f"{args.count} martin2014 craters, irregular rims + zone roughness", f"{t:.2f} s"))

    t = best_of(lambda: generate_fbm(FBMConfig(), grid, np.random.default_rng(0)), args.repeats)
    rows.append((f"fBm {n}^2 (Fourier filtering)", f"{t:.3f} s"))
    t = best_of(lambda: generate_diamond_square(DiamondSquareConfig(), grid, np.random.default_rng(0)), args.repeats)
    rows.append((f"diamond-square {n}^2", f"{t:.3f} s"))
    m = (n - 1) // 8 + 1  # 3 RMD levels: (m - 1) * 8 + 1 = n
    coarse = generate_fbm(FBMConfig(), GridConfig(rows=m, cols=m, cell_size_m=0.4), np.random.default_rng(0))
    t = best_of(lambda: rmd_expand(RMDExpandConfig(levels=3), coarse, np.random.default_rng(0)), args.repeats)
    rows.append((f"RMD expansion {m}^2 -> {n}^2 (3 levels)", f"{t:.3f} s"))
    t = best_of(lambda: spectral_restore(SpectralRestoreConfig(cutoff_wavelength_m=1.0), base, np.random.default_rng(0)), args.repeats)
    rows.append((f"spectral restoration of {n}^2, cutoff 1 m", f"{t:.3f} s"))
    holes = np.array(base.z)
    yy, xx = np.mgrid[0:n, 0:n]
    f = n / 1009
    holes[(xx - 500 * f) ** 2 + (yy - 400 * f) ** 2 < (60 * f) ** 2] = np.nan
    holes[int(100 * f):int(110 * f) + 1, int(200 * f):int(700 * f)] = np.nan
    gaps = int(np.isnan(holes).sum())
    t = best_of(lambda: fill_gaps(holes, 0.05, 0.2, np.random.default_rng(0)), 1)
    rows.append((f"gap filling, {gaps} NaN pixels in {n}^2", f"{t:.2f} s"))

    width = max(len(r[0]) for r in rows)
    for what, fig in rows:
        print(f"{what:<{width}}  {fig}")


if __name__ == "__main__":
    main()
