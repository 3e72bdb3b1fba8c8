"""CPU seconds per trial step of the MuJoCo paper study's trial loop, and how much of it is Python:
code trees side by side, alternated in one run.

    .venv/bin/python benchmarks/bench_trial_step.py [--tree PATH ...] [--missions 10] [--rounds 3] [--smoke]

Each tree (default: this checkout; e.g. a ``git archive`` of an older commit to compare with) runs
in fresh processes, one after the other, ``--rounds`` times: each prepares the MuJoCo paper study's
first terrain of D = 2.45 (``experiments/majhor2023-mujoco.toml``), builds its world, drives its
first mission once (warm-up: numba's kernels, the first allocations) and then ``--missions``
missions, timed by the process's CPU clock (user + system; the terrain and world are not counted).
A second process of the same tree does the same with the compiled trial step (``_tyres_c.STEP``)
timed around each call (this thread's CPU clock, less the timer's own cost measured on an empty call),
and the rest of that process's CPU time, less the timing wrapper's own cost, is the Python of the
trial loop (both per trial step, including the settling at each spawn). The first process's CPU
time per trial step has no timer in it; the split comes from the second, on the same trials. Also printed: the trial steps driven and a
digest of the trials' rows and telemetry, which must be the same for every tree.

Prints figures; record them in benchmarks/RESULTS.md. Not a test. ``--smoke``: one round, two
missions, on a 161^2 map with 5 m missions (seconds; its figures mean nothing).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def child(missions: int, timed: bool, rows: int | None) -> dict:
    """In this (fresh) process, with the tree first on sys.path."""
    import hashlib
    import time

    import numpy as np

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_study
    from offroadbench.sim import open_world
    from offroadbench.sim.engines.mujoco import _tyres_c
    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.sim.trial.runner import drive_mission

    compiled = [0.0, 0]
    if timed:
        step, clock = _tyres_c.STEP, time.thread_time

        def timed_step(*args):
            t = clock()
            step(*args)
            compiled[0] += clock() - t
            compiled[1] += 1

        def empty(*args):
            t = clock()
            compiled[0] += clock() - t

        _tyres_c.STEP = timed_step
        t0 = time.process_time()
        for _ in range(100_000):
            empty(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13)
        wrapper_s = (time.process_time() - t0) / 100_000  # the whole wrapper, per call
        timer_s = compiled[0] / 100_000  # what of it falls inside the timed window
        compiled[0] = 0.0
    bench_study.STUDY = ROOT / "experiments" / "majhor2023-mujoco.toml"
    tasks, _ = bench_study._tasks(1, missions + 1, rows)
    task = tasks[1]  # D = 2.45, terrain 0
    settings = task.cell.trial_settings
    prepared = prepare_terrain(task.cell.recipe(), task.terrain_seed, settings, task.missions)
    digest = hashlib.sha256()
    with open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim)) as world:
        drive_mission(world, prepared.missions[0], settings=settings, classes=prepared.maps.closed)
        compiled[:] = [0.0, 0]
        steps = 0
        t0 = time.process_time()
        for m in prepared.missions[1:]:
            rec = drive_mission(world, m, settings=settings, classes=prepared.maps.closed)
            steps += round(rec.result.sim_time_s * world.sim.physics_rate_hz)
            digest.update(repr(rec.result).encode())
            for name in sorted(rec.telemetry):
                digest.update(np.ascontiguousarray(rec.telemetry[name]).tobytes())
        cpu = time.process_time() - t0
    out = {"cpu_s": cpu, "steps": steps, "digest": digest.hexdigest()[:12]}
    if timed:
        out["compiled_s"] = compiled[0] - compiled[1] * timer_s
        out["python_s"] = cpu - compiled[0] - compiled[1] * (wrapper_s - timer_s)  # the wrapper is not the loop's
        out["compiled_calls"] = compiled[1]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", action="append", default=[], help="a checkout of offroadbench (repeat); default this one")
    ap.add_argument("--missions", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--smoke", action="store_true", help="one round of two short missions on a 161^2 map (CI)")
    ap.add_argument("--child", choices=["plain", "timed"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    rows = 161 if args.smoke else None
    if args.smoke:
        args.missions, args.rounds = 2, 1
    if args.child:
        print("RESULT " + json.dumps(child(args.missions, args.child == "timed", rows)))
        return
    from offroadbench.study.store.store import machine_description

    trees = args.tree or [str(ROOT)]
    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f}")
    print("tree | trial steps | CPU us per trial step (untimed) | compiled step us | Python us per trial step | digest")
    digests = set()
    for _ in range(args.rounds):
        for tree in trees:
            res = {}
            for mode in ("plain", "timed"):
                code = (f"import sys; sys.path.insert(0, {tree!r}); sys.argv[1:] = {['--child', mode, '--missions', str(args.missions)] + (['--smoke'] if args.smoke else [])!r}; "
                        f"sys.path.insert(1, {str(ROOT / 'benchmarks')!r}); import bench_trial_step; bench_trial_step.main()")
                out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tree)
                line = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT ")]
                if out.returncode or not line:
                    print(f"{tree} ({mode}): failed\n{out.stderr[-2000:]}")
                    break
                res[mode] = json.loads(line[0][7:])
            else:
                plain, timed = res["plain"], res["timed"]
                per = plain["cpu_s"] / plain["steps"] * 1e6
                comp = timed["compiled_s"] / timed["steps"] * 1e6  # the settling's steps too, as in cpu_s
                py = timed["python_s"] / timed["steps"] * 1e6
                digests.update((plain["digest"], timed["digest"]))
                print(f"{tree} | {plain['steps']} | {per:.1f} | {comp:.1f} | {py:.1f} | {plain['digest']}", flush=True)
    print(f"same trials for every tree: {len(digests) == 1}")


if __name__ == "__main__":
    main()
