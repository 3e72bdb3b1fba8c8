"""Executors: run terrain tasks somewhere and hand every message back to the coordinator.

Registry :data:`EXECUTORS` (name -> class). Each executor's ``run(tasks, trial_fn, handle)``
calls ``handle(message)`` in the calling process for every message of every task (see
:mod:`offroadbench.study.execution.tasks`); the coordinator commits them to the store. Whatever the
executor, a task's results depend only on the task, so all of them give the same table.

* ``local`` (default): ``workers`` forked processes pull tasks from a queue and stream each
  trial back as soon as it finishes. Workers ignore Ctrl-C (the coordinator stops them) and die
  with the coordinator (``PR_SET_PDEATHSIG``), so a killed study leaves no orphans behind. With
  ``trial_timeout_s`` a worker that sends nothing for that long (a terrain build, or one trial,
  that hangs) is killed and replaced, the trial is stored as a fault and the study goes on.
* ``inline``: runs in the calling process (debugging, profiling).
* ``batched``: for a batched engine (``mujoco_warp``), every pending terrain built in the calling
  process and the trials of all terrains that can share a model run as one batch of worlds
  (offroadbench.study.execution.batched); other engines' tasks run as ``inline``.
* ``dask``: one Dask task per terrain on a ``distributed`` cluster (``scheduler`` address, or a
  ``LocalCluster`` of ``workers`` processes when no address is given). A task's trials arrive
  when its terrain is done, so a killed coordinator loses the terrains in flight. Killed or
  hung workers and a lost scheduler: see :class:`DaskExecutor`.

The executors live in ``executor_local``, ``executor_dask`` and (what they share)
``executor_common``; this module is their registry.
"""

from __future__ import annotations

from typing import Sequence

from offroadbench.errors import InputError, StudyError
from offroadbench.registry import Registry
from offroadbench.study.execution.tasks import TerrainTask, TrialFn, run_terrain
from offroadbench.study.execution.dask import DaskExecutor
from offroadbench.study.execution.dask_worker import TrialTimeout, dask_task  # noqa: F401  (re-exported)
from offroadbench.study.execution.common import Handle, MAX_TRIAL_TIMEOUT_S, check_trial_timeout
from offroadbench.study.execution.local import LocalExecutor
from offroadbench.study.execution.batched import BatchedExecutor

__all__ = ["EXECUTORS", "MAX_TRIAL_TIMEOUT_S", "check_trial_timeout", "get_executor", "StudyError", "TrialTimeout", "InlineExecutor", "LocalExecutor", "DaskExecutor",
           "BatchedExecutor"]


class InlineExecutor:
    """Run every task in this process, one after the other."""

    def __init__(self, workers: int = 1, scheduler: str | None = None) -> None:
        self.workers = 1

    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None, handle: Handle) -> None:
        for task in tasks:
            for msg in run_terrain(task, trial_fn):
                handle(msg)


#: executor name -> class(workers, scheduler, **options); installed packages add executor classes
#: through the entry-point group ``offroadbench.executors``
EXECUTORS: Registry[type] = Registry("executor", entry_point_group="offroadbench.executors")
EXECUTORS.register("local", LocalExecutor)
EXECUTORS.register("inline", InlineExecutor)
EXECUTORS.register("dask", DaskExecutor)
EXECUTORS.register("batched", BatchedExecutor)


def get_executor(name: str, workers: int | None = None, scheduler: str | None = None, **options):
    """An executor by name; an unknown name lists the known ones. ``options`` go to the executor
    (``trial_timeout_s`` for dask)."""
    cls = EXECUTORS.get(name)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InputError(f"--workers = {workers!r}; must be an integer >= 1")
    return cls(workers, scheduler, **options)
