"""The line tracker's per-tick arithmetic in plain floats gives the bits of its numpy form (the form
the study's rows were recorded with): the same operations in the same order, on random states."""

from __future__ import annotations

import math

import numpy as np

from offroadbench.sim import ControllerConfig, load_vehicle
from offroadbench.sim.trial.controller import LineTracker, SpeedProfile, speed_loop


def _numpy_command(start, unit, length_m, lookahead_m, w_max, speed: SpeedProfile, pos, yaw, vel):
    """LineTracker.command as it was written with numpy arrays (commit 6dcab05)."""
    def dot2(x, y, u):
        return float(x) * float(u[0]) + float(y) * float(u[1])

    pos, vel = np.array(pos), np.array(vel)
    s = dot2(pos[0] - start[0], pos[1] - start[1], unit)
    v = speed.command(s, dot2(vel[0], vel[1], unit))
    target = start + unit * min(max(s, 0.0) + lookahead_m, length_m)
    d = np.asarray(target, dtype=float) - np.asarray(pos, dtype=float)
    dist = math.hypot(d[0], d[1])
    if dist < 1e-9:
        return v, 0.0, s
    alpha = math.atan2(d[1], d[0]) - yaw
    return v, max(-w_max, min(w_max, v * (2.0 * math.sin(alpha) / dist))), s


def test_line_tracker_floats_match_the_numpy_form_bit_for_bit():
    spec, cfg = load_vehicle("husky"), ControllerConfig()
    rng = np.random.default_rng(7)
    for _ in range(20):
        start, goal = rng.uniform(0.0, 50.0, 2), rng.uniform(0.0, 50.0, 2)
        tracker = LineTracker(start, goal, spec, cfg)
        reference = speed_loop(tracker.length_m, spec, cfg)  # its own speed loop, fed the same inputs
        pos = start + rng.normal(0.0, 0.3, 2)
        for _ in range(200):
            yaw, vel = rng.uniform(-math.pi, math.pi), rng.normal(0.5, 0.3, 2)
            got = tracker.command((float(pos[0]), float(pos[1])), yaw, (float(vel[0]), float(vel[1])))
            want = _numpy_command(tracker.start, tracker.unit, tracker.length_m, cfg.lookahead_m,
                                  spec.max_yaw_rate_rad_s, reference, pos, yaw, vel)
            assert [x.hex() for x in map(float, got)] == [x.hex() for x in map(float, want)]
            assert float(tracker.progress(pos)).hex() == float(want[2]).hex()
            pos = pos + vel * 0.05 + rng.normal(0.0, 0.01, 2)
