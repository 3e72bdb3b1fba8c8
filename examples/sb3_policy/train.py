"""Train a PPO agent on offroadbench/Traverse-v0 with stable-baselines3 and save it.

    python train.py --steps 50000 --out ppo_traverse.zip

The env is built exactly as stable-baselines3 builds any registered env, make_vec_env(ID, n_envs=2)
with no extra arguments (so Traverse-v0's defaults: the D = 2.45 paper preset cut to a 12 m map,
terrain seed 0, 6 m missions, the Husky); check_env runs on one copy first.
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium as gym
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.env_util import make_vec_env

import offroadbench.envs  # registers offroadbench/Traverse-v0

ENV_ID = offroadbench.envs.TRAVERSE_ID


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=50_000, help="PPO timesteps (summed over both envs)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="ppo_traverse.zip", help="where the model is saved")
    args = ap.parse_args()

    torch.set_num_threads(1)  # a small MLP: one thread is about as fast, and leaves the other core free
    env = gym.make(ENV_ID)
    check_env(env.unwrapped)  # the env itself, without gymnasium's wrappers
    env.close()

    t0 = time.perf_counter()
    venv = make_vec_env(ENV_ID, n_envs=2)  # no extra arguments: render_mode="rgb_array" and defaults
    venv.seed(args.seed)  # episode seeds args.seed, args.seed + 1 for the first reset
    model = PPO("MultiInputPolicy", venv, n_steps=512, batch_size=128, seed=args.seed, device="cpu", verbose=0)
    model.learn(total_timesteps=args.steps)
    wall = time.perf_counter() - t0
    model.save(args.out)

    # the last (up to) 100 training episodes, from make_vec_env's Monitor wrappers
    eps = [(e["r"], e["l"]) for e in model.ep_info_buffer]
    summary = {"timesteps": model.num_timesteps, "wall_time_s": round(wall, 1), "model": args.out,
               "episodes_in_buffer": len(eps),
               "mean_return": round(sum(r for r, _ in eps) / max(len(eps), 1), 2),
               "mean_length_steps": round(sum(n for _, n in eps) / max(len(eps), 1), 1)}
    print(json.dumps(summary))
    venv.close()


if __name__ == "__main__":
    main()
