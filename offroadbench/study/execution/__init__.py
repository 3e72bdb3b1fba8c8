"""Running a study's trials: terrain tasks, the executor protocol and its local-process and Dask executors."""

from offroadbench.study.execution.executors import DaskExecutor, EXECUTORS, LocalExecutor, MAX_TRIAL_TIMEOUT_S, StudyError, check_trial_timeout, get_executor
from offroadbench.study.execution.tasks import NO_MISSION_FAULT, REFUSED_FAULT, TerrainBuilt, TerrainTask, TrialDone, TrialFaulted, TrialFn, keeps_telemetry, prepare_cell, replay_trial, run_terrain, unexplained_variance

__all__ = ['DaskExecutor', 'EXECUTORS', 'LocalExecutor', 'MAX_TRIAL_TIMEOUT_S', 'StudyError', 'check_trial_timeout', 'get_executor', 'NO_MISSION_FAULT', 'REFUSED_FAULT', 'TerrainBuilt', 'TerrainTask', 'TrialDone', 'TrialFaulted', 'TrialFn', 'keeps_telemetry', 'prepare_cell', 'replay_trial', 'run_terrain', 'unexplained_variance']
