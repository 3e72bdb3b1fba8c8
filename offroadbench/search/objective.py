"""The failure objective of a search: a continuous margin, negative exactly when a trial fails.

A falsifier needs a gradient to follow before it has seen its first failure, and the
cross-entropy method needs levels between "easy" and "failed" (Rubinstein & Kroese 2004,
Sec. 3.4), so a pass/fail bit is not enough. The margin of one trial's row
(offroadbench.sim.TrialResult) is

* on failure: ``-max(d / L, 1e-3)``, with d the distance left to the goal when the trial ended and
  L the mission's straight length (a trial that failed far from its goal is "more failed");
* on success: ``max(min(tip margin, time margin), 1e-6)``, where the tip margin is
  ``1 - max(|roll|, |pitch|) / tip_angle_deg`` and the time margin is ``1 - t v / (k L)``: the
  traversal time t over the timeout of a straight path (``rules.timeout_factor`` k times L / v,
  v the cruise speed capped by the vehicle's top speed), clipped at 0 for detours longer than that.

So a trial that nearly tipped, or crawled to its goal, has a margin near 0 from above.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

__all__ = ["failure_margin"]


def failure_margin(row: Mapping[str, Any], *, tip_angle_deg: float, timeout_factor: float, speed_m_s: float) -> float:
    """The margin of one trial row (see the module docstring); negative iff ``row["success"]`` is false."""
    length = math.hypot(row["goal_x_m"] - row["start_x_m"], row["goal_y_m"] - row["start_y_m"])
    length = max(length, 1e-9)
    if not row["success"]:
        d = float(row["final_distance_to_goal_m"])
        return -max(d / length if math.isfinite(d) else 1.0, 1e-3)
    tip = 1.0 - max(abs(row["max_abs_roll_deg"]), abs(row["max_abs_pitch_deg"])) / tip_angle_deg
    t = float(row["traversal_time_s"])
    slow = t * speed_m_s / (timeout_factor * length) if math.isfinite(t) else 1.0
    time_margin = max(1.0 - slow, 0.0)
    return max(min(tip, time_margin), 1e-6)
