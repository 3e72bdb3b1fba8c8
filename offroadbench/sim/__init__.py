"""Traversal trials in PyBullet: the only package that imports pybullet.

Public API: SimConfig, ControllerConfig, FailureRules (frozen configs), VehicleSpec /
load_vehicle, World, TrialResult, run_mission, run_missions.
"""

from offroadbench.sim.config import ControllerConfig, FailureRules, SimConfig
from offroadbench.sim.trial import FAILURE_REASONS, TELEMETRY_COLUMNS, TrialResult, run_mission, run_missions
from offroadbench.sim.vehicle import VehicleSpec, list_vehicles, load_vehicle
from offroadbench.sim.world import World

__all__ = [
    "SimConfig",
    "ControllerConfig",
    "FailureRules",
    "VehicleSpec",
    "load_vehicle",
    "list_vehicles",
    "World",
    "TrialResult",
    "FAILURE_REASONS",
    "TELEMETRY_COLUMNS",
    "run_mission",
    "run_missions",
]
