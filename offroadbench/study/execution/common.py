"""What the executors of offroadbench.study.execution.executors share: worker set-up (die with the parent,
ignore Ctrl-C), the per-trial time limit and how a failed or hung task becomes an error or faults."""

from __future__ import annotations

import gc
import logging
import os
import signal
import sys
from typing import Callable

from offroadbench.errors import InputError, StudyError
from offroadbench.study.execution.tasks import TIMEOUT_KIND, TerrainTask, TrialFaulted, remaining_task

log = logging.getLogger(__name__)


Handle = Callable[[tuple], None]


# ---------------------------------------------------------------------------- local processes
def die_with_parent(parent_pid: int) -> None:
    """Ask Linux to SIGKILL this process when its parent dies; exit if it already has."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:  # pragma: no cover - no libc: the ppid check below still applies
            pass
    if os.getppid() != parent_pid:
        os._exit(1)


#: a worker's cyclic-collector thresholds (gc.set_threshold: allocations before a young collection,
#: young collections before a middle one, middle ones before a full one; Python's default is 700, 10, 10)
WORKER_GC_THRESHOLDS = (700, 10, 100)


def worker_bootstrap() -> None:
    """What every worker process does first: import pybullet without its banner, have malloc give a
    freed terrain's arrays back to the system (offroadbench.memory.release_large_blocks), and make
    the cyclic garbage collector's full collections ten times rarer (:data:`WORKER_GC_THRESHOLDS`;
    the objects inherited from the coordinator frozen, ``gc.freeze``). A full collection walks every
    tracked object, ~140 k once numba's and MuJoCo's modules are loaded (~60 ms each); the trial
    loop's few cycles wait longer for it. Measured on 60 MuJoCo paper missions in one process: the
    collector's CPU while driving 0.110 -> 0.029 s of 7.1-7.3 s (benchmarks/RESULTS.md, branch
    ``perf3``); results do not depend on when garbage is collected."""
    from offroadbench.memory import release_large_blocks
    from offroadbench.sim import import_pybullet_quietly

    import_pybullet_quietly()
    release_large_blocks()
    gc.freeze()
    gc.set_threshold(*WORKER_GC_THRESHOLDS)


def error_message(key: tuple[int, int], exc: BaseException, tb: str) -> tuple:
    """An ("error", ...) message that survives pickling, whatever the exception."""
    import pickle

    try:
        pickle.dumps(exc)
        carried = exc
    except Exception:  # an unpicklable exception: keep its text
        carried = None
    return ("error", key, carried, f"{type(exc).__name__}: {exc}", tb)


#: the largest per-trial wall-clock limit accepted, seconds (30 days): a larger one is no limit in
#: practice, and timeouts beyond ``threading.TIMEOUT_MAX`` overflow (Dask's helper thread)
MAX_TRIAL_TIMEOUT_S = 30 * 86400.0


def check_trial_timeout(value: float | None) -> float | None:
    """``trial_timeout_s`` validated: None (no limit) or a finite number of seconds in (0, 30 days]."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= MAX_TRIAL_TIMEOUT_S:
        raise InputError(f"trial_timeout_s = {value!r}; must be > 0 and at most {MAX_TRIAL_TIMEOUT_S:g} seconds "
                         "(30 days)")
    return float(value)


#: no engine steps a vehicle faster than this many physics steps per wall-clock second: fifteen
#: times the fastest measured (60 Hz at a real-time factor of 109, 6,540 steps/s: benchmarks/RESULTS.md)
MAX_STEPS_PER_S = 100_000.0


def shortest_trial_s(plans) -> tuple[float, str]:
    """(seconds, how): the floor of any successful trial's wall-clock time over the cells ``plans``
    (CellPlans), and the sentence that says how it is computed. A trial that reaches its goal
    simulates at least its settling (``sim.settle_time_s``) and its mission driven at top speed
    (``missions.length_m`` at the lower of ``controller.cruise_speed_m_s`` and the vehicle's
    ``max_speed_m_s``), that is so many physics steps (``sim.physics_rate_hz``), and no engine
    steps faster than :data:`MAX_STEPS_PER_S`. A per-trial limit below it makes every trial a fault."""
    best = None
    for p in plans:
        sim, missions = p.section("sim"), p.section("missions")
        speed = min(p.section("controller").cruise_speed_m_s, p.section("vehicle").max_speed_m_s)
        steps = (sim.settle_time_s + missions.length_m / speed) * sim.physics_rate_hz
        floor = steps / MAX_STEPS_PER_S
        if best is None or floor < best[0]:
            best = (floor, f"a trial that reaches its goal simulates at least its settling ({sim.settle_time_s:g} s) "
                           f"and its mission at top speed ({missions.length_m:g} m at {speed:g} m/s), "
                           f"{steps:.0f} physics steps at {sim.physics_rate_hz} Hz, and no engine runs faster "
                           f"than {MAX_STEPS_PER_S:g} steps/s (15 times the fastest measured)")
    return best if best is not None else (0.0, "no trial")


def check_trial_floor(value: float | None, plans, option: str = "--trial-timeout-s") -> None:
    """Refuse (InputError, one line) a per-trial limit below :func:`shortest_trial_s` of ``plans``."""
    if value is None:
        return
    floor, how = shortest_trial_s(plans)
    if value < floor:
        raise InputError(f"{option} {value:g} is below this study's shortest possible trial, {floor:.3g} s: {how}; "
                         "every trial would be a fault, so give at least that")


def task_failure(key: tuple[int, int], exc: BaseException | None, text: str, tb: str = "") -> Exception:
    """The error the coordinator raises for a failed terrain task: bad input stays an InputError
    (naming the terrain), anything else is a one-line StudyError; the traceback goes to the log."""
    if tb:
        log.info("terrain %d of cell %d failed:\n%s", key[1], key[0], tb)
    where = f"cell {key[0]}, terrain {key[1]}"
    if isinstance(exc, InputError):
        return InputError(f"{where}: {exc}")
    return StudyError(f"{where} failed in a worker: {' '.join(text.split())}")


def timeout_faults(task: TerrainTask, hung: int | None, finished: set, limit_s: float,
                   where: str = "") -> tuple[list[TrialFaulted], TerrainTask | None]:
    """The fault message(s) of a task whose trial (``hung``; None: the terrain build) ran past
    ``limit_s``, and the task of the missions still to run after it (None if none)."""
    seeds = dict(task.missions)
    cell, terrain = task.cell.index, task.terrain
    if hung is None:  # the build hung: none of the task's missions can run
        reason = f"the terrain build ran longer than {limit_s:g} s, the per-trial limit{where}"
        return [TrialFaulted(cell, terrain, k, task.terrain_seed, s, reason, TIMEOUT_KIND)
                for k, s in task.missions if k not in finished], None
    reason = f"the trial ran longer than {limit_s:g} s, the per-trial limit{where}"
    return ([TrialFaulted(cell, terrain, hung, task.terrain_seed, seeds[hung], reason, TIMEOUT_KIND)],
            remaining_task(task, hung))
