"""A Gymnasium environment for mission driving on one terrain: ``offroadbench/Traverse-v0``.

Each episode is one mission drawn by :func:`offroadbench.navigation.missions.sample_missions` (Majhor & Bos
Sec. 2.3) on the closed roughness-class map of the terrain (Eq. 3-4; its start cells and goal map,
:func:`offroadbench.navigation.missions.mission_sites`, computed at the first draw and kept for the
terrain, as a study's are), with the generator Gymnasium seeds in ``reset(seed=...)`` (Gymnasium's own episode seeding; the terrain's seed follows
:mod:`offroadbench.seeding`): the same seed gives the same mission and, because
:meth:`World.spawn` resets every piece of vehicle state, the same episode bit for bit.

- **Action**: ``(v, omega)``, forward speed (m/s) and yaw rate (rad/s, CCW +), in a Box bounded by
  the vehicle's ``max_speed_m_s`` (either direction) and ``max_yaw_rate_rad_s``; mapped to joint
  commands by the vehicle's steering kind (:func:`offroadbench.sim.trial.steering.drive_twist`) and held for one
  control tick (``1 / control_rate_hz``, 20 Hz by default, i.e. physics_rate / 20 physics steps).
  Actions outside the Box are clipped to the vehicle's limits in float64, as the trial runner
  clips a policy's (offroadbench.sim.trial.runner.clamp_action). There is no speed profile: the agent commands the wheels.
  A non-finite action (NaN or infinite in either component) or one that is not two numbers is
  refused with an InputError before anything reaches the physics: the episode and the world are
  left as they were (the agent may ``step`` again with a finite action). Clipping NaN has no
  meaningful value, and a NaN reaching Bullet would poison the world for later episodes.
- **Episode end**: ``step`` after the episode ended (``terminated`` or ``truncated``) raises
  RuntimeError; call ``reset``. ``reset(options=...)`` takes None or a dict whose only key is
  ``"mission"``; anything else is an InputError.
- **Observation**: a Dict of
  ``state`` (float32, 10): goal x and y in the vehicle's heading frame (m; x forward, y left,
  horizontal), roll and pitch (rad, as in :mod:`offroadbench.navigation.metrics`), body roll, pitch and yaw
  rates (rad/s), and the base velocity in the body frame (forward, left, up; m/s);
  ``height_patch`` (float32, n x n): terrain heights relative to the base (m), on a square grid
  centred on the vehicle and aligned with its heading (see :func:`height_patch`; samples off the
  map read the map's lowest height less ``rules.fall_depth_m``, a drop), and where the sensor has
  not measured the sample (see Sensor) ``UNKNOWN_FILL_M`` = 0.0 m, the base's own height;
  ``known`` (float32, n x n, in [0, 1]): 1.0 where ``height_patch`` is a measurement (everywhere
  under the oracle, off-map samples included), 0.0 where it is that fill, so a learner tells the
  two apart. Every entry is finite and the observation is inside ``observation_space`` under
  either sensor. The goal distance is the norm of (goal x, goal y) and its direction their angle
  (rad, CCW + from the heading).
- **Sensor** (``perception=``, or ``settings.planner.perception``): ``"oracle"`` (default) observes the
  true terrain and pose; ``"mast"`` (or a PerceptionConfig with ``sensor = "mast"``) observes through
  the mast sensor of :mod:`offroadbench.navigation.sensor` exactly as a policy does in a study's
  trials (:func:`offroadbench.sim.trial.runner.drive_mission`): the goal and the patch are in the
  **believed** frame (odometry drift), the patch is read from the map the sensor has built so far,
  and a sample next to a cell the sensor has not seen (occluded or out of range; never guessed
  flat) reads the fill with ``known`` 0. The trial runner gives a policy the same observation with
  NaN at those samples and no ``known``
  (:func:`offroadbench.navigation.observation.nan_observation` turns the env's into it, bit for
  bit: ``ppo.features(nan_observation(obs))`` is what the ``ppo`` policy reads in a trial).
  Attitude, rates and body velocity are the IMU's (true) values. The sensor's stream is the mission's
  (offroadbench.navigation.perception.perception_seed): an episode replays bit for bit.
  ``info["believed_pose"]`` is ``{"x_m", "y_m", "yaw_rad"}`` (the truth under the oracle). The
  reward and ``info``'s distance are measured on the true pose.
- **The trial**: an episode is a trial of the trial runner, stepped through the same per-tick code
  (offroadbench.sim.trial.runner.TrialLoop): the same spawn, telemetry, failure rules (checked at
  the telemetry rate, 20 Hz), timeout and metrics. Driving a mission with the same actions through
  the env and through the trial runner (the actions as a policy) gives the same trial row and
  telemetry (``tests/contracts/test_gym_env.py``); :meth:`TraverseEnv.trial_record` gives them.
- **Settings**: a :class:`~offroadbench.sim.trial.pipeline.TrialSettings` (``settings=``, or built
  from the other arguments): its vehicle, physics, controller (control rate, cruise speed), rules,
  missions (length, border), roughness and observation. The terrain is prepared as a study prepares
  it (offroadbench.sim.trial.pipeline.prepare_terrain), its recipe's ``[body]`` and ``[soil]``
  included: ``TraverseEnv("lunar-mare")`` runs in the Moon's gravity, 1.62 m/s^2.
- **End**: ``terminated`` on success (within ``rules.goal_tolerance_m`` of the goal) or on the
  trial runner's failure rules (offroadbench.navigation.rules: tipped, off_map, stuck, entrapped,
  with the stuck window capped below the timeout); ``truncated`` at the timeout, the trials' rule
  (offroadbench.navigation.rules.trial_timeout_s): ``rules.timeout_factor`` times the mission
  length over the controller's cruise speed capped by the vehicle's top speed.
  ``info["failure_reason"]`` is "" while running and on success, else one of the failure reasons;
  ``info["success"]`` says whether the goal was reached. A rule that fires at the start (a vehicle
  spawned tipped) ends the first step, which then takes no physics step.
- **Pose**: ``info["pose"]`` after ``reset`` and every ``step`` is the base's ground truth,
  ``{"x_m", "y_m", "z_m", "roll_rad", "pitch_rad", "yaw_rad"}``: the position of the base (its
  centre of mass) on the map and the Z-Y-X Euler angles of the trial runner's telemetry (pitch
  nose-up positive, as in :mod:`offroadbench.navigation.metrics`), so that
  a user can check the dynamics against the commands (e.g. the yaw rate against ``omega``).
- **Planner** (optional): ``planner="astar"`` (any registered planner, name or
  :class:`~offroadbench.navigation.planners.PlannerChoice`) plans each episode's mission on the class map,
  with the vehicle limits a study's trial gives it (a name: as ``[planner] name = "astar"``, the
  maker's published limits by default, offroadbench.navigation.perception ``limits``), so its path is
  the trial runner's for that mission;
  the waypoints are in ``info["path_xy"]`` after ``reset`` and drawn by ``render``.
- **Rendering**: ``render_mode="rgb_array"`` returns the view of a replay animation
  (:class:`offroadbench.plots.animate.TrialView`, uint8, H x W x 3): the hillshade under the closed
  class map (paper Fig. 4 colours), the planned path (white, dashed; the start-goal line without a
  planner), the path driven so far and the vehicle's footprint (its front edge white), beside the
  episode's speed, pitch, roll and vertical acceleration against time, the end marked.
  :func:`top_down_image` is the older, cheaper pixel map.
- **Reward** per control tick of length ``dt``, with ``d`` the horizontal distance to the goal::

      r = w_progress * (d_prev - d) - dt * (w_accel * a_z^2 + w_rate * (p^2 + q^2))
          + success_bonus [on success] - failure_penalty [on tipped, stuck or off_map]

  ``a_z`` is the vertical acceleration of the base (change of its world z velocity over the tick;
  ``dt`` the simulated time the step took, shorter where a rule ends the trial inside it)
  and ``p``, ``q`` the body roll and pitch rates: summed over an episode of duration T the penalty
  is ``T * (w_accel * RMS(a_z)^2 + w_rate * (RMS(p)^2 + RMS(q)^2))``, the squares of the paper's
  comfort metrics (Sec. 2.4). The progress term telescopes to ``d_0 - d_end``. A timeout adds
  nothing beyond the accumulated terms.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from offroadbench.analysis.roughness import RoughnessConfig
from offroadbench.config import check_int, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission, MissionConfig, MissionSites, mission_sites, sample_missions
from offroadbench.navigation.observation import (STATE_FIELDS, UNKNOWN_FILL_M, ObservationConfig, finite_observation,
                                                 height_patch, observation)
from offroadbench.navigation.perception import PerceptionConfig
from offroadbench.navigation.planners import PLANNERS, PlannerChoice, PlanningProblem, planner_from_table
from offroadbench.navigation.rules import FailureRules
from offroadbench.navigation.sensor import make_sensing, sheet_envelope
from offroadbench.sim.config import ControllerConfig, SimConfig
from offroadbench.sim.engine import TrialWorld, open_world
from offroadbench.sim.trial.pipeline import TrialSettings, prepare_terrain, terrain_body
from offroadbench.sim.trial.limits import plan_within_limits
from offroadbench.sim.trial.runner import (TrialLoop, TrialRecord, body_velocity, clamp_action, control_steps,
                                           vehicle_envelope)
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle

from offroadbench.sim.topdown import top_down_image  # noqa: E402  (the env's public name, kept)

__all__ = ["TraverseConfig", "TraverseEnv", "height_patch", "top_down_image", "DEFAULT_TERRAIN", "DEFAULT_OVERRIDES",
           "STATE_FIELDS", "UNKNOWN_FILL_M"]

#: the default terrain: the paper's D = 2.45 preset, cut to 241 x 241 cells (12 m at 5 cm)
DEFAULT_TERRAIN = "paper-d2.45"
DEFAULT_OVERRIDES: Mapping[str, Any] = {"grid.rows": 241, "grid.cols": 241}

@dataclass(frozen=True, kw_only=True)
class TraverseConfig:
    """Missions, observation and reward of the Traverse environment."""

    mission_length_m: float = 6.0
    """Straight-line start-goal distance of each episode's mission, m (small maps: short missions)."""
    border_m: float = 2.0
    """No start or goal closer than this to the map edge, m."""
    control_rate_hz: int = 20
    """Actions per simulated second; must divide SimConfig.physics_rate_hz (paper: 20 Hz)."""
    patch_cells: int = 16
    """Side of the square height patch, samples."""
    patch_spacing_m: float = 0.1
    """Distance between height-patch samples, m (16 x 0.1 m: a 1.5 m square around a 1 m vehicle)."""
    progress_weight: float = 1.0
    """Reward per metre of progress toward the goal."""
    accel_weight: float = 0.01
    """Penalty per (m/s^2)^2 s of vertical acceleration."""
    rate_weight: float = 0.1
    """Penalty per (rad/s)^2 s of body roll and pitch rate."""
    success_bonus: float = 10.0
    """Reward added when the goal is reached."""
    failure_penalty: float = 10.0
    """Reward subtracted when the episode ends tipped, stuck or off_map (not on timeout)."""

    def __post_init__(self) -> None:
        check_range(self, "mission_length_m", self.mission_length_m, lo=0, lo_open=True)
        check_range(self, "border_m", self.border_m, lo=0)
        check_int(self, "control_rate_hz", self.control_rate_hz, lo=1, hi=1000)
        check_int(self, "patch_cells", self.patch_cells, lo=1, hi=512)
        check_range(self, "patch_spacing_m", self.patch_spacing_m, lo=0, lo_open=True)
        for name in ("progress_weight", "accel_weight", "rate_weight", "success_bonus", "failure_penalty"):
            check_range(self, name, getattr(self, name), lo=0)


def _terrain(terrain: str | Heightmap, seed: int, overrides: Mapping[str, Any] | None):
    """(Heightmap, its gravity, its soil, its soil map) of what the env was given (terrain_body, soil_map_for)."""
    from offroadbench.terrain.recipe import load_terrain
    from offroadbench.terrain.soil_map import soil_map_for

    if overrides is None and not isinstance(terrain, Heightmap) and not str(terrain).lower().endswith(".png"):
        overrides = DEFAULT_OVERRIDES
    hm, recipe = load_terrain(terrain, seed, overrides)
    return (hm, *terrain_body(terrain, recipe), soil_map_for(recipe, hm, seed) if recipe is not None else None)


#: the TraverseConfig fields that are the trial settings' own, field -> (TrialSettings section, its
#: field): one table for both ways (the env's settings from its config, its config from given settings)
SETTINGS_FIELDS: Mapping[str, tuple[str, str]] = {
    "mission_length_m": ("missions", "length_m"), "border_m": ("missions", "border_m"),
    "control_rate_hz": ("controller", "control_rate_hz"),
    "patch_cells": ("observation", "patch_cells"), "patch_spacing_m": ("observation", "patch_spacing_m")}


def _settings(config: TraverseConfig, vehicle, sim: SimConfig, rules: FailureRules,
              roughness: RoughnessConfig) -> TrialSettings:
    """The trial settings of the env's own arguments (one mission per episode)."""
    spec = vehicle if isinstance(vehicle, VehicleSpec) else load_vehicle(vehicle)
    kw: dict[str, dict[str, Any]] = {"controller": {}, "missions": {"count": 1}, "observation": {}}
    for field, (section, name) in SETTINGS_FIELDS.items():
        kw[section][name] = getattr(config, field)
    return TrialSettings(vehicle=spec, sim=sim, rules=rules, roughness=roughness, controller=ControllerConfig(
        **kw["controller"]), missions=MissionConfig(**kw["missions"]), observation=ObservationConfig(**kw["observation"]))


def _config_of(config: TraverseConfig, settings: TrialSettings) -> TraverseConfig:
    """``config`` with the fields that are the settings' taken from ``settings`` (its reward kept)."""
    return dataclasses.replace(config, **{field: getattr(getattr(settings, section), name)
                                          for field, (section, name) in SETTINGS_FIELDS.items()})


class TraverseEnv(gym.Env):
    """Drive sampled missions on one terrain with (v, omega) commands; see the module docstring.

    ``terrain`` is a preset name, a recipe TOML path, a 16-bit PNG (with its sidecar) or a
    :class:`Heightmap` (offroadbench.terrain.recipe.load_terrain). A preset or recipe is
    generated with ``terrain_seed``, the integer ``offroadbench generate --seed`` takes and every
    terrain table shows (terrain j of a root seed s is ``offroadbench.seeding.terrain_seed(s, j)``),
    after ``overrides`` (dotted recipe keys; default
    :data:`DEFAULT_OVERRIDES`, a 12 m map; pass ``{}`` for the recipe's own size). The terrain and
    its world are built once, in the constructor; call :meth:`close` to free them.

    ``settings`` (a TrialSettings) gives the vehicle, physics, controller, rules, missions,
    roughness and observation all at once; then ``vehicle``, ``sim``, ``rules`` and ``roughness``
    must be left out, and ``config`` gives only the reward (its mission, control-rate and patch
    fields are the settings'). Without it they are built from the arguments.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        terrain: str | Heightmap = DEFAULT_TERRAIN,
        *,
        terrain_seed: int = 0,
        overrides: Mapping[str, Any] | None = None,
        vehicle: VehicleSpec | str | None = None,
        config: TraverseConfig = TraverseConfig(),
        sim: SimConfig | None = None,
        rules: FailureRules | None = None,
        roughness: RoughnessConfig | None = None,
        settings: TrialSettings | None = None,
        planner: str | PlannerChoice | None = None,
        render_mode: str | None = None,
        perception: PerceptionConfig | str | None = None,
    ) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise InputError(f"render_mode {render_mode!r} is not supported; allowed: None, "
                             f"{', '.join(map(repr, self.metadata['render_modes']))}")
        if settings is None:
            settings = _settings(config, "husky" if vehicle is None else vehicle, sim or SimConfig(),
                                 rules or FailureRules(), roughness or RoughnessConfig())
        else:
            given = [n for n, v in (("vehicle", vehicle), ("sim", sim), ("rules", rules), ("roughness", roughness))
                     if v is not None]
            if given:
                raise InputError(f"TraverseEnv: give {', '.join(given)} inside settings, not beside it")
            config = _config_of(config, settings)
        control_steps(settings.sim.physics_rate_hz, config.control_rate_hz, "TraverseConfig.control_rate_hz")
        if isinstance(planner, str):  # as a study's [planner] table names it (its default limits included)
            PLANNERS.get(planner)  # a policy's or an unknown name: the registry's one-line error
            planner = planner_from_table({"name": planner}, where="TraverseEnv planner")
        self.perception = _perception(settings.planner.perception if perception is None else perception)
        """What the agent observes through (None: the oracle; see the module docstring, Sensor)."""
        self.planner = planner
        self.render_mode = render_mode
        self.cfg = config
        self.settings = settings
        self.rules = settings.rules
        hm, gravity, soil, soil_map = _terrain(terrain, terrain_seed, overrides)
        self.terrain = prepare_terrain(hm, terrain_seed, settings, [], gravity_m_s2=gravity, soil=soil, soil_map=soil_map)
        self.hm = hm
        self.closed_classes = self.terrain.maps.closed  # the map the trials' missions use
        self._mission_cfg = dataclasses.replace(settings.missions, count=1)
        self._sites: MissionSites | None = None  # the terrain's start cells and goal map, at the first draw
        self._sensing = None  # the episode's Oracle or MastSensor (offroadbench.navigation.sensor)
        self._world: TrialWorld | None = open_world(hm, settings.vehicle, self.terrain.sim_for(settings.sim),
                                                    soil_map=self.terrain.soil_map_for(settings.sim))
        spec = self._world.spec
        self.vehicle = spec
        self.sim = self._world.sim
        """The physics the world runs (the terrain's gravity and soil filled in)."""
        self.envelope = vehicle_envelope(self._world)
        limits = planner.perception.limits if planner is not None and planner.perception is not None else "measured"
        self._plan_envelope = sheet_envelope(self.envelope, spec) if limits == "sheet" else self.envelope
        """The limits the planner plans with: the trial runner's (drive_mission) for this PlannerChoice."""
        self.dt_s = 1.0 / config.control_rate_hz
        self._fill_m = hm.z_min_m - settings.rules.fall_depth_m

        high = np.array([spec.max_speed_m_s, spec.max_yaw_rate_rad_s], dtype=np.float32)
        self.action_space = spaces.Box(-high, high, dtype=np.float32)
        n = config.patch_cells
        self.observation_space = spaces.Dict({
            "state": spaces.Box(-np.inf, np.inf, shape=(len(STATE_FIELDS),), dtype=np.float32),
            "height_patch": spaces.Box(-np.inf, np.inf, shape=(n, n), dtype=np.float32),
            "known": spaces.Box(0.0, 1.0, shape=(n, n), dtype=np.float32),
        })
        self.mission: Mission | None = None
        self.path_xy: np.ndarray | None = None
        self._loop: TrialLoop | None = None
        self._view = None  # the rgb_array view of the episode (built at the first render)
        self._shade = None  # the terrain's hillshade, for every episode's view
        self._track: dict[str, list[float]] = {}
        self._end_reason: str | None = None
        self._ended = False

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Sample a mission with the env's generator (or take ``options["mission"]``, a Mission, to
        replay one the trial runner drove) and spawn the vehicle at its start, settled."""
        if options is not None and not isinstance(options, Mapping):
            raise InputError(f"reset options must be a dict (or None), got {type(options).__name__}")
        unknown = sorted(map(str, set(options or {}) - {"mission"}))
        if unknown:
            raise InputError(f"reset options: unknown key(s) {', '.join(unknown)}; allowed: mission")
        super().reset(seed=seed)
        world = self._require_world()
        given = (options or {}).get("mission")
        if given is not None and not isinstance(given, Mission):
            raise InputError(f"reset options['mission'] must be an offroadbench.navigation.missions.Mission, got {type(given).__name__}")
        if given is None and self._sites is None:  # once per terrain, as a study's (prepare_terrain)
            self._sites = mission_sites(self.hm, self.closed_classes, self._mission_cfg)
        self.mission = given or sample_missions(self.hm, self.closed_classes, self._mission_cfg, self.np_random,
                                                self._sites)[0]
        m = self.mission
        self.path_xy = None
        if self.planner is not None:
            problem = PlanningProblem(hm=self.hm, classes=self.closed_classes, start_xy=m.start_xy_m,
                                      goal_xy=m.goal_xy_m, border_m=self.cfg.border_m, vehicle=self._plan_envelope)
            self.path_xy = plan_within_limits(self.planner, problem)
        self._goal = np.asarray(m.goal_xy_m, dtype=float)
        s = self.settings
        # an agent drives: the trial's nominal length is the mission's (as for a policy in the runner)
        self._loop = loop = TrialLoop(world, m, s, length_m=m.length_m)
        loop.record(self._progress)  # the start; a rule firing here ends the first step
        self._sensing = make_sensing(self.hm, self.perception, m)
        self._ended = False
        state = self._read_state()
        self._dist = state["dist"]
        self._vz = state["lin"][2]
        self._t = loop.t_s
        self._state = state
        self._view, self._end_reason, self._track = None, None, {}
        self._record(state, 0.0)
        return self._observation(state), self._info(state, "")

    def step(self, action):
        self._require_world()
        if self.mission is None:
            raise RuntimeError("call reset() before step()")
        loop = self._loop
        if self._ended:
            raise RuntimeError("the episode has ended (terminated or truncated); call reset() before step()")
        try:
            a = np.asarray(action, dtype=float).reshape(2)
        except (TypeError, ValueError):
            raise InputError(f"action {action!r}: expected (v, omega), two finite numbers") from None
        if not np.all(np.isfinite(a)):
            raise InputError(f"action {a.tolist()}: not finite; expected (v, omega), two finite numbers "
                             "(the step was not taken)")
        v, w = clamp_action((float(a[0]), float(a[1])), self.vehicle)
        loop.command(v, w)
        if not loop.ended:  # a trial ended at reset (e.g. spawned tipped) ends this step, no physics
            loop.step_to_next_control(self._progress) or loop.record(self._progress)
        state = self._read_state()
        self._state = state

        cfg = self.cfg
        dt = loop.t_s - self._t
        a_z = (state["lin"][2] - self._vz) / dt if dt > 0.0 else 0.0
        p, q = state["rates"][0], state["rates"][1]
        reward = cfg.progress_weight * (self._dist - state["dist"])
        reward -= dt * (cfg.accel_weight * a_z * a_z + cfg.rate_weight * (p * p + q * q))
        self._dist = state["dist"]
        self._vz = state["lin"][2]
        self._t = loop.t_s

        reason = loop.reason
        truncated = reason == "timeout"
        terminated = reason is not None and not truncated
        if reason == "":
            reward += cfg.success_bonus
        elif terminated:
            reward -= cfg.failure_penalty
        self._record(state, v)
        if terminated or truncated:
            self._end_reason = reason
        self._ended = terminated or truncated
        return self._observation(state), float(reward), terminated, truncated, self._info(state, reason or "")

    def trial_record(self) -> TrialRecord:
        """The episode as the trial runner records a trial: its row (TrialResult, once the episode has
        ended), its telemetry, and the planned path (the start-goal line without a planner)."""
        if self._loop is None:
            raise RuntimeError("call reset() before trial_record()")
        m = self.mission
        path = self.path_xy if self.path_xy is not None else np.array([m.start_xy_m, m.goal_xy_m], dtype=float)
        return TrialRecord(self._loop.result(), self._loop.telemetry(), np.asarray(path, dtype=float))

    def close(self) -> None:
        if self._world is not None:
            self._world.close()
            self._world = None
        super().close()

    # ------------------------------------------------------------------ helpers
    def _require_world(self) -> TrialWorld:
        if self._world is None:
            raise RuntimeError("the environment is closed")
        return self._world

    def _progress(self, pos) -> float:
        """A telemetry row's progress: the mission length less the distance left (as for a policy)."""
        return self.mission.length_m - math.hypot(self._goal[0] - pos[0], self._goal[1] - pos[1])

    def _read_state(self) -> dict:
        world = self._require_world()
        pos, quat, lin, ang, roll, pitch, yaw, rates = self._loop.state
        v_body = body_velocity(world, quat, lin)
        dist = math.hypot(self._goal[0] - pos[0], self._goal[1] - pos[1])
        belief = self._sensing.update(pos, yaw)  # once per control tick, as the trial runner does
        return {"pos": pos, "lin": lin, "roll": roll, "pitch": pitch, "yaw": yaw, "rates": rates,
                "v_body": v_body, "dist": dist, "belief": belief}

    def _observation(self, s: dict) -> dict[str, np.ndarray]:
        bx, by, byaw = s["belief"]
        sensing = self._sensing
        return finite_observation(observation(
            self.hm, self.settings.observation, self._goal, (bx, by, s["pos"][2]), s["roll"], s["pitch"], byaw,
            s["rates"], s["v_body"], self._fill_m, None if sensing.name == "oracle" else sensing.z))

    def _info(self, s: dict, reason: str) -> dict[str, Any]:
        return {
            "failure_reason": reason,
            "success": reason == "" and s["dist"] <= self.rules.goal_tolerance_m,
            "distance_to_goal_m": s["dist"],
            "t_s": self._loop.t_s,
            "mission": self.mission,
            "path_xy": None if self.path_xy is None else self.path_xy.copy(),
            "pose": {"x_m": float(s["pos"][0]), "y_m": float(s["pos"][1]), "z_m": float(s["pos"][2]),
                     "roll_rad": float(s["roll"]), "pitch_rad": float(s["pitch"]), "yaw_rad": float(s["yaw"])},
            "believed_pose": dict(zip(("x_m", "y_m", "yaw_rad"), map(float, s["belief"]), strict=True)),
        }

    def _record(self, s: dict, cmd_v: float) -> None:
        """One sample of the episode's track (the telemetry columns the rgb_array view draws)."""
        if self.render_mode != "rgb_array":
            return
        values = {"t_s": self._loop.t_s, "x_m": s["pos"][0], "y_m": s["pos"][1], "z_m": s["pos"][2],
                  "yaw_rad": s["yaw"], "roll_rad": s["roll"], "pitch_rad": s["pitch"], "vx_m_s": s["lin"][0],
                  "vy_m_s": s["lin"][1], "cmd_v_m_s": cmd_v}
        for k, v in values.items():
            self._track.setdefault(k, []).append(float(v))

    def render(self) -> np.ndarray | None:
        """The replay view of the episode so far (``render_mode="rgb_array"``; see the module
        docstring), else None."""
        if self.render_mode != "rgb_array":
            return None
        if self.mission is None:
            raise RuntimeError("call reset() before render()")
        from offroadbench.plots.animate import TrialView
        from offroadbench.plots.terrain import hillshade

        if self._view is None:
            m = self.mission
            path = self.path_xy if self.path_xy is not None else np.array([m.start_xy_m, m.goal_xy_m])
            if self._shade is None:
                self._shade = hillshade(self.hm)
            self._view = TrialView(self.hm, self.closed_classes, path, shade=self._shade,
                                   footprint_m=(self.envelope.length_m, self.envelope.width_m),
                                   t_max_s=self._loop.timeout_s,
                                   title=f"planner {self.planner.name}" if self.planner else "agent")
        self._view.draw({k: np.asarray(v) for k, v in self._track.items()}, failure_reason=self._end_reason)
        return self._view.to_rgb()


def _perception(given: PerceptionConfig | str | None) -> PerceptionConfig | None:
    """The env's sensing: None for the oracle, else a PerceptionConfig naming the ``mast`` sensor
    (``"mast"`` takes its defaults)."""
    if given is None or isinstance(given, PerceptionConfig):
        return given if given is not None and given.sensor != "oracle" else None
    if isinstance(given, str):
        return _perception(PerceptionConfig(sensor=given))
    raise InputError(f"TraverseEnv perception: expected 'oracle', 'mast' or a PerceptionConfig, got {given!r}")
