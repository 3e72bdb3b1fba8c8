"""Failure search: trials the falsifier and nominal (random) sampling spend to find their first k
distinct failures, over several seeds, on the same small domain.

    .venv/bin/python benchmarks/bench_search.py [--seeds 0 1 2] [--k 10] [--falsify-budget 96] \
        [--random-budget 320] [--workers 2] [--planner straight|astar] [--keep DIR] [--smoke]

The domain is experiments/failure-search.toml's (D_high ~ N(2.5, 0.1) on [2.3, 2.99], relief ~
N(3.84, 0.3) m on [3, 5], cruise speed ~ N(1, 0.1) m/s on [0.6, 1.6]) on the smoke study's small
maps (257 x 257 at 5 cm = 12.8 m, 6 m missions, 1 m border) with the straight line (``--planner astar``: A*). Each seed is
the study's root seed: it changes the optimiser's and the sampler's streams and the terrains and
missions. A stream that has not found k distinct failures within its budget counts as "> budget".
Distinct: at least ``distinct_distance`` (0.1) of a range apart in some parameter
(offroadbench.search.estimators.distinct_failures). Prints one row per seed and the medians with
their range, and P(failure) by plain Monte Carlo from the random streams (all seeds pooled).
``--smoke``: one seed, budgets 8, k = 1 (checks that the benchmark runs).
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time
from pathlib import Path

import numpy as np

from offroadbench.config import load_toml
from offroadbench.search import run_search, search_from_data
from offroadbench.search.estimators import mc_estimate
from offroadbench.search.report import first_failures, search_table

ROOT = Path(__file__).resolve().parents[1]


def domain(seed: int, method: str, budget: int, planner: str = "straight") -> dict:
    data = copy.deepcopy(load_toml(ROOT / "experiments" / "failure-search.toml"))
    data.pop("grid", None)
    data["study"].update(name=f"bench-search-{method}-{seed}", root_seed=seed)
    data["recipe_overrides"] = {"grid.rows": 257, "grid.cols": 257}
    data["roughness"] = {"border_m": 1.0}
    data["missions"] = {"length_m": 6.0, "border_m": 1.0}
    data["search"].update(methods=[method], budget=budget)
    data["planner"] = {"name": planner}
    return data


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--k", type=int, default=10)
    ap.add_argument("--falsify-budget", type=int, default=96)
    ap.add_argument("--random-budget", type=int, default=320)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--planner", default="straight", help="straight (default) or astar")
    ap.add_argument("--keep", help="keep the run directories here (default: a temporary folder)")
    ap.add_argument("--smoke", action="store_true")
    args = ap.parse_args()
    if args.smoke:
        args.seeds, args.k, args.falsify_budget, args.random_budget = args.seeds[:1], 1, 8, 8
    base = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-search-"))
    found = {"falsify": [], "random": []}
    nominal_failed = []
    for seed in args.seeds:
        row = []
        for method, budget in (("falsify", args.falsify_budget), ("random", args.random_budget)):
            plan = search_from_data(domain(seed, method, budget, args.planner), where=f"bench seed {seed}")
            out = base / f"{method}-{seed}"
            t0 = time.perf_counter()
            run_search(plan, out, executor="local", workers=args.workers)
            df, _ = search_table(out)
            n = first_failures(plan.search, df, args.k)
            found[method].append(n if np.isfinite(n) else np.inf)
            if method == "random":
                nominal_failed.extend(df["failed"].tolist())
            row.append(f"{method}: {int(df['failed'].sum())} failures in {len(df)} trials, k-th distinct at "
                       f"{'> ' + str(budget) if not np.isfinite(n) else int(n)} ({time.perf_counter() - t0:.0f} s)")
        print(f"seed {seed}: " + "; ".join(row), flush=True)
    for method, values in found.items():
        v = np.array(values, dtype=float)
        print(f"{method}: trials to {args.k} distinct failures, median {np.median(v):g} (range {v.min():g}-{v.max():g})")
    est = mc_estimate(nominal_failed)
    print(f"P(failure), nominal sampling pooled: {est.p:.4f} ({est.failures}/{est.n}; 95 % CI {est.low:.4f}-{est.high:.4f})")
    print(f"run directories: {base}")


if __name__ == "__main__":
    main()
