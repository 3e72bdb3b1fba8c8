"""MPPI speed: one control tick of the ``mppi`` policy (issue 31 target: >= 1,000 samples over a
2-3 s horizon within 20 ms per tick on one core).

Prints figures; record them in benchmarks/RESULTS.md. Not a test: nothing here asserts a time.

The map is a 1009^2 paper-d2.6-like surface at 5 cm (fBm, 0.5 m relief); the vehicle the Husky
envelope; the control rate 20 Hz, so a 2.5 s horizon is 50 steps. A tick is timed as the policy
runs it in a trial: ``act`` on a fresh observation as the vehicle moves 5 cm per tick (so the cost
window is re-computed every ``recost_every_m`` = 0.25 m, one tick in five), and separately with the
window re-computed every tick (the worst case: a new sensor map every tick). The cost-to-go (a global
Dijkstra over the planners' cost grid, once per mission on the true map, every metre under a sensor)
is timed apart; the ticks keep the one computed in the warm-up. Wall time and the
process's CPU time are printed: on a shared machine the CPU time is what one uncontended core
takes. Run it on one core:
``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_mppi.py``.

Usage:  python benchmarks/bench_mppi.py [--ticks 100] [--samples 1024] [--horizon 2.5]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time

import numpy as np

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.drivers import PolicyContext
from offroadbench.navigation.policies.mppi import MppiConfig, MppiPolicy, cost_to_go
from offroadbench.navigation.problem import PlanningProblem
from offroadbench.terrain.fractal.fbm import FBMConfig, generate_fbm
from offroadbench.terrain.grid import GridConfig


def terrain() -> Heightmap:
    hm = generate_fbm(FBMConfig(D=2.6, relief_m=0.5), GridConfig(rows=1009, cols=1009, cell_size_m=0.05), np.random.default_rng(0))
    return hm


def run(policy: MppiPolicy, hm: Heightmap, ticks: int, fresh_map: bool) -> tuple[np.ndarray, np.ndarray]:
    """Wall and CPU (this process's) milliseconds of each tick."""
    problem = PlanningProblem(hm=hm, classes=None, start_xy=(10.0, 10.0), goal_xy=(40.0, 40.0))
    policy.reset(problem)
    wall, cpu = [], []
    pose = np.array([10.0, 10.0, 0.785])
    for _ in range(ticks):
        z = hm.z.copy() if fresh_map else hm.z  # a new array object: the policy re-computes its window
        t0, c0 = time.perf_counter(), time.process_time()
        v, w = policy.act({"pose": pose, "elevation_m": z})
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        pose = pose + [v * 0.05 * np.cos(pose[2]), v * 0.05 * np.sin(pose[2]), w * 0.05]
    return np.array(wall) * 1e3, np.array(cpu) * 1e3


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--ticks", type=int, default=100)
    ap.add_argument("--samples", type=int, default=1024)
    ap.add_argument("--horizon", type=float, default=2.5)
    ap.add_argument("--smoke", action="store_true", help="5 ticks of each case (CI: the script cannot rot)")
    args = ap.parse_args()
    if args.smoke:
        args.ticks = 5
    hm = terrain()
    cfg = MppiConfig(samples=args.samples, horizon_s=args.horizon)
    policy = MppiPolicy(cfg, PolicyContext())
    cpu = platform.processor() or platform.machine()
    print(f"machine: {cpu}, {os.cpu_count()} cpus visible, load average {os.getloadavg()[0]:.1f}, numpy {np.__version__}")
    print(f"mppi: {cfg.samples} samples x {policy.steps} steps ({cfg.horizon_s} s at 20 Hz), map 1009^2 at 5 cm")
    problem = PlanningProblem(hm=hm, classes=None, start_xy=(10.0, 10.0), goal_xy=(40.0, 40.0))
    t0, c0 = time.perf_counter(), time.process_time()
    cost_to_go(problem, cfg.cost_to_go_grid_m)
    print(f"  cost-to-go on the 1009^2 map (footprint hazard + Dijkstra): wall {time.perf_counter() - t0:.2f} s, "
          f"cpu {time.process_time() - c0:.2f} s")
    t0, c0 = time.perf_counter(), time.process_time()
    cost_to_go(problem, cfg.cost_to_go_grid_m)
    print(f"  again, hazard cached for the map: wall {time.perf_counter() - t0:.2f} s, cpu {time.process_time() - c0:.2f} s")
    for label, fresh in (("moving, window every 0.25 m", False), ("new map every tick", True)):
        # the cost-to-go is the global step (once per mission on the true map; every metre under a
        # sensor), timed on its own below: here it is computed in the warm-up and kept
        policy = MppiPolicy(dataclasses.replace(cfg, cost_to_go_every_m=1e9), PolicyContext())
        run(policy, hm, 5, fresh)  # warm up
        wall, cpu = (a[1:] for a in run(policy, hm, args.ticks + 1, fresh))  # tick 0: the mission's cost-to-go
        for kind, ms in (("wall", wall), ("cpu", cpu)):
            print(f"  {label:30s} {kind:4s} median {np.median(ms):6.2f} ms  p90 {np.percentile(ms, 90):6.2f} ms  "
                  f"max {ms.max():6.2f} ms per tick ({args.ticks} ticks)")


if __name__ == "__main__":
    main()
