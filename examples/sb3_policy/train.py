"""Train a PPO agent on offroadbench/Traverse-v0 with stable-baselines3 and save it.

    python train.py --steps 50000 --out ppo_traverse.zip --curve learning_curve.csv --summary training.json

The env is built exactly as stable-baselines3 builds any registered env, make_vec_env(ID, n_envs=2)
with no extra arguments (so Traverse-v0's defaults: the D = 2.45 paper preset cut to a 12 m map,
terrain seed 0, 6 m missions, the Husky); check_env runs on one copy first.

Writes the model (``--out``), the learning curve (``--curve``: one row per finished training
episode, in the order they ended: the env copy, the total timesteps when it ended, its return and
length in steps of 0.05 s, and the wall time since training started in s) and the summary
(``--summary``, JSON, also printed: timesteps, wall time, and the mean return and length over the
last 100 episodes, the window stable-baselines3 logs as ``rollout/ep_rew_mean``).
"""

from __future__ import annotations

import argparse
import csv
import json
import time

import gymnasium as gym
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.env_util import make_vec_env

import offroadbench.envs  # registers offroadbench/Traverse-v0

ENV_ID = offroadbench.envs.TRAVERSE_ID
CURVE_COLUMNS = ("episode", "env", "timesteps", "return", "length_steps", "wall_s")


class EpisodeLog(BaseCallback):
    """Every finished episode (from make_vec_env's Monitor wrappers), in the order they ended."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[tuple] = []
        self.t0 = time.perf_counter()

    def _on_step(self) -> bool:
        for env_index, info in enumerate(self.locals["infos"]):
            ep = info.get("episode")
            if ep is not None:
                self.rows.append((len(self.rows), env_index, self.num_timesteps, round(float(ep["r"]), 4),
                                  int(ep["l"]), round(time.perf_counter() - self.t0, 2)))
        return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=50_000, help="PPO timesteps (summed over both envs)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="ppo_traverse.zip", help="where the model is saved")
    ap.add_argument("--curve", default="learning_curve.csv", help="where the per-episode learning curve goes")
    ap.add_argument("--summary", default="training.json", help="where the summary JSON goes")
    args = ap.parse_args()

    torch.set_num_threads(1)  # a small MLP: one thread is about as fast, and leaves the other core free
    env = gym.make(ENV_ID)
    check_env(env.unwrapped)  # the env itself, without gymnasium's wrappers
    env.close()

    t0 = time.perf_counter()
    venv = make_vec_env(ENV_ID, n_envs=2)  # no extra arguments: render_mode="rgb_array" and defaults
    venv.seed(args.seed)  # episode seeds args.seed, args.seed + 1 for the first reset
    model = PPO("MultiInputPolicy", venv, n_steps=512, batch_size=128, seed=args.seed, device="cpu", verbose=0)
    log = EpisodeLog()
    model.learn(total_timesteps=args.steps, callback=log)
    wall = time.perf_counter() - t0
    model.save(args.out)

    with open(args.curve, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(CURVE_COLUMNS)
        w.writerows(log.rows)

    # the last (up to) 100 training episodes, from make_vec_env's Monitor wrappers
    eps = [(e["r"], e["l"]) for e in model.ep_info_buffer]
    summary = {"timesteps": model.num_timesteps, "wall_time_s": round(wall, 1), "model": args.out,
               "episodes": len(log.rows), "episodes_in_buffer": len(eps),
               "mean_return": round(sum(r for r, _ in eps) / max(len(eps), 1), 2),
               "mean_length_steps": round(sum(n for _, n in eps) / max(len(eps), 1), 1),
               "seed": args.seed, "torch": torch.__version__,
               "stable_baselines3": __import__("stable_baselines3").__version__,
               "gymnasium": gym.__version__, "offroadbench": offroadbench.__version__}
    with open(args.summary, "w") as f:
        json.dump(summary, f, indent=1)
        f.write("\n")
    print(json.dumps(summary))
    venv.close()


if __name__ == "__main__":
    main()
