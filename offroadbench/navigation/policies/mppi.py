"""``mppi``: model-predictive path integral control over a skid-steer model and the perceived map.

Each control tick the policy samples ``samples`` control sequences ``u_k(t) = U(t) + eps_k(t)``
(speed and yaw rate) around its mean sequence ``U`` over ``horizon_s``, rolls each out through the
vehicle model below, scores it on the planner's elevation map, and moves ``U`` to the
temperature-weighted mean of the samples (Williams et al. 2017, "Information theoretic MPC for
model-based reinforcement learning", ICRA; the update without its control-cost term):

    w_k = exp(-(S_k - min_j S_j) / lambda) / sum_j exp(-(S_j - min_i S_i) / lambda)
    U(t) <- U(t) + sum_k w_k eps_k(t)

It drives ``U(0)`` and shifts ``U`` one tick left for the next (the warm start; the last entry
repeats). Sample 0 is ``U`` itself (no noise), so the update never scores worse than the mean.

**Noise.** Time-correlated: ``eps(t) = a eps(t - 1) + sqrt(1 - a^2) sigma n(t)`` with ``n`` standard
normal and ``a = exp(-dt / noise_corr_s)``, a discretised Ornstein-Uhlenbeck process started from its
stationary law (every ``eps(t)`` has standard deviation ``sigma``): smooth trials that a skid-steer
drive can follow, rather than white noise that averages to nothing over a horizon.

**Model** (a unicycle with a slip term, the kinematic skid-steer model of Kozlowski & Pazderski 2004,
"Modeling and control of a 4-wheel skid-steering mobile robot", Int. J. Appl. Math. Comput. Sci. 14,
reduced to a unicycle, with a slip that grows with the grade): state ``(x, y, theta)`` in map metres and
radians, controls ``(v, omega)``, step ``dt`` = the control period,

    theta(t + 1) = theta(t) + (1 - s_yaw) omega(t) dt
    x(t + 1) = x(t) + (1 - s(t)) v(t) cos theta(t) dt,   y likewise with sin
    s(t) = clip(slip_base + slip_per_grade * max(g(t), 0), 0, 1)

where ``g`` is the uphill grade (rise/run) of the map along the heading at the no-slip position
``(x0, y0)(t)`` (the same recursion with ``s = 0``): one fixed-point pass, which keeps the rollout
two cumulative sums over the whole (samples x steps) array. ``s_yaw`` is the yaw-rate loss of a
skid-steer turn beyond what the drive's own track factor already corrects.

**Costs** from the perceived elevation map ``z`` (NaN = unknown), computed on a window round the
vehicle that every rollout stays inside and re-computed when the vehicle has moved
``recost_every_m`` or the map changed. Per cell: the footprint's slope plane (the height difference
across a vehicle half-diagonal, both axes), the **step** (the largest rise within a wheel radius
of the wheel's envelope, the terrain dilated by a ball of the wheel's radius, over
``max_step_m``; read under each wheel track), the **belly clearance** (the
highest point under the belly above the footprint's mean height, over ``ground_clearance_m``) and
the **roughness** (the standard deviation of the heights under the footprint over
``ground_clearance_m``). At each rollout step the hazard is ``H = max(step left, step right,
belly, |g_along| / max_slope, |g_cross| / max_slope)`` with the slope resolved along and across the sampled heading;
a cell within a footprint of an unknown cell has ``H = unknown_hazard`` (unknown is neither flat nor
forbidden). A rollout pays, per second, ``hazard_weight H^2 + roughness_weight r + lethal_cost [H >= 1]``
(``lethal_cost`` also off the map), plus ``goal_weight`` times its time-averaged and its final
progress term; steps after a rollout first comes within ``goal_tolerance_m`` of the goal cost
nothing (the trial has ended there).

**Progress** (``cost_to_go``, the default): the cost-to-go to the goal, a Dijkstra search from the
goal over the footprint-hazard cost grid that ``astar`` plans on (offroadbench.navigation.costmap;
8-connected, each move its length times the mean cost per metre of its two cells; the relaxed grid
when the strict one has no path), read bilinearly every 0.25 s along each rollout and at its end;
cells the strict grid forbids are lethal too. It is the terminal cost that lets a short horizon go
round an obstacle wider than it can see (the global-guidance of MPPI navigation stacks, e.g.
Nav2's path-following critics), computed once per mission on the true map, and on a sensor's map
(unseen ground continued smoothly, as the planners see it) each time the map has changed and the
vehicle has moved ``cost_to_go_every_m``. Without it: the straight-line distance to the goal.

**Recovery.** The kinematic model cannot know that a wheel is held by a step: when the measured
forward speed (``observation["state"]``, ``v_forward_m_s``) stays below 0.05 m/s for ``stall_s``
while the policy commands at least 0.3 m/s, it backs up for ``backup_s`` (speeds sampled in
``[-0.5 v_top, 0]``, the same costs), then drives on (a back-up recovery, as Nav2's BackUp behaviour).

What it needs: ``observation["pose"]`` (believed x, y, yaw) and ``observation["elevation_m"]`` (the
map it plans on, on the terrain's grid; NaN unknown), which the runner adds for entries that declare
``map`` (offroadbench.navigation.drivers.NEEDS): the true map and pose for the ``oracle`` arm, the
sensor's (offroadbench.navigation.sensor) otherwise.

Randomness: its own stream per mission, from ``seed`` and the exact bits of the mission's start and
goal (``reset``), so a trial replays bit for bit and does not depend on other trials.

Portability: a trial is the same to the last bit on every x86-64 CPU the project runs on (README,
"Reproducibility"). numpy's ``sin``, ``cos`` and ``exp`` run the SIMD loops of the CPU's dispatch
level and ``tensordot`` is a BLAS product: each gave other last bits with the dispatch switched down
(tests/test_portable.py). So the headings' cosines and sines are the C library's scalar double ones
rounded to float32 (:func:`cos_sin`; compiled by numba when it is installed, the same bits), the
weights' ``exp`` is ``math.exp``, and the update sums the weighted samples in sample order (a
cumulative sum). The rest is elementwise IEEE arithmetic (exact on any SIMD width), numpy's pairwise
sums (a fixed order), scipy's compiled filters and interpolation (no run-time dispatch) and the
random stream (scalar code), which gave the same bits.

The cost maps (the local window and the cost-to-go) are in :mod:`offroadbench.navigation.policies.mppi_costs`.
"""

from __future__ import annotations

import hashlib
import math
import struct
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from offroadbench.config import check_int, check_range
from offroadbench.navigation.drivers import PolicyContext, register_policy
from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope
from offroadbench.navigation.policies.mppi_costs import CostToGo, CostWindow, cost_to_go, cost_window

__all__ = ["MppiConfig", "MppiPolicy", "MPPI_STREAM", "CostWindow", "CostToGo", "cost_window", "cost_to_go", "cos_sin",
           "rollout"]

#: first spawn-key entry of MPPI's stream (terrains 0, missions 1, perception 2; offroadbench.seeding)
MPPI_STREAM = 3

#: whether :func:`cos_sin` may use the compiled pass (tests switch it off to compare)
USE_COMPILED_TRIG = True


def _compiled_trig():
    """offroadbench.navigation.compiled.mppi, or None (numba missing, with SVML, or unable to compile)."""
    if not USE_COMPILED_TRIG:
        return None
    try:
        from offroadbench.navigation.compiled import mppi
    except (ImportError, RuntimeError):
        return None
    return mppi


def cos_sin(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``cos`` and ``sin`` of the float32 angles ``th`` (rad) as float32 arrays of its shape: the C
    library's scalar double functions (``math.cos``, ``math.sin``), each rounded to float32, so the
    same bits on every CPU (module docstring, "Portability"); numba's compiled pass when installed
    (offroadbench.navigation.compiled.mppi, the same bits)."""
    compiled = _compiled_trig()
    if compiled is not None:
        return compiled.cos_sin(th)
    shape = np.shape(th)
    flat = np.asarray(th, dtype=np.float32).ravel().tolist()
    try:
        cs = [np.fromiter(map(f, flat), np.float64, len(flat)).astype(np.float32) for f in (math.cos, math.sin)]
    except ValueError:  # an infinite angle: NaN, as the C library (and the compiled pass) gives
        cs = [np.fromiter((f(a) if math.isfinite(a) else math.nan for a in flat), np.float64, len(flat)).astype(np.float32)
              for f in (math.cos, math.sin)]
    return cs[0].reshape(shape), cs[1].reshape(shape)


@dataclass(frozen=True, kw_only=True)
class MppiConfig:
    """Settings of the ``mppi`` policy (see offroadbench.navigation.policies.mppi)."""

    samples: int = 1024
    """Control sequences sampled per tick (sample 0 is the mean itself)."""
    horizon_s: float = 2.5
    """Length of each rollout, s (in steps of the control period)."""
    temperature: float = 0.3
    """lambda of the weights ``exp(-(S - min S) / lambda)``, in cost units (metres of distance)."""
    noise_v_m_s: float = 0.3
    """Standard deviation of the speed noise, m/s."""
    noise_omega_rad_s: float = 0.4
    """Standard deviation of the yaw-rate noise, rad/s."""
    noise_corr_s: float = 0.4
    """Correlation time of the noise (Ornstein-Uhlenbeck), s."""
    cruise_speed_m_s: float = 1.0
    """Top speed the policy commands, m/s (capped by the vehicle's)."""
    goal_weight: float = 1.0
    """Cost per metre of the time-averaged and of the final distance to the goal."""
    hazard_weight: float = 4.0
    """Cost per second at hazard 1 (grows as H^2)."""
    roughness_weight: float = 1.0
    """Cost per second per unit of roughness (height std / ground clearance)."""
    lethal_cost: float = 20.0
    """Cost per second at or past one of the vehicle's limits (H >= 1) or off the map (finite: the
    hazard is a proxy, and a vehicle may have to cross a short band of it to get anywhere)."""
    goal_tolerance_m: float = 0.5
    """A rollout that comes this close to the goal has arrived (the trial's success radius): its
    later steps cost nothing."""
    unknown_hazard: float = 0.5
    """Hazard assumed on and next to unknown (unseen) cells."""
    slip_base: float = 0.05
    """Longitudinal slip on level ground (fraction of the commanded speed lost)."""
    slip_per_grade: float = 0.5
    """Extra slip per unit of uphill grade (rise/run)."""
    yaw_slip: float = 0.1
    """Fraction of the commanded yaw rate lost in a skid-steer turn."""
    cost_to_go: bool = True
    """Score progress by the cost-to-go to the goal over the planners' cost grid (Dijkstra on the
    perceived map, module docstring) instead of the straight-line distance (which traps a 2.5 s
    horizon behind any obstacle wider than it can see round)."""
    cost_to_go_grid_m: float = 0.25
    """Cell of the cost-to-go grid, m."""
    cost_to_go_every_m: float = 1.0
    """Re-compute the cost-to-go after the vehicle has moved this far and the map has changed, m."""
    recost_every_m: float = 0.25
    """Re-compute the cost window after the vehicle has moved this far (or when the map changes), m."""
    stall_s: float = 1.5
    """Recovery: when the measured forward speed has stayed below 0.05 m/s for this long while the
    policy commanded at least 0.3 m/s, the model is wrong (a wheel against a step it cannot climb):
    the policy backs up (s); 0 disables it."""
    backup_s: float = 1.5
    """Recovery: how long it backs up, sampling only speeds in [-0.5 top speed, 0], s."""
    seed: int = 0
    """Root of the policy's random stream (with the mission's start and goal)."""

    def __post_init__(self) -> None:
        check_int(self, "samples", self.samples, lo=2, hi=1_000_000)
        check_int(self, "seed", self.seed, lo=0)
        for name in ("horizon_s", "temperature", "noise_corr_s", "cruise_speed_m_s", "recost_every_m",
                     "goal_tolerance_m", "cost_to_go_grid_m", "cost_to_go_every_m"):
            check_range(self, name, getattr(self, name), lo=0, lo_open=True)
        for name in ("stall_s", "backup_s", "noise_v_m_s", "noise_omega_rad_s", "goal_weight", "hazard_weight", "roughness_weight",
                     "lethal_cost", "unknown_hazard", "slip_per_grade"):
            check_range(self, name, getattr(self, name), lo=0)
        for name in ("slip_base", "yaw_slip"):
            check_range(self, name, getattr(self, name), lo=0, hi=1, hi_open=True)


def rollout(pose, u: np.ndarray, dt: float, win: CostWindow, cfg: MppiConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions and headings of the controls ``u`` (K, T, 2) from ``pose`` (x, y, theta) through the
    slip model of the module docstring: (x, y, theta), each (K, T), the state after each step
    (float32, relative to the pose's position: add ``pose[:2]`` for map metres)."""
    return _rollout(pose, u, dt, win, cfg)[:3]


def _rollout(pose, u: np.ndarray, dt: float, win: CostWindow, cfg: MppiConfig) -> tuple[np.ndarray, ...]:
    """:func:`rollout`'s (x, y, theta) and the cosines and sines of the headings (K, T + 1): the
    pose's, then the one after each step (:func:`cos_sin`)."""
    x0, y0, th0 = (float(a) for a in pose)
    v, w = u[..., 0], u[..., 1]
    dth = ((1.0 - cfg.yaw_slip) * dt) * w
    th = np.cumsum(dth, axis=1)
    th += np.float32(th0)
    knots = np.empty((th.shape[0], th.shape[1] + 1), dtype=np.float32)
    knots[:, 0] = th0
    knots[:, 1:] = th
    c_all, s_all = cos_sin(knots)
    c, s = c_all[:, :-1], s_all[:, :-1]  # the heading before each step
    vdt = v * np.float32(dt)
    dx, dy = vdt * c, vdt * s
    # the no-slip positions before each step: where the slip is read
    xn = np.cumsum(dx, axis=1)
    xn -= dx
    yn = np.cumsum(dy, axis=1)
    yn -= dy
    idx, inside = win.index(xn, yn, x0, y0)
    grade = win.gx.ravel()[idx] * c
    grade += win.gy.ravel()[idx] * s
    keep = 1.0 - np.clip(np.float32(cfg.slip_base) + np.float32(cfg.slip_per_grade) * np.maximum(grade, 0.0), 0.0, 1.0)
    x = np.cumsum(keep * dx, axis=1)
    y = np.cumsum(keep * dy, axis=1)
    return x, y, th, c_all, s_all


def _costs(pose, x: np.ndarray, y: np.ndarray, c: np.ndarray, s: np.ndarray, goal: np.ndarray, dt: float,
           win: CostWindow, veh: VehicleEnvelope, cfg: MppiConfig, ctg: "CostToGo | None" = None) -> np.ndarray:
    """The cost S_k of each rollout (see the module docstring); ``x, y`` relative to ``pose``, ``c, s``
    the cosine and sine of the heading after each step."""
    ox, oy = float(pose[0]), float(pose[1])
    idx, _ = win.index(x, y, ox, oy)
    static = win.static.ravel()[idx]  # inf off the map (the window's out-of-map cells and its margin)
    gx, gy = win.gx.ravel()[idx], win.gy.ravel()[idx]
    slope = np.maximum(np.abs(gx * c + gy * s), np.abs(gy * c - gx * s))
    slope *= np.float32(1.0 / veh.max_slope)
    hz = np.maximum(static, slope)
    half = np.float32(0.5 * (veh.width_m - veh.wheel_radius_m))  # the wheel tracks, either side
    step = win.step.ravel()
    for side in (half, -half):
        hz = np.maximum(hz, step[win.index(x - side * s, y + side * c, ox, oy)[0]])
    lethal = hz >= 1.0
    if ctg is not None:  # the planners' footprint hazard past a limit counts as lethal too
        lethal |= ctg.forbidden_at(x + np.float32(ox), y + np.float32(oy)) > 0
    per_s = np.minimum(hz, 1.0)
    per_s *= per_s
    per_s *= np.float32(cfg.hazard_weight)
    per_s += np.float32(cfg.lethal_cost) * lethal
    per_s += np.float32(cfg.roughness_weight) * np.minimum(win.rough.ravel()[idx], 1.0)
    dist = np.hypot(x - np.float32(goal[0] - pose[0]), y - np.float32(goal[1] - pose[1]))
    # the trial ends at the goal: nothing counts after a rollout first comes within the tolerance
    going = np.cumsum(dist <= np.float32(cfg.goal_tolerance_m), axis=1) == 0
    per_s *= going
    hazard = dt * per_s.sum(axis=1, dtype=np.float64)
    if ctg is not None:  # progress by the cost-to-go, read every 0.25 s of the rollout and at its end
        every = max(1, int(round(0.25 / dt)))
        ts = np.arange(x.shape[1] - 1, -1, -every)[::-1]
        togo = ctg.at(x[:, ts] + np.float32(pose[0]), y[:, ts] + np.float32(pose[1])) * going[:, ts]
        return hazard + cfg.goal_weight * (togo.mean(axis=1) + togo[:, -1])
    dist *= going
    return hazard + cfg.goal_weight * (dist.mean(axis=1, dtype=np.float64) + dist[:, -1])


def _stream_seed(problem: PlanningProblem, seed: int) -> int:
    """The seed of one mission's stream: a stable hash of its start and goal, then ``seed``."""
    from offroadbench.seeding import derive_seed

    data = struct.pack("<4d", *problem.start_xy, *problem.goal_xy)
    root = int.from_bytes(hashlib.sha256(data).digest()[:8], "little") >> 1
    return derive_seed(root, MPPI_STREAM, seed)


@register_policy("mppi", config=MppiConfig, needs=frozenset({"vehicle", "map"}),
                 summary="sampling-based MPC (MPPI) over a skid-steer slip model on the perceived elevation map")
class MppiPolicy:
    """MPPI on the perceived elevation map (module docstring: model, noise, costs, update).

    Optimises: the time-averaged and final distance to the goal over ``horizon_s`` plus the hazard
    (step, belly, roughness, heading-resolved slope) under the sampled paths.
    Cannot see: beyond its horizon (a dead end longer than ~2.5 m traps it), the vehicle's dynamics
    beyond the kinematic slip model.
    """

    def __init__(self, cfg: MppiConfig, context: PolicyContext) -> None:
        self.cfg = cfg
        self.veh = context.vehicle if context.vehicle is not None else VehicleEnvelope()
        self.dt = 1.0 / context.control_rate_hz
        self.steps = max(1, int(round(cfg.horizon_s / self.dt)))
        self.v_max = min(cfg.cruise_speed_m_s, self.veh.max_speed_m_s)
        self.w_max = self.veh.max_yaw_rate_rad_s
        a = math.exp(-self.dt / cfg.noise_corr_s)
        self._ar = (a, math.sqrt(1.0 - a * a))
        self._sigma = np.array([cfg.noise_v_m_s, cfg.noise_omega_rad_s])
        self._half_m = self.v_max * self.steps * self.dt + self.veh.half_diagonal_m + cfg.recost_every_m + 0.2
        self.rng = np.random.default_rng(cfg.seed)
        self.goal = np.zeros(2)
        self.cell_m = 0.05
        self.U = np.zeros((self.steps, 2))
        self._win: CostWindow | None = None
        self._win_at = np.zeros(2)
        self._win_map: object = None
        self._problem: PlanningProblem | None = None
        self._ctg: CostToGo | None = None
        self._ctg_at = np.zeros(2)
        self._ctg_map: object = None
        self._stalled_s = 0.0
        self._backup_left_s = 0.0

    def reset(self, problem: PlanningProblem) -> None:
        """Start a mission: its goal, grid, stream and a mean sequence of cruising straight on."""
        self.goal = np.asarray(problem.goal_xy, dtype=float)
        self.cell_m = problem.hm.cell_size_m
        self.rng = np.random.default_rng(_stream_seed(problem, self.cfg.seed))
        self.U = np.zeros((self.steps, 2))
        self.U[:, 0] = self.v_max
        self._win = None
        self._win_map = None
        self._problem = problem
        self._ctg = None
        self._ctg_map = None
        self._stalled_s = 0.0
        self._backup_left_s = 0.0

    def noise(self, k: int) -> np.ndarray:
        """(k, T, 2) time-correlated noise from the policy's stream (stationary OU, module docstring), float32."""
        a, b = self._ar
        eps = self.rng.standard_normal((self.steps, k, 2), dtype=np.float32)
        eps *= self._sigma.astype(np.float32)
        eps[1:] *= np.float32(b)
        for t in range(1, self.steps):  # eps(t) = a eps(t - 1) + b sigma n(t); eps(0) = sigma n(0)
            eps[t] += np.float32(a) * eps[t - 1]
        return eps.transpose(1, 0, 2)

    def _window(self, z: np.ndarray, xy: np.ndarray) -> CostWindow:
        if (self._win is None or z is not self._win_map
                or math.hypot(*(xy - self._win_at)) > self.cfg.recost_every_m):
            self._win = cost_window(z, self.cell_m, xy, self._half_m, self.veh, self.cfg.unknown_hazard)
            self._win_at, self._win_map = xy.copy(), z
        return self._win

    def _cost_to_go(self, z: np.ndarray, xy: np.ndarray) -> "CostToGo | None":
        """The cost-to-go on the map ``z``, re-computed when the map changed and the vehicle moved
        ``cost_to_go_every_m`` (the true map: once per mission)."""
        if not self.cfg.cost_to_go or self._problem is None:
            return None
        stale = self._ctg is None or (z is not self._ctg_map
                                      and math.hypot(*(xy - self._ctg_at)) >= self.cfg.cost_to_go_every_m)
        if stale:
            import dataclasses

            from offroadbench.heightmap import Heightmap
            from offroadbench.navigation.perception import seen_map

            hm = self._problem.hm
            if z is not hm.z:  # a sensor's map: unseen ground continues the seen (as the planners see it)
                seen = ~np.isnan(z)
                hm = seen_map(Heightmap(np.where(seen, z, 0.0), self.cell_m), seen)
            inside = self._problem.inside_border(xy)[0]
            start = (float(xy[0]), float(xy[1])) if inside else self._problem.start_xy
            problem = dataclasses.replace(self._problem, hm=hm, start_xy=start, vehicle=self.veh)
            self._ctg = cost_to_go(problem, self.cfg.cost_to_go_grid_m)
            self._ctg_at, self._ctg_map = xy.copy(), z
        return self._ctg

    def plan(self, pose: np.ndarray, z: np.ndarray) -> np.ndarray:
        """One MPPI iteration from ``pose`` on ``z``: updates and returns the mean sequence (T, 2)."""
        cfg = self.cfg
        xy = np.asarray(pose[:2], dtype=float)
        win = self._window(z, xy)
        ctg = self._cost_to_go(z, xy)
        eps = self.noise(cfg.samples)
        eps[0] = 0.0
        backing = self._backup_left_s > 0.0
        lo = np.array([-0.5 * self.v_max if backing else 0.0, -self.w_max])
        hi = np.array([0.0 if backing else self.v_max, self.w_max])
        u = np.clip(self.U.astype(np.float32)[None] + eps, lo.astype(np.float32), hi.astype(np.float32))
        x, y, _, c, s = _rollout(pose, u, self.dt, win, cfg)
        cost = _costs(pose, x, y, c[:, 1:], s[:, 1:], self.goal, self.dt, win, self.veh, cfg, ctg)
        cost = np.where(np.isfinite(cost), cost, np.finfo(float).max / 4)
        scaled = ((cost - cost.min()) / cfg.temperature).tolist()
        w = np.fromiter((math.exp(-a) for a in scaled), np.float64, len(scaled))  # libm, not numpy's SIMD exp
        w /= w.sum()
        step = u.astype(np.float64) - self.U[None]
        step *= w[:, None, None]
        # sum_k w_k (u_k - U), summed in sample order (not a BLAS product)
        self.U = np.clip(self.U + np.cumsum(step, axis=0)[-1], lo, hi)
        self.last_cost = cost
        return self.U

    def _recovery(self, observation: Mapping[str, np.ndarray]) -> None:
        """Count the time stalled (commanded >= 0.3 m/s, measured < 0.05 m/s forward) and start or
        run down a back-up (``stall_s``, ``backup_s``)."""
        cfg = self.cfg
        if self._backup_left_s > 0.0:
            self._backup_left_s -= self.dt
            if self._backup_left_s <= 0.0:  # forward again, from a fresh mean
                self.U[:, 0] = self.v_max
            return
        state = observation.get("state")
        if cfg.stall_s <= 0.0 or state is None:
            return
        stalled = self.U[0, 0] >= 0.3 and abs(float(state[7])) < 0.05
        self._stalled_s = self._stalled_s + self.dt if stalled else 0.0
        if self._stalled_s >= cfg.stall_s:
            self._stalled_s = 0.0
            self._backup_left_s = cfg.backup_s
            self.U[:, 0] = -0.3 * self.v_max

    def act(self, observation: Mapping[str, np.ndarray]) -> tuple[float, float]:
        pose = np.asarray(observation["pose"], dtype=float)
        self._recovery(observation)
        U = self.plan(pose, observation["elevation_m"])
        v, w = float(U[0, 0]), float(U[0, 1])
        self.U = np.vstack([U[1:], U[-1:]])  # warm start of the next tick
        return v, w
