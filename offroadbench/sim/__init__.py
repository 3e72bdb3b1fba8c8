"""Traversal trials: the only package that talks to a physics engine (PyBullet by default; the
engine boundary is offroadbench.sim.engine).

Layout: ``engine.py`` (the TrialWorld protocol and the engine registry), ``engines/`` (one package
per engine, ``base.py`` what they share), ``tyre_laws/`` (engine-neutral force laws), ``trial/``
(settings, terrain preparation, the tick loop, the controller, the vehicle), ``rigs/`` (``vehicle
check``, ``soil check``), ``gym_env.py`` (the Gymnasium env) and ``config.py`` (SimConfig,
ControllerConfig).

Public API: SimConfig, ControllerConfig, FailureRules (frozen configs), VehicleSpec /
load_vehicle, World (PyBullet), open_world / TrialWorld / VehicleGeometry / ENGINES (the engine
boundary, offroadbench.sim.engine), TrialResult, run_mission, run_missions, drive_missions / DriveRun,
and import_pybullet_quietly (for application entry points: the CLI and the study workers).

The names load lazily (PEP 562), so importing a config (``offroadbench.sim.config``) or this
package does not import pybullet; only touching ``World`` or the runner does.
"""

from __future__ import annotations

from offroadbench.lazy import lazy_exports

#: public name -> the submodule that defines it
_EXPORTS = {
    "SimConfig": "config",
    "ControllerConfig": "config",
    "FailureRules": "config",
    "VehicleSpec": "trial.vehicle",
    "load_vehicle": "trial.vehicle",
    "list_vehicles": "trial.vehicle",
    "vehicle_from_table": "trial.vehicle",
    "World": "engines.pybullet.world",
    "TrialWorld": "engine",
    "VehicleGeometry": "engine",
    "ENGINES": "engine",
    "open_world": "engine",
    "TrialResult": "trial.runner",
    "FAILURE_REASONS": "trial.runner",
    "TELEMETRY_COLUMNS": "trial.runner",
    "run_mission": "trial.runner",
    "run_missions": "trial.pipeline",
    "TrialSettings": "trial.pipeline",
    "PreparedTerrain": "trial.pipeline",
    "prepare_terrain": "trial.pipeline",
    "drive_terrain": "trial.pipeline",
    "DriveRun": "trial.batch",
    "drive_missions": "trial.batch",
    "import_pybullet_quietly": "_banner",
}

__all__ = list(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
