"""When a trial ends: the failure rules of Majhor & Bos 2023, Sec. 2.4, shared by the trial runner
and the Gymnasium env.

A trial ends, checked in this order at every telemetry sample:

* ``tipped``: |roll| or |pitch| above ``tip_angle_deg`` (paper: 75 deg), or the tilt of the body's
  z axis from the vertical above it. For Z-Y-X Euler angles ``cos(tilt) = cos(roll) cos(pitch)``,
  so the tilt catches a vehicle lying on a corner (roll and pitch both 60 deg: tilt 75.5 deg);
* ``off_map``: the base left the map horizontally, or fell ``fall_depth_m`` below its lowest point;
* success (end reason ``""``): the base within ``goal_tolerance_m`` of the goal (horizontal);
* ``entrapped`` (soft soil; only when the caller gives the wheels' slip and sinkage, i.e. with the
  ``terramechanics`` tyre model): the wheels turn but the vehicle does not go anywhere, and they
  have dug in. Over the last ``entrap_window_s``: the mean wheel slip stayed above ``entrap_slip``
  at every sample (the wheels turn much faster than the ground passes: a wheel that is not turned
  has slip near 0), the base came less than ``entrap_progress_radii`` wheel radii closer to the
  goal (a vehicle sliding back down a slope while its wheels spin forward made negative progress),
  and the window's median deepest-wheel sinkage is at least ``entrap_sinkage_ratio`` times the
  settled sinkage (the deepest sinkage at the trial's first sample, the vehicle at rest): Spirit at
  Troy, 2009. See "Entrapment thresholds" below;
* ``stuck``: the base stayed within ``stuck_distance_m`` of where it was one stuck window ago
  for the whole window (paper: 0.2 m in 30 s);
* ``timeout``: the caller's clock passed ``timeout_factor`` times the nominal time (path length
  over cruise speed). The runner ends the trial; the env truncates the episode.

The stuck window. The paper's 30 s window cannot fire on a mission shorter than 10 m at 1 m/s
with a 3x timeout: the timeout comes first. The window used is therefore
``min(stuck_window_s, stuck_window_max_fraction * timeout)``; with the defaults, 35 m missions
keep the paper's 30 s and a 6 m mission (18 s timeout) gets 9 s. :func:`unreachable` names any
rule a configuration makes impossible to fire, and :class:`RuleChecker` logs it as a warning.

Entrapment thresholds, from single-wheel tests and the soil model (offroadbench.sim.tyre_laws.terramechanics):

* ``entrap_slip = 0.6``: by slip 0.6 a wheel has most of its drawbar pull (the Wong-Reece pull of
  the Husky's wheel on lunar regolith is 89 % of its peak there in lunar gravity, 98 % in Earth
  gravity; ``offroadbench soil check``), so more slip buys little more traction, and single-wheel tests find the sinkage several
  times the static one there (Ding et al. 2010: 3-7x at slip 0.6 for lugged wheels on a lunar
  simulant).
* ``entrap_sinkage_ratio = 1.5``: the soil model with slip-sinkage ``n1 = 0.4`` gave 1.8-2.2x the
  static sinkage at slip 0.6 (lunar and Earth gravity), so 1.5x was crossed by any wheel held at
  slip 0.6 or more, and not by load transfer alone on flat ground. That ``n1`` had no published
  source and the shipped soils now have ``n1 = 0`` (issue 47), under which the sinkage at slip 0.6
  is about 1.05x the static one: the rule then fires only where the wheels sink on their own (soft
  ground, load transfer), and a vehicle spinning in place on firm regolith ends ``stuck`` instead.
  In this model the sinkage follows the slip quasi-statically (no excavation that accumulates over
  time), so "sinkage rising" is measured against the settled sinkage, not as a trend within the
  window; on a soil without slip-sinkage (``n1 = 0``) only load transfer raises it.
* ``entrap_progress_radii = 1``: under one wheel radius of net progress towards the goal in 5 s
  while the wheels turn at slip 0.6 or more. A wheel turning at 1 m/s for 5 s passes 5 m of rim:
  one radius (0.165 m for the Husky) is a window slip above 0.96. A detour away from the goal
  counts as no progress (at slip 0.6 or more and sunk 1.5x, a vehicle there is in trouble either
  way).
* ``entrap_window_s = 5``: about one wheel revolution per second at 1 m/s, so several
  revolutions; far shorter than the 30 s stuck window.
"""

from __future__ import annotations

import collections
import functools
import logging
import math
import statistics
from dataclasses import dataclass

from offroadbench.config import check_range

__all__ = ["FAILURE_REASONS", "FailureRules", "trial_timeout_s", "stuck_window_s", "unreachable", "end_reason",
           "RuleChecker"]

log = logging.getLogger(__name__)

#: failure_reason values; "" means success
FAILURE_REASONS = ("tipped", "stuck", "timeout", "off_map", "entrapped")


@dataclass(frozen=True, kw_only=True)
class FailureRules:
    """When a trial ends, paper Sec. 2.4 (tip-over 75 deg; stuck = under 0.2 m in 30 s)."""

    tip_angle_deg: float = 75.0
    """A trial fails as ``tipped`` once |roll|, |pitch| or the tilt of the body z axis from the
    vertical exceeds this, degrees."""
    stuck_distance_m: float = 0.2
    """A trial fails as ``stuck`` if the vehicle stays within this distance of where it was ..."""
    stuck_window_s: float = 30.0
    """... for this long, seconds (capped by ``stuck_window_max_fraction``)."""
    stuck_window_max_fraction: float = 0.5
    """The stuck window is at most this fraction of the trial's timeout, so that ``stuck`` can fire
    on short missions (a 6 m mission at 1 m/s times out after 18 s: its window is 9 s). 35 m
    missions keep the paper's 30 s. 1 or more lets the timeout pre-empt the stuck rule."""
    timeout_factor: float = 3.0
    """A trial fails as ``timeout`` after this many times the nominal time (length / cruise speed)."""
    goal_tolerance_m: float = 0.5
    """The mission succeeds when the vehicle's centre is this close to the goal (horizontal), m."""
    fall_depth_m: float = 1.0
    """A vehicle this far below the lowest terrain point has left the map (``off_map``), m."""
    entrap_slip: float = 0.6
    """A trial fails as ``entrapped`` while the mean wheel slip stays above this: the wheels turn,
    and by slip 0.6 a wheel has 89-98 % of its peak pull on lunar regolith while single-wheel tests
    find its sinkage severalfold the static one (Ding et al. 2010: 3-7x; offroadbench.navigation.rules,
    "Entrapment thresholds") ..."""
    entrap_progress_radii: float = 1.0
    """... and the base comes less than this many wheel radii closer to the goal (one radius in 5 s
    at 1 m/s of wheel rim: a slip above 0.96) ..."""
    entrap_sinkage_ratio: float = 1.5
    """... with the window's median deepest-wheel sinkage at least this many times the settled
    sinkage (at the trial's first sample; chosen when the soils had an unsourced slip-sinkage; with
    the shipped soils' n1 = 0 the model gives about 1.05x at slip 0.6: see the module docstring) ..."""
    entrap_window_s: float = 5.0
    """... over this long, seconds (several wheel revolutions at 1 m/s)."""

    def __post_init__(self) -> None:
        check_range(self, "tip_angle_deg", self.tip_angle_deg, lo=0, hi=180, lo_open=True)
        check_range(self, "stuck_distance_m", self.stuck_distance_m, lo=0, lo_open=True)
        check_range(self, "stuck_window_s", self.stuck_window_s, lo=0, lo_open=True)
        check_range(self, "stuck_window_max_fraction", self.stuck_window_max_fraction, lo=0, lo_open=True)
        check_range(self, "timeout_factor", self.timeout_factor, lo=1.0)
        check_range(self, "goal_tolerance_m", self.goal_tolerance_m, lo=0, lo_open=True)
        check_range(self, "fall_depth_m", self.fall_depth_m, lo=0, lo_open=True)
        check_range(self, "entrap_slip", self.entrap_slip, lo=0, hi=1)
        check_range(self, "entrap_progress_radii", self.entrap_progress_radii, lo=0, lo_open=True)
        check_range(self, "entrap_sinkage_ratio", self.entrap_sinkage_ratio, lo=0)
        check_range(self, "entrap_window_s", self.entrap_window_s, lo=0, lo_open=True)


def trial_timeout_s(rules: FailureRules, length_m: float, cruise_speed_m_s: float, max_speed_m_s: float) -> float:
    """The simulated time a trial may take, seconds: ``rules.timeout_factor`` times the nominal time,
    the path length over the speed it is driven at (the cruise speed, capped by the vehicle's top
    speed). The one rule for the trial runner and the Gymnasium env."""
    return rules.timeout_factor * length_m / min(cruise_speed_m_s, max_speed_m_s)


def stuck_window_s(rules: FailureRules, timeout_s: float) -> float:
    """The stuck window of a trial with this timeout, seconds (see the module docstring)."""
    return min(rules.stuck_window_s, rules.stuck_window_max_fraction * timeout_s)


def unreachable(rules: FailureRules, timeout_s: float, mission_length_m: float) -> list[str]:
    """The rules that cannot fire in a trial with this timeout and mission, each with the reason."""
    out = []
    window = stuck_window_s(rules, timeout_s)
    if window >= timeout_s:
        out.append(f"stuck: the {window:g} s stuck window is not shorter than the {timeout_s:g} s timeout")
    if rules.tip_angle_deg >= 180.0:
        out.append(f"tipped: tip_angle_deg = {rules.tip_angle_deg:g}; |roll| never exceeds 180 deg")
    if rules.goal_tolerance_m >= mission_length_m:
        out.append(f"success at the start: goal_tolerance_m = {rules.goal_tolerance_m:g} reaches the "
                   f"{mission_length_m:g} m mission's start")
    return out


def end_reason(rules: FailureRules, bounds: tuple[float, float, float], goal_xy, pos, roll: float, pitch: float,
               xy_hist, window: int) -> str | None:
    """The reason a trial ends now (``""`` = success), or None to go on.

    ``bounds`` = (width, height, lowest z) of the map, metres; ``pos`` = (x, y, z) of the base;
    ``roll``, ``pitch`` in radians; ``xy_hist`` the (x, y) samples so far, the current one last;
    ``window`` the stuck window in samples.
    """
    return _end_reason(_limits(rules, bounds), goal_xy, pos, roll, pitch, xy_hist, window)


def _limits(rules: FailureRules, bounds) -> tuple[float, ...]:
    """What :func:`end_reason` compares against, worked out once per trial: (tip angle rad, its
    cosine, map width, map height, the off-map floor z, goal tolerance, stuck distance), metres."""
    tip = math.radians(rules.tip_angle_deg)
    width, height, z_min = bounds
    return (tip, math.cos(tip), width, height, z_min - rules.fall_depth_m, rules.goal_tolerance_m,
            rules.stuck_distance_m)


def _end_reason(limits: tuple[float, ...], goal_xy, pos, roll: float, pitch: float, xy_hist,
                window: int) -> str | None:
    """:func:`end_reason` with its :func:`_limits`."""
    tip, cos_tip, width, height, floor_z, goal_tolerance, stuck_distance = limits
    if abs(roll) > tip or abs(pitch) > tip or math.cos(roll) * math.cos(pitch) < cos_tip:
        return "tipped"
    if not (0.0 <= pos[0] <= width and 0.0 <= pos[1] <= height) or pos[2] < floor_z:
        return "off_map"
    if math.hypot(pos[0] - goal_xy[0], pos[1] - goal_xy[1]) <= goal_tolerance:
        return ""
    if len(xy_hist) > window:
        first = xy_hist[-window - 1]
        # cheap test first: only a vehicle back near where it was a window ago can be stuck
        if math.hypot(pos[0] - first[0], pos[1] - first[1]) < stuck_distance:
            # metrics.stuck_index on the last window + 1 samples (its one end: every sample of the
            # window within the distance of the first), on the samples as they are, not an array's copy
            x0, y0 = first
            if all(math.hypot(x - x0, y - y0) < stuck_distance for x, y in xy_hist[-window:]):
                return "stuck"
    return None


@functools.lru_cache(maxsize=64)
def _warn_once(why: str) -> None:
    """Log an unreachable rule once per process (a study checks thousands of trials)."""
    log.warning("failure rule cannot fire: %s", why)


class RuleChecker:
    """The rules of one trial, fed one sample at a time.

    Args:
        rules: the failure rules.
        bounds: (width, height, lowest z) of the map, metres.
        goal_xy: the mission's goal, metres.
        timeout_s: the trial's timeout, seconds (sets the stuck window).
        sample_rate_hz: how often :meth:`check` is called per simulated second.
        mission_length_m: start-goal distance, for the reachability warning.
    """

    def __init__(self, rules: FailureRules, bounds, goal_xy, *, timeout_s: float, sample_rate_hz: float,
                 mission_length_m: float, wheel_radius_m: float | None = None) -> None:
        self.rules = rules
        self.bounds = tuple(bounds)
        self._limits = _limits(rules, self.bounds)
        self.goal = (float(goal_xy[0]), float(goal_xy[1]))
        self.window_s = stuck_window_s(rules, timeout_s)
        self.window = max(1, int(round(self.window_s * sample_rate_hz)))
        self.xy_hist: list[tuple[float, float]] = []
        self.entrap_window = max(1, round(rules.entrap_window_s * sample_rate_hz))
        self._radius_m = wheel_radius_m
        self._settled_m: float | None = None  # the deepest sinkage at the first sample with one
        self._dug: collections.deque = collections.deque(maxlen=self.entrap_window + 1)  # (x, y, slip, sinkage)
        for why in unreachable(rules, timeout_s, mission_length_m):
            _warn_once(why)

    def check(self, pos, roll: float, pitch: float, slip: float | None = None,
              sinkage_m: float | None = None) -> str | None:
        """Record the sample and return the end reason (``""`` = success), or None to go on.

        ``slip`` (mean wheel slip) and ``sinkage_m`` (deepest wheel sinkage) feed the ``entrapped``
        rule when the checker knows the wheel radius; None skips it."""
        self.xy_hist.append((pos[0], pos[1]))
        reason = _end_reason(self._limits, self.goal, pos, roll, pitch, self.xy_hist, self.window)
        if reason is None or reason == "stuck":
            if self._entrapped(pos, slip, sinkage_m):
                return "entrapped"
        return reason

    def _entrapped(self, pos, slip: float | None, sinkage_m: float | None) -> bool:
        """The ``entrapped`` rule on the samples of the last window (module docstring)."""
        if self._radius_m is None or slip is None or sinkage_m is None:
            self._dug.clear()
            return False
        if self._settled_m is None and sinkage_m > 0.0:
            self._settled_m = sinkage_m
        if slip <= self.rules.entrap_slip:
            self._dug.clear()
            return False
        self._dug.append((pos[0], pos[1], slip, sinkage_m))
        if len(self._dug) <= self.entrap_window or self._settled_m is None:
            return False
        x0, y0 = self._dug[0][0], self._dug[0][1]
        gx, gy = self.goal
        progress = math.hypot(gx - x0, gy - y0) - math.hypot(gx - pos[0], gy - pos[1])  # < 0: slid back
        if progress >= self.rules.entrap_progress_radii * self._radius_m:
            return False
        return statistics.median(d[3] for d in self._dug) >= self.rules.entrap_sinkage_ratio * self._settled_m
