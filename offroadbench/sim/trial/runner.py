"""The trial runner: drive one mission in a World, apply the failure rules, compute the metrics.

The per-tick code is :class:`TrialLoop`; :func:`drive_mission` drives it with a planner's path or a
policy, the Gymnasium env (offroadbench.sim.gym_env) with an agent's actions, so both are one trial.

Loop, per physics step at ``k * dt``: at telemetry ticks (20 Hz) the base state is recorded and
the failure rules of offroadbench.navigation.rules are checked (tipped, off_map, success, stuck);
at control ticks the driver issues (v, omega), mapped to joint commands by the vehicle's steering
kind (offroadbench.sim.trial.steering).
The driver is the study's ``[planner]`` (offroadbench.navigation.drivers): a planner
(offroadbench.navigation.planners; default ``straight``, the start-goal line) whose path pure
pursuit follows, or a closed-loop policy (offroadbench.navigation.policies) fed the Gymnasium env's
observation; each is given what its registry entry declares it needs. The clock starts after the
vehicle has settled at the start; the trial ends as ``timeout`` after ``rules.timeout_factor``
times the nominal time ``path length / cruise speed`` (for a policy, the mission length).

Metrics follow Majhor & Bos 2023, Sec. 2.4 (see offroadbench.navigation.metrics) and are computed from the
20 Hz telemetry between the clock start and the end of the trial.

The row type, :class:`TrialResult`, and the telemetry columns are in :mod:`offroadbench.sim.trial.result`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from offroadbench.errors import InputError, PluginError
from offroadbench.navigation import metrics
from offroadbench.navigation.missions import Mission, MissionConfig
from offroadbench.navigation.observation import ObservationConfig
from offroadbench.navigation.observation import observation as observe
from offroadbench.navigation.drivers import PlannerChoice, PolicyContext, make_policy
from offroadbench.navigation.perception import Replanner
from offroadbench.navigation.sensor import Belief, make_sensing, sheet_envelope
from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope
from offroadbench.navigation.rules import FAILURE_REASONS, FailureRules, RuleChecker, trial_timeout_s
from offroadbench.sim.config import ControllerConfig
from offroadbench.sim.trial.steering import make_vehicle_tracker, min_turn_radius_m, reference_layout, twist_driver
from offroadbench.sim.engine import TrialWorld
from offroadbench.sim.engines.base import max_height_near
from offroadbench.bounds import check_settled
from offroadbench.sim.trial.limits import plan_within_limits
from offroadbench.sim.trial.result import TELEMETRY_COLUMNS, TrialResult, make_result
from offroadbench.sim.trial.settings import TrialSettings

__all__ = ["TrialResult", "TrialRecord", "TrialLoop", "FAILURE_REASONS", "TELEMETRY_COLUMNS", "drive_mission",
           "run_mission", "settings_of", "clamp_action", "vehicle_envelope", "body_velocity", "body_frame",
           "control_steps"]

#: where the commands (v, omega) sit in a telemetry row: by name (TELEMETRY_COLUMNS), not by position
_CMD_V, _CMD_OMEGA = TELEMETRY_COLUMNS.index("cmd_v_m_s"), TELEMETRY_COLUMNS.index("cmd_omega_rad_s")
assert _CMD_OMEGA == _CMD_V + 1, "TrialLoop.command rewrites the two commands as one slice of a row"


def control_steps(sim_physics_rate_hz: int, control_rate_hz: int,
                  name: str = "ControllerConfig.control_rate_hz") -> int:
    """Physics steps per control tick; the control rate (``name``, Hz) must divide the physics rate
    (Hz), else one InputError naming both."""
    if sim_physics_rate_hz % control_rate_hz:
        raise InputError(f"{name} = {control_rate_hz} must divide SimConfig.physics_rate_hz = {sim_physics_rate_hz}")
    return sim_physics_rate_hz // control_rate_hz


def body_frame(world: TrialWorld, quat: tuple, ang_world: tuple) -> tuple[float, float, float, float, float, float]:
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


def vehicle_envelope(world: TrialWorld) -> VehicleEnvelope:
    """The footprint and limits of ``world``'s vehicle, for planners, from its measured geometry
    (``world.geometry``, offroadbench.sim.engine.VehicleGeometry): overall length and width, the
    belly's height above the wheels' bottoms, and the step limit (the spec's ``rated_step_m``, else
    offroadbench.sim.rigs.vehicle_check.step_bound_m of that geometry, the bound ``offroadbench vehicle check``
    tests)."""
    from offroadbench.sim.rigs.vehicle_check import step_bound_m

    spec, geo = world.spec, world.geometry
    step = spec.rated_step_m
    if step is None:
        step = step_bound_m(spec.wheel_radius_m, geo.belly_m, geo.wheelbase_m, geo.overhang)
    return VehicleEnvelope(length_m=geo.length_m, width_m=geo.width_m,
                           max_speed_m_s=spec.max_speed_m_s, max_yaw_rate_rad_s=spec.max_yaw_rate_rad_s,
                           max_slope=spec.wheel_friction * world.sim.terrain_friction,
                           max_step_m=float(step), ground_clearance_m=geo.belly_m, wheel_radius_m=spec.wheel_radius_m,
                           min_turn_radius_m=min_turn_radius_m(spec, reference_layout(spec, geo.wheel_centres_m)))


@dataclass(frozen=True, eq=False)
class TrialRecord:
    """Everything one trial produced: the result row, the 20 Hz telemetry and the planned path."""

    result: TrialResult
    telemetry: dict[str, np.ndarray]
    """TELEMETRY_COLUMNS, each a 1-D array."""
    path_xy: np.ndarray
    """The planner's waypoints (N, 2), map metres; for a policy, ``[start, goal]``."""
    belief: Belief | None = None
    """Under the ``mast`` sensor: the believed path and the map it built (None for the oracle)."""


class TrialLoop:
    """One trial in progress: the per-tick functions that :func:`drive_mission` and the Gymnasium env
    (offroadbench.sim.gym_env) both call, so a trial is the same code whoever chooses the commands.

    Built at the mission's start (the vehicle spawned and settled, the clock at 0, the state read
    into :attr:`state`). Each control tick, the driver sets the wheels with :meth:`command` and
    the tick is recorded with :meth:`record` (the telemetry row at a telemetry tick, Majhor & Bos
    2023, Sec. 2.4: 20 Hz, and the failure rules, offroadbench.navigation.rules, checked on it);
    :meth:`step_to_next_control` then runs the physics to the next control tick, recording the
    telemetry ticks on the way. Either returns True once the trial has ended: a rule fired
    (:attr:`reason`), or the timeout (``rules.timeout_factor`` times the nominal time ``length_m``
    over the cruise speed). ``progress_m`` maps the base position to a row's progress along the path.
    ``settings`` (TrialSettings) give the controller and the failure rules, whole; the world holds
    the vehicle and physics the trial runs with.

    The trial runner commands first and then records a control tick (the row carries the command
    chosen there); the env records on arriving at a tick (so the step that ends a trial says so)
    and its next :meth:`command` writes the new command into that tick's row: the rows are the same.
    """

    def __init__(self, world: TrialWorld, mission: Mission, settings: TrialSettings, *, length_m: float,
                 name: str = "agent", spawn_roll_rad: float = 0.0) -> None:
        sim, controller, rules = world.sim, settings.controller, settings.rules
        hm, spec = world.hm, world.spec
        self.world = world
        self.mission = mission
        self.name = name
        self.ctrl_every = control_steps(sim.physics_rate_hz, controller.control_rate_hz)
        self.tel_every = sim.physics_rate_hz // sim.telemetry_rate_hz
        self.goal = np.asarray(mission.goal_xy_m, dtype=float)
        self.timeout_s = trial_timeout_s(rules, length_m, controller.cruise_speed_m_s, spec.max_speed_m_s)
        self.n_steps = int(math.ceil(self.timeout_s * sim.physics_rate_hz))
        self.checker = RuleChecker(rules, (hm.width_m, hm.height_m, hm.z_min_m), self.goal, timeout_s=self.timeout_s,
                                   sample_rate_hz=sim.telemetry_rate_hz, mission_length_m=mission.length_m,
                                   wheel_radius_m=spec.wheel_radius_m)
        self.rows: list[tuple] = []
        self._row_k = -1  # the tick of the last row
        self.slips: list[float] = []
        self._outside = getattr(world, "wheel_outside_model", None)
        self.outside: list[float] = []
        """Per telemetry row: 1 where a wheel bottomed out (outside the soil model), 0 where not, NaN
        where the engine or the tyre model has no soil."""
        self.cmd_v = self.cmd_w = 0.0
        self.reason: str | None = None
        """None while the trial runs, then "" (success) or its failure reason."""
        self.traversal_time_s = float("nan")
        self.end_step = self.n_steps
        self.k = 0
        world.spawn(mission.start_xy_m[0], mission.start_xy_m[1], mission.heading_rad, roll_rad=spawn_roll_rad)
        # what every tick calls, looked up once: the world's methods, the drive's mapping (its wheel
        # layout worked out once), the physics step
        self._drive = twist_driver(world)
        self._step, self._advance_n = world.step, getattr(world, "advance", None)
        self._base_state, self._rotation = world.base_state, world.rotation_matrix
        self._penetration, self._slip = world.wheel_penetration_m, world.wheel_slip
        self._dt_s = world.dt_s
        self._read()
        # a vehicle thrown while settling is a fault, not a trial (offroadbench.bounds)
        check_settled(self.state[0], self.state[2],
                      max_height_near(hm, *mission.start_xy_m, spec.wheel_radius_m + spec.track_m),
                      size_m=spec.track_m + 2 * spec.wheel_radius_m, where=f"mission {mission.index}")

    def _read(self) -> None:
        pos, quat, lin, ang = self._base_state()
        # body_frame, inline (the same operations)
        r = self._rotation(quat)  # row-major 3x3, body -> world
        wx, wy, wz = ang
        self.state = (pos, quat, lin, ang, math.atan2(r[7], r[8]), math.asin(max(-1.0, min(1.0, r[6]))),
                      math.atan2(r[3], r[0]),
                      [r[0] * wx + r[3] * wy + r[6] * wz, r[1] * wx + r[4] * wy + r[7] * wz,
                       r[2] * wx + r[5] * wy + r[8] * wz])
        """(position, quaternion, linear and angular velocity, roll, pitch, yaw, body rates) at the
        last control or telemetry tick (offroadbench.sim.engine.TrialWorld.base_state, body_frame)."""

    @property
    def t_s(self) -> float:
        """Simulated time since the clock started, s."""
        return self.k * self.world.dt_s

    @property
    def ended(self) -> bool:
        """True once :meth:`record` or :meth:`step_to_next_control` has ended the trial."""
        return self.reason is not None

    def command(self, v_m_s: float, omega_rad_s: float) -> None:
        """Drive at (v, omega) from this tick (the vehicle's steering kind maps it to joint commands:
        offroadbench.sim.trial.steering); a row already recorded at this tick takes the command."""
        self.cmd_v, self.cmd_w = v_m_s, omega_rad_s
        self._drive(v_m_s, omega_rad_s)
        if self._row_k == self.k:
            row = self.rows[-1]
            self.rows[-1] = (*row[:_CMD_V], v_m_s, omega_rad_s, *row[_CMD_OMEGA + 1:])

    def record(self, progress_m) -> bool:
        """At a telemetry tick, the row and the failure rules; then the timeout. True when the trial
        has ended here."""
        k = self.k
        if k % self.tel_every == 0:
            pos, quat, lin, ang, roll, pitch, yaw, rates = self.state
            t_s = k * self._dt_s
            _check_state(self.name, t_s, pos, quat, lin, ang)
            progress = progress_m(pos)
            penetration = self._penetration()
            self.rows.append((t_s, *pos, *quat, roll, pitch, yaw, *lin, *rates,
                              self.cmd_v, self.cmd_w, progress, penetration))
            self._row_k = k
            slip = self._slip()
            self.slips.append(math.nan if slip is None else slip)  # one per telemetry row
            outside = self._outside() if self._outside is not None else None
            self.outside.append(math.nan if outside is None else float(outside))
            done = self.checker.check(pos, roll, pitch, slip, penetration)
            if done is not None:
                self.reason = done
                self.end_step = k
                if done == "":
                    self.traversal_time_s = t_s
                return True
        if k >= self.n_steps:
            self.reason = "timeout"
            return True
        return False

    def step_to_next_control(self, progress_m) -> bool:
        """Physics steps up to the next control tick (its state read, not yet recorded), recording
        the telemetry ticks on the way; True when the trial has ended on the way."""
        tel_every, ctrl_every, n_steps = self.tel_every, self.ctrl_every, self.n_steps
        advance, step = self._advance_n, self._step  # advance: n steps in one call (TrialWorld.step n times), if it can
        while True:
            k = self.k
            # the steps before the next telemetry or control tick (or the timeout) do nothing but step
            n = min(tel_every - k % tel_every, ctrl_every - k % ctrl_every, max(1, n_steps - k))
            if n > 1 and advance is not None:
                advance(n - 1)
                self.k = k = k + n - 1
            step()
            self.k = k = k + 1
            tel, ctrl = k % tel_every == 0, k % ctrl_every == 0
            if tel or ctrl:
                self._read()
            if ctrl:
                return False
            if self.record(progress_m):
                return True

    def result(self, telemetry: dict[str, np.ndarray] | None = None) -> TrialResult:
        """The trial's row (:class:`TrialResult`), once it has ended; ``telemetry``: :meth:`telemetry`'s
        columns if the caller has them already."""
        tel = self.telemetry() if telemetry is None else telemetry
        reason = "timeout" if self.reason is None else self.reason
        result = make_result(self.mission, tel, reason, self.traversal_time_s, self.end_step * self.world.dt_s,
                         1.0 / self.world.sim.telemetry_rate_hz, self.goal)
        if any(map(math.isfinite, self.slips)):  # on soil: slip and sinkage over the moving samples
            moving = metrics.moving_samples(tel["cmd_v_m_s"], tel["vx_m_s"], tel["vy_m_s"])
            on_soil = moving & np.isfinite(np.asarray(self.slips))
            median, p95 = metrics.sinkage_summary(tel["penetration_m"], on_soil)
            result = dataclasses.replace(result, mean_slip=metrics.mean_where(self.slips, on_soil),
                                         sinkage_median_m=median, sinkage_p95_m=p95)
        if any(map(math.isfinite, self.outside)):  # the fraction of the whole trial, every tick
            result = dataclasses.replace(result, outside_model_fraction=float(np.nanmean(self.outside)))
        dropped = getattr(self.world, "dropped_contacts", lambda: None)()  # optional: TrialWorld.dropped_contacts
        if dropped is not None:  # since the spawn, settling included
            result = dataclasses.replace(result, dropped_contacts=float(dropped))
        return result

    def telemetry(self) -> dict[str, np.ndarray]:
        """The telemetry so far, TELEMETRY_COLUMNS."""
        return {name: np.array(col, dtype=float) for name, col in zip(TELEMETRY_COLUMNS, zip(*self.rows, strict=True), strict=True)}


def drive_mission(
    world: TrialWorld,
    mission: Mission,
    *,
    settings: TrialSettings | None = None,
    classes: np.ndarray | None = None,
    spawn_roll_rad: float = 0.0,
    planner: PlannerChoice | None = None,
    border_m: float | None = None,
    controller: ControllerConfig | None = None,
    rules: FailureRules | None = None,
    observation: ObservationConfig | None = None,
) -> TrialRecord:
    """Drive one mission in ``world`` with a planner (pure pursuit on its path) or a policy, through
    :class:`TrialLoop`.

    ``settings`` (offroadbench.sim.trial.pipeline.TrialSettings, as :func:`drive_terrain` passes
    them) give the planner, controller, failure rules, observation and the missions' border, whole
    (the world already holds its vehicle and physics). Without them, ``planner``, ``controller``,
    ``rules``, ``observation`` and ``border_m`` (each defaulting to its config's default; border
    0 m) are made into one TrialSettings (:func:`settings_of`); giving both is an InputError.

    ``classes`` is the closed roughness-class map the planner sees (the study's; needed by a driver
    whose registry entry declares it, see offroadbench.navigation.drivers.NEEDS), ``border_m`` the
    mission border planned paths keep to. The vehicle's envelope is measured only for a driver that
    declares ``vehicle``.
    ``spawn_roll_rad`` tilts the vehicle about its long axis at spawn (a test hook: 90 deg puts it
    on its side).
    """
    pieces = {"planner": planner, "border_m": border_m, "controller": controller, "rules": rules,
              "observation": observation}
    if settings is None:
        settings = settings_of(world, **pieces)
    elif any(v is not None for v in pieces.values()):
        given = ", ".join(k for k, v in pieces.items() if v is not None)
        raise InputError(f"drive_mission: give {given} inside settings, not beside it")
    planner, controller, observation = settings.planner, settings.controller, settings.observation
    border_m = settings.missions.border_m
    sim = world.sim
    control_steps(sim.physics_rate_hz, controller.control_rate_hz)
    hm = world.hm
    spec = world.spec
    goal = np.asarray(mission.goal_xy_m, dtype=float)

    policy = tracker = replanner = None
    needs = planner.needs  # declared on the planner's or policy's registry entry
    if "classes" in needs and classes is None:
        raise InputError(f"{planner.kind} {planner.name!r} needs the class map (classes=...)")
    perception = planner.perception
    envelope = vehicle_envelope(world) if "vehicle" in needs else None
    if envelope is not None and perception is not None and perception.limits == "sheet":
        envelope = sheet_envelope(envelope, spec)
    problem = PlanningProblem(hm=hm, classes=classes if "classes" in needs else None, start_xy=mission.start_xy_m,
                              goal_xy=mission.goal_xy_m, border_m=border_m, vehicle=envelope)
    sensing = make_sensing(hm, perception, mission)  # what the driver knows: the truth, or the mast sensor's
    if planner.kind == "policy":
        waypoints = problem.endpoints()
        policy = _policy_call(planner.name, "could not be built", make_policy, planner.name, planner.config, PolicyContext(
            observation=observation, vehicle=problem.vehicle, track_m=spec.track_m,
            control_rate_hz=controller.control_rate_hz))
        _policy_call(planner.name, "failed in reset()", policy.reset, problem)
    elif planner.perception is not None:  # the planner sees a degraded map (navigation.perception)
        replanner = Replanner(lambda p: plan_within_limits(planner, p), problem, mission, perception, sensing)
        waypoints = replanner.waypoints
    else:
        waypoints = plan_within_limits(planner, problem)
    if policy is None:
        tracker = make_vehicle_tracker(waypoints, spec, controller, world)
        length = tracker.length_m
    else:
        length = mission.length_m
    fill_m = hm.z_min_m - settings.rules.fall_depth_m if policy is not None else None  # a policy's map fill

    if replanner is None and tracker is not None:
        progress_m = tracker.progress  # reads pos[0] and pos[1] only
    else:
        straight_m, gx, gy = mission.length_m, float(goal[0]), float(goal[1])

        def progress_m(pos) -> float:
            return straight_m - math.hypot(gx - pos[0], gy - pos[1])

    loop = TrialLoop(world, mission, settings, length_m=length, name=planner.name, spawn_roll_rad=spawn_roll_rad)
    while True:
        pos, quat, lin, ang, roll, pitch, yaw, rates = loop.state
        bx, by, byaw = sensing.update(pos, yaw)  # the believed pose (the true one for the oracle)
        if policy is None:
            if replanner is not None and replanner.update((bx, by)) is not None:
                tracker = make_vehicle_tracker(replanner.waypoints, spec, controller, world)
            v, w, _ = tracker.command((bx, by), byaw, lin[:2])
        else:
            obs = observe(hm, observation, goal, (bx, by, pos[2]), roll, pitch, byaw, rates,
                          body_velocity(world, quat, lin), fill_m, None if sensing.name == "oracle" else sensing.z)
            if "map" in needs:
                obs["pose"], obs["elevation_m"] = np.array((bx, by, byaw)), sensing.z
            act = _policy_call(planner.name, f"failed in act() at t = {loop.t_s:.2f} s", policy.act, obs)
            v, w = clamp_action(_checked_action(planner.name, act, loop.t_s), spec)
        loop.command(v, w)
        if loop.record(progress_m) or loop.step_to_next_control(progress_m):
            break
    path = replanner.trace if replanner is not None else waypoints
    belief = None if sensing.name == "oracle" else Belief(np.asarray(sensing.trail, dtype=float).reshape(-1, 2), sensing.seen)
    telemetry = loop.telemetry()
    return TrialRecord(loop.result(telemetry), telemetry, np.asarray(path, dtype=float), belief)


def settings_of(world: TrialWorld, *, planner: PlannerChoice | None = None, border_m: float | None = None,
                controller: ControllerConfig | None = None, rules: FailureRules | None = None,
                observation: ObservationConfig | None = None) -> TrialSettings:
    """The TrialSettings of ``world`` (its vehicle and physics) with these parts; a part left out
    takes its config's default, the border 0 m."""
    return TrialSettings(vehicle=world.spec, sim=world.sim, planner=planner or PlannerChoice(),
                         controller=controller or ControllerConfig(), rules=rules or FailureRules(),
                         observation=observation or ObservationConfig(),
                         missions=MissionConfig(border_m=0.0 if border_m is None else border_m))


def clamp_action(action: tuple[float, float], spec) -> tuple[float, float]:
    """A (v, omega) command within the vehicle's top speed (either direction) and yaw-rate limit."""
    v_lim, w_lim = spec.max_speed_m_s, spec.max_yaw_rate_rad_s
    return min(max(action[0], -v_lim), v_lim), min(max(action[1], -w_lim), w_lim)


def _policy_call(name: str, what: str, fn, *args):
    """A policy's own code (built, reset, act): its exception is a one-line PluginError naming the
    policy (the traceback goes to the log), as a planner's is (:func:`plan_within_limits`)."""
    try:
        return fn(*args)
    except (PluginError, InputError):
        raise
    except Exception as exc:
        import logging

        logging.getLogger(__name__).info("policy %r %s", name, what, exc_info=True)
        raise PluginError(f"policy {name!r} {what}: {type(exc).__name__}: {' '.join(str(exc).split())[:300]}") from exc


def _checked_action(name: str, action, t_s: float) -> tuple[float, float]:
    """A policy's (v, omega) as two finite floats, else a PluginError naming the policy and value."""
    try:
        v, w = (float(x) for x in np.asarray(action, dtype=float).reshape(2))
    except (TypeError, ValueError):
        raise PluginError(f"policy {name!r} returned {action!r} at t = {t_s:.2f} s; expected (v, omega), "
                          "two finite numbers") from None
    if not (math.isfinite(v) and math.isfinite(w)):
        raise PluginError(f"policy {name!r} returned a non-finite action ({v!r}, {w!r}) at t = {t_s:.2f} s")
    return v, w


def _check_state(name: str, t_s: float, pos, quat, lin, ang) -> None:
    """Refuse a non-finite base state (the physics blew up): a fault, not an outcome such as tipped."""
    if not all(map(math.isfinite, (*pos, *quat, *lin, *ang))):
        raise PluginError(f"the simulation state became non-finite at t = {t_s:.2f} s (position {tuple(pos)}) "
                          f"while driving with {name!r}")


def run_mission(world: TrialWorld, mission: Mission, **kwargs) -> tuple[TrialResult, dict[str, np.ndarray]]:
    """:func:`drive_mission`, returning (result, telemetry columns)."""
    rec = drive_mission(world, mission, **kwargs)
    return rec.result, rec.telemetry


def body_velocity(world: TrialWorld, quat: tuple, lin: tuple) -> tuple[float, float, float]:
    """The base's velocity in the body frame (forward, left, up), m/s."""
    r = world.rotation_matrix(quat)  # row-major, body -> world
    return tuple(r[i] * lin[0] + r[i + 3] * lin[1] + r[i + 6] * lin[2] for i in range(3))
