"""The trial runner's per-tick Python, apart from the physics: CPU microseconds per control tick of
trial code (offroadbench.sim.trial.runner and what it calls: tracker, speed loop, steering, rules,
sensing, telemetry rows) and of the engine's calls, and a digest of the trials' bits.

    .venv/bin/python benchmarks/bench_tick.py [--case NAME ...] [--missions 6] [--rounds 3]
                                              [--tree PATH ...] [--profile] [--digest] [--smoke]

Each case (``--case``, default ``mujoco-husky-coulomb-straight``; ``--digest`` runs all of
:data:`CASES`) drives ``--missions`` missions of about 8 m on a 12 m x 12 m map of sine waves
(roll, pitch and yaw all move) in one world, after one warm-up mission. The world's engine
calls (``step``, ``advance``, ``spawn``, ``base_state``, ``rotation_matrix``, the wheel reads and
commands) are wrapped and timed with the thread's CPU clock, less the wrapper's own cost measured on
an empty call; the planner's call (``plan_within_limits``) likewise. The rest of the missions' CPU
time is the trial code. Both are given per control tick (the ticks at which a command was sent),
and the trial code also per trial step (physics step of the runner). Each tree (``--tree``, default
this checkout: e.g. a ``git worktree`` of main to compare with) runs in its own fresh process, the
trees alternated ``--rounds`` times, so a before/after comparison shares the machine's moments.

``--stub``: the trial loop alone, for the default case's vehicle (the Husky on MuJoCo): a world
whose physics calls are stubs returning a canned state that moves 0.1 mm per tick (no physics, no
engine Python), 20,000 control ticks of the runner's loop as :func:`drive_mission` runs it (oracle
sensing, the line tracker, command, record, step to the next control tick), CPU microseconds per
control tick per tree: the cleanest figure of the per-tick Python (what wrapper timing cannot
resolve on a loaded machine).

``--scan``: the mast sensor's scan (offroadbench.navigation.sensor.MastSensor, default settings: 8 m
range) at 20 positions on a 1009^2 map at 5 cm (the paper's size), CPU ms per scan per tree, with a
digest of the maps it built (and of the first, built with the sensor before the clock starts: since
branch ``mastperf`` only the 20 scans' calls are timed, not the sensor's first scan, imports,
compiled-code loading or the digest's hashing of each map; before, 21 scans were timed from the
sensor's construction, with the hashing).

``--digest``: a sha256 of every case's TrialRecords (the result row's repr, every telemetry column's
bytes, the path, the belief) per tree: the figure an optimisation must keep (README,
"Reproducibility"). ``--profile``: cProfile of the first case's missions, top 25 by own time.

Prints figures; record them in benchmarks/RESULTS.md. Not a test. ``--smoke``: one round of each
mode, small: the scan on a 201^2 map, 2,000 stub ticks, the default case with two short missions
(seconds; its figures mean nothing).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from _timing import run_in_tree

ROOT = Path(__file__).resolve().parents[1]

#: name -> (engine, vehicle, tyre model, driver table); the digest runs all of them
CASES = {
    "mujoco-husky-coulomb-straight": ("mujoco", "husky", "coulomb", {"name": "straight"}),
    "mujoco-husky-terramechanics-straight": ("mujoco", "husky", "terramechanics", {"name": "straight"}),
    "mujoco-hunter-coulomb-lattice": ("mujoco", "hunter", "coulomb", {"name": "lattice"}),
    "mujoco-sojourner-coulomb-straight": ("mujoco", "sojourner", "coulomb", {"name": "straight"}),
    "mujoco-sojourner-terramechanics-astar": ("mujoco", "sojourner", "terramechanics", {"name": "astar"}),
    "mujoco-husky-coulomb-reactive": ("mujoco", "husky", "coulomb", {"name": "reactive"}),
    "mujoco-husky-coulomb-astar-mast": ("mujoco", "husky", "coulomb", {"name": "astar", "sensor": "mast"}),
    "pybullet-husky-coulomb-straight": ("pybullet", "husky", "coulomb", {"name": "straight"}),
    "pybullet-husky-terramechanics-astar": ("pybullet", "husky", "terramechanics", {"name": "astar"}),
    "pybullet-hunter-coulomb-straight": ("pybullet", "hunter", "coulomb", {"name": "straight"}),
    "pybullet-sojourner-terramechanics-straight": ("pybullet", "sojourner", "terramechanics", {"name": "straight"}),
    "pybullet-hunter-coulomb-reactive": ("pybullet", "hunter", "coulomb", {"name": "reactive"}),
}
DEFAULT_CASE = "mujoco-husky-coulomb-straight"
#: the engine calls timed apart (physics and the engine's own reads and writes)
ENGINE_CALLS = ("step", "advance", "spawn", "base_state", "rotation_matrix", "wheel_penetration_m", "wheel_slip",
                "wheel_outside_model", "command_wheels", "command_steering", "command_wheel_speeds")
COMMANDS = ("command_wheels", "command_wheel_speeds")  # one of them per control tick


def _terrain(rows: int):
    """A rows x rows map at 5 cm of crossing sine waves (the same bits everywhere: numpy's sin on
    a small grid is only used to build the terrain, not in the timed loop)."""
    import numpy as np

    from offroadbench.heightmap import Heightmap

    y, x = np.mgrid[0:rows, 0:rows] * 0.05
    z = 0.06 * np.sin(2 * np.pi * x / 1.7) + 0.05 * np.sin(2 * np.pi * (x + 0.6 * y) / 1.1) + 0.03 * np.sin(y / 0.7)
    return Heightmap(z, 0.05)


def _missions(n: int, size_m: float, length_m: float):
    """``n`` missions of ``length_m`` across the map's middle, each at another angle."""
    import math

    from offroadbench.navigation.missions import Mission

    c, out = 0.5 * size_m, []
    for i in range(n):
        a = 0.7 * i + 0.3
        dx, dy = 0.5 * length_m * math.cos(a), 0.5 * length_m * math.sin(a)
        out.append(Mission.between(i, (c - dx, c - dy), (c + dx, c + dy)))
    return out


def _timed(fn, clock, acc: list, count: list | None = None, depth: list | None = None):
    """``fn`` timed into ``acc`` = [seconds, calls]; with ``depth`` (shared by the wrappers of one
    world), only the outermost call is timed (``spawn`` steps the world through its own ``step``)."""
    depth = [0] if depth is None else depth

    def wrapper(*args, **kwargs):
        if depth[0]:
            return fn(*args, **kwargs)
        depth[0] += 1
        t = clock()
        try:
            return fn(*args, **kwargs)
        finally:
            acc[0] += clock() - t
            acc[1] += 1
            depth[0] -= 1
            if count is not None:
                count[0] += 1
    return wrapper


def child(case: str, missions: int, smoke: bool, profile: bool) -> dict:
    """One case in this (fresh) process, with the tree first on sys.path."""
    import hashlib
    import time

    import numpy as np

    from offroadbench.navigation.drivers import planner_from_table
    from offroadbench.sim import open_world
    from offroadbench.sim.config import SimConfig
    from offroadbench.sim.trial import runner

    engine, vehicle, tyre, driver = CASES[case]
    rows, length = (101, 3.0) if smoke else (241, 8.0)
    hm = _terrain(rows)
    clock = time.thread_time
    # the wrapper's own cost: what of it falls inside the timed window, and the whole of it
    cal = [0.0, 0]
    empty = _timed(lambda: None, clock, cal)
    t0 = clock()
    for _ in range(50_000):
        empty()
    whole_s = (clock() - t0) / 50_000
    inside_s = cal[0] / 50_000
    engine_acc, plan_acc, ticks = [0.0, 0], [0.0, 0], [0]
    plan = runner.plan_within_limits
    runner.plan_within_limits = _timed(plan, clock, plan_acc)
    choice = planner_from_table(driver)
    classes = np.zeros(hm.shape, dtype=np.uint8)
    digest = hashlib.sha256()
    todo = _missions(missions + 1, hm.width_m, length)
    with open_world(hm, vehicle, SimConfig(engine=engine, tyre_model=tyre)) as world:
        depth = [0]
        for name in ENGINE_CALLS:
            fn = getattr(world, name, None)
            if fn is not None:
                setattr(world, name, _timed(fn, clock, engine_acc, ticks if name in COMMANDS else None, depth))
        runner.drive_mission(world, todo[0], planner=choice, classes=classes, border_m=0.5)  # warm-up
        engine_acc[:], plan_acc[:], ticks[0] = [0.0, 0], [0.0, 0], 0
        steps = 0
        prof = None
        if profile:
            import cProfile

            prof = cProfile.Profile()
            prof.enable()
        t0 = clock()
        for m in todo[1:]:
            rec = runner.drive_mission(world, m, planner=choice, classes=classes, border_m=0.5)
            steps += round(rec.result.sim_time_s / world.dt_s)
            digest.update(repr(rec.result).encode())
            for key in sorted(rec.telemetry):
                digest.update(key.encode() + np.ascontiguousarray(rec.telemetry[key]).tobytes())
            digest.update(np.ascontiguousarray(rec.path_xy).tobytes())
            if rec.belief is not None:
                digest.update(np.ascontiguousarray(rec.belief.trail_xy).tobytes() + rec.belief.seen.tobytes())
        cpu = clock() - t0
        if prof is not None:
            prof.disable()
    runner.plan_within_limits = plan
    calls = engine_acc[1] + plan_acc[1]
    engine_s = engine_acc[0] - engine_acc[1] * inside_s
    plan_s = plan_acc[0] - plan_acc[1] * inside_s
    trial_s = cpu - engine_s - plan_s - calls * whole_s
    out = {"case": case, "ticks": ticks[0], "steps": steps, "cpu_s": cpu, "engine_s": engine_s, "plan_s": plan_s,
           "trial_s": trial_s, "wrapper_us": whole_s * 1e6, "digest": digest.hexdigest()[:16]}
    if prof is not None:
        import io
        import pstats

        text = io.StringIO()
        if os.environ.get("TICK_PROFILE_OUT"):  # the raw stats too, for pstats' callers
            prof.dump_stats(os.environ["TICK_PROFILE_OUT"])
        pstats.Stats(prof, stream=text).sort_stats("tottime").print_stats(int(os.environ.get("TICK_TOP", "25")))
        out["profile"] = text.getvalue()
    return out


def stub_child(ticks: int) -> dict:
    """``--stub`` in this (fresh) process, with the tree first on sys.path."""
    import time

    import numpy as np

    from offroadbench.heightmap import Heightmap
    from offroadbench.navigation.missions import Mission
    from offroadbench.navigation.sensor import Oracle
    from offroadbench.sim import open_world
    from offroadbench.sim.config import SimConfig
    from offroadbench.sim.trial import runner
    from offroadbench.sim.trial.steering import make_vehicle_tracker

    hm = Heightmap(np.zeros((401, 401)), 0.05)
    with open_world(hm, "husky", SimConfig(engine="mujoco")) as world:
        mission = Mission.between(0, (2.0, 10.0), (18.0, 10.0))
        settings = runner.settings_of(world)
        tracker = make_vehicle_tracker(np.array([mission.start_xy_m, mission.goal_xy_m]), world.spec,
                                       settings.controller, world)
        quat, lin, ang = (0.0, 0.0, 0.0, 1.0), [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        rot, k = world.rotation_matrix(quat), [0]

        def base_state():
            k[0] += 1
            return [2.0 + 1e-4 * k[0], 10.0, 0.3], quat, lin, ang

        stubs = {"step": lambda: None, "advance": lambda n: None, "spawn": lambda *a, **kw: None,
                 "base_state": base_state, "rotation_matrix": lambda q: rot, "wheel_penetration_m": lambda: 0.0,
                 "wheel_slip": lambda: None, "wheel_outside_model": lambda: None, "command_wheels": lambda l, r: None}
        for name, fn in stubs.items():
            setattr(world, name, fn)
        loop = runner.TrialLoop(world, mission, settings, length_m=tracker.length_m)
        loop.n_steps = loop.checker.window = 10**9  # neither the timeout nor the stuck rule ends it
        sensing, progress = Oracle(hm.z), tracker.progress
        t0 = time.process_time()
        for _ in range(ticks):
            pos, quat_, lin_, ang_, roll, pitch, yaw, rates = loop.state
            bx, by, byaw = sensing.update(pos, yaw)
            v, w, _ = tracker.command((bx, by), byaw, lin_[:2])
            loop.command(v, w)
            if loop.record(progress) or loop.step_to_next_control(progress):
                raise RuntimeError("the stub trial ended")
        cpu = time.process_time() - t0
    return {"ticks": ticks, "us_per_tick": cpu / ticks * 1e6}


def scan_child(rows: int) -> dict:
    """``--scan`` in this (fresh) process, with the tree first on sys.path."""
    import hashlib
    import time

    import numpy as np

    from offroadbench.heightmap import Heightmap
    from offroadbench.navigation.perception import PerceptionConfig
    from offroadbench.navigation.sensor import MastSensor

    y, x = np.mgrid[0:rows, 0:rows] * 0.05
    hm = Heightmap(0.3 * np.sin(x / 1.3) + 0.2 * np.sin((x + y) / 0.9), 0.05)
    centre, digest = 0.025 * rows, hashlib.sha256()
    # built (its first scan, and the one-off imports and loading of compiled code) before the clock starts
    sensor = MastSensor(hm, PerceptionConfig(sensor="mast"), np.random.default_rng(3), (centre, centre), 0.3)
    digest.update(sensor.z.tobytes())
    cpu = 0.0
    for i in range(20):
        xy = np.array((centre + 0.1 * i, centre + 0.05 * i))
        t0 = time.process_time()
        sensor._scan(xy)
        cpu += time.process_time() - t0
        digest.update(sensor.z.tobytes())  # not timed (hashing the 8 MB map costs as much as a scan)
    return {"scans": 20, "ms_per_scan": cpu / 20 * 1e3, "digest": digest.hexdigest()[:16]}


def _run_child(tree: str, case: str, args) -> dict | None:
    if case == "scan":
        argv = ["--child-scan"] + (["--smoke"] if args.smoke else [])
    elif case == "stub":
        argv = ["--child-stub", "--missions", str(args.missions)] + (["--smoke"] if args.smoke else [])
    else:
        argv = ["--child", case, "--missions", str(args.missions)] + (["--smoke"] if args.smoke else []) + (
            ["--profile"] if args.profile else [])
    return run_in_tree(tree, "bench_tick", argv, case)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", action="append", choices=sorted(CASES), help=f"repeat; default {DEFAULT_CASE}")
    ap.add_argument("--tree", action="append", default=[], help="a checkout of offroadbench (repeat); default this one")
    ap.add_argument("--missions", type=int, default=6)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--digest", action="store_true", help="every case once per tree: the trials' digests")
    ap.add_argument("--profile", action="store_true", help="cProfile of the first case (top 25 by own time)")
    ap.add_argument("--smoke", action="store_true", help="one round, two short missions (CI)")
    ap.add_argument("--stub", action="store_true", help="the trial loop alone on stubbed physics (see the docstring)")
    ap.add_argument("--child", choices=sorted(CASES), help=argparse.SUPPRESS)
    ap.add_argument("--scan", action="store_true", help="the mast sensor's scan on a 1009^2 map (see the docstring)")
    ap.add_argument("--child-stub", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--child-scan", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.smoke:
        args.missions, args.rounds = 2, 1
    if args.child_scan:
        print("RESULT " + json.dumps(scan_child(201 if args.smoke else 1009)))
        return
    if args.child_stub:
        print("RESULT " + json.dumps(stub_child(2_000 if args.smoke else 20_000)))
        return
    if args.child:
        print("RESULT " + json.dumps(child(args.child, args.missions, args.smoke, args.profile)))
        return
    from offroadbench.study.store.store import machine_description

    trees = args.tree or [str(ROOT)]
    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f}")
    if args.digest:
        cases, rounds = sorted(CASES), 1
    else:
        cases, rounds = args.case or [DEFAULT_CASE], args.rounds
    if args.profile:
        cases, rounds, trees = cases[:1], 1, trees[:1]
    if args.scan or args.smoke:  # the smoke mode runs every mode
        print("tree | scans | CPU ms per scan | digest of the maps")
        scans = set()
        for _ in range(rounds):
            for tree in trees:
                r = _run_child(tree, "scan", args)
                if r is not None:
                    scans.add(r["digest"])
                    print(f"{tree} | {r['scans']} | {r['ms_per_scan']:.2f} | {r['digest']}", flush=True)
        print(f"same maps for every tree: {len(scans) == 1}")
        if args.scan:
            return
    if args.stub or args.smoke:  # the smoke mode runs both
        print("tree | control ticks | trial loop us per control tick (stubbed physics)")
        for _ in range(rounds):
            for tree in trees:
                r = _run_child(tree, "stub", args)
                if r is not None:
                    print(f"{tree} | {r['ticks']} | {r['us_per_tick']:.2f}", flush=True)
        if args.stub:
            return
    print("tree | case | control ticks | trial steps | trial code us per control tick | per trial step | "
          "engine calls us per control tick | planning s | digest")
    digests: dict[str, set] = {}
    for _ in range(rounds):
        for case in cases:
            for tree in trees:
                r = _run_child(tree, case, args)
                if r is None:
                    continue
                digests.setdefault(case, set()).add(r["digest"])
                n = max(r["ticks"], 1)
                print(f"{tree} | {case} | {r['ticks']} | {r['steps']} | {r['trial_s'] / n * 1e6:.2f} | "
                      f"{r['trial_s'] / max(r['steps'], 1) * 1e6:.2f} | {r['engine_s'] / n * 1e6:.2f} | "
                      f"{r['plan_s']:.3f} | {r['digest']}", flush=True)
                if "profile" in r:
                    print(r["profile"])
    same = all(len(d) == 1 for d in digests.values())
    print(f"same trials for every tree: {same}")
    if not same:
        sys.exit(1)


if __name__ == "__main__":
    main()
