"""CPU seconds per trial step of the MuJoCo paper study's trial loop, and how much of it is Python:
code trees side by side, alternated in one run.

    .venv/bin/python benchmarks/bench_trial_step.py [--tree PATH ...] [--missions 10] [--rounds 3] [--replay] [--smoke]

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

``--replay`` measures the Python alone, by replaying recorded states (:func:`replay_child`): on a
loaded machine the compiled step's CPU time swings by more than the whole Python part, the
replay's much less.

Prints figures; record them in benchmarks/RESULTS.md. Not a test. ``--smoke``: one round of both
modes, two missions, on a 161^2 map with 5 m missions (seconds; its figures mean nothing).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from _timing import run_in_tree

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


def replay_child(missions: int, rows: int | None) -> dict:
    """The trial loop's Python per trial step, replayed: the missions are driven once with every
    trial step's MuJoCo state (qpos, qvel) and wheel penetration recorded, then driven again with
    ``world.step`` loading the next recorded state instead of stepping (``world.spawn`` loading the
    settled one): the same ticks, commands, rows and rules (checked: the telemetry is the same bits),
    with no physics. Its CPU time per trial step, less the replay's own cost per step (timed alone),
    is the trial loop's Python; ``world.step``'s own Python around the compiled call is timed apart,
    with the compiled call swapped for an empty function."""
    import time


    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_study
    from offroadbench.sim import open_world
    from offroadbench.sim.engines.mujoco import _tyres_c
    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.sim.trial.runner import drive_mission

    bench_study.STUDY = ROOT / "experiments" / "majhor2023-mujoco.toml"
    tasks, _ = bench_study._tasks(1, missions, rows)
    task = tasks[1]  # D = 2.45, terrain 0
    settings = task.cell.trial_settings
    prepared = prepare_terrain(task.cell.recipe(), task.terrain_seed, settings, task.missions)
    states, spawned = [], []
    with open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim)) as world:
        d, step, spawn = world.data, world.step, world.spawn

        def recording_step() -> None:
            step()
            states.append((d.qpos.copy(), d.qvel.copy(), world.wheel_penetration_m()))

        def recording_spawn(*args, **kwargs) -> None:
            spawn(*args, **kwargs)
            spawned.append(len(states) - 1)

        world.step, world.spawn = recording_step, recording_spawn
        world.advance = None  # every trial step through world.step (the replay's Python: the loop stepping one by one)
        recorded = [drive_mission(world, m, settings=settings, classes=prepared.maps.closed).telemetry
                    for m in prepared.missions]
        at = [0]

        def load(i: int) -> None:
            at[0] = i
            q, v, _ = states[i]
            d.qpos[:] = q
            d.qvel[:] = v

        def replay_step() -> None:
            load(at[0] + 1)

        def replay_spawn(*args, **kwargs) -> None:
            load(spawned.pop(0))

        world.step, world.spawn = replay_step, replay_spawn
        world.wheel_penetration_m = lambda: states[at[0]][2]
        spawns = list(spawned)
        replayed, ends = [], []
        t0 = time.process_time()
        for m in prepared.missions:
            replayed.append(drive_mission(world, m, settings=settings, classes=prepared.maps.closed).telemetry)
            ends.append(at[0])
        cpu = time.process_time() - t0
        same = all(a.keys() == b.keys() and all(a[k].tobytes() == b[k].tobytes() for k in a)
                   for a, b in zip(recorded, replayed, strict=True))
        steps = sum(e - s for s, e in zip(spawns, ends, strict=True))  # the trial steps replayed
        load(0)
        t0 = time.process_time()
        for _ in range(len(states) - 1):
            replay_step()
        own = (time.process_time() - t0) / (len(states) - 1)
    # world.step's Python around the compiled call: the call swapped for an empty one
    _tyres_c.STEP = lambda *args: None
    with open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim)) as world:
        empty = world.step
        t0 = time.process_time()
        for _ in range(100_000):
            empty()
        step_py = (time.process_time() - t0) / 100_000
    return {"loop_python_s_per_step": cpu / steps - own, "step_python_s": step_py,
            "same_telemetry": same, "steps": steps, "spawns": len(spawns)}


def _run_child(tree: str, mode: str, args, smoke: bool) -> dict | None:
    argv = ['--child', mode, '--missions', str(args.missions)] + (['--smoke'] if smoke else [])
    return run_in_tree(tree, "bench_trial_step", argv, mode)


def _replay_rounds(trees: list[str], args, rows: int | None) -> None:
    print("tree | trial steps replayed | trial loop Python us per trial step | world.step's Python us | "
          "total Python us per trial step | replay = recorded telemetry")
    for _ in range(args.rounds):
        for tree in trees:
            r = _run_child(tree, "replay", args, rows is not None)
            if r is not None:
                loop, step = r["loop_python_s_per_step"] * 1e6, r["step_python_s"] * 1e6
                print(f"{tree} | {r['steps']} | {loop:.2f} | {step:.2f} | {loop + step:.2f} | {r['same_telemetry']}",
                      flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", action="append", default=[], help="a checkout of offroadbench (repeat); default this one")
    ap.add_argument("--missions", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--smoke", action="store_true", help="one round of both modes, two short missions on a 161^2 map (CI)")
    ap.add_argument("--replay", action="store_true", help="the trial loop's Python by replay (see replay_child)")
    ap.add_argument("--child", choices=["plain", "timed", "replay"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    rows = 161 if args.smoke else None
    if args.smoke:
        args.missions, args.rounds = 2, 1
    if args.child == "replay":
        print("RESULT " + json.dumps(replay_child(args.missions, rows)))
        return
    if args.child:
        print("RESULT " + json.dumps(child(args.missions, args.child == "timed", rows)))
        return
    from offroadbench.study.store.store import machine_description

    trees = args.tree or [str(ROOT)]
    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f}")
    if args.replay or args.smoke:  # the smoke mode runs both
        _replay_rounds(trees, args, rows)
        if args.replay:
            return
    print("tree | trial steps | CPU us per trial step (untimed) | compiled step us | Python us per trial step | digest")
    digests = set()
    for _ in range(args.rounds):
        for tree in trees:
            res = {}
            for mode in ("plain", "timed"):
                res[mode] = _run_child(tree, mode, args, args.smoke)
                if res[mode] is None:
                    break
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
