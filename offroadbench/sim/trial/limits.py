"""A planner's limits in a trial: wall-clock time to plan one mission, the number of waypoints and the
path's length (:func:`plan_within_limits`; the trial runner and the Gymnasium env plan through it)."""

from __future__ import annotations

import math

import numpy as np

from offroadbench.errors import InputError, PluginError
from offroadbench.navigation.drivers import PlannerChoice, plan
from offroadbench.navigation.problem import PlanningProblem

__all__ = ["PLANNING_LIMIT_S", "MAX_WAYPOINTS", "MAX_PATH_FACTOR", "MAX_PATH_EXTRA_M", "plan_within_limits"]

#: wall-clock seconds a planner may take for one mission (enforced in the main thread; elsewhere a
#: study's per-trial limit applies)
PLANNING_LIMIT_S = 120.0
#: the most waypoints a planned path may have (the tracker's cost grows with them)
MAX_WAYPOINTS = 100_000
#: a planned path may be at most this many times the start-goal distance, plus MAX_PATH_EXTRA_M
MAX_PATH_FACTOR = 20.0
MAX_PATH_EXTRA_M = 10.0


def plan_within_limits(planner: PlannerChoice, problem: PlanningProblem) -> np.ndarray:
    """:func:`~offroadbench.navigation.planners.plan` within PLANNING_LIMIT_S, and a path within
    MAX_WAYPOINTS and MAX_PATH_FACTOR; a planner beyond a limit is a PluginError naming it."""
    import signal
    import threading

    def too_slow(signum, frame):
        raise PluginError(f"planner {planner.name!r} took longer than {PLANNING_LIMIT_S:g} s to plan one mission")

    timed = (threading.current_thread() is threading.main_thread()
             and signal.getsignal(signal.SIGALRM) in (signal.SIG_DFL, None)
             and signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0))
    if timed:
        signal.signal(signal.SIGALRM, too_slow)
        signal.setitimer(signal.ITIMER_REAL, PLANNING_LIMIT_S)
    try:
        wp = plan(planner, problem)
    except (PluginError, InputError):
        raise
    except Exception as exc:  # a plug-in's own failure: one line naming it (the traceback goes to the log)
        import logging

        logging.getLogger(__name__).info("planner %r failed", planner.name, exc_info=True)
        raise PluginError(f"planner {planner.name!r} failed: {type(exc).__name__}: {' '.join(str(exc).split())[:300]}"
                          ) from exc
    finally:
        if timed:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
    if len(wp) > MAX_WAYPOINTS:
        raise PluginError(f"planner {planner.name!r} returned {len(wp)} waypoints; at most {MAX_WAYPOINTS} are allowed")
    straight = math.hypot(problem.goal_xy[0] - problem.start_xy[0], problem.goal_xy[1] - problem.start_xy[1])
    length = math.fsum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(wp[:-1].tolist(), wp[1:].tolist(), strict=True))
    if length > MAX_PATH_FACTOR * straight + MAX_PATH_EXTRA_M:
        raise PluginError(f"planner {planner.name!r} returned a path of {length:.1f} m for a {straight:.1f} m mission; "
                          f"at most {MAX_PATH_FACTOR:g} x + {MAX_PATH_EXTRA_M:g} m is allowed")
    return wp
