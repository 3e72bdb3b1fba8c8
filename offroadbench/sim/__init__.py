"""Traversal trials: the only package that talks to a physics engine (PyBullet by default; the
engine boundary is offroadbench.sim.engine).

Public API: SimConfig, ControllerConfig, FailureRules (frozen configs), VehicleSpec /
load_vehicle, World (PyBullet), open_world / TrialWorld / VehicleGeometry / ENGINES (the engine
boundary, offroadbench.sim.engine), TrialResult, run_mission, run_missions, drive_missions / DriveRun,
and import_pybullet_quietly (for application entry points: the CLI and the study workers).

The names load lazily (PEP 562), so importing a config (``offroadbench.sim.config``) or this
package does not import pybullet; only touching ``World`` or the runner does.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> the submodule that defines it
_EXPORTS = {
    "SimConfig": "config",
    "ControllerConfig": "config",
    "FailureRules": "config",
    "VehicleSpec": "vehicle",
    "load_vehicle": "vehicle",
    "list_vehicles": "vehicle",
    "vehicle_from_table": "vehicle",
    "World": "world",
    "TrialWorld": "engine",
    "VehicleGeometry": "engine",
    "ENGINES": "engine",
    "open_world": "engine",
    "TrialResult": "runner",
    "FAILURE_REASONS": "runner",
    "TELEMETRY_COLUMNS": "runner",
    "run_mission": "runner",
    "run_missions": "pipeline",
    "TrialSettings": "pipeline",
    "PreparedTerrain": "pipeline",
    "prepare_terrain": "pipeline",
    "drive_terrain": "pipeline",
    "DriveRun": "batch",
    "drive_missions": "batch",
    "import_pybullet_quietly": "_banner",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'offroadbench.sim' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"offroadbench.sim.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
