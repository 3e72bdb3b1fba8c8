"""Crater stamping speed: 10,000 craters on a 1009^2 map (target <= 5 s), and the enhancement steps.

Prints figures; record them in benchmarks/RESULTS.md. Not a test: nothing here asserts a time.

The population is 10,000 martin2014 craters with diameters 0.3-10 m drawn from the k = 1.8 power
law (Li et al. 2022, Eq. 21), uniform positions, random degradation, oldest first, on a 1009^2 map at 5 cm.

Usage:  python benchmarks/bench_craters.py [--repeats 3] [--count 10000]
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


def population(count: int, profile: str, rng: np.random.Generator) -> CraterTable:
    d = inverse_cdf_diameters(rng.random(count), 0.3, 10.0, 1.8)
    return CraterTable(
        x_m=rng.uniform(0, 50.4, count), y_m=rng.uniform(0, 50.4, count), diameter_m=d,
        age=rng.random(count), degradation=rng.random(count), profile=(profile,) * count,
    ).oldest_first()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--count", type=int, default=10_000)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    base = generate_fbm(FBMConfig(D=2.2, relief_m=0.8), GridConfig(rows=1009, cols=1009), rng)

    rows = []
    for profile in ("martin2014", "yoshikawa", "li_fresh"):
        table = population(args.count, profile, np.random.default_rng(1))
        t = best_of(lambda: stamp_craters(base, table, np.random.default_rng(2)), args.repeats)
        rows.append((f"{args.count} {profile} craters on 1009^2 (0.3-10 m, k = 1.8)", f"{t:.2f} s"))
    table = population(args.count, "martin2014", np.random.default_rng(1))
    opts = StampOptions(rim_irregularity=0.05, roughness=0.05)
    t = best_of(lambda: stamp_craters(base, table, np.random.default_rng(2), opts), args.repeats)
    rows.append((f"{args.count} martin2014 craters, irregular rims + zone roughness", f"{t:.2f} s"))

    t = best_of(lambda: generate_fbm(FBMConfig(), GridConfig(rows=1009, cols=1009), np.random.default_rng(0)), args.repeats)
    rows.append(("fBm 1009^2 (Fourier filtering)", f"{t:.3f} s"))
    t = best_of(lambda: generate_diamond_square(DiamondSquareConfig(), GridConfig(), np.random.default_rng(0)), args.repeats)
    rows.append(("diamond-square 1009^2 (from 1025^2)", f"{t:.3f} s"))
    coarse = generate_fbm(FBMConfig(), GridConfig(rows=127, cols=127, cell_size_m=0.4), np.random.default_rng(0))
    t = best_of(lambda: rmd_expand(RMDExpandConfig(levels=3), coarse, np.random.default_rng(0)), args.repeats)
    rows.append(("RMD expansion 127^2 -> 1009^2 (3 levels)", f"{t:.3f} s"))
    t = best_of(lambda: spectral_restore(SpectralRestoreConfig(cutoff_wavelength_m=1.0), base, np.random.default_rng(0)), args.repeats)
    rows.append(("spectral restoration of 1009^2, cutoff 1 m", f"{t:.3f} s"))
    holes = np.array(base.z)
    yy, xx = np.mgrid[0:1009, 0:1009]
    holes[(xx - 500) ** 2 + (yy - 400) ** 2 < 60**2] = np.nan
    holes[100:110, 200:700] = np.nan
    gaps = int(np.isnan(holes).sum())
    t = best_of(lambda: fill_gaps(holes, 0.05, 0.2, np.random.default_rng(0)), 1)
    rows.append((f"gap filling, {gaps} NaN pixels in 1009^2", f"{t:.2f} s"))

    width = max(len(r[0]) for r in rows)
    for what, fig in rows:
        print(f"{what:<{width}}  {fig}")


if __name__ == "__main__":
    main()
