"""A cheap, deterministic stand-in for a trial (no physics) whose failure region is known: the
vehicle fails when its cruise speed is high on a steep mission line."""

import numpy as np

#: trials fail when cruise speed + SLOPE_WEIGHT * (steepest slope along the line) exceeds this
LIMIT = 1.9
SLOPE_WEIGHT = 0.5

SEARCH = {
    "study": {"name": "stand-in-search", "recipe": "paper-d2.45", "root_seed": 3},
    "recipe_overrides": {"grid.rows": 121, "grid.cols": 121},
    "roughness": {"border_m": 0.5},
    "missions": {"length_m": 3.0, "border_m": 0.5},
    "search": {
        "budget": 24, "batch_size": 4, "startup_trials": 4, "ce_stage_size": 10,
        "params": [
            {"key": "controller.cruise_speed_m_s", "low": 0.5, "high": 2.0, "nominal": "normal", "mean": 1.0, "sd": 0.3},
            {"key": "recipe.layers.base.D_high", "low": 2.3, "high": 2.6},
        ],
    },
}


def stand_in_trials(prepared, settings):
    hm = prepared.hm
    speed = settings.controller.cruise_speed_m_s
    for m in prepared.missions:
        (sx, sy), (gx, gy) = m.start_xy_m, m.goal_xy_m
        t = np.linspace(0.0, 1.0, 31)
        z = hm.height_at(sx + t * (gx - sx), sy + t * (gy - sy))
        slope = float((np.abs(np.diff(z)) / (m.length_m / 30)).max())
        score = speed + SLOPE_WEIGHT * slope
        ok = bool(score < LIMIT)
        yield {
            "mission_index": m.index, "success": ok, "failure_reason": "" if ok else "tipped",
            "traversal_time_s": m.length_m / speed if ok else float("nan"),
            "path_length_m": m.length_m, "max_abs_roll_deg": 75.0 * min(score / LIMIT, 1.0) * 0.99,
            "max_abs_pitch_deg": 0.0, "rms_vertical_accel_m_s2": 0.0, "rms_pitch_rate_deg_s": 0.0,
            "rms_roll_rate_deg_s": 0.0, "max_penetration_m": 0.0, "sim_time_s": 1.0,
            "final_distance_to_goal_m": 0.0 if ok else m.length_m * 0.5,
            "start_x_m": sx, "start_y_m": sy, "goal_x_m": gx, "goal_y_m": gy, "heading_deg": 0.0,
        }
