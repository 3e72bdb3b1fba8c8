"""The ``ppo`` policy: its shipped weights load in a fresh process without torch and act
deterministically; it drives through the trial pipeline (drive_mission, a study slice) and replays
bit for bit, and through the env alike (tests/contracts/test_gym_env.py checks the env's ``mast``
observation against the sensor's map); the features never read unknown ground as flat; an SB3 model
exports to the same numbers."""

from __future__ import annotations

import importlib.util
import math
import json
import subprocess
import sys

import numpy as np
import pytest

from offroadbench import resources
from offroadbench.config import load_toml
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.drivers import PolicyContext
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.observation import ObservationConfig
from offroadbench.navigation.planners import planner_from_table
from offroadbench.navigation.policies import make_policy
from tests.navigation.test_policies import roll_out
from offroadbench.navigation.policies.ppo import (
    MlpWeights,
    PpoConfig,
    feature_size,
    features,
    load_weights,
    save_weights,
    shipped_weights,
)

CELL = 0.05


def _obs(seed: int = 0, nan_cells: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    patch = rng.normal(-0.3, 0.05, (16, 16))
    patch.ravel()[:nan_cells] = np.nan
    return {"state": np.array([4.0, -1.0, 0.05, -0.1, 0.0, 0.1, 0.2, 0.5, 0.0, 0.0], dtype=np.float32),
            "height_patch": patch.astype(np.float32)}


_CHILD = """
import json, sys
import numpy as np
from offroadbench.navigation.drivers import PolicyContext
from offroadbench.navigation.policies import make_policy
from offroadbench.navigation.policies.ppo import PpoConfig
obs = {k: np.array(v, dtype=np.float32) for k, v in json.loads(sys.stdin.read()).items()}
p = make_policy("ppo", PpoConfig(), PolicyContext())
print(json.dumps([p.act(obs), "torch" in sys.modules]))
"""


def test_shipped_weights_load_in_a_fresh_process_without_torch_and_act_deterministically():
    assert shipped_weights().is_file()
    w = load_weights(shipped_weights())
    assert w.pi_w0.shape == (64, feature_size(16)) and w.mu_w.shape == (2, 64)
    obs = _obs(nan_cells=5)
    payload = json.dumps({k: np.where(np.isnan(v), None, v).tolist() for k, v in obs.items()}).replace("null", "NaN")
    runs = [subprocess.run([sys.executable, "-c", _CHILD], input=payload, capture_output=True, text=True, check=True)
            for _ in range(2)]
    (a, torch_a), (b, _) = (json.loads(r.stdout) for r in runs)
    assert a == b and not torch_a  # bit for bit across processes, numpy only
    here = make_policy("ppo", PpoConfig(), PolicyContext()).act(obs)
    assert list(here) == a
    assert all(np.isfinite(a)) and abs(a[0]) <= w.action_scale[0] and abs(a[1]) <= w.action_scale[1]


def test_features_count_unknown_cells_as_unknown_not_as_flat_ground():
    obs = _obs()
    f = features(obs)
    assert f.shape == (feature_size(16),) and np.all(np.isfinite(f))
    assert np.all(f[-64:] == 1.0)  # all known under the oracle
    obs["height_patch"][:2, :2] = np.nan  # one whole 2 x 2 block unknown
    g = features(obs)
    assert np.all(np.isfinite(g)) and g[-64] == 0.0 and g[11] == 0.0  # known fraction 0, height 0
    obs["height_patch"][0, 0] = 0.4  # three unknown, one known: the mean of the known one
    h = features(obs)
    assert h[-64] == 0.25 and h[11] == pytest.approx(0.4)
    assert features({**obs, "state": np.array([0, 3.0, *np.zeros(8)])})[:3] == pytest.approx([0.0, 1.0, 0.3])


def test_bad_weights_and_a_patch_it_was_not_trained_on_are_refused(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not an npz")
    with pytest.raises(InputError, match="cannot be read"):
        load_weights(bad)
    w = load_weights(shipped_weights())
    short = tmp_path / "short.npz"
    save_weights(short, MlpWeights(**{**w.__dict__, "obs_mean": w.obs_mean[:-1]}))
    with pytest.raises(InputError, match="obs_mean"):
        load_weights(short)
    with pytest.raises(InputError, match="patch_cells = 16"):
        make_policy("ppo", PpoConfig(), PolicyContext(observation=ObservationConfig(patch_cells=8)))


def _rough(n: int = 161, seed: int = 1) -> Heightmap:
    from scipy.ndimage import gaussian_filter

    z = gaussian_filter(np.random.default_rng(seed).normal(0, 1, (n, n)), 6) * 2.0
    return Heightmap(z - z.min(), CELL)


def test_ppo_drives_a_mission_through_drive_mission_and_the_env_alike_and_replays_bit_for_bit():
    from offroadbench.sim import World
    from offroadbench.sim.gym_env import TraverseConfig, TraverseEnv
    from offroadbench.sim.trial.runner import drive_mission

    hm = _rough()
    mission = Mission.between(0, (2.0, 2.5), (5.5, 5.0))
    choice = planner_from_table({"name": "ppo", "sensor": "mast"})
    with World(hm) as world:
        a = drive_mission(world, mission, planner=choice, border_m=1.0)
        b = drive_mission(world, mission, planner=choice, border_m=1.0)
    assert a.result.failure_reason in ("", "stuck", "tipped", "timeout", "off_map", "entrapped")
    for k in a.telemetry:
        assert np.array_equal(a.telemetry[k], b.telemetry[k], equal_nan=True), k
    assert a.belief is not None and a.belief.seen.any() and not a.belief.seen.all()
    with TraverseEnv(hm, config=TraverseConfig(mission_length_m=4.0, border_m=1.0), perception="mast") as env:
        obs, _ = env.reset(seed=0, options={"mission": mission})
        policy = make_policy("ppo", PpoConfig(), PolicyContext())
        xy, info = roll_out(env, policy, obs)
    tel = np.column_stack([a.telemetry["x_m"], a.telemetry["y_m"]])[1:]  # the runner also records the start
    assert len(xy) - len(tel) in (0, 1)  # a timeout ends the env's last step between telemetry samples
    assert np.array_equal(np.array(xy[:len(tel)]), tel)
    assert info["failure_reason"] == a.result.failure_reason


def test_ppo_drives_a_study_slice(tmp_path):
    from offroadbench.study import load, run_study, study_from_dict
    from offroadbench.study.spec.config import plan_cells

    data = load_toml(resources.study_files()["smoke"])
    data["study"].update(terrains_per_cell=1, missions_per_terrain=2)
    data["grid"] = {"recipe.layers.base.D_high": [2.45], "planner.name": ["ppo"]}
    data["recipe_overrides"] = {"grid.rows": 161, "grid.cols": 161}
    data["missions"].update(length_m=4.0)
    data["planner"] = {"sensor": "mast"}
    study = study_from_dict(data)
    run_study(study, plan_cells(study), tmp_path / "run", executor="inline")
    df = load(tmp_path / "run")
    assert len(df) == 2
    assert set(df["planner"]) == {"ppo"}
    assert df["failure_reason"].isin(["", "tipped", "stuck", "timeout", "off_map", "entrapped"]).all()


@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None, reason="stable-baselines3 not installed")
def test_an_sb3_model_exports_to_the_same_mean_actions(tmp_path):
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from offroadbench.navigation.policies.ppo import export_sb3

    n = feature_size(16)

    class Box(gym.Env):
        observation_space = gym.spaces.Box(-np.inf, np.inf, (n,), np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            return self.np_random.normal(size=n).astype(np.float32), {}

        def step(self, a):
            return self.np_random.normal(size=n).astype(np.float32), 0.0, False, False, {}

    venv = VecNormalize(DummyVecEnv([Box]), norm_reward=False)
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=32, n_epochs=1, seed=0, device="cpu",
                policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [64, 64]}, "activation_fn": torch.nn.Tanh})
    model.learn(128)
    w = export_sb3(model, tmp_path / "m.npz", obs_rms=venv.obs_rms, action_scale=(1.0, 2.0))
    f = np.random.default_rng(1).normal(size=(5, n))
    sb3, _ = model.predict(venv.normalize_obs(f.astype(np.float32)), deterministic=True)
    assert w.mean_action(f) == pytest.approx(sb3, abs=1e-5)  # float32 torch against float64 numpy
    assert load_weights(tmp_path / "m.npz").mean_action(f) == pytest.approx(w.mean_action(f), abs=0)


@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None, reason="stable-baselines3 not installed")
def test_the_shipped_weights_loaded_into_sb3_give_the_numpy_mean_actions():
    """The other direction of the export: the shipped arrays put into an SB3 MlpPolicy (torch) and its
    VecNormalize act as the numpy inference does, on features of real and partly unknown patches."""
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    w = load_weights(shipped_weights())
    n = feature_size(w.patch_cells)

    class Box(gym.Env):
        observation_space = gym.spaces.Box(-np.inf, np.inf, (n,), np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

    venv = VecNormalize(DummyVecEnv([Box]), norm_reward=False, clip_obs=10.0)
    venv.obs_rms.mean, venv.obs_rms.var = w.obs_mean.copy(), w.obs_var.copy()
    model = PPO("MlpPolicy", venv, device="cpu",
                policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [64, 64]}, "activation_fn": torch.nn.Tanh})
    sd = model.policy.state_dict()
    for key, name in (("mlp_extractor.policy_net.0.weight", "pi_w0"), ("mlp_extractor.policy_net.0.bias", "pi_b0"),
                      ("mlp_extractor.policy_net.2.weight", "pi_w1"), ("mlp_extractor.policy_net.2.bias", "pi_b1"),
                      ("action_net.weight", "mu_w"), ("action_net.bias", "mu_b"), ("log_std", "log_std")):
        sd[key] = torch.as_tensor(getattr(w, name), dtype=torch.float32)
    model.policy.load_state_dict(sd)
    f = np.array([features(_obs(seed, nan_cells=seed * 20)) for seed in range(8)])
    sb3, _ = model.predict(venv.normalize_obs(f.astype(np.float32)), deterministic=True)
    assert w.mean_action(f) == pytest.approx(sb3, abs=1e-5)  # float32 torch against float64 numpy
    assert np.ptp(sb3, axis=0).max() > 1e-3  # the observations differ enough to move the action


def test_the_mlp_sums_each_dot_product_left_to_right_without_blas():
    """Each layer's dot products are summed in input order (the same bits on every CPU, whatever BLAS
    kernel it would select): 1e16 + 1 rounds to 1e16, so the order shows in the sum; a batch gives
    each row's own numbers; and the network is the BLAS formula's to rounding (so it still matches
    stable-baselines3, tests above)."""
    from offroadbench.navigation.policies.ppo import _affine, _tanh

    w, b = np.ones((1, 3)), np.zeros(1)
    assert _affine(w, b, np.array([1e16, 1.0, -1e16]))[0] == 0.0  # (1e16 + 1) - 1e16
    assert _affine(w, b, np.array([1e16, -1e16, 1.0]))[0] == 1.0
    assert _affine(w, b, np.array([[1e16, 1.0, -1e16], [1e16, -1e16, 1.0]])).tolist() == [[0.0], [1.0]]
    h = np.linspace(-3.0, 3.0, 13)
    assert _tanh(h).tolist() == [math.tanh(v) for v in h]
    wts = load_weights(shipped_weights())
    f = np.array([features(_obs(seed, nan_cells=seed * 20)) for seed in range(6)])
    rows = np.array([wts.mean_action(r) for r in f])
    assert np.array_equal(wts.mean_action(f), rows)
    x = np.clip((f - wts.obs_mean) / np.sqrt(wts.obs_var + 1e-8), -10.0, 10.0)
    blas = np.tanh(np.tanh(x @ wts.pi_w0.T + wts.pi_b0) @ wts.pi_w1.T + wts.pi_b1) @ wts.mu_w.T + wts.mu_b
    assert rows == pytest.approx(np.clip(blas, -1.0, 1.0), abs=1e-14)
    assert np.ptp(rows, axis=0).max() > 1e-3
