"""The trial loop's per-tick code, made cheaper (branch ``tickcost``), gives the bits of the form the
committed rows were recorded with: the path tracker, the bicycle tracker's look-ahead, the twist
driver of each steering kind, the failure rules and the mast sensor's ray table, each against its
earlier numpy (or per-tick) form on random states, compared as float hex."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from offroadbench.heightmap import Heightmap
from offroadbench.navigation import metrics
from offroadbench.navigation.rules import FailureRules, RuleChecker
from offroadbench.navigation.sensor import viewshed
from offroadbench.sim import ControllerConfig, load_vehicle
from offroadbench.sim.trial import skid_steer
from offroadbench.sim.trial.ackermann import BicycleTracker
from offroadbench.sim.trial.controller import LineTracker, PathTracker, speed_loop
from offroadbench.sim.trial.steering import reference_layout, steered_commands, twist_driver


def _hex(values) -> list[str]:
    return [float(x).hex() for x in values]


class _NumpyPath:
    """PathTracker's projection, look-ahead point and command as they were written with numpy arrays
    (commit 83d44ec), on the tracker's own arrays, with its own speed loop fed the same inputs."""

    def __init__(self, tracker: PathTracker, spec, cfg) -> None:
        self.t, self.spec, self.cfg = tracker, spec, cfg
        self.seg, self.s = 0, 0.0
        self.speed = speed_loop(tracker.length_m, spec, cfg)

    def project(self, pos_xy):
        t = self.t
        last = len(t._seg_len) - 1
        best = (math.inf, self.seg, 0.0)
        k = self.seg
        while k <= last and (k == self.seg or t._cum[k] <= self.s + t._window_m):
            u = t._unit[k]
            tt = float(pos_xy[0] - t.points[k][0]) * float(u[0]) + float(pos_xy[1] - t.points[k][1]) * float(u[1])
            t_c = tt if (k == 0 and tt < 0) or (k == last and tt > 0) else min(max(tt, 0.0), t._seg_len[k])
            foot = t.points[k] + t_c * t._unit[k]
            d = math.hypot(pos_xy[0] - foot[0], pos_xy[1] - foot[1])
            if d < best[0]:
                best = (d, k, float(t._cum[k] + t_c))
            k += 1
        self.seg, self.s = best[1], best[2]
        return self.s

    def point_at(self, s_m):
        t = self.t
        s = min(max(s_m, 0.0), t.length_m)
        k = min(int(np.searchsorted(t._cum, s, side="right")) - 1, len(t._seg_len) - 1)
        return t.points[k] + (s - t._cum[k]) * t._unit[k]

    def command(self, pos_xy, yaw, vel_xy):
        t = self.t
        s = self.project(np.asarray(pos_xy, dtype=float))
        p = np.asarray(pos_xy, dtype=float)
        to_goal = math.hypot(t.points[-1][0] - p[0], t.points[-1][1] - p[1])
        u = t._unit[self.seg]
        v = self.speed.command(min(s, t.length_m - to_goal), float(vel_xy[0]) * float(u[0]) + float(vel_xy[1]) * float(u[1]))
        target = self.point_at(max(s, 0.0) + self.cfg.lookahead_m)
        d = target - p
        alpha = (math.atan2(d[1], d[0]) - yaw + math.pi) % (2.0 * math.pi) - math.pi
        w_max = self.spec.max_yaw_rate_rad_s
        if abs(alpha) > 0.5 * math.pi:
            omega = max(-w_max, min(w_max, math.copysign(2.0 * v / max(math.hypot(d[0], d[1]), 1e-9), alpha)))
        else:
            dx, dy = float(target[0]) - float(p[0]), float(target[1]) - float(p[1])
            dist = math.hypot(dx, dy)
            omega = 0.0 if dist < 1e-9 else max(-w_max, min(w_max, v * (2.0 * math.sin(math.atan2(dy, dx) - yaw) / dist)))
        return v, omega, s


def _random_path(rng, n: int) -> np.ndarray:
    steps = rng.normal(0.0, 1.0, (n - 1, 2)) + np.array([0.8, 0.3])
    pts = np.concatenate([[rng.uniform(5.0, 10.0, 2)], steps]).cumsum(axis=0)
    pts[3] = pts[2]  # a repeated waypoint (dropped)
    return pts


def test_path_tracker_floats_match_the_numpy_form_bit_for_bit():
    spec, cfg = load_vehicle("husky"), ControllerConfig()
    rng = np.random.default_rng(11)
    for _ in range(10):
        pts = _random_path(rng, 12)
        tracker = PathTracker(pts, spec, cfg)
        ref = _NumpyPath(tracker, spec, cfg)
        pos = pts[0] + rng.normal(0.0, 0.3, 2)
        for i in range(300):
            yaw, vel = rng.uniform(-math.pi, math.pi), rng.normal(0.6, 0.4, 2)
            got = tracker.command((float(pos[0]), float(pos[1])), yaw, (float(vel[0]), float(vel[1])))
            want = ref.command(pos, yaw, vel)
            assert _hex(got) == _hex(want), i
            s = rng.uniform(-2.0, tracker.length_m + 2.0)
            assert _hex(tracker.point_at(s)) == _hex(ref.point_at(s))
            pos = pos + vel * 0.05 + rng.normal(0.0, 0.02, 2)


@pytest.mark.parametrize("path", [False, True])
def test_bicycle_tracker_look_ahead_matches_the_numpy_form(path):
    spec, cfg = load_vehicle("hunter"), ControllerConfig()
    rng = np.random.default_rng(5)
    pts = _random_path(rng, 8) if path else np.array([[2.0, 3.0], [20.0, 11.0]])
    make = (lambda: PathTracker(pts, spec, cfg)) if path else (lambda: LineTracker(pts[0], pts[1], spec, cfg))
    tracker = BicycleTracker(make(), spec, cfg, wheelbase_m=0.65, max_steer_rad=0.5)
    twin = make()  # the same base, driven by the earlier numpy form of the look-ahead below
    steer = 0.0
    pos = pts[0] + rng.normal(0.0, 0.2, 2)
    for _ in range(300):
        yaw, vel = rng.uniform(-math.pi, math.pi), rng.normal(0.6, 0.4, 2)
        got = tracker.command((float(pos[0]), float(pos[1])), yaw, (float(vel[0]), float(vel[1])))
        v, _, s = twin.command((float(pos[0]), float(pos[1])), yaw, (float(vel[0]), float(vel[1])))
        ahead = max(s, 0.0) + cfg.lookahead_m
        target = twin.point_at(ahead) if path else twin.start + twin.unit * min(ahead, twin.length_m)
        d = target - np.asarray(pos, dtype=float)
        from offroadbench.sim.trial.ackermann import bicycle_steer_rad

        want = bicycle_steer_rad(math.atan2(d[1], d[0]) - yaw, math.hypot(d[0], d[1]), 0.65, 0.5)
        steer = max(steer - tracker.max_step_rad, min(steer + tracker.max_step_rad, want))
        assert _hex(got) == _hex((v, v * math.tan(steer) / 0.65, s))
        pos = pos + vel * 0.05


class _Recorder:
    """A world's command methods, recording what they were given."""

    def __init__(self, spec, centres) -> None:
        self.spec, self.geometry, self.got = spec, SimpleNamespace(wheel_centres_m=centres), []

    def command_wheels(self, left, right):
        self.got.append(("wheels", left, right))

    def command_steering(self, angles):
        self.got.append(("steer", *angles))

    def command_wheel_speeds(self, speeds):
        self.got.append(("speeds", *speeds))


@pytest.mark.parametrize("vehicle", ["husky", "hunter", "sojourner", "talon"])
def test_twist_driver_matches_the_per_tick_steering_functions(vehicle):
    spec = load_vehicle(vehicle)
    rng = np.random.default_rng(3)
    n = len(spec.wheel_joints)
    centres = [(float(x), float(y), 0.1) for x, y in rng.uniform(-0.5, 0.5, (n, 2))]
    world = _Recorder(spec, centres)
    drive = twist_driver(world)
    layout = reference_layout(spec, centres)
    for v, w in rng.normal(0.0, 1.5, (500, 2)).tolist() + [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (-1.0, 3.0)]:
        drive(v, w)
        if spec.steering == "skid":
            want = [("wheels", *skid_steer.wheel_speeds(v, w, spec))]
        else:
            speeds, angles = steered_commands(v, w, spec, layout)
            want = [("steer", *angles), ("speeds", *speeds)]
        got, world.got = world.got, []
        assert [(k, *_hex(x)) for k, *x in got] == [(k, *_hex(x)) for k, *x in want]


def _end_reason_before(rules, bounds, goal_xy, pos, roll, pitch, xy_hist, window):
    """offroadbench.navigation.rules.end_reason as written before its limits were worked out once."""
    tip = math.radians(rules.tip_angle_deg)
    if abs(roll) > tip or abs(pitch) > tip or math.cos(roll) * math.cos(pitch) < math.cos(tip):
        return "tipped"
    width, height, z_min = bounds
    if not (0.0 <= pos[0] <= width and 0.0 <= pos[1] <= height) or pos[2] < z_min - rules.fall_depth_m:
        return "off_map"
    if math.hypot(pos[0] - goal_xy[0], pos[1] - goal_xy[1]) <= rules.goal_tolerance_m:
        return ""
    if len(xy_hist) > window:
        first = xy_hist[-window - 1]
        if math.hypot(pos[0] - first[0], pos[1] - first[1]) < rules.stuck_distance_m:
            if metrics.stuck_index(np.asarray(xy_hist[-window - 1:]), window, rules.stuck_distance_m) is not None:
                return "stuck"
    return None


def test_rule_checker_ends_trials_where_the_earlier_rules_did():
    rng = np.random.default_rng(9)
    rules = FailureRules(tip_angle_deg=40.0, stuck_window_s=2.0, fall_depth_m=0.3)
    reasons = set()
    for trial in range(40):
        goal = tuple(rng.uniform(2.0, 8.0, 2))
        checker = RuleChecker(rules, (10.0, 10.0, -0.5), goal, timeout_s=20.0, sample_rate_hz=20, mission_length_m=5.0)
        hist, pos = [], [5.0, 5.0, 0.0]
        for _ in range(400):
            step = rng.normal(0.0, 0.02 if trial % 2 else 0.15, 2)
            pos = [pos[0] + step[0], pos[1] + step[1], float(rng.normal(-0.2, 0.2))]
            roll, pitch = rng.normal(0.0, 0.25, 2).tolist()
            hist.append((pos[0], pos[1]))
            want = _end_reason_before(rules, checker.bounds, checker.goal, pos, roll, pitch, hist, checker.window)
            got = checker.check(pos, roll, pitch)
            assert got == want
            if got is not None:
                reasons.add(got)
                break
    assert {"tipped", "off_map", "stuck"} <= reasons  # the samples reach the rules compared


def _viewshed_before(hm, xy, sensor_z_m, range_m):
    """offroadbench.navigation.sensor.viewshed as written before its rays were cached."""
    from scipy.ndimage import map_coordinates

    cell = hm.cell_size_m
    n_r = max(1, int(range_m / cell))
    n_a = max(8, int(math.ceil(2.0 * math.pi * range_m / cell)))
    r = (np.arange(1, n_r + 1) * cell)[None, :]
    phi = (np.arange(n_a) * (2.0 * math.pi / n_a))[:, None]
    x = xy[0] + r * np.cos(phi)
    y = xy[1] + r * np.sin(phi)
    col, row = x / cell, y / cell
    on = (col >= 0) & (col <= hm.cols - 1) & (row >= 0) & (row <= hm.rows - 1)
    z = map_coordinates(hm.z, [row, col], order=1, mode="nearest")
    tan = np.where(on, (z - sensor_z_m) / r, np.inf)
    horizon = np.maximum.accumulate(tan, axis=1)
    before = np.concatenate([np.full((n_a, 1), -np.inf), horizon[:, :-1]], axis=1)
    vis = on & (tan >= before - 1e-12) & np.cumprod(on, axis=1, dtype=bool)
    return x[vis], y[vis], z[vis], np.broadcast_to(r, x.shape)[vis]


def test_viewshed_with_cached_rays_gives_the_bits_of_the_per_scan_arithmetic():
    rng = np.random.default_rng(2)
    hm = Heightmap(rng.normal(0.0, 0.2, (90, 110)), 0.1)
    for xy, z0, range_m in [((4.3, 5.1), 0.8, 3.0), ((0.5, 8.0), 0.3, 3.0), ((6.0, 2.2), 1.5, 2.5)]:
        for _ in range(2):  # the second call takes the cached rays
            got, want = viewshed(hm, xy, z0, range_m), _viewshed_before(hm, xy, z0, range_m)
            assert want[0].size > 0
            assert [a.tobytes() for a in got] == [a.tobytes() for a in want]


@pytest.mark.parametrize("outlier", [None, 0, 1, 2, 20, 39, 40])
def test_stuck_rule_judges_every_sample_of_the_window_as_before(outlier):
    # a vehicle that stays within 0.15 m of where it started, except for one sample (index in the
    # window + 1 samples) 0.25 m away from the start: stuck exactly when there is no outlier
    rules = FailureRules(stuck_window_s=2.0)
    checker = RuleChecker(rules, (10.0, 10.0, -0.5), (9.0, 9.0), timeout_s=20.0, sample_rate_hz=20, mission_length_m=5.0)
    window = checker.window
    assert window == 40
    rng = np.random.default_rng(outlier or 0)
    hist, got = [], None
    for i in range(window + 1):
        a = rng.uniform(0.0, 2.0 * math.pi)
        r = 0.25 if i == outlier else rng.uniform(0.0, 0.15) if i else 0.0
        pos = [5.0 + r * math.cos(a), 5.0 + r * math.sin(a), 0.0]
        hist.append((pos[0], pos[1]))
        got = checker.check(pos, 0.0, 0.0)
        want = _end_reason_before(rules, checker.bounds, checker.goal, pos, 0.0, 0.0, hist, window)
        assert got == want
    assert got == ("stuck" if outlier is None else None)
