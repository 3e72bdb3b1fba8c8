"""The run directory's storage: the SQLite store (the only SQL of the package), the lock, the per-file store
helpers, a search's own table and loading results."""

from offroadbench.study.store.search import add_search_batch, ensure_search_table, next_search_cell, search_rows, stream_trials
from offroadbench.study.store.results import load, load_meta, load_platforms, load_terrains, telemetry_paths, trial_platform
from offroadbench.study.store.store import LOCK_NAME, RunDirLocked, RunLock, STORE_NAME, Store, machine_description, remove_stale_temp_files, remove_store

__all__ = ['add_search_batch', 'ensure_search_table', 'next_search_cell', 'search_rows', 'stream_trials', 'load', 'load_meta', 'load_platforms', 'load_terrains', 'telemetry_paths', 'trial_platform', 'LOCK_NAME', 'RunDirLocked', 'RunLock', 'STORE_NAME', 'Store', 'machine_description', 'remove_stale_temp_files', 'remove_store']
