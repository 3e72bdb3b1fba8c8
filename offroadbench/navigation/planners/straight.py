"""``straight``: the paper's start-goal line. It needs neither the class map nor the vehicle."""

from __future__ import annotations

import numpy as np

from offroadbench.navigation.drivers import NoConfig, register_planner
from offroadbench.navigation.problem import PlanningProblem

__all__ = ["plan_straight"]


@register_planner("straight", summary="the start-goal line (the paper's naive plan)", needs=frozenset())
def plan_straight(problem: PlanningProblem, cfg: NoConfig = NoConfig()) -> np.ndarray:
    """The start-goal line (Majhor & Bos 2023, Sec. 2.3): waypoints ``[start, goal]``.

    Optimises: length. Cannot see: anything of the terrain.
    """
    return problem.endpoints()
