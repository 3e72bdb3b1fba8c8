"""The policies' per-tick code, made cheaper (branch ``obsperf``), gives the bits of the form the
committed rows were recorded with: the ``reactive`` policy's action (all arcs' heights in one
interpolation, the fixed arcs' coordinates computed once per policy) and the observation's height
patch (its body-frame grid computed once per size), each against its earlier per-tick form (commit
99e44a1) on random inputs, compared as float hex."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.drivers import PolicyContext, make_policy
from offroadbench.navigation.observation import ObservationConfig, height_patch, observation
from offroadbench.navigation.policies.reactive import ReactiveConfig
from offroadbench.navigation.problem import VehicleEnvelope


def _hex(values) -> list[str]:
    return [float(x).hex() for x in np.ravel(values)]


def _old_reactive_act(policy, obs, rough: list | None = None) -> tuple[float, float]:
    """ReactivePolicy.act as written at 99e44a1: two interpolations per arc, each arc's coordinates
    and roughness computed per tick, with the policy's config and context; each arc's roughness is
    appended to ``rough``."""
    cfg, veh, ctx = policy.cfg, policy.ctx.vehicle, policy.ctx
    ds = ctx.observation.patch_spacing_m
    centre, h = (ctx.observation.patch_cells - 1) / 2.0, 0.5 * ctx.track_m
    n_s = np.linspace(0.0, max(centre * ds, ds), 10)

    def heights(patch, xb, yb):
        return map_coordinates(patch, [yb / ds + centre, xb / ds + centre], order=1, mode="nearest")

    def roughness(patch, kappa):
        s = n_s
        if abs(kappa) < 1e-9:
            x, y, th = s, 0.0 * s, 0.0 * s
        else:
            th = kappa * s
            x, y = np.sin(th) / kappa, (1.0 - np.cos(th)) / kappa
        nx, ny = -np.sin(th), np.cos(th)
        zl = heights(patch, x + h * nx, y + h * ny)
        zr = heights(patch, x - h * nx, y - h * ny)
        step = s[1] - s[0]
        m = veh.max_slope
        along = np.minimum(np.abs(np.diff(np.stack([zl, zr]), axis=1)) / (step * m), 2.0)
        cross = np.minimum(np.abs(zl - zr) / (2.0 * h * m), 2.0)
        return float(max(along.mean(axis=1).max(), cross.mean()))

    state = obs["state"]
    gx, gy = float(state[0]), float(state[1])
    d = math.hypot(gx, gy)
    k_max = cfg.max_curvature_1_m
    v_top = min(cfg.cruise_speed_m_s, veh.max_speed_m_s)
    if d < 1e-6:
        return 0.0, 0.0
    if gx <= 0.0:
        v = 0.3 * v_top
        return v, max(-veh.max_yaw_rate_rad_s, min(veh.max_yaw_rate_rad_s, math.copysign(v * k_max, gy)))
    tx, ty = (gx, gy) if d <= cfg.lookahead_m else (gx * cfg.lookahead_m / d, gy * cfg.lookahead_m / d)
    k_star = max(-k_max, min(k_max, 2.0 * ty / (tx * tx + ty * ty)))
    patch = np.asarray(obs["height_patch"], dtype=float)
    best = (math.inf, k_star, 0.0)
    for k in (k_star, *np.linspace(-k_max, k_max, cfg.candidates)):
        r = roughness(patch, float(k)) if cfg.roughness_weight > 0 else 0.0
        if rough is not None:
            rough.append(r)
        score = ((k - k_star) * n_s[-1]) ** 2 + cfg.roughness_weight * r * r
        if score < best[0]:
            best = (score, float(k), r)
    _, k, r = best
    v = v_top * (1.0 - cfg.slow_down * min(r, 1.0))
    v = min(v, math.sqrt(2.0 * 0.5 * max(d - 0.2, 0.0)) + 0.1)
    omega = max(-veh.max_yaw_rate_rad_s, min(veh.max_yaw_rate_rad_s, v * k))
    return v, omega


def _old_height_patch(hm, x_m, y_m, yaw_rad, cells, spacing_m, fill_m, z_m=None):
    """observation.height_patch as written at 99e44a1 (its grid built per call)."""
    offs = (np.arange(cells) - (cells - 1) / 2.0) * spacing_m
    yb, xb = np.meshgrid(offs, offs, indexing="ij")
    cos, sin = math.cos(yaw_rad), math.sin(yaw_rad)
    xw = x_m + cos * xb - sin * yb
    yw = y_m + sin * xb + cos * yb
    col = xw / hm.cell_size_m
    row = yw / hm.cell_size_m
    z = map_coordinates(hm.z if z_m is None else z_m, [row, col], order=1, mode="nearest")
    outside = (col < 0) | (col > hm.cols - 1) | (row < 0) | (row > hm.rows - 1)
    z[outside] = fill_m
    return z


@pytest.mark.parametrize("seed", range(6))
def test_reactive_act_gives_the_bits_of_its_per_arc_form(seed):
    rng = np.random.default_rng(seed)
    cfg = ReactiveConfig(candidates=int(rng.choice([1, 2, 5, 11, 24])),
                         max_curvature_1_m=float(rng.uniform(0.2, 2.5)), lookahead_m=float(rng.uniform(0.5, 3.0)),
                         roughness_weight=(0.5, 8.0, 40.0, 0.0, 8.0, 2.0)[seed], slow_down=float(rng.uniform(0, 1)))
    cells, spacing = int(rng.integers(2, 33)), float(rng.uniform(0.03, 0.2))
    ctx = PolicyContext(observation=ObservationConfig(patch_cells=cells, patch_spacing_m=spacing),
                        vehicle=VehicleEnvelope(max_slope=float(rng.uniform(0.3, 1.2))),
                        track_m=float(rng.uniform(0.2, 1.2)))
    policy = make_policy("reactive", cfg, ctx)
    checked = 0
    for i in range(60):
        state = np.zeros(10, dtype=np.float32)
        state[0], state[1] = rng.uniform(-1.0, 6.0), rng.uniform(-3.0, 3.0)
        if i % 10 == 0:
            state[1] = 0.0  # the straight arc
        scale = rng.choice([0.0, 0.01, 0.3, 2.0])
        patch = (scale * rng.standard_normal((cells, cells))).astype(np.float32)
        if i % 4 == 1:  # a mast sensor's unknown samples
            patch[rng.random((cells, cells)) < 0.1] = np.nan
        obs = {"state": state, "height_patch": patch}
        rough: list[float] = []
        new, old = policy.act(obs), _old_reactive_act(policy, obs, rough)
        assert _hex(new) == _hex(old), (seed, i)
        if rough and cfg.roughness_weight > 0:  # every arc's roughness, not only the chosen one's
            gx, gy = float(state[0]), float(state[1])
            d, la, k_max = math.hypot(gx, gy), cfg.lookahead_m, cfg.max_curvature_1_m
            tx, ty = (gx, gy) if d <= la else (gx * la / d, gy * la / d)
            k_star = max(-k_max, min(k_max, 2.0 * ty / (tx * tx + ty * ty)))
            assert _hex(policy._roughness(np.asarray(patch, dtype=float), k_star)) == _hex(rough), (seed, i)
            checked += 1
    assert checked > 10 or cfg.roughness_weight == 0  # most ticks compared the arcs' roughness


@pytest.mark.parametrize("seed", range(4))
def test_height_patch_gives_the_bits_of_its_per_call_grid(seed):
    rng = np.random.default_rng(10 + seed)
    rows, cols = int(rng.integers(5, 80)), int(rng.integers(5, 80))
    hm = Heightmap(rng.standard_normal((rows, cols)), float(rng.uniform(0.02, 0.2)))
    sensed = hm.z.copy()
    sensed[rng.random(hm.shape) < 0.2] = np.nan
    kinds = set()
    for i in range(120):
        cells, spacing = int(rng.integers(1, 20)), float(rng.choice([0.1, rng.uniform(0.01, 0.5)]))
        x, y = rng.uniform(-1.0, hm.width_m + 1.0), rng.uniform(-1.0, hm.height_m + 1.0)
        if i % 2:  # near the middle: no sample off the map, the mask skipped
            cells, spacing = int(rng.integers(1, 8)), 0.5 * hm.cell_size_m
            x, y = 0.5 * hm.width_m + rng.uniform(-0.1, 0.1), 0.5 * hm.height_m + rng.uniform(-0.1, 0.1)
        yaw = float(rng.uniform(-4.0, 4.0))
        z_m = sensed if i % 3 == 0 else None
        new = height_patch(hm, x, y, yaw, cells, spacing, -7.5, z_m)
        old = _old_height_patch(hm, x, y, yaw, cells, spacing, -7.5, z_m)
        assert new.shape == old.shape == (cells, cells) and _hex(new) == _hex(old), (seed, i)
        kinds.add(bool(np.any(_old_height_patch(hm, x, y, yaw, cells, spacing, np.inf) == np.inf)))
        new[...] = 99.0  # the caller owns the patch: the next call's grid is not touched
    assert kinds == {True, False}  # patches with samples off the map and patches without
    cfg = ObservationConfig()
    for _ in range(20):
        args = ((3.0, 2.0), (rng.uniform(0, hm.width_m), rng.uniform(0, hm.height_m), 0.2), 0.01, -0.02,
                float(rng.uniform(-4, 4)), (0.1, -0.2, 0.3), (0.5, 0.01, -0.02), -3.0)
        obs = observation(hm, cfg, *args)
        pos, yaw = args[1], args[4]
        ref = (_old_height_patch(hm, pos[0], pos[1], yaw, 16, 0.1, -3.0) - pos[2]).astype(np.float32)
        assert _hex(obs["height_patch"]) == _hex(ref)
