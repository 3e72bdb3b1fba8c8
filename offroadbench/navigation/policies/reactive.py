"""``reactive``: pure pursuit to the goal, bent away from steep steps seen in the height patch."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.navigation.drivers import PolicyContext, register_policy
from offroadbench.navigation.problem import PlanningProblem

__all__ = ["ReactiveConfig", "ReactivePolicy"]


@dataclass(frozen=True, kw_only=True)
class ReactiveConfig:
    """Settings of the ``reactive`` policy."""

    cruise_speed_m_s: float = 1.0
    """Speed on smooth ground, m/s (capped by the vehicle's top speed)."""
    lookahead_m: float = 1.5
    """Distance of the pure-pursuit point toward the goal, m."""
    max_curvature_1_m: float = 1.0
    """Tightest arc among the candidates, 1/m."""
    candidates: int = 11
    """Arcs compared per control tick (evenly spread in curvature, plus the pure-pursuit arc)."""
    roughness_weight: float = 8.0
    """Weight of the terrain term against the heading term (0: pure pursuit to the goal)."""
    slow_down: float = 0.5
    """Fraction of the speed given up on the roughest arc (roughness 1 = the vehicle's max slope)."""

    def __post_init__(self) -> None:
        for name in ("cruise_speed_m_s", "lookahead_m", "max_curvature_1_m"):
            check_range(self, name, getattr(self, name), lo=0, lo_open=True)
        check_int(self, "candidates", self.candidates, lo=1, hi=101)
        check_range(self, "roughness_weight", self.roughness_weight, lo=0)
        check_range(self, "slow_down", self.slow_down, lo=0, hi=1)


@register_policy("reactive", config=ReactiveConfig, needs=frozenset({"vehicle"}),
                 summary="pure pursuit to the goal, bent away from steep steps seen in the height patch")
class ReactivePolicy:
    """A reactive, terrain-aware policy on the observation alone.

    Each tick it compares arcs of several curvatures (plus the pure-pursuit arc to a point
    ``lookahead_m`` toward the goal, curvature ``2 y / (x^2 + y^2)``, Coulter 1992). Along each arc,
    as far as the height patch reaches, it reads the heights under the left and right wheel tracks
    and takes the arc's roughness ``r`` as the larger of the mean along-track slope (per track) and
    the mean cross slope, each over the vehicle's max slope and clipped at 2 (the patch's samples
    beyond its edge read the nearest edge sample). It drives the arc minimising ``(heading change
    against the pure-pursuit arc over the patch's reach)^2 + roughness_weight * r^2`` at ``cruise * (1 - slow_down * min(r, 1))``, slowing to stop at the goal
    within the vehicle's acceleration. A goal behind the vehicle is turned toward on the tightest arc.

    Optimises: progress toward the goal with the gentlest ground under the wheels in the next metre.
    Cannot see: beyond the height patch (0.75 m ahead by default), the class map, the way round a
    large obstacle (it is greedy and can be trapped in a dead end).
    """

    def __init__(self, cfg: ReactiveConfig, context: PolicyContext) -> None:
        self.cfg = cfg
        self.ctx = context
        obs = context.observation
        self._n = obs.patch_cells
        self._ds = obs.patch_spacing_m
        self._centre = (obs.patch_cells - 1) / 2.0
        reach = self._centre * self._ds
        self._s = np.linspace(0.0, max(reach, self._ds), 10)
        self._half_track = 0.5 * context.track_m
        self._track_sign = np.array([[self._half_track], [-self._half_track]])  # left, right: +h, -h (m)
        # the fixed candidates' curvatures (1/m) and their tracks' patch coordinates, once per policy
        self._k_fixed = np.linspace(-cfg.max_curvature_1_m, cfg.max_curvature_1_m, cfg.candidates)
        # the coordinates of every arc's samples: the pure-pursuit arc's first (written each tick)
        self._rc = np.concatenate([np.zeros((2, 2 * self._s.size))]
                                  + [self._track_coords(float(k)) for k in self._k_fixed], axis=1)

    def reset(self, problem: PlanningProblem) -> None:
        """Nothing to remember between missions."""

    def _track_coords(self, kappa: float) -> np.ndarray:
        """The patch coordinates (row; column: 2 x 20, samples) of the left then the right wheel
        track's 10 points along the arc of curvature ``kappa`` (1/m)."""
        s = self._s
        if abs(kappa) < 1e-9:
            x, y, th = s, 0.0 * s, 0.0 * s
            sin, cos = np.sin(th), np.cos(th)
        else:
            th = kappa * s
            sin, cos = np.sin(th), np.cos(th)
            x, y = sin / kappa, (1.0 - cos) / kappa
        # [y; x] (2, 1, 10) + [h; -h] (2, 1) * the track normal [n_y; n_x] = [cos; -sin] (2, 1, 10): the
        # left and right tracks' (2, 2, 10), each entry the one sum (x - h n_x is x + (-h) n_x in IEEE)
        n = s.size
        yx, normal = np.empty((2, 1, n)), np.empty((2, 1, n))
        yx[0, 0], yx[1, 0], normal[0, 0] = y, x, cos
        np.negative(sin, out=normal[1, 0])
        tracks = yx + self._track_sign * normal
        return (tracks / self._ds + self._centre).reshape(2, 2 * n)

    def _roughness(self, patch: np.ndarray, k_star: float) -> np.ndarray:
        """Roughness of the pure-pursuit arc ``k_star`` (1/m) then of each fixed candidate, one
        interpolation for all their samples (each sample's value is that of its own call)."""
        from scipy.ndimage import map_coordinates

        rc, n = self._rc, self._s.size
        rc[:, :2 * n] = self._track_coords(k_star)
        z = map_coordinates(patch, rc, order=1, mode="nearest").reshape(-1, 2, n)
        s, h = self._s, self._half_track
        step = s[1] - s[0]
        m = self.ctx.vehicle.max_slope
        # ndarray.mean is add.reduce then a division by the count, np.diff the subtraction of the slices
        along = np.minimum(np.abs(z[:, :, 1:] - z[:, :, :-1]) / (step * m), 2.0)
        along = np.maximum.reduce(np.add.reduce(along, axis=2) / (n - 1), axis=1)
        cross = np.add.reduce(np.minimum(np.abs(z[:, 0] - z[:, 1]) / (2.0 * h * m), 2.0), axis=1) / n
        return np.where(cross > along, cross, along)  # max(along, cross), NaN as Python's max

    def act(self, observation: Mapping[str, np.ndarray]) -> tuple[float, float]:
        cfg, veh = self.cfg, self.ctx.vehicle
        state = observation["state"]
        gx, gy = float(state[0]), float(state[1])
        d = math.hypot(gx, gy)
        k_max = cfg.max_curvature_1_m
        v_top = min(cfg.cruise_speed_m_s, veh.max_speed_m_s)
        if d < 1e-6:
            return 0.0, 0.0
        if gx <= 0.0:  # goal behind: the tightest arc toward it, slowly
            v = 0.3 * v_top
            return v, max(-veh.max_yaw_rate_rad_s, min(veh.max_yaw_rate_rad_s, math.copysign(v * k_max, gy)))
        tx, ty = (gx, gy) if d <= cfg.lookahead_m else (gx * cfg.lookahead_m / d, gy * cfg.lookahead_m / d)
        k_star = max(-k_max, min(k_max, 2.0 * ty / (tx * tx + ty * ty)))
        patch = np.asarray(observation["height_patch"], dtype=float)
        best = (math.inf, k_star, 0.0)
        rough = self._roughness(patch, k_star).tolist() if cfg.roughness_weight > 0 else [0.0] * (cfg.candidates + 1)
        for k, r in zip((k_star, *self._k_fixed), rough, strict=True):
            score = ((k - k_star) * self._s[-1]) ** 2 + cfg.roughness_weight * r * r
            if score < best[0]:
                best = (score, float(k), r)
        _, k, r = best
        v = v_top * (1.0 - cfg.slow_down * min(r, 1.0))
        v = min(v, math.sqrt(2.0 * 0.5 * max(d - 0.2, 0.0)) + 0.1)  # arrive gently (0.5 m/s^2)
        omega = max(-veh.max_yaw_rate_rad_s, min(veh.max_yaw_rate_rad_s, v * k))
        return v, omega
