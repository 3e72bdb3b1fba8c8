"""A trial's outcome: :class:`TrialResult` (the row a study stores: the failure reason, the metrics
of Majhor & Bos 2023, Eq. 5, and the traversal times) and the telemetry columns that it is
computed from (the trial loop is offroadbench.sim.trial.runner)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from offroadbench.navigation import metrics


#: telemetry columns, each a 1-D array sampled at SimConfig.telemetry_rate_hz
TELEMETRY_COLUMNS = (
    "t_s", "x_m", "y_m", "z_m", "qx", "qy", "qz", "qw", "roll_rad", "pitch_rad", "yaw_rad",
    "vx_m_s", "vy_m_s", "vz_m_s", "roll_rate_body_rad_s", "pitch_rate_body_rad_s", "yaw_rate_body_rad_s",
    "cmd_v_m_s", "cmd_omega_rad_s", "progress_m", "penetration_m",
)


@dataclass(frozen=True)
class TrialResult:
    """The outcome of one mission; :meth:`as_row` gives the flat table row.

    Angle and rate metrics follow the paper's definitions (see offroadbench.navigation.metrics). Metrics are
    computed for every trial; the paper analyses them for successful trials only.
    """

    mission_index: int
    """Index k of the mission on its terrain (the mission sampler's order)."""
    success: bool
    """True when the vehicle came within the goal tolerance before any failure rule fired."""
    failure_reason: str
    """"" on success, else one of FAILURE_REASONS."""
    traversal_time_s: float
    """Time from the clock start to reaching the goal; NaN if the mission failed."""
    path_length_m: float
    """Length of the 20 Hz 3-D trajectory of the vehicle's base."""
    max_abs_roll_deg: float
    """Largest |roll| over the trial, degrees."""
    max_abs_pitch_deg: float
    """Largest |pitch| over the trial, degrees."""
    rms_vertical_accel_m_s2: float
    """RMS of the base's vertical acceleration (z differentiated twice at 20 Hz), m/s^2 (Majhor & Bos 2023, Sec. 2.4)."""
    rms_pitch_rate_deg_s: float
    """RMS pitch rate from the unwrapped pitch angle, deg/s (Majhor & Bos 2023, Sec. 2.4)."""
    rms_roll_rate_deg_s: float
    """RMS roll rate from the unwrapped roll angle, deg/s (Majhor & Bos 2023, Sec. 2.4)."""
    max_penetration_m: float
    """Deepest wheel-terrain penetration seen at the telemetry ticks (a transient maximum: on soil
    use ``sinkage_median_m`` and ``sinkage_p95_m``)."""
    sim_time_s: float
    """Simulated time at the end of the trial (success, failure or timeout)."""
    final_distance_to_goal_m: float
    """Horizontal distance from the base to the goal when the trial ended, metres."""
    start_x_m: float
    """Mission start x on the map, metres."""
    start_y_m: float
    """Mission start y on the map, metres."""
    goal_x_m: float
    """Mission goal x on the map, metres."""
    goal_y_m: float
    """Mission goal y on the map, metres."""
    heading_deg: float
    """Direction from start to goal, degrees counter-clockwise from +x."""
    mean_slip: float = float("nan")
    """Mean longitudinal wheel slip over the moving telemetry ticks with a wheel on the soil (the
    ``terramechanics`` tyre model; NaN with the other models; moving: offroadbench.navigation.metrics)."""
    sinkage_median_m: float = float("nan")
    """Median of the deepest wheel's soil sinkage over the moving telemetry ticks, m (the
    ``terramechanics`` tyre model; NaN with the other models)."""
    sinkage_p95_m: float = float("nan")
    """95th percentile of the deepest wheel's soil sinkage over the moving telemetry ticks, m (as
    ``sinkage_median_m``)."""
    outside_model_fraction: float = float("nan")
    """Fraction of the telemetry ticks at which a wheel had bottomed out, outside the soil model (its
    penetration past the tables' top: the soil's sinkage cap of 0.75 r reached, the tyre spring
    alone carrying it; offroadbench.sim.tyre_laws.terramechanics.SoilTables.outside), 0-1 (the
    ``terramechanics`` tyre model; NaN with the other models). Above 0, the trial's soil forces
    there are not the Wong-Reece model's."""
    dropped_contacts: float = float("nan")
    """Terrain contacts the engine took out of its constraint solver during the trial, from the
    spawn (settling included) to the trial's last state read, summed over its physics steps (a
    contact dropped in n steps counts n times): the ``mujoco_warp`` engine's false height-field
    contacts (offroadbench.sim.engines.mujoco_warp.kernels.drop_false_contacts;
    docs/mujoco-warp.md, 'Not done' item 5); NaN on the engines that drop none by design
    (``pybullet``, ``mujoco``: TrialWorld.dropped_contacts absent or None). Above 0, the trial
    ran through a contact the engine's collision gave and the solver never saw."""

    def as_row(self) -> dict:
        return dataclasses.asdict(self)

    def __eq__(self, other: object) -> bool:
        """Field-wise equality in which NaN equals NaN (failed trials have a NaN traversal time)."""
        if not isinstance(other, TrialResult):
            return NotImplemented
        return all(
            a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))
            for a, b in zip(dataclasses.astuple(self), dataclasses.astuple(other), strict=True)
        )

    __hash__ = None  # type: ignore[assignment]  # NaN-aware equality has no matching hash


def make_result(mission, tel, reason, traversal_time, end_time, dt, goal) -> TrialResult:
    return TrialResult(
        mission_index=mission.index,
        success=reason == "",
        failure_reason=reason,
        traversal_time_s=traversal_time,
        path_length_m=metrics.path_length(np.column_stack([tel["x_m"], tel["y_m"], tel["z_m"]])),
        max_abs_roll_deg=float(np.degrees(np.max(np.abs(tel["roll_rad"])))),
        max_abs_pitch_deg=float(np.degrees(np.max(np.abs(tel["pitch_rad"])))),
        rms_vertical_accel_m_s2=metrics.rms_vertical_acceleration(tel["z_m"], dt),
        rms_pitch_rate_deg_s=metrics.rms_angle_rate_deg_s(tel["pitch_rad"], dt),
        rms_roll_rate_deg_s=metrics.rms_angle_rate_deg_s(tel["roll_rad"], dt),
        max_penetration_m=float(np.max(tel["penetration_m"])),
        sim_time_s=end_time,
        final_distance_to_goal_m=float(math.hypot(tel["x_m"][-1] - goal[0], tel["y_m"][-1] - goal[1])),
        start_x_m=float(mission.start_xy_m[0]),
        start_y_m=float(mission.start_xy_m[1]),
        goal_x_m=float(mission.goal_xy_m[0]),
        goal_y_m=float(mission.goal_xy_m[1]),
        heading_deg=float(np.degrees(mission.heading_rad)),
    )
