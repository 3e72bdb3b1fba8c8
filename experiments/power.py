"""Power of the planner-stress study's confirmatory tests, by simulation (issue 29).

The test is the one the study's plan uses: the exact two-sided sign-flip test of the mean per-terrain
difference, at Holm's strictest level alpha / m (m = the plan's tests; the power of the first Holm
step, a lower bound for the later ones). The effects are the pilot's per-terrain
differences, resampled as the truth (offroadbench.study.clustered.sign_flip_power). The pilot is the
planner-stress run of 2026-11-25 (root_seed 11, 12 terrains x 8 missions per cell), kept as its
per-terrain success counts in experiments/pilots/planner-stress-2026-11-25.csv so that the design's
justification does not change when the study is re-run.

    python experiments/power.py [--n-sim 400]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from offroadbench.study.clustered import sign_flip_power

HERE = Path(__file__).resolve().parent
#: (name, planner, D_high, band_limited, map_noise_m) of treatment and control: the plan's tests
TESTS = [
    ("astar - straight, 2.95", ("astar", 2.95, False, 0.0), ("straight", 2.95, False, 0.0)),
    ("astar - straight, 2.99", ("astar", 2.99, False, 0.0), ("straight", 2.99, False, 0.0)),
    ("lattice - straight, 2.95", ("lattice", 2.95, False, 0.0), ("straight", 2.95, False, 0.0)),
    ("lattice - straight, 2.99", ("lattice", 2.99, False, 0.0), ("straight", 2.99, False, 0.0)),
    ("straight: band-limited - aliased, 2.95", ("straight", 2.95, True, 0.0), ("straight", 2.95, False, 0.0)),
    ("straight: band-limited - aliased, 2.99", ("straight", 2.99, True, 0.0), ("straight", 2.99, False, 0.0)),
]
#: not in the plan: its effect (about -6 points, sd 17) needs far more terrains than any design here
NOT_PLANNED = [("astar: 5 cm map error - true map, 2.99", ("astar", 2.99, False, 0.05), ("astar", 2.99, False, 0.0))]
COLS = ["planner", "D_high", "band_limited", "map_noise_m"]


PILOT = HERE / "pilots" / "planner-stress-2026-11-25.csv"


def load_pilot() -> pd.DataFrame:
    """The pilot's per-terrain table: the axes, terrain, terrain_seed, successes and missions."""
    return pd.read_csv(PILOT)


def per_terrain(pilot: pd.DataFrame, cell: tuple) -> pd.Series:
    """Success rate (percent) per terrain of one cell of the pilot."""
    t = pilot
    for col, v in zip(COLS, cell, strict=True):
        t = t[np.isclose(t[col], v)] if isinstance(v, float) else t[t[col] == v]
    return 100.0 * (t.set_index("terrain")["successes"] / t.set_index("terrain")["missions"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-sim", type=int, default=400)
    ap.add_argument("--alpha", type=float, default=0.05)
    args = ap.parse_args()
    trials = load_pilot()
    level = args.alpha / len(TESTS)
    rng = np.random.default_rng(29)
    print(f"exact sign-flip test at alpha / m = {args.alpha} / {len(TESTS)} = {level:.4f} (pilot: 12 terrains)")
    print(f"{'test':42s} {'mean':>6s} {'sd':>6s}  power at K = 8 / 12 / 16 / 20 / 24")
    for name, tr, co in TESTS + NOT_PLANNED:
        d = (per_terrain(trials, tr) - per_terrain(trials, co)).dropna().to_numpy()
        powers = [sign_flip_power(d, k, level, rng, n_sim=args.n_sim) for k in (8, 12, 16, 20, 24)]
        note = "" if (name, tr, co) in TESTS else "  (not in the plan)"
        print(f"{name:42s} {d.mean():6.1f} {d.std(ddof=1):6.1f}  " + " / ".join(f"{p:.2f}" for p in powers) + note)


if __name__ == "__main__":
    main()
