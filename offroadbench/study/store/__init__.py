"""The run directory's storage: the SQLite store, the lock, the per-file store helpers and loading results."""

from offroadbench.study.store.results import load, load_meta, load_platforms, load_terrains, telemetry_paths, trial_platform
from offroadbench.study.store.store import LOCK_NAME, RunDirLocked, RunLock, STORE_NAME, Store, machine_description, remove_stale_temp_files, remove_store

__all__ = ['load', 'load_meta', 'load_platforms', 'load_terrains', 'telemetry_paths', 'trial_platform', 'LOCK_NAME', 'RunDirLocked', 'RunLock', 'STORE_NAME', 'Store', 'machine_description', 'remove_stale_temp_files', 'remove_store']
