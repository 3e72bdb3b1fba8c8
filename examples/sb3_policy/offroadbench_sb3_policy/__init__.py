"""An offroadbench policy plug-in: a stable-baselines3 model trained on ``offroadbench/Traverse-v0``.

Installed, its entry point (``offroadbench.policies``, see pyproject.toml) adds the policy ``sb3``,
so a study's ``[planner] name = "sb3"`` drives each mission with the model: the trial runner builds
the same observation the env gave during training (offroadbench.navigation.observation; the plug-in
turns the runner's form, NaN at patch samples the ``mast`` sensor has not measured, into the env's
with ``finite_observation``: the fill and the ``known`` channel) and applies the returned
``(v, omega)`` at the control rate, with the same failure rules as for a planner. A model trained
before the env had ``known`` (``state`` and ``height_patch`` only) gets those two entries.
"""

from __future__ import annotations

import functools
import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from offroadbench.config import check_choice
from offroadbench.errors import InputError
from offroadbench.navigation.observation import finite_observation
from offroadbench.navigation.planners import PlanningProblem
from offroadbench.navigation.policies import PolicyContext, PolicySpec

__all__ = ["SB3Config", "SB3Policy", "SB3_POLICY", "ALGORITHMS"]

log = logging.getLogger(__name__)

#: stable-baselines3 classes whose saved models this plug-in loads
ALGORITHMS = ("PPO", "A2C", "SAC", "TD3", "DDPG")


@dataclass(frozen=True, kw_only=True)
class SB3Config:
    """Settings of ``sb3`` (the fields of a study's ``[planner]`` table)."""

    model: str = "ppo_traverse.zip"
    """Saved model (``model.save(...)``, a .zip): absolute, or relative to the directory
    ``offroadbench study run`` / ``drive`` is started from."""
    algorithm: str = "PPO"
    """The stable-baselines3 class that saved it (one of ALGORITHMS)."""

    def __post_init__(self) -> None:
        check_choice(self, "algorithm", self.algorithm, ALGORITHMS)
        if not Path(self.model).is_file():
            raise InputError(f"SB3Config.model = {self.model!r}: no such file (train one with train.py; "
                             f"relative paths start at {os.getcwd()})")


@functools.lru_cache(maxsize=4)
def _load(path: str, mtime_ns: int, algorithm: str):
    """The model at ``path`` (one load per worker process and file version)."""
    import stable_baselines3
    import torch

    # one thread: a small MLP is fastest so, study workers do not oversubscribe the cores, and a
    # fixed reduction order keeps the actions identical from run to run
    torch.set_num_threads(1)
    return getattr(stable_baselines3, algorithm).load(path, device="cpu")


class SB3Policy:
    """Deterministic actions of a trained stable-baselines3 model: ``model.predict(obs, deterministic=True)``.

    Optimises: whatever the model was trained for (Traverse-v0's reward: progress toward the goal,
    minus vertical acceleration and roll/pitch rates, plus success / minus failure terms).
    Cannot see: beyond its height patch, the class map; it knows only the terrain it was trained on.
    """

    def __init__(self, cfg: SB3Config, context: PolicyContext) -> None:
        path = Path(cfg.model).resolve()
        self.model = _load(str(path), path.stat().st_mtime_ns, cfg.algorithm)
        space = self.model.observation_space
        n = context.observation.patch_cells
        want = {"state": (10,), "height_patch": (n, n)}
        have = {k: tuple(s.shape) for k, s in getattr(space, "spaces", {}).items()}
        if "known" in have:  # trained on the env since it marks unmeasured patch samples
            want["known"] = (n, n)
        if have != want:
            raise InputError(f"SB3Config.model = {cfg.model!r} was trained on observations {have}; "
                             f"this study gives {want}")
        self.keys = tuple(have)
        high = np.asarray(self.model.action_space.high, dtype=float)
        limits = np.array([context.vehicle.max_speed_m_s, context.vehicle.max_yaw_rate_rad_s])
        if high.shape != (2,) or not np.allclose(high, limits):
            log.warning("sb3: the model's action bounds %s differ from this vehicle's limits %s "
                        "(actions are clipped to the vehicle's)", high.tolist(), limits.tolist())

    def reset(self, problem: PlanningProblem) -> None:
        """Nothing to remember between missions (the model sees only the observation)."""

    def act(self, observation: Mapping[str, np.ndarray]) -> tuple[float, float]:
        obs = finite_observation(observation)
        action, _ = self.model.predict({k: obs[k] for k in self.keys}, deterministic=True)
        a = np.asarray(action, dtype=float).reshape(-1)
        return float(a[0]), float(a[1])


SB3_POLICY = PolicySpec(SB3Policy, SB3Config, "a trained stable-baselines3 model, deterministic actions")
