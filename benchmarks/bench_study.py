"""Study throughput: store commits, and the paper study (experiments/majhor2023.toml) with 1 and 2 workers.

    .venv/bin/python benchmarks/bench_study.py [--terrains 2] [--missions 20] [--workers 1 2]

Runs the paper study cut to ``--terrains`` terrains per D (same seeds, same first terrains as
the full study) with each worker count, and prints wall time, trials per second and the wall
time of the full 1200-trial study extrapolated from it (the study is a sum of independent
terrain tasks, so time grows with their number). The full study itself records its wall time
in its report (experiments/results/majhor2023/).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from offroadbench.study import load, load_study, run_study  # noqa: E402
from offroadbench.study.spec import plan_cells  # noqa: E402
from offroadbench.study.store import Store, machine_description  # noqa: E402


def bench_store(n: int = 5000) -> float:
    """Seconds per committed trial row (one transaction each)."""
    row = {"mission_index": 0, "success": True, "failure_reason": "", **{f"m{i}": 1.2345 for i in range(16)}}
    with tempfile.TemporaryDirectory() as d, Store(d, create=True) as store:
        t0 = time.perf_counter()
        for k in range(n):
            store.add_trial(0, k // 20, k % 20, 1, 2, row)
        return (time.perf_counter() - t0) / n


def bench_paper(terrains: int, missions: int, workers: int) -> tuple[float, int, int, int]:
    study, _ = load_study(ROOT / "experiments" / "majhor2023.toml")
    full = study.n_trials
    study = dataclasses.replace(study, terrains_per_cell=terrains, missions_per_terrain=missions)
    cells = plan_cells(study)
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        run_study(study, cells, d, executor="local", workers=workers)
        wall = time.perf_counter() - t0
        ok = int(load(d)["success"].sum())
    return wall, study.n_trials, full, ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--terrains", type=int, default=2, help="terrains per D (full study: 20)")
    ap.add_argument("--missions", type=int, default=20, help="missions per terrain (full study: 20)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    print(f"machine: {machine_description()}")
    print(f"store: {bench_store() * 1e6:.0f} us per committed trial")
    for w in args.workers:
        wall, n, full, ok = bench_paper(args.terrains, args.missions, w)
        print(
            f"paper study, {args.terrains} terrains x 3 D x {args.missions} missions = {n} trials, {w} worker(s): "
            f"{wall:.1f} s ({n / wall:.2f} trials/s, {ok} successes); full {full} trials extrapolated: "
            f"{wall * full / n / 60:.1f} min"
        )


if __name__ == "__main__":
    main()
