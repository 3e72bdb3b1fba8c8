"""An example offroadbench plug-in: the ``via`` planner and the ``cautious`` policy.

Installed, its entry points (see pyproject.toml) add both to offroadbench's registries.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from offroadbench.analysis.roughness import HIGH, SEMI
from offroadbench.config import check_int, check_range
from offroadbench.navigation.planners import PlannerSpec, PlanningProblem
from offroadbench.navigation.policies import PolicyContext, PolicySpec, ReactiveConfig, ReactivePolicy

__all__ = ["ViaConfig", "plan_via", "VIA", "CautiousConfig", "CAUTIOUS"]


@dataclass(frozen=True, kw_only=True)
class ViaConfig:
    """Settings of ``via``."""

    offsets: int = 6
    """Via points tried on each side of the start-goal line."""
    offset_step_m: float = 1.0
    """Sideways distance between neighbouring via points, m."""

    def __post_init__(self) -> None:
        check_int(self, "offsets", self.offsets, lo=0, hi=100)
        check_range(self, "offset_step_m", self.offset_step_m, lo=0, lo_open=True)


def _crossed(problem: PlanningProblem, points: np.ndarray) -> tuple[int, int, float]:
    """(high pixels, semi pixels, length) crossed by the polyline, sampled at half a cell."""
    cell = problem.hm.cell_size_m
    n_hi = n_semi = 0
    length = 0.0
    for a, b in zip(points[:-1], points[1:], strict=True):
        seg = float(np.hypot(*(b - a)))
        length += seg
        t = np.linspace(0.0, 1.0, max(2, int(seg / (0.5 * cell)) + 1))[:, None]
        p = a + t * (b - a)
        r = np.clip(np.rint(p[:, 1] / cell).astype(int), 0, problem.hm.rows - 1)
        c = np.clip(np.rint(p[:, 0] / cell).astype(int), 0, problem.hm.cols - 1)
        cls = problem.classes[r, c]
        n_hi += int(np.count_nonzero(cls == HIGH))
        n_semi += int(np.count_nonzero(cls == SEMI))
    return n_hi, n_semi, length


def plan_via(problem: PlanningProblem, cfg: ViaConfig) -> np.ndarray:
    """The straight line or a two-leg path through one sideways via point, whichever crosses the
    fewest high, then semi, pixels (ties: the shortest). Via points outside the mission border are
    skipped.

    Optimises: rough pixels crossed, then length. Cannot see: anything a single detour cannot
    avoid, slopes, the vehicle's size.
    """
    start, goal = problem.endpoints()
    mid = 0.5 * (start + goal)
    d = goal - start
    normal = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-12)
    best = (_crossed(problem, problem.endpoints()), problem.endpoints())
    for k in range(1, cfg.offsets + 1):
        for side in (1.0, -1.0):
            via = mid + side * k * cfg.offset_step_m * normal
            if not problem.inside_border(via[None, :])[0]:
                continue
            path = np.vstack([start, via, goal])
            score = _crossed(problem, path)
            if score < best[0]:
                best = (score, path)
    return best[1]


VIA = PlannerSpec(plan_via, ViaConfig, "the straight line or one sideways via point, fewest rough pixels crossed")


@dataclass(frozen=True, kw_only=True)
class CautiousConfig:
    """Settings of ``cautious``."""

    speed_m_s: float = 0.6
    """Cruise speed, m/s."""

    def __post_init__(self) -> None:
        check_range(self, "speed_m_s", self.speed_m_s, lo=0, lo_open=True)


def make_cautious(cfg: CautiousConfig, context: PolicyContext) -> ReactivePolicy:
    """offroadbench's ``reactive`` policy, slower and pulled harder away from rough ground."""
    return ReactivePolicy(ReactiveConfig(cruise_speed_m_s=cfg.speed_m_s, roughness_weight=3.0), context)


CAUTIOUS = PolicySpec(make_cautious, CautiousConfig, "the reactive policy, slower and more wary of rough ground")
