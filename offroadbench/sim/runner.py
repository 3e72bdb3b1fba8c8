"""The trial runner: drive one mission in a World, apply the failure rules, compute the metrics.

Loop, per physics step at ``k * dt``: at telemetry ticks (20 Hz) the base state is recorded and
the end conditions are checked in the order tipped, off_map, success, stuck; at control ticks
the path tracker issues (v, omega), mapped to wheel speeds by the skid-steer drive. The path is
``controller.planner``'s (offroadbench.navigation.planners; default ``straight``, the start-goal line). The
clock starts after the vehicle has settled at the start; the trial ends as ``timeout`` after
``rules.timeout_factor`` times the nominal time ``path length / cruise speed``.

Metrics follow Majhor & Bos 2023, Sec. 2.4 (see offroadbench.navigation.metrics) and are computed from the
20 Hz telemetry between the clock start and the end of the trial.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from offroadbench.navigation import metrics
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.planners import plan_path
from offroadbench.progress import ProgressFn, report
from offroadbench.sim.config import ControllerConfig, FailureRules, SimConfig
from offroadbench.sim.controller import make_tracker
from offroadbench.sim.skid_steer import wheel_speeds
from offroadbench.sim.vehicle import VehicleSpec
from offroadbench.sim.world import World

__all__ = ["TrialResult", "FAILURE_REASONS", "TELEMETRY_COLUMNS", "run_mission", "run_missions"]

#: failure_reason values; "" means success
FAILURE_REASONS = ("tipped", "stuck", "timeout", "off_map")

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
    """Deepest wheel-terrain penetration seen at the telemetry ticks."""
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

    def as_row(self) -> dict:
        return dataclasses.asdict(self)

    def __eq__(self, other: object) -> bool:
        """Field-wise equality in which NaN equals NaN (failed trials have a NaN traversal time)."""
        if not isinstance(other, TrialResult):
            return NotImplemented
        return all(
            a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))
            for a, b in zip(dataclasses.astuple(self), dataclasses.astuple(other))
        )

    __hash__ = None  # type: ignore[assignment]  # NaN-aware equality has no matching hash


def _frame(world: World, quat: tuple, ang_world: tuple) -> tuple[float, float, float, float, float, float]:
    """(roll, pitch, yaw, body roll rate, body pitch rate, body yaw rate) from the base quaternion
    and world angular velocity; angles as in metrics.roll_pitch_yaw_from_quat (scalar, fast path)."""
    r = world.rotation_matrix(quat)  # row-major 3x3, body -> world
    roll = math.atan2(r[7], r[8])
    pitch = math.asin(max(-1.0, min(1.0, r[6])))
    yaw = math.atan2(r[3], r[0])
    wx, wy, wz = ang_world
    # body rates = R^T omega
    return (roll, pitch, yaw,
            r[0] * wx + r[3] * wy + r[6] * wz,
            r[1] * wx + r[4] * wy + r[7] * wz,
            r[2] * wx + r[5] * wy + r[8] * wz)


def run_mission(
    world: World,
    mission: Mission,
    *,
    controller: ControllerConfig = ControllerConfig(),
    rules: FailureRules = FailureRules(),
    spawn_roll_rad: float = 0.0,
) -> tuple[TrialResult, dict[str, np.ndarray]]:
    """Drive one mission in ``world``; returns the result and the telemetry columns.

    ``spawn_roll_rad`` tilts the vehicle about its long axis at spawn (a test hook: 90 deg puts it
    on its side).
    """
    sim = world.sim
    if sim.physics_rate_hz % controller.control_rate_hz:
        raise InputError(
            f"ControllerConfig.control_rate_hz = {controller.control_rate_hz} must divide "
            f"SimConfig.physics_rate_hz = {sim.physics_rate_hz}"
        )
    hm = world.hm
    spec = world.spec
    ctrl_every = sim.physics_rate_hz // controller.control_rate_hz
    tel_every = sim.physics_rate_hz // sim.telemetry_rate_hz
    tel_dt = 1.0 / sim.telemetry_rate_hz
    stuck_window = int(round(rules.stuck_window_s * sim.telemetry_rate_hz))
    tip = math.radians(rules.tip_angle_deg)
    goal = np.asarray(mission.goal_xy_m, dtype=float)
    bounds = (hm.width_m, hm.height_m, hm.z_min_m)

    waypoints = plan_path(controller.planner, hm, mission.start_xy_m, mission.goal_xy_m)
    tracker = make_tracker(waypoints, spec, controller)
    timeout_s = rules.timeout_factor * tracker.length_m / min(controller.cruise_speed_m_s, spec.max_speed_m_s)
    n_steps = int(math.ceil(timeout_s * sim.physics_rate_hz))

    world.spawn(mission.start_xy_m[0], mission.start_xy_m[1], mission.heading_rad, roll_rad=spawn_roll_rad)

    rows: list[tuple] = []
    xy_hist: list[tuple[float, float]] = []
    cmd_v = cmd_w = progress = 0.0
    reason = "timeout"
    traversal_time = float("nan")
    end_step = n_steps
    for k in range(n_steps + 1):
        tel_tick = k % tel_every == 0
        ctrl_tick = k % ctrl_every == 0
        if tel_tick or ctrl_tick:
            pos, quat, lin, ang = world.base_state()
            roll, pitch, yaw, *rates = _frame(world, quat, ang)
        if ctrl_tick:
            cmd_v, cmd_w, progress = tracker.command(np.array(pos[:2]), yaw, np.array(lin[:2]))
            world.command_wheels(*wheel_speeds(cmd_v, cmd_w, spec))
        if tel_tick:
            rows.append(
                (k * world.dt_s, *pos, *quat, roll, pitch, yaw, *lin, *rates,
                 cmd_v, cmd_w, tracker.progress(np.array(pos[:2])), world.wheel_penetration_m())
            )
            xy_hist.append((pos[0], pos[1]))
            done = _end_reason(bounds, rules, tip, goal, pos, roll, pitch, xy_hist, stuck_window)
            if done is not None:
                reason = done
                end_step = k
                if done == "":
                    traversal_time = k * world.dt_s
                break
        if k < n_steps:
            world.step()

    tel = {name: np.array(col, dtype=float) for name, col in zip(TELEMETRY_COLUMNS, zip(*rows))}
    result = _result(mission, tel, reason, traversal_time, end_step * world.dt_s, tel_dt, goal)
    return result, tel


def _end_reason(bounds, rules, tip, goal, pos, roll, pitch, xy_hist, stuck_window) -> str | None:
    """The reason the trial ends now ('' = success), or None to go on.

    ``bounds`` = (width, height, lowest z) of the map, metres."""
    if abs(roll) > tip or abs(pitch) > tip:
        return "tipped"
    width, height, z_min = bounds
    if not (0.0 <= pos[0] <= width and 0.0 <= pos[1] <= height) or pos[2] < z_min - rules.fall_depth_m:
        return "off_map"
    if math.hypot(pos[0] - goal[0], pos[1] - goal[1]) <= rules.goal_tolerance_m:
        return ""
    if len(xy_hist) > stuck_window:
        first = xy_hist[-stuck_window - 1]
        # cheap test first: only a vehicle back near where it was a window ago can be stuck
        if math.hypot(pos[0] - first[0], pos[1] - first[1]) < rules.stuck_distance_m:
            window = np.asarray(xy_hist[-stuck_window - 1 :])
            if metrics.stuck_index(window, stuck_window, rules.stuck_distance_m) is not None:
                return "stuck"
    return None


def _result(mission, tel, reason, traversal_time, end_time, dt, goal) -> TrialResult:
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


def run_missions(
    hm: Heightmap,
    missions: Sequence[Mission],
    *,
    vehicle: VehicleSpec | str = "husky",
    controller: ControllerConfig = ControllerConfig(),
    sim: SimConfig = SimConfig(),
    rules: FailureRules = FailureRules(),
    progress: ProgressFn | None = None,
    telemetry_dir: str | Path | None = None,
) -> list[TrialResult]:
    """Run every mission on one terrain (built once) and return one TrialResult per mission.

    With ``telemetry_dir`` the telemetry of each trial is saved there as
    ``mission_<index>.npz`` (see offroadbench.io.telemetry).
    """
    from offroadbench.io.telemetry import save_telemetry

    out_dir = Path(telemetry_dir) if telemetry_dir is not None else None
    if out_dir is not None and not out_dir.is_dir():
        raise InputError(f"telemetry_dir {out_dir} is not a directory")
    results: list[TrialResult] = []
    with World(hm, vehicle, sim) as world:
        for i, mission in enumerate(missions):
            result, tel = run_mission(world, mission, controller=controller, rules=rules)
            results.append(result)
            if out_dir is not None:
                save_telemetry(tel, out_dir / f"mission_{mission.index:03d}.npz")
            report(progress, i + 1, len(missions))
    return results
