"""Train the ``ppo`` policy with stable-baselines3 and export it to the numpy ``.npz`` the plug-in ships.

    pip install -e ".[rl]"
    nice -n 10 python experiments/train_ppo.py --steps 313344 --seed 0 --out runs/ppo --ship   # the shipped weights
    python experiments/train_ppo.py --evaluate runs/ppo/ppo_husky.npz --out runs/ppo

Training distribution (``terrain_pool``): the paper's multifractal presets paper-d2.3, paper-d2.45 and
paper-d2.6 (Majhor & Bos 2023, Table 1) cut to 401 x 401 cells (20 m at 5 cm), ``--terrains``
terrains in turn (terrain i: preset i mod 3, generated with ``derive_seed(seed, 1, i)``), missions of
10 m drawn on each terrain's closed class map 2 m from the edge, the Husky on PyBullet, observed
through the ``mast`` sensor (occlusion, range noise, odometry drift; a 3 m range in training, which
covers the 1.5 m height patch and costs a seventh of the default 8 m range's scan). One env,
``offroadbench.rl.pool.TerrainPool``; SB3's PPO (MlpPolicy, pi and vf 2 x 64 tanh, n_steps 2048,
otherwise SB3's defaults) on VecNormalize'd observations and rewards; torch on one thread.

Evaluation (``--evaluate``, also run after training): 20 held-out missions, 4 on each of 5 terrains
not in the pool (seeds ``derive_seed(seed, 2, j)``, presets in turn), driven through the trial
pipeline (offroadbench.sim.trial.pipeline.drive_terrain) by ``ppo`` through the default mast sensor
(8 m) and through the oracle, and by the straight line (oracle and mast). Writes ``evaluation.csv``
(one row per trial) and prints the success counts.

Writes to ``--out``: ``learning_curve.csv`` (one row per episode: env steps at its end, return,
length, success, failure reason, terrain), ``learning_curve.png``, ``ppo_husky.npz`` and
``training.json`` (arguments, SB3/torch versions, wall time, machine), ``ppo_sb3.zip`` (the SB3
model of the same policy; not shipped) and, with ``--checkpoints``, ``ppo_husky_STEPS.npz``. ``--ship`` copies the npz to
``offroadbench/navigation/policies/data/``. The same seed and step count give the same weights on
the same machine (SB3's seeding of torch, numpy and the env; one torch thread).
"""

from __future__ import annotations

import argparse
import json
import platform
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from offroadbench.navigation.perception import PerceptionConfig
from offroadbench.navigation.policies.ppo import export_sb3, shipped_weights
from offroadbench.seeding import derive_seed, mission_seed

PRESETS = ("paper-d2.3", "paper-d2.45", "paper-d2.6")
OVERRIDES = {"grid.rows": 401, "grid.cols": 401}
MISSION_M = 10.0
BORDER_M = 2.0
TRAIN_SENSOR = PerceptionConfig(sensor="mast", sensor_range_m=3.0)


def terrain_pool(seed: int, count: int):
    """The training envs (module docstring)."""
    from offroadbench.sim.gym_env import TraverseConfig, TraverseEnv

    cfg = TraverseConfig(mission_length_m=MISSION_M, border_m=BORDER_M)
    return [TraverseEnv(PRESETS[i % 3], terrain_seed=derive_seed(seed, 1, i), overrides=OVERRIDES, config=cfg,
                        perception=TRAIN_SENSOR) for i in range(count)]


class Curve:
    """SB3 callback: a tqdm bar over the steps and one learning-curve row per finished episode; with
    ``max_s``, training stops at the first rollout that starts after ``max_s`` seconds, and
    ``snapshot`` is the policy and observation statistics as they were at that rollout's start: the
    same as a run with ``--steps`` = ``snapshot_steps`` (constant learning rate and clip range)."""

    def __new__(cls, total: int, max_s: float | None = None, checkpoints=(), save=None):
        from stable_baselines3.common.callbacks import BaseCallback
        from tqdm import tqdm

        class _Curve(BaseCallback):
            def __init__(self):
                super().__init__()
                self.rows: list[dict] = []
                self.bar = tqdm(total=total, unit="step", desc="ppo", mininterval=5.0)
                self._ret = 0.0
                self._len = 0
                self.t0 = time.time()
                self.snapshot = None
                self.snapshot_steps = 0
                self.stopped = False
                self.pending = sorted(checkpoints)

            def _on_rollout_start(self) -> None:
                import copy

                venv = self.model.get_env()
                while self.pending and self.num_timesteps >= self.pending[0]:
                    # the policy a --steps run of pending[0] steps ends with (it also finishes its rollout)
                    save(self.model, venv.obs_rms, self.num_timesteps, self.pending.pop(0))
                self.snapshot = (copy.deepcopy(self.model.policy.state_dict()), copy.deepcopy(venv.obs_rms))
                self.snapshot_steps = self.num_timesteps
                self.stopped = max_s is not None and time.time() - self.t0 > max_s

            def _on_step(self) -> bool:
                if self.stopped:
                    return False
                self.bar.update(1)
                self._ret += float(self.locals["infos"][0].get("raw_reward", 0.0))
                self._len += 1
                if self.locals["dones"][0]:
                    info = self.locals["infos"][0]
                    self.rows.append({"steps": self.num_timesteps, "return": self._ret, "length": self._len,
                                      "success": int(info["success"]), "failure_reason": info["failure_reason"],
                                      "terrain": info["terrain_index"]})
                    self._ret, self._len = 0.0, 0
                return True

            def _on_training_end(self) -> None:
                self.bar.close()

        return _Curve()


def _raw_reward_env(pool, time_penalty_per_s: float = 0.0):
    """The pool, with the env's unnormalised reward in info (for the curve) and the terrain index kept;
    the reward trained on is the env's less ``time_penalty_per_s`` per simulated second (one control
    tick per step)."""
    import gymnasium as gym

    tick_s = 1.0 / pool.current.settings.controller.control_rate_hz

    class RawReward(gym.Wrapper):
        def reset(self, **kw):
            obs, info = self.env.reset(**kw)
            self._terrain = info["terrain_index"]
            return obs, info

        def step(self, action):
            obs, r, term, trunc, info = self.env.step(action)
            info["raw_reward"], info["terrain_index"] = r, self._terrain
            return obs, r - time_penalty_per_s * tick_s, term, trunc, info

    return RawReward(pool)


def train(args) -> Path:
    import stable_baselines3
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from offroadbench.rl.pool import TerrainPool

    torch.set_num_threads(1)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    envs = terrain_pool(args.seed, args.terrains)
    pool = TerrainPool(envs)
    venv = VecNormalize(DummyVecEnv([lambda: _raw_reward_env(pool, args.time_penalty)]), norm_obs=True, norm_reward=True, clip_obs=10.0)
    model = PPO("MlpPolicy", venv, n_steps=2048, seed=args.seed, device="cpu", verbose=0,
                policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [64, 64]}, "activation_fn": torch.nn.Tanh})
    obs_cfg = envs[0].settings.observation

    def save(model_, obs_rms_, steps_, asked):
        export_sb3(model_, out / f"ppo_husky_{asked}.npz", obs_rms=obs_rms_, action_scale=pool.action_scale,
                   patch_cells=obs_cfg.patch_cells, patch_spacing_m=obs_cfg.patch_spacing_m, seed=str(args.seed),
                   steps=str(steps_), trained_by="experiments/train_ppo.py")

    curve = Curve(args.steps, None if args.max_minutes is None else 60.0 * args.max_minutes,
                  checkpoints=args.checkpoints, save=save)
    t0, cpu0 = time.time(), time.process_time()
    model.learn(total_timesteps=args.steps, callback=curve)
    wall, cpu = time.time() - t0, time.process_time() - cpu0
    steps = args.steps
    obs_rms = venv.obs_rms
    if curve.stopped:  # the state at the start of the rollout that was cut: a --steps run of that length
        model.policy.load_state_dict(curve.snapshot[0])
        obs_rms, steps = curve.snapshot[1], curve.snapshot_steps
        curve.rows = [r for r in curve.rows if r["steps"] <= steps]
    npz = out / "ppo_husky.npz"
    export_sb3(model, npz, obs_rms=obs_rms, action_scale=pool.action_scale, patch_cells=obs_cfg.patch_cells,
               patch_spacing_m=obs_cfg.patch_spacing_m, seed=str(args.seed), steps=str(steps),
               trained_by="experiments/train_ppo.py")
    model.save(out / "ppo_sb3.zip")  # the same policy for SB3 (torch), to check the npz's mean actions against
    _write_curve(curve.rows, out)
    meta = {"seed": args.seed, "steps": steps, "steps_asked": args.steps, "stopped_by_max_minutes": curve.stopped,
            "cpu_s": round(cpu, 1), "terrains": args.terrains, "presets": PRESETS,
            "overrides": OVERRIDES, "mission_length_m": MISSION_M, "border_m": BORDER_M,
            "time_penalty_per_s": args.time_penalty, "train_sensor": {"sensor": "mast", "sensor_range_m": TRAIN_SENSOR.sensor_range_m},
            "wall_s": round(wall, 1), "episodes": len(curve.rows), "python": sys.version.split()[0],
            "stable_baselines3": stable_baselines3.__version__, "torch": torch.__version__,
            "numpy": np.__version__, "machine": platform.processor() or platform.machine(),
            "cpu": _cpu_name(), "started_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime(t0))}
    (out / "training.json").write_text(json.dumps(meta, indent=2) + "\n")
    pool.close()
    if args.ship:
        shutil.copyfile(npz, shipped_weights())
    return npz


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def _write_curve(rows: list[dict], out: Path) -> None:
    import pandas as pd
    from matplotlib.figure import Figure

    df = pd.DataFrame(rows, columns=["steps", "return", "length", "success", "failure_reason", "terrain"])
    df.to_csv(out / "learning_curve.csv", index=False)
    fig = Figure(figsize=(8, 3.2))
    ax1, ax2 = fig.subplots(1, 2)
    w = max(1, min(50, len(df) // 10))
    ax1.plot(df["steps"], df["return"], ".", ms=2, alpha=0.3, color="0.5")
    ax1.plot(df["steps"], df["return"].rolling(w, min_periods=1).mean(), color="C0")
    ax1.set(xlabel="env steps", ylabel="episode return", title="return (dots: episodes; line: mean of %d)" % w)
    ax2.plot(df["steps"], df["success"].rolling(w, min_periods=1).mean(), color="C2")
    ax2.set(xlabel="env steps", ylabel="success rate", ylim=(-0.02, 1.02), title="success (mean of %d episodes)" % w)
    fig.tight_layout()
    fig.savefig(out / "learning_curve.png", dpi=110)


ARMS = ("straight/oracle", "straight/mast", "ppo/oracle", "ppo/mast")


def evaluate(weights: Path, seed: int, out: Path, terrains: int = 5, per_terrain: int = 4, arms=ARMS):
    """Held-out missions (module docstring): one row per trial, and the success counts per arm
    (``arms``: a subset of :data:`ARMS`)."""
    import pandas as pd

    from offroadbench.navigation.planners import planner_from_table
    from offroadbench.sim.trial.pipeline import TrialSettings, drive_terrain, prepare_terrain, terrain_body
    from offroadbench.navigation.missions import MissionConfig
    from offroadbench.terrain.recipe import load_terrain

    tables = {"straight/oracle": {"name": "straight"}, "straight/mast": {"name": "straight", "sensor": "mast"},
              "ppo/oracle": {"name": "ppo", "weights": str(weights)},
              "ppo/mast": {"name": "ppo", "weights": str(weights), "sensor": "mast"}}
    arms = {a: tables[a] for a in arms}
    rows = []
    base = TrialSettings(missions=MissionConfig(length_m=MISSION_M, border_m=BORDER_M))
    for j in range(terrains):
        t_seed = derive_seed(seed, 2, j)
        hm, recipe = load_terrain(PRESETS[j % 3], t_seed, OVERRIDES)
        gravity, soil = terrain_body(PRESETS[j % 3], recipe)
        missions = [(k, mission_seed(t_seed, j, k)) for k in range(per_terrain)]
        prepared = prepare_terrain(hm, t_seed, base, missions, gravity_m_s2=gravity, soil=soil)
        for arm, table in arms.items():
            settings = base.replace(planner=planner_from_table(table))
            for k, rec in enumerate(drive_terrain(prepared, settings)):
                r = rec.result
                rows.append({"arm": arm, "preset": PRESETS[j % 3], "terrain_seed": t_seed, "mission": k,
                             "success": int(r.success), "failure_reason": r.failure_reason,
                             "traversal_time_s": r.traversal_time_s, "path_length_m": r.path_length_m})
    df = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "evaluation.csv", index=False)
    return df.groupby("arm", sort=False)["success"].agg(["sum", "count"])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=150_000, help="env steps of training (default 150000)")
    p.add_argument("--seed", type=int, default=0, help="root seed of training and of the held-out missions")
    p.add_argument("--terrains", type=int, default=6, help="terrains in the training pool (default 6)")
    p.add_argument("--time-penalty", type=float, default=0.0, metavar="PER_S",
                   help="reward subtracted per simulated second of an episode (default 0: the env's reward)")
    p.add_argument("--out", default="runs/ppo", help="output folder")
    p.add_argument("--max-minutes", type=float, default=None,
                   help="stop at the first rollout that starts after this wall time and keep the policy as it "
                        "was then (training.json says the steps: rerun with --steps STEPS to reproduce)")
    p.add_argument("--checkpoints", type=int, nargs="*", default=[], metavar="STEPS",
                   help="also write ppo_husky_STEPS.npz: the policy a --steps STEPS run of the same seed ends with")
    p.add_argument("--ship", action="store_true", help="copy the trained npz into the package's data")
    p.add_argument("--evaluate", metavar="NPZ", default=None, help="only evaluate these weights")
    p.add_argument("--arms", nargs="+", choices=ARMS, default=list(ARMS), help="the evaluation's arms (default all)")
    p.add_argument("--no-evaluate", action="store_true", help="train only")
    args = p.parse_args(argv)
    weights = Path(args.evaluate) if args.evaluate else train(args)
    if args.evaluate or not args.no_evaluate:
        t0 = time.time()
        table = evaluate(weights, args.seed, Path(args.out), arms=args.arms)
        print(table.to_string())
        print(f"evaluation: {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
