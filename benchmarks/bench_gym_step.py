"""The Gymnasium env's step rate: CPU seconds of ``TraverseEnv.step`` with a fixed action, per tree,
and a digest of what the steps returned (the figure an optimisation must keep).

    .venv/bin/python benchmarks/bench_gym_step.py [--tree PATH ...] [--rounds 3] [--episodes 4]
                                                  [--steps 300] [--engine mujoco] [--perception oracle]
                                                  [--smoke]

Each tree (``--tree``, default this checkout; e.g. a ``git worktree`` of main) runs in its own fresh
process, the trees alternated ``--rounds`` times. A process builds ``TraverseEnv`` on a 121^2 map
at 5 cm of crossing sine waves (6 m x 6 m; missions of 3 m, border 1 m) for the Husky on
``--engine``, observing through ``--perception`` (``oracle`` or ``mast``), steps one warm-up
episode, then ``--episodes`` episodes (``reset(seed=i)``), each at most ``--steps`` steps of the
action (0.6 m/s, 0.15 rad/s) or until it ends. Only the ``step`` calls are timed (the process's CPU
clock, all threads): steps per CPU second and CPU us per step. The digest is a sha256 of every
step's observation arrays, reward and flags. Prints figures; record them in
benchmarks/RESULTS.md. Not a test. ``--smoke``: one round, one short episode (seconds; its
figures mean nothing).
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from _timing import run_in_tree

ROOT = Path(__file__).resolve().parents[1]
ACTION = (0.6, 0.15)


def child(engine: str, perception: str, episodes: int, steps: int) -> dict:
    """The episodes in this (fresh) process, with the tree first on sys.path."""
    import hashlib
    import time

    import numpy as np

    from offroadbench.heightmap import Heightmap
    from offroadbench.sim.config import SimConfig
    from offroadbench.sim.gym_env import TraverseConfig, TraverseEnv

    y, x = np.mgrid[0:121, 0:121] * 0.05
    hm = Heightmap(0.05 * np.sin(x / 0.4) + 0.04 * np.sin((x + 0.6 * y) / 0.25) + 0.03 * np.sin(y / 0.7), 0.05)
    action = np.array(ACTION, dtype=np.float32)
    digest, n, cpu = hashlib.sha256(), 0, 0.0
    with TraverseEnv(hm, config=TraverseConfig(mission_length_m=3.0, border_m=1.0), sim=SimConfig(engine=engine),
                     perception=perception) as env:
        for ep in range(-1, episodes):  # -1: the warm-up episode (imports, first calls)
            env.reset(seed=1000 + ep)
            for _ in range(steps):
                t0 = time.process_time()
                obs, reward, terminated, truncated, _ = env.step(action)
                dt = time.process_time() - t0
                if ep >= 0:
                    cpu += dt
                    n += 1
                    for key in sorted(obs):
                        digest.update(key.encode() + np.ascontiguousarray(obs[key]).tobytes())
                    digest.update(repr((reward, terminated, truncated)).encode())
                if terminated or truncated:
                    break
    return {"steps": n, "cpu_s": cpu, "digest": digest.hexdigest()[:16]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", action="append", default=[], help="a checkout of offroadbench (repeat); default this one")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--episodes", type=int, default=4)
    ap.add_argument("--steps", type=int, default=300, help="at most this many steps per episode")
    ap.add_argument("--engine", default="mujoco", choices=("mujoco", "pybullet"))
    ap.add_argument("--perception", default="oracle", choices=("oracle", "mast"))
    ap.add_argument("--smoke", action="store_true", help="one round, one short episode")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.smoke:
        args.rounds, args.episodes, args.steps = 1, 1, 20
    if args.child:
        print("RESULT " + json.dumps(child(args.engine, args.perception, args.episodes, args.steps)))
        return
    from offroadbench.study.store.store import machine_description

    trees = args.tree or [str(ROOT)]
    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f}")
    print(f"engine {args.engine}, perception {args.perception}, action {ACTION}")
    print("tree | steps | CPU s | steps per CPU s | CPU us per step | digest")
    argv = ["--child", "--engine", args.engine, "--perception", args.perception, "--episodes", str(args.episodes),
            "--steps", str(args.steps)]
    digests = set()
    for _ in range(args.rounds):
        for tree in trees:
            r = run_in_tree(tree, "bench_gym_step", argv, "gym step")
            if r is None:
                continue
            digests.add(r["digest"])
            print(f"{tree} | {r['steps']} | {r['cpu_s']:.3f} | {r['steps'] / r['cpu_s']:.1f} | "
                  f"{r['cpu_s'] / r['steps'] * 1e6:.1f} | {r['digest']}", flush=True)
    print(f"same steps for every tree: {len(digests) == 1}")


if __name__ == "__main__":
    main()
