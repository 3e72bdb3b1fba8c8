"""The planning problem: what a planner or a policy is told about one mission and the vehicle.

:class:`PlanningProblem` is one query (terrain, closed class map, start, goal, mission border,
vehicle); :class:`VehicleEnvelope` is what a planner knows of the vehicle: its footprint and limits.
Both are plain frozen data with no registry and no search, so every planner, policy and the trial
runner (offroadbench.sim.trial.runner) can import them without importing each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from offroadbench.config import check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

__all__ = ["VehicleEnvelope", "PlanningProblem", "PlannerRefusal"]



class PlannerRefusal(InputError):
    """A planner or policy cannot drive this vehicle (e.g. A*'s turns on the spot for an Ackermann
    car): a property of the (planner, vehicle) pair, not of the terrain. ``drive`` reports it as bad
    input (one line); a study stores the pair's trials as faults, so a cartesian grid of vehicles and
    planners runs to the end and its report shows the pair as refused
    (offroadbench.study.execution.tasks.run_terrain)."""

@dataclass(frozen=True, kw_only=True)
class VehicleEnvelope:
    """What a planner knows of the vehicle: its footprint and limits (defaults: the Husky)."""

    length_m: float = 0.99
    """Overall length of the footprint, m (Clearpath Husky A200: 0.99 m)."""
    width_m: float = 0.67
    """Overall width of the footprint, m (Husky: 0.67 m)."""
    max_speed_m_s: float = 1.0
    """Top speed, m/s."""
    max_yaw_rate_rad_s: float = 2.0
    """Largest yaw rate command, rad/s."""
    max_slope: float = 0.8
    """Steepest climbable slope, rise/run (about the tyre friction coefficient on a slope)."""
    max_step_m: float = 0.13
    """Highest step the vehicle climbs, m (Husky: 0.13 m, the geometric bound of
    offroadbench.sim.rigs.vehicle_check.step_bound_m: the chassis nose strikes a step higher than the belly)."""
    ground_clearance_m: float = 0.13
    """Height of the belly above flat ground, m (Husky: 0.13 m, the spec sheet's and the URDF's)."""
    wheel_radius_m: float = 0.1651
    """Wheel radius, m (Husky: 0.1651 m): a wheel rides on the terrain's envelope at this radius."""
    min_turn_radius_m: float = 0.0
    """Smallest turning radius, m (0: turns in place, as a skid-steer; an Ackermann car's is
    offroadbench.sim.trial.steering.min_turn_radius_m)."""

    def __post_init__(self) -> None:
        for name in ("length_m", "width_m", "max_speed_m_s", "max_yaw_rate_rad_s", "max_slope", "max_step_m",
                     "ground_clearance_m", "wheel_radius_m"):
            check_range(self, name, getattr(self, name), lo=0, lo_open=True)
        check_range(self, "min_turn_radius_m", self.min_turn_radius_m, lo=0)

    @property
    def half_diagonal_m(self) -> float:
        return 0.5 * math.hypot(self.length_m, self.width_m)


@dataclass(frozen=True, eq=False)
class PlanningProblem:
    """One planning query: terrain, classes, the mission's ends, its border and the vehicle."""

    hm: Heightmap
    """The terrain."""
    classes: np.ndarray | None
    """The closed roughness-class map (uint8 LOW/SEMI/HIGH, the heightmap's shape), classified with
    the study's ``[roughness]`` config: the map the missions were drawn on. None when the driver's
    registry entry does not declare that it needs it (offroadbench.navigation.drivers.NEEDS)."""
    start_xy: tuple[float, float]
    """Mission start, map metres."""
    goal_xy: tuple[float, float]
    """Mission goal, map metres."""
    border_m: float = 0.0
    """Missions keep this far from the map edge; planned paths must too."""
    vehicle: VehicleEnvelope | None = field(default_factory=VehicleEnvelope)
    """Footprint and limits of the vehicle that will drive the path (the trial runner measures them
    from the loaded vehicle); None when the driver's entry does not declare that it needs them."""

    def __post_init__(self) -> None:
        if self.classes is not None:
            classes = np.asarray(self.classes)
            if classes.shape != self.hm.shape:
                raise InputError(f"class map shape {classes.shape} does not match the heightmap's {self.hm.shape}")
            object.__setattr__(self, "classes", classes)
        object.__setattr__(self, "start_xy", (float(self.start_xy[0]), float(self.start_xy[1])))
        object.__setattr__(self, "goal_xy", (float(self.goal_xy[0]), float(self.goal_xy[1])))

    @property
    def heading_rad(self) -> float:
        """Direction start -> goal: the vehicle is spawned facing it."""
        return math.atan2(self.goal_xy[1] - self.start_xy[1], self.goal_xy[0] - self.start_xy[0])

    def endpoints(self) -> np.ndarray:
        """``[start, goal]`` as a (2, 2) array: the straight plan."""
        return np.array([self.start_xy, self.goal_xy], dtype=float)

    def inside_border(self, xy: np.ndarray, tol_m: float = 1e-9) -> np.ndarray:
        """Which points (N, 2) lie inside the mission border."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        lo = self.border_m - tol_m
        x_hi = (self.hm.cols - 1) * self.hm.cell_size_m - self.border_m + tol_m
        y_hi = (self.hm.rows - 1) * self.hm.cell_size_m - self.border_m + tol_m
        return (p[:, 0] >= lo) & (p[:, 0] <= x_hi) & (p[:, 1] >= lo) & (p[:, 1] <= y_hi)
