"""``ppo``: a small MLP policy trained with PPO in ``offroadbench/Traverse-v0``, run in pure numpy.

The policy reads the observation every policy of a trial gets (offroadbench.navigation.observation;
through the ``mast`` sensor when the trial's ``[planner] sensor = "mast"``, the truth otherwise),
turns it into a fixed feature vector (:func:`features`), normalises it with the running mean and
variance kept during training, and returns the **mean** of its Gaussian action (no sampling), so a
trial replays bit for bit. No torch at run time: the weights are an ``.npz`` (:func:`load_weights`);
the shipped ``data/ppo_husky.npz`` was trained by ``experiments/train_ppo.py`` (its seed, curve and
terrain distribution in ``experiments/results/ppo-training/``).

Network (the layout of stable-baselines3's ``MlpPolicy`` with ``net_arch=dict(pi=[64, 64])``,
``activation_fn=Tanh``; Raffin et al. 2021, JMLR 22(268))::

    x = clip((f - obs_mean) / sqrt(obs_var + 1e-8), -10, 10)        # VecNormalize's observation
    h1 = tanh(pi_w0 x + pi_b0);  h2 = tanh(pi_w1 h1 + pi_b1)
    a = clip(mu_w h2 + mu_b, -1, 1);  (v, omega) = a * action_scale   # m/s, rad/s

The ``.npz`` holds exactly these arrays (weights ``(out, in)`` as torch stores them) plus
``log_std`` (not used for the mean action), ``action_scale`` (the training vehicle's top speed and
yaw rate), ``patch_cells`` and ``patch_spacing_m`` (the observation it was trained on) and
``feature_version``. :func:`export_sb3` writes the same file from a stable-baselines3 PPO model.

Features (:data:`FEATURE_VERSION` 1, in order; what a pure-numpy rollout and the env both compute):
the goal's bearing as (cos, sin) in the (believed) heading frame, its distance ``min(d, 10 m) / 10``,
roll and pitch (rad), body roll, pitch and yaw rates (rad/s), body velocity forward, left, up (m/s),
then the height patch averaged over 2 x 2 blocks (an 8 x 8 grid for the default 16 x 16 patch; m,
relative to the base, clipped to +-1 m; an unknown cell counts 0), and each block's fraction of known
cells (0-1; 1 everywhere under the oracle). An unknown (NaN) cell is never read as flat ground:
the network sees that it is unknown.

Portability: the action is the same to the last bit on every x86-64 CPU the project runs on (README,
"Reproducibility"). A BLAS matrix product sums in the order of the kernel the CPU selects, and
numpy's ``tanh`` runs the SIMD loop of the CPU's dispatch level: both gave other last bits with the
dispatch switched down (tests/test_portable.py). So each layer's dot products are summed left to
right in plain float64 (elementwise products, then a cumulative sum: every step one IEEE operation)
and ``tanh`` is the C library's scalar one; the rest (normalisation, clipping, the features) is
elementwise IEEE arithmetic, exact on any SIMD width. The same function as before to rounding
(~1e-16): it still matches stable-baselines3's torch inference to float32 precision.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench.errors import InputError
from offroadbench.navigation.drivers import PolicyContext, register_policy
from offroadbench.navigation.problem import PlanningProblem

__all__ = ["FEATURE_VERSION", "PpoConfig", "PpoPolicy", "MlpWeights", "features", "feature_size", "load_weights",
           "save_weights", "export_sb3", "shipped_weights"]

#: the layout of :func:`features` (stored in the .npz; a mismatch is refused)
FEATURE_VERSION = 1
#: goal distance beyond which the distance feature saturates, m
GOAL_SCALE_M = 10.0
#: the height features are clipped to this, m
HEIGHT_CLIP_M = 1.0
#: the shipped weights (package data)
SHIPPED = "ppo_husky.npz"


def shipped_weights() -> Path:
    """The path of the shipped ``ppo_husky.npz`` (inside the installed package)."""
    from importlib.resources import files

    return Path(str(files("offroadbench.navigation.policies").joinpath("data", SHIPPED)))


def _pool(patch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean of the known cells and the known fraction over 2 x 2 blocks (an odd side drops its last
    row and column)."""
    n = patch.shape[0] // 2 * 2
    p = patch[:n, :n]
    known = np.isfinite(p)
    z = np.where(known, np.clip(p, -HEIGHT_CLIP_M, HEIGHT_CLIP_M), 0.0)
    m = n // 2
    cnt = known.reshape(m, 2, m, 2).sum(axis=(1, 3)).astype(float)
    tot = z.reshape(m, 2, m, 2).sum(axis=(1, 3))
    mean = np.divide(tot, cnt, out=np.zeros_like(tot), where=cnt > 0)
    return mean, cnt / 4.0


def feature_size(patch_cells: int) -> int:
    """Length of :func:`features` for a ``patch_cells`` square patch."""
    m = max(patch_cells // 2, 0)
    return 11 + 2 * m * m


def features(observation: Mapping[str, np.ndarray]) -> np.ndarray:
    """The policy's input (module docstring), float64, from an observation Dict (``state`` and
    ``height_patch``; NaN cells are unknown)."""
    s = np.asarray(observation["state"], dtype=float)
    gx, gy = s[0], s[1]
    d = math.hypot(gx, gy)
    bearing = (gx / d, gy / d) if d > 1e-9 else (1.0, 0.0)
    mean, known = _pool(np.asarray(observation["height_patch"], dtype=float))
    head = np.array([bearing[0], bearing[1], min(d, GOAL_SCALE_M) / GOAL_SCALE_M, *s[2:10]])
    return np.concatenate([head, mean.ravel(), known.ravel()])


@dataclass(frozen=True, eq=False)
class MlpWeights:
    """The arrays of a ppo ``.npz`` (module docstring)."""

    pi_w0: np.ndarray
    pi_b0: np.ndarray
    pi_w1: np.ndarray
    pi_b1: np.ndarray
    mu_w: np.ndarray
    mu_b: np.ndarray
    log_std: np.ndarray
    obs_mean: np.ndarray
    obs_var: np.ndarray
    action_scale: np.ndarray
    patch_cells: int
    patch_spacing_m: float
    feature_version: int = FEATURE_VERSION

    def mean_action(self, f: np.ndarray) -> np.ndarray:
        """The clipped mean action in [-1, 1]^2 for one feature vector (or a batch, rows); the same
        bits on every CPU (module docstring, "Portability")."""
        x = np.clip((np.asarray(f, dtype=np.float64) - self.obs_mean) / np.sqrt(self.obs_var + 1e-8), -10.0, 10.0)
        h = _tanh(_affine(self.pi_w0, self.pi_b0, x))
        h = _tanh(_affine(self.pi_w1, self.pi_b1, h))
        return np.clip(_affine(self.mu_w, self.mu_b, h), -1.0, 1.0)


def _affine(w: np.ndarray, b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``w x + b`` for ``x`` (in,) or rows (n, in): each dot product summed left to right over the
    inputs (a cumulative sum: one IEEE addition after another), then the bias; float64, no BLAS."""
    return np.cumsum(x[..., None, :] * w, axis=-1)[..., -1] + b


def _tanh(h: np.ndarray) -> np.ndarray:
    """tanh of each element through the C library's scalar ``tanh`` (``math.tanh``), not numpy's SIMD loop."""
    return np.fromiter(map(math.tanh, h.ravel().tolist()), np.float64, h.size).reshape(h.shape)


_ARRAYS = ("pi_w0", "pi_b0", "pi_w1", "pi_b1", "mu_w", "mu_b", "log_std", "obs_mean", "obs_var", "action_scale")


def save_weights(path: str | Path, w: MlpWeights, **meta: str) -> None:
    """Write ``w`` as an ``.npz`` (float64 arrays; ``meta`` as string entries, e.g. the training seed)."""
    arrays = {k: np.asarray(getattr(w, k), dtype=np.float64) for k in _ARRAYS}
    arrays.update(patch_cells=np.int64(w.patch_cells), patch_spacing_m=np.float64(w.patch_spacing_m),
                  feature_version=np.int64(w.feature_version))
    arrays.update({f"meta_{k}": np.str_(v) for k, v in meta.items()})
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


def load_weights(path: str | Path) -> MlpWeights:
    """Read a ppo ``.npz``, checking its arrays' names and shapes; InputError naming the file otherwise."""
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise InputError(f"ppo weights {path}: cannot be read ({exc})") from None
    missing = [k for k in (*_ARRAYS, "patch_cells", "patch_spacing_m", "feature_version") if k not in data]
    if missing:
        raise InputError(f"ppo weights {path}: missing {', '.join(missing)}")
    w = MlpWeights(**{k: np.asarray(data[k], dtype=np.float64) for k in _ARRAYS},
                   patch_cells=int(data["patch_cells"]), patch_spacing_m=float(data["patch_spacing_m"]),
                   feature_version=int(data["feature_version"]))
    n_in = feature_size(w.patch_cells)
    shapes = {"pi_w0": (w.pi_b0.size, n_in), "pi_w1": (w.pi_b1.size, w.pi_b0.size), "mu_w": (2, w.pi_b1.size),
              "mu_b": (2,), "obs_mean": (n_in,), "obs_var": (n_in,), "action_scale": (2,)}
    bad = [f"{k} {getattr(w, k).shape} (expected {v})" for k, v in shapes.items() if getattr(w, k).shape != v]
    if w.feature_version != FEATURE_VERSION:
        bad.append(f"feature_version {w.feature_version} (this code reads {FEATURE_VERSION})")
    if bad:
        raise InputError(f"ppo weights {path}: {'; '.join(bad)}")
    return w


def export_sb3(model: Any, path: str | Path, *, obs_rms: Any = None, action_scale=(1.0, 1.0),
               patch_cells: int = 16, patch_spacing_m: float = 0.1, **meta: str) -> MlpWeights:
    """Write a stable-baselines3 PPO model (``MlpPolicy``, ``net_arch=dict(pi=[h, h])``, Tanh, on a
    Box of :func:`features` with the action Box [-1, 1]^2) as a ppo ``.npz``. ``obs_rms`` is a
    VecNormalize's ``obs_rms`` (mean, var); without it the features are not normalised. Needs torch
    (the ``rl`` extra); the written file needs only numpy."""
    sd = {k: v.detach().cpu().numpy().astype(np.float64) for k, v in model.policy.state_dict().items()}
    n_in = sd["mlp_extractor.policy_net.0.weight"].shape[1]
    mean = np.zeros(n_in) if obs_rms is None else np.asarray(obs_rms.mean, dtype=np.float64)
    var = np.ones(n_in) - 1e-8 if obs_rms is None else np.asarray(obs_rms.var, dtype=np.float64)
    w = MlpWeights(pi_w0=sd["mlp_extractor.policy_net.0.weight"], pi_b0=sd["mlp_extractor.policy_net.0.bias"],
                   pi_w1=sd["mlp_extractor.policy_net.2.weight"], pi_b1=sd["mlp_extractor.policy_net.2.bias"],
                   mu_w=sd["action_net.weight"], mu_b=sd["action_net.bias"], log_std=sd["log_std"],
                   obs_mean=mean, obs_var=var, action_scale=np.asarray(action_scale, dtype=np.float64),
                   patch_cells=patch_cells, patch_spacing_m=patch_spacing_m)
    save_weights(path, w, **meta)
    return w


@dataclass(frozen=True, kw_only=True)
class PpoConfig:
    """Settings of the ``ppo`` policy."""

    weights: str = "shipped"
    """The ``.npz`` to load: ``shipped`` (``ppo_husky.npz``, trained by experiments/train_ppo.py) or a
    path to one written by its training or by offroadbench.navigation.policies.ppo.export_sb3."""

    def __post_init__(self) -> None:
        if not isinstance(self.weights, str) or not self.weights:
            raise InputError(f"PpoConfig.weights = {self.weights!r}: expected 'shipped' or the path of an .npz")


@register_policy("ppo", config=PpoConfig, needs=frozenset(),
                 summary="an MLP trained with PPO in the Gymnasium env (shipped weights, numpy inference, mean action)")
class PpoPolicy:
    """The trained MLP (module docstring) as a trial's closed-loop driver.

    Optimises: what its reward paid in training (progress toward the goal, less vertical
    acceleration and roll/pitch rates, a bonus at the goal and a penalty for tipping, sticking or
    leaving the map; offroadbench.sim.gym_env). Cannot see: beyond its 1.5 m height patch; knows
    only the terrains it was trained on (experiments/results/ppo-training/README.md).
    """

    def __init__(self, cfg: PpoConfig, context: PolicyContext) -> None:
        path = shipped_weights() if cfg.weights == "shipped" else Path(cfg.weights)
        self.w = load_weights(path)
        obs = context.observation
        if (obs.patch_cells, obs.patch_spacing_m) != (self.w.patch_cells, self.w.patch_spacing_m):
            raise InputError(
                f"ppo weights {path} were trained on a {self.w.patch_cells} x {self.w.patch_spacing_m} m height "
                f"patch; this trial observes {obs.patch_cells} x {obs.patch_spacing_m} m: set [observation] "
                f"patch_cells = {self.w.patch_cells}, patch_spacing_m = {self.w.patch_spacing_m}")

    def reset(self, problem: PlanningProblem) -> None:
        """Nothing to remember between missions (a memoryless policy)."""

    def act(self, observation: Mapping[str, np.ndarray]) -> tuple[float, float]:
        a = self.w.mean_action(features(observation)) * self.w.action_scale
        return float(a[0]), float(a[1])
