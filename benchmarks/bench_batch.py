"""Throughput of the batched MuJoCo Warp engine (issue 48): world-steps per second against the number
of worlds in a batch.

Each batch size N drives N trials at once (the smoke study's protocol: 12.8 m paper-d2.45 maps,
6 m missions, terrains 0 and 1 of root seed 7, missions drawn in turn from both) on the Warp
device given (``cpu`` here; ``cuda`` where a GPU is), through
offroadbench.sim.engines.mujoco_warp.runner.drive_batch: the trials' own code per world, the
physics of all worlds advanced together once per trial tick. Reported per N: wall time of the
batch (after a warm-up batch that compiles the kernels), MuJoCo world-steps per second (MuJoCo
steps of every world, idle ones included, over the wall time), trial steps per second
(simulated seconds of the trials, settling included, times the physics rate, over the wall time)
and host exchanges; and, for reference, the MuJoCo engine (one CPU core, the same trials one
after the other) in trial steps per second.

    .venv/bin/python benchmarks/bench_batch.py [--worlds 1,4,16,64] [--device cpu]
    .venv/bin/python benchmarks/bench_batch.py --smoke      # CI: 2 worlds, short missions; figures mean nothing

The kernels' first compile on a cold cache (``WARP_CACHE_PATH``) is timed by the warm-up batch.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import time

from offroadbench.analysis.roughness import RoughnessConfig
from offroadbench.navigation.missions import MissionConfig
from offroadbench.seeding import mission_seed, terrain_seed
from offroadbench.sim.config import SimConfig
from offroadbench.sim.trial.pipeline import TrialSettings, drive_terrain, prepare_terrain
from offroadbench.terrain.recipe import apply_overrides, load_recipe


def _prepared(n: int, length_m: float, rows: int):
    """``n`` missions drawn alternately on terrains 0 and 1 of root seed 7 (two PreparedTerrains)."""
    recipe = apply_overrides(load_recipe("paper-d2.45"), {"grid.rows": rows, "grid.cols": rows})
    settings = TrialSettings(missions=MissionConfig(count=n, length_m=length_m, border_m=1.0),
                             roughness=RoughnessConfig(border_m=1.0))
    counts = [(n + 1) // 2, n // 2]
    prepared = [prepare_terrain(recipe, terrain_seed(7, j), settings, [(k, mission_seed(7, j, k)) for k in range(c)])
                for j, c in enumerate(counts) if c]
    return prepared, settings


def _sim_steps(records, sim: SimConfig) -> int:
    """Trial steps the records simulated (each trial's time plus its settle), at the physics rate."""
    return sum(round((r.result.sim_time_s + sim.settle_time_s) * sim.physics_rate_hz) for r in records)


def main() -> None:
    from offroadbench.sim.engines.mujoco_warp.runner import drive_batch

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", default="1,4,16,64", help="batch sizes, comma-separated")
    ap.add_argument("--device", default="cpu", help="Warp device: cpu, cuda, cuda:N")
    ap.add_argument("--length", type=float, default=6.0, help="mission length, m")
    ap.add_argument("--reference", type=int, default=8, help="trials the MuJoCo engine drives for reference (0: none)")
    ap.add_argument("--smoke", action="store_true", help="2 worlds, 2 m missions on 129^2 maps (CI)")
    args = ap.parse_args()
    sizes = [2] if args.smoke else [int(v) for v in args.worlds.split(",")]
    length, rows = (2.0, 129) if args.smoke else (args.length, 257)
    base = SimConfig(engine="mujoco_warp")
    sim = dataclasses.replace(base, mujoco_warp=dataclasses.replace(base.mujoco_warp, device=args.device))
    print(f"bench_batch: {platform.processor() or platform.machine()}, device {args.device}, "
          f"{length:g} m missions on {rows}^2 maps", flush=True)
    prepared, settings = _prepared(2, length, rows)
    t0 = time.perf_counter()
    drive_batch(prepared, settings.replace(sim=sim))
    print(f"warm-up batch of 2 worlds (kernel compile on a cold cache): {time.perf_counter() - t0:.1f} s", flush=True)
    print(f"{'worlds':>6s} {'wall_s':>8s} {'world-steps/s':>13s} {'trial-steps/s':>13s} {'advances':>8s} {'ok':>5s}")
    for n in sizes:
        prepared, settings = _prepared(n, length, rows)
        t0 = time.perf_counter()
        run = drive_batch(prepared, settings.replace(sim=sim), worlds=n)
        wall = time.perf_counter() - t0
        recs = [r for rs in run.records for r in rs if not isinstance(r, BaseException)]
        ok = sum(r.result.success for r in recs)
        print(f"{n:6d} {wall:8.2f} {run.world_steps / wall:13.0f} {_sim_steps(recs, sim) / wall:13.0f} "
              f"{run.advances:8d} {ok:>2d}/{n:<2d}", flush=True)
    nref = 1 if args.smoke else args.reference
    if nref:
        prepared, settings = _prepared(nref, length, rows)
        ref = dataclasses.replace(SimConfig(), engine="mujoco")
        t0 = time.perf_counter()
        recs = [r for p in prepared for r in drive_terrain(p, settings.replace(sim=ref))]
        wall = time.perf_counter() - t0
        print(f"MuJoCo engine, {nref} trials one after the other: {_sim_steps(recs, ref) / wall:.0f} trial-steps/s "
              f"({wall:.2f} s)", flush=True)


if __name__ == "__main__":
    main()
