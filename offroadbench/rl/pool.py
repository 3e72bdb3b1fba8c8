"""A Gymnasium env over a pool of terrains with the ``ppo`` policy's features as observation.

Each ``reset`` moves to the next terrain of the pool (round robin: episode e drives terrain
``e mod K``), each terrain a :class:`offroadbench.sim.gym_env.TraverseEnv` with its own mission
generator. ``reset(seed=s)`` seeds terrain i's env with ``offroadbench.seeding.derive_seed(s, i)``
the first time, as Gymnasium seeds once and then continues the generator; so an episode sequence is
a pure function of the seed and the pool.

- Observation: ``offroadbench.navigation.policies.ppo.features`` of the TraverseEnv's observation in
  the trial runner's form (``offroadbench.navigation.observation.nan_observation``), as the ``ppo``
  policy reads it in a trial (a finite float32 vector; unknown cells of the ``mast`` sensor counted
  as unknown, not as ground).
- Action: ``a`` in [-1, 1]^2 (clipped), driven as ``(v, omega) = a * action_scale`` with
  ``action_scale`` = the vehicle's (top speed m/s, yaw-rate limit rad/s).
- Reward, termination, truncation and ``info``: the TraverseEnv's.
"""

from __future__ import annotations

from typing import Sequence

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from offroadbench.navigation.observation import nan_observation
from offroadbench.navigation.policies.ppo import feature_size, features
from offroadbench.seeding import derive_seed

__all__ = ["TerrainPool"]


class TerrainPool(gym.Env):
    """Episodes in turn over ``envs`` (TraverseEnvs sharing one vehicle and observation layout)."""

    def __init__(self, envs: Sequence) -> None:
        if not envs:
            raise ValueError("TerrainPool needs at least one env")
        self.envs = list(envs)
        first = self.envs[0]
        self.action_scale = np.array([first.vehicle.max_speed_m_s, first.vehicle.max_yaw_rate_rad_s], dtype=float)
        n = feature_size(first.settings.observation.patch_cells)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(n,), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self._episode = -1
        self._seeded = [False] * len(self.envs)
        self._root: int | None = None
        self.current = first

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None:
            self._root, self._seeded, self._episode = int(seed), [False] * len(self.envs), -1
        self._episode += 1
        i = self._episode % len(self.envs)
        self.current = env = self.envs[i]
        sub_seed = None
        if not self._seeded[i] and self._root is not None:
            sub_seed, self._seeded[i] = derive_seed(self._root, i), True
        obs, info = env.reset(seed=sub_seed, options=options)
        info["terrain_index"] = i
        return features(nan_observation(obs)).astype(np.float32), info

    def step(self, action):
        a = np.clip(np.asarray(action, dtype=float).reshape(2), -1.0, 1.0) * self.action_scale
        obs, reward, terminated, truncated, info = self.current.step(a)
        return features(nan_observation(obs)).astype(np.float32), reward, terminated, truncated, info

    def close(self) -> None:
        for env in self.envs:
            env.close()
        super().close()
