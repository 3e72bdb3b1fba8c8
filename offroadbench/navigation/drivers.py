"""What drives a trial: what a study's ``[planner]`` table names, a planner or a policy.

Two registries share the ``[planner] name`` namespace (a planner of the same name wins):

* :data:`PLANNERS`: :class:`PlannerSpec` entries, ``plan(problem, cfg) -> (N, 2) waypoints`` that
  pure pursuit follows (offroadbench.sim.trial.controller); built in: offroadbench.navigation.planners;
* :data:`POLICIES`: :class:`PolicySpec` entries, ``make(cfg, context) -> Policy``, a closed loop
  ``act(observation) -> (v, omega)``; built in: offroadbench.navigation.policies.

Each entry declares what it needs from the trial beyond the mission (:data:`NEEDS`): the closed
class map (``classes``), the vehicle's measured envelope (``vehicle``) and, for a policy, the
believed pose and perceived elevation map in every observation (``map``: ``observation["pose"]``,
x, y, yaw in map metres and radians; ``observation["elevation_m"]``, heights on the terrain's grid,
NaN where unseen; the truth for the ``oracle`` arm, offroadbench.navigation.sensor otherwise). The trial runner and the
study's workers read ``PlannerChoice.needs`` instead of testing names: the built-in ``straight``
needs neither, so no class map is computed and no envelope measured for it. An entry that says
nothing needs ``classes`` and ``vehicle`` (what every plug-in got before entries could say).

Installed packages add entries through the entry-point groups ``offroadbench.planners`` and
``offroadbench.policies``. The built-in entries are registered by importing
offroadbench.navigation.planners and offroadbench.navigation.policies, which import this module;
the registries' ``loader`` imports them by name the first time a registry is read, so this module
imports neither (no import cycle).
"""

from __future__ import annotations

import dataclasses
import importlib
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Protocol

import numpy as np

from offroadbench.config import from_dict
from offroadbench.errors import InputError, PluginError
from offroadbench.navigation.observation import ObservationConfig
from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope
from offroadbench.registry import Registry

__all__ = [
    "NEEDS",
    "NoConfig",
    "PlannerSpec",
    "PolicySpec",
    "Policy",
    "PolicyContext",
    "PLANNERS",
    "POLICIES",
    "register_planner",
    "register_policy",
    "PlannerChoice",
    "planner_from_table",
    "entry_config",
    "plan",
    "make_policy",
]

#: what a driver may need from the trial beyond the mission: the closed roughness-class map the
#: missions were drawn on, the vehicle's envelope (measured from the loaded vehicle), and (policies)
#: the believed pose and perceived elevation map in each observation
NEEDS = frozenset({"classes", "vehicle", "map"})
#: what an entry that says nothing needs
DEFAULT_NEEDS = frozenset({"classes", "vehicle"})


def _check_needs(kind: str, needs: frozenset[str]) -> frozenset[str]:
    needs = frozenset(needs)
    if not needs <= NEEDS:
        raise ValueError(f"{kind} needs {sorted(needs - NEEDS)}: unknown; allowed: {sorted(NEEDS)}")
    return needs


@dataclass(frozen=True, kw_only=True)
class NoConfig:
    """A planner or policy without settings."""


@dataclass(frozen=True)
class PlannerSpec:
    """A planner's registry entry: the plan function, its config class, a one-line summary and
    what it needs (a subset of :data:`NEEDS`)."""

    plan: Callable[[PlanningProblem, Any], np.ndarray]
    config: type = NoConfig
    summary: str = ""
    needs: frozenset[str] = DEFAULT_NEEDS

    def __post_init__(self) -> None:
        object.__setattr__(self, "needs", _check_needs("planner", self.needs))


class Policy(Protocol):
    """A closed-loop driver: ``reset`` once per mission, then ``act`` at the control rate."""

    def reset(self, problem: PlanningProblem) -> None: ...

    def act(self, observation: Mapping[str, np.ndarray]) -> tuple[float, float]: ...


@dataclass(frozen=True, kw_only=True)
class PolicyContext:
    """What a policy is built with: the observation layout, the vehicle and the control rate."""

    observation: ObservationConfig = ObservationConfig()
    vehicle: VehicleEnvelope | None = VehicleEnvelope()
    """The vehicle's envelope; None when the policy's entry does not declare it needs it."""
    track_m: float = 0.571
    """Distance between the left and right wheels, m."""
    control_rate_hz: int = 20
    """How often ``act`` is called per simulated second."""


@dataclass(frozen=True)
class PolicySpec:
    """A policy's registry entry: ``make(cfg, context) -> Policy``, its config class, a one-line
    summary and what it needs (a subset of :data:`NEEDS`)."""

    make: Callable[[Any, PolicyContext], Policy]
    config: type = NoConfig
    summary: str = ""
    needs: frozenset[str] = DEFAULT_NEEDS

    def __post_init__(self) -> None:
        object.__setattr__(self, "needs", _check_needs("policy", self.needs))


def _as_planner_spec(name: str, obj: object) -> PlannerSpec:
    """An entry point's object as a PlannerSpec: a PlannerSpec, or a plan function (whose
    ``config`` attribute, if any, is its config class)."""
    if isinstance(obj, PlannerSpec):
        return obj
    if callable(obj):
        doc = (getattr(obj, "__doc__", None) or "").strip().splitlines()
        return PlannerSpec(obj, getattr(obj, "config", NoConfig), doc[0] if doc else "")
    raise TypeError(f"planner {name!r}: expected a PlannerSpec or a function, got {type(obj).__name__}")


def _as_policy_spec(name: str, obj: object) -> PolicySpec:
    if isinstance(obj, PolicySpec):
        return obj
    raise TypeError(f"policy {name!r}: expected a PolicySpec, got {type(obj).__name__}")


#: name -> PlannerSpec; installed packages add entries through the ``offroadbench.planners`` group
PLANNERS: Registry[PlannerSpec] = Registry(
    "planner", entry_point_group="offroadbench.planners", adapt=_as_planner_spec,
    loader=lambda: importlib.import_module("offroadbench.navigation.planners"),  # registers the built-ins
)

#: name -> PolicySpec; installed packages add entries through the ``offroadbench.policies`` group
POLICIES: Registry[PolicySpec] = Registry(
    "policy", entry_point_group="offroadbench.policies", adapt=_as_policy_spec,
    loader=lambda: importlib.import_module("offroadbench.navigation.policies"),  # registers the built-ins
)


def register_planner(name: str, *, config: type = NoConfig, summary: str = "", needs: frozenset[str] = DEFAULT_NEEDS):
    """Decorator: register ``fn(problem, cfg) -> waypoints`` as planner ``name`` with its config
    class and what it needs from the trial (:data:`NEEDS`)."""

    def deco(fn):
        doc = (fn.__doc__ or "").strip().splitlines()
        PLANNERS.add(name, PlannerSpec(fn, config, summary or (doc[0] if doc else ""), needs))
        return fn

    return deco


def register_policy(name: str, *, config: type = NoConfig, summary: str = "", needs: frozenset[str] = DEFAULT_NEEDS):
    """Decorator: register a class (or factory) ``make(cfg, context)`` as policy ``name``. Policy and
    planner names share the ``[planner] name`` namespace; a planner of the same name wins."""

    def deco(make):
        doc = (make.__doc__ or "").strip().splitlines()
        POLICIES.add(name, PolicySpec(make, config, summary or (doc[0] if doc else ""), needs))
        return make

    return deco


@dataclass(frozen=True)
class PlannerChoice:
    """What drives a trial: a planner (or a policy) by name, with its frozen config. A study's
    ``[planner]`` table."""

    name: str = "straight"
    config: Any = NoConfig()
    kind: str = "planner"
    """``planner`` (pure pursuit follows its path) or ``policy`` (closed loop on observations)."""
    perception: Any = None
    """What the planner's map gets wrong (offroadbench.navigation.perception.PerceptionConfig; None:
    it plans on the true terrain)."""

    @property
    def params(self) -> dict[str, Any]:
        """The config's fields as a plain dict (for tables and replays)."""
        return dataclasses.asdict(self.config) if dataclasses.is_dataclass(self.config) else {}

    @property
    def spec(self) -> PlannerSpec | PolicySpec:
        """The registry entry (of :data:`PLANNERS` or :data:`POLICIES`, by ``kind``)."""
        return (POLICIES if self.kind == "policy" else PLANNERS).get(self.name)

    @property
    def needs(self) -> frozenset[str]:
        """What this driver needs from the trial beyond the mission (:data:`NEEDS`), as its entry declares."""
        return self.spec.needs


def planner_from_table(table: Mapping[str, Any], where: str = "[planner]") -> PlannerChoice:
    """A study's ``[planner]`` table: ``name`` (a planner or a policy; default ``straight``), the
    fields of that entry's config, and the map-error keys of
    offroadbench.navigation.perception.PerceptionConfig. Unknown names and fields are InputErrors."""
    from offroadbench.navigation.perception import split_perception

    perception, data = split_perception(dict(table), where)
    name = data.pop("name", "straight")
    if not isinstance(name, str):
        raise InputError(f"{where}: name must be a string, got {name!r}")
    if name in PLANNERS:
        spec, kind = PLANNERS.get(name), "planner"
    elif name in POLICIES:
        spec, kind = POLICIES.get(name), "policy"
    else:  # the did-you-mean error over both registries: --planner and [planner] name take either
        from offroadbench.registry import unknown_name

        raise unknown_name("planner or policy", name, [*PLANNERS.names(), *POLICIES.names()],
                           extra=f"(planners: {', '.join(PLANNERS.names())}; policies: {', '.join(POLICIES.names())})")
    try:
        cfg = from_dict(spec.config, data, where=f"{where} ({name})")
    except TypeError as exc:
        raise InputError(f"{where} ({name}): {exc}") from None
    # the default limits ("sheet") matter only to a driver that plans with the vehicle: for one that does not
    # (the straight line), the truth stays None, so its trials and settings are what they were before the default
    only_limits = perception.active and not dataclasses.replace(perception, limits="measured").active
    if only_limits and "limits" not in table and "vehicle" not in spec.needs:
        return PlannerChoice(name, cfg, kind, None)
    return PlannerChoice(name, cfg, kind, perception if perception.active else None)


def entry_config(kind: str, name: str, cfg: Any, expected: type) -> Any:
    """``cfg`` for the registered ``kind`` (planner or policy) ``name`` whose config class is
    ``expected``: the default ``NoConfig()`` of a bare ``PlannerChoice(name)`` becomes
    ``expected()``; a config of another class is an InputError."""
    if isinstance(cfg, expected):
        return cfg
    if type(cfg) is NoConfig:
        return expected()
    raise InputError(f"{kind} {name!r} takes config class {expected.__name__}, got {type(cfg).__name__}")


def plan(choice: PlannerChoice | str, problem: PlanningProblem) -> np.ndarray:
    """Waypoints (N, 2) from a planner, checked: finite, at least two, from exactly the start to
    exactly the goal, on the map. A plug-in that breaks the contract raises PluginError (a RuntimeError)."""
    if isinstance(choice, str):
        choice = PlannerChoice(choice)
    if choice.kind != "planner":
        raise InputError(f"{choice.name!r} is a policy, not a planner")
    spec = PLANNERS.get(choice.name)
    wp = np.asarray(spec.plan(problem, entry_config("planner", choice.name, choice.config, spec.config)), dtype=float)
    bad = None
    if wp.ndim != 2 or wp.shape[1] != 2 or len(wp) < 2 or not np.all(np.isfinite(wp)):
        bad = f"returned an array of shape {wp.shape}; expected (N >= 2, 2) finite waypoints"
    elif not (np.array_equal(wp[0], problem.start_xy) and np.array_equal(wp[-1], problem.goal_xy)):
        bad = f"runs from {wp[0].tolist()} to {wp[-1].tolist()}, not from the start {problem.start_xy} to the goal {problem.goal_xy}"
    elif not np.all((wp[1:-1] >= 0) & (wp[1:-1] <= [problem.hm.width_m, problem.hm.height_m])):
        bad = "leaves the map"  # between the mission's own start and goal (which a test may put off the map)
    if bad:
        raise PluginError(f"planner {choice.name!r} {bad}")
    return wp


def make_policy(name: str, cfg: Any, context: PolicyContext) -> Policy:
    """Build the registered policy ``name`` (``cfg`` as in :func:`entry_config`)."""
    spec = POLICIES.get(name)
    return spec.make(entry_config("policy", name, cfg, spec.config), context)
