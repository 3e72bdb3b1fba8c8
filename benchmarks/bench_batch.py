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
host exchanges, and the CPU seconds of the process (all threads) with world-steps per CPU
second (the figure to compare on a shared machine); the host's share of the wall time (``host_s``:
the wall time outside the batch's advances, i.e. the trials' per-tick code in their slots and its
scheduling) and that per world and advance (``host_us/world``, idle worlds counted) and per busy
world's trial tick (``ticks``, ``host_us/tick``: what bounds a GPU's throughput, where the advances
themselves cost little; a world whose trial has ended costs the host nothing); and, for reference, the MuJoCo engine (one CPU core,
the same trials one after the other) in trial steps per second.

    .venv/bin/python benchmarks/bench_batch.py [--worlds 1,4,16,64] [--device cpu] [--tyre-model terramechanics]
    .venv/bin/python benchmarks/bench_batch.py --smoke      # CI: 2 worlds, short missions; figures mean nothing

``--hash`` adds a digest of each batch's rows and telemetry (give the same N twice to see whether
the device repeats itself); ``--cuda-graph off`` launches the trial step's kernels one by one on a
CUDA device instead of as the captured graph.

``--lunar`` drives on the lunar-soil study's maps (lunar-mare with its relief and craters, lunar
regolith and the Moon's gravity from the recipe) in place of paper-d2.45's.
``--tyre-model terramechanics`` runs every engine with the soil law (Wong-Reece forces on the
default soil, offroadbench.sim.engines.mujoco_warp.soil_kernels on the batch) in place of the
``coulomb`` tyres; ``--compare`` then also compares the median sinkage and the mean slip.

The warm-up batch times the kernels' compile where they are not cached yet (a fresh
``WARP_CACHE_PATH``: the cold compile).

``--compare N`` instead drives N missions (half on each terrain) three ways, trial by trial: the
MuJoCo engine, the MuJoCo engine with a 0.1 mm higher spawn (the chaos yardstick of
``bench_sim.py --paired``: the closed loop's own run-to-run spread) and one batch of N worlds; it
prints each trial's outcome and ride metrics, the outcome flips against the MuJoCo engine, and per
ride metric the median over the trials both finished of |log(other / MuJoCo)| and of the ratio
(what tests/sim/test_mujoco_warp.py holds a batch of 8 to).

    .venv/bin/python benchmarks/bench_batch.py --compare 20

``--contacts N`` counts the wheels' terrain contacts in both engines (MuJoCo Warp keeps at most 4
per geom pair, MuJoCo up to 50; the tyre tuning counted on 4-5 a wheel): N missions, each vehicle
spawned at its start and driven straight at 3 rad/s for 2 s, the contacts of each MuJoCo step's
last substep counted per wheel that has any.

    .venv/bin/python benchmarks/bench_batch.py --contacts 8
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


#: ``--lunar``: the lunar-soil study's maps (experiments/lunar-soil.toml's recipe overrides but the grid)
LUNAR = ("lunar-mare", {"layers.base.relief_m": 0.6, "layers.craters.population.d_max_m": 6.0})
RECIPE = ("paper-d2.45", {})


def _prepared(n: int, length_m: float, rows: int, recipe: tuple = RECIPE):
    """``n`` missions drawn alternately on terrains 0 and 1 of root seed 7 (two PreparedTerrains)."""
    name, overrides = recipe
    loaded = apply_overrides(load_recipe(name), {"grid.rows": rows, "grid.cols": rows, **overrides})
    settings = TrialSettings(missions=MissionConfig(count=n, length_m=length_m, border_m=1.0),
                             roughness=RoughnessConfig(border_m=1.0))
    counts = [(n + 1) // 2, n // 2]
    prepared = [prepare_terrain(loaded, terrain_seed(7, j), settings, [(k, mission_seed(7, j, k)) for k in range(c)])
                for j, c in enumerate(counts) if c]
    return prepared, settings


def _sim_steps(records, sim: SimConfig) -> int:
    """Trial steps the records simulated (each trial's time plus its settle), at the physics rate."""
    return sum(round((r.result.sim_time_s + sim.settle_time_s) * sim.physics_rate_hz) for r in records)


def _digest(records) -> str:
    """16 hex digits of SHA-256 over the batch's results and telemetry, in mission order (a trial's
    exception by its text)."""
    import hashlib

    import numpy as np

    h = hashlib.sha256()
    for rs in records:
        for r in rs:
            if isinstance(r, BaseException):
                h.update(repr(r).encode())
                continue
            h.update(repr(r.result).encode())
            for k in sorted(r.telemetry):
                h.update(np.ascontiguousarray(r.telemetry[k]).tobytes())
    return h.hexdigest()[:16]


METRICS = ("rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s")


def compare(n: int, length: float, rows: int, sim: SimConfig, recipe: tuple = RECIPE) -> None:
    """The trial-by-trial comparison of ``--compare``."""
    import math

    import numpy as np

    from offroadbench.sim.engines.mujoco_warp.runner import drive_batch

    prepared, settings = _prepared(n, length, rows, recipe)
    runs = {}
    soil = sim.tyre_model == "terramechanics"
    metrics = METRICS + (("sinkage_median_m", "mean_slip") if soil else ())
    mujoco = SimConfig(engine="mujoco", tyre_model=sim.tyre_model)
    for name, variant in (("mujoco", mujoco), ("mujoco+0.1mm", dataclasses.replace(mujoco, spawn_clearance_m=0.0201))):
        runs[name] = [r.result for p in prepared for r in drive_terrain(p, settings.replace(sim=variant))]
    batch = drive_batch(prepared, settings.replace(sim=sim), worlds=n)
    runs["mujoco_warp"] = [r.result for rs in batch.records for r in rs]
    for name, res in runs.items():
        print(f"{name}: " + " ".join(r.failure_reason or "ok" for r in res), flush=True)
    ref = runs["mujoco"]
    print(f"{'variant':14s} {'flips':>5s} " + " ".join(f"{m[:14]:>14s} |log| {'ratio':>6s}" for m in metrics))
    for name in ("mujoco+0.1mm", "mujoco_warp"):
        res = runs[name]
        flips = sum(a.failure_reason != b.failure_reason for a, b in zip(ref, res, strict=True))
        both = [(a, b) for a, b in zip(ref, res, strict=True) if a.success and b.success]
        cols = []
        for m in metrics:
            ratios = [getattr(b, m) / getattr(a, m) for a, b in both]
            cols.append(f"{np.median([abs(math.log(x)) for x in ratios]):20.2e} {np.median(ratios):6.3f}")
        print(f"{name:14s} {flips:5d} " + " ".join(cols) + f"   ({len(both)} trials both finished)", flush=True)


def contacts(n: int, length: float, rows: int, sim: SimConfig, recipe: tuple = RECIPE) -> None:
    """The contact count of ``--contacts``."""
    import numpy as np

    from offroadbench.sim.engine import open_world

    prepared, _ = _prepared(n, length, rows, recipe)
    for name, variant in (("mujoco", SimConfig(engine="mujoco", tyre_model=sim.tyre_model)), ("mujoco_warp", sim)):
        counts = []
        for p in prepared:
            with open_world(p.hm, "husky", variant) as world:
                model = world.model if name == "mujoco" else world.batch.model.model
                wheels = [g for g in range(model.ngeom) if model.geom(g).name.startswith("wheel_")]
                for m in p.missions:
                    world.spawn(*m.start_xy_m, m.heading_rad)
                    for _ in range(2 * variant.physics_rate_hz):
                        world.command_wheels(3.0, 3.0)
                        world.step()
                        world.base_state()  # the lazy world runs its step here
                        if name == "mujoco":
                            geoms = world.data.contact.geom[:world.data.ncon]
                        else:
                            d = world.batch.d
                            geoms = d.contact.geom.numpy()[:int(d.nacon.numpy()[0])]
                        per = [int(np.sum(np.any(geoms == g, axis=1))) for g in wheels]
                        counts += [c for c in per if c]
        counts = np.array(counts)
        print(f"{name:12s} contacts per touching wheel: mean {counts.mean():.2f}, median {np.median(counts):.0f}, "
              f"max {counts.max()}; {len(counts)} wheel-steps", flush=True)


def main() -> None:
    import importlib.util
    import sys

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", default="1,4,16,64", help="batch sizes, comma-separated")
    ap.add_argument("--device", default="cpu", help="Warp device: cpu, cuda, cuda:N")
    ap.add_argument("--length", type=float, default=6.0, help="mission length, m")
    ap.add_argument("--reference", type=int, default=8, help="trials the MuJoCo engine drives for reference (0: none)")
    ap.add_argument("--smoke", action="store_true", help="2 worlds, 2 m missions on 129^2 maps (CI)")
    ap.add_argument("--contacts", type=int, default=0, help="count the wheels' contacts in both engines, N missions")
    ap.add_argument("--compare", type=int, default=0, help="trial-by-trial comparison with the MuJoCo engine, N trials")
    ap.add_argument("--lunar", action="store_true",
                    help="the lunar-soil study's maps (lunar-mare: regolith and the Moon's gravity from the recipe)")
    ap.add_argument("--hash", action="store_true",
                    help="print a digest of each batch's rows and telemetry (the same N twice: is the device deterministic?)")
    ap.add_argument("--cuda-graph", default="on", choices=("on", "off"),
                    help="[sim.mujoco_warp] cuda_graph on a CUDA device (default on)")
    ap.add_argument("--tyre-model", default="coulomb", choices=("coulomb", "terramechanics"),
                    help="the tyre model of every engine (terramechanics: the soil law on the default soil)")
    args = ap.parse_args()
    recipe = LUNAR if args.lunar else RECIPE
    if importlib.util.find_spec("mujoco_warp") is None:
        # the engine is an optional extra: CI installs it only where its kernels' cold compile (~2 min) fits
        print("bench_batch: mujoco_warp is not installed (pip install 'offroadbench[warp]'); nothing measured",
              file=sys.stderr)
        sys.exit(0 if args.smoke else 2)
    from offroadbench.sim.engines.mujoco_warp.runner import drive_batch

    sizes = [2] if args.smoke else [int(v) for v in args.worlds.split(",")]
    length, rows = (2.0, 129) if args.smoke else (args.length, 257)
    base = SimConfig(engine="mujoco_warp", tyre_model=args.tyre_model)
    sim = dataclasses.replace(base, mujoco_warp=dataclasses.replace(base.mujoco_warp, device=args.device,
                                                                    cuda_graph=args.cuda_graph == "on"))
    print(f"bench_batch: {platform.processor() or platform.machine()}, device {args.device}, "
          f"{length:g} m missions on {rows}^2 {recipe[0]} maps, tyre model {args.tyre_model}", flush=True)
    if args.compare:
        compare(args.compare, length, rows, sim, recipe)
        return
    if args.contacts:
        contacts(args.contacts, length, rows, sim, recipe)
        return
    prepared, settings = _prepared(2, length, rows, recipe)
    t0 = time.perf_counter()
    drive_batch(prepared, settings.replace(sim=sim))
    print(f"warm-up batch of 2 worlds (compiles the kernels not yet cached): {time.perf_counter() - t0:.1f} s",
          flush=True)
    print(f"{'worlds':>6s} {'wall_s':>8s} {'world-steps/s':>13s} {'trial-steps/s':>13s} {'advances':>8s} {'ok':>5s} "
          f"{'cpu_s':>8s} {'world-steps/cpu-s':>17s} {'host_s':>7s} {'host_us/world':>14s} {'ticks':>7s} {'host_us/tick':>12s}" + (" digest" if args.hash else ""))
    for n in sizes:
        prepared, settings = _prepared(n, length, rows, recipe)
        t0, c0 = time.perf_counter(), time.process_time()
        run = drive_batch(prepared, settings.replace(sim=sim), worlds=n)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        recs = [r for rs in run.records for r in rs if not isinstance(r, BaseException)]
        ok = sum(r.result.success for r in recs)
        host = wall - run.advance_s
        print(f"{n:6d} {wall:8.2f} {run.world_steps / wall:13.0f} {_sim_steps(recs, sim) / wall:13.0f} "
              f"{run.advances:8d} {ok:>2d}/{n:<2d} {cpu:8.2f} {run.world_steps / cpu:17.0f} {host:7.2f} "
              f"{1e6 * host / (run.advances * n):14.1f} {run.ticks:7d} {1e6 * host / run.ticks:12.1f}" + (f" {_digest(run.records)}" if args.hash else ""), flush=True)
    nref = 1 if args.smoke else args.reference
    if nref:
        prepared, settings = _prepared(nref, length, rows, recipe)
        ref = SimConfig(engine="mujoco", tyre_model=args.tyre_model)
        t0 = time.perf_counter()
        recs = [r for p in prepared for r in drive_terrain(p, settings.replace(sim=ref))]
        wall = time.perf_counter() - t0
        print(f"MuJoCo engine, {nref} trials one after the other: {_sim_steps(recs, ref) / wall:.0f} trial-steps/s "
              f"({wall:.2f} s)", flush=True)


if __name__ == "__main__":
    main()
