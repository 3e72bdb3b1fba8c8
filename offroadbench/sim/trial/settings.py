"""The settings of a trial, :class:`TrialSettings`: every setting except the terrain and seeds,
frozen and nested, built from a study cell's or a command's TOML tables
(:meth:`TrialSettings.from_tables`), and written out and read back whole
(:meth:`TrialSettings.to_dict` / :meth:`TrialSettings.from_dict`: a study store keeps them so).

Its own module, below both the pipeline (offroadbench.sim.trial.pipeline, which re-exports it) and
the trial runner (offroadbench.sim.trial.runner), which both take it whole.
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass, field
from typing import Any, Mapping

from offroadbench.analysis.roughness import RoughnessConfig
from offroadbench.config import from_dict, to_dict
from offroadbench.errors import InputError
from offroadbench.navigation.drivers import PlannerChoice, planner_from_table
from offroadbench.navigation.missions import MissionConfig
from offroadbench.navigation.observation import ObservationConfig
from offroadbench.sim.config import ControllerConfig, FailureRules, SimConfig
from offroadbench.sim.trial.vehicle import VehicleSpec, load_vehicle, vehicle_from_table

__all__ = ["TrialSettings", "SETTINGS_TABLES", "settings_part"]


def _builder(cls: type):
    def build(table: Mapping[str, Any], where: str):
        return from_dict(cls, dict(table), where=where)

    return build


#: TOML table name -> fn(table, where) building that part of :class:`TrialSettings`
SETTINGS_TABLES = {
    "roughness": _builder(RoughnessConfig),
    "missions": _builder(MissionConfig),
    "vehicle": vehicle_from_table,
    "controller": _builder(ControllerConfig),
    "sim": _builder(SimConfig),
    "rules": _builder(FailureRules),
    "planner": planner_from_table,
}


def _default_vehicle() -> VehicleSpec:
    return load_vehicle("husky")


@dataclass(frozen=True, kw_only=True)
class TrialSettings:
    """Everything that decides how a terrain's missions are driven, except the terrain and seeds."""

    vehicle: VehicleSpec = field(default_factory=_default_vehicle)
    """The vehicle (``[vehicle]``: a name and VehicleSpec fields; default the Husky)."""
    sim: SimConfig = SimConfig()
    """Physics settings (``[sim]``)."""
    controller: ControllerConfig = ControllerConfig()
    """Path tracking and speed profile (``[controller]``)."""
    rules: FailureRules = FailureRules()
    """When a trial ends and why (``[rules]``)."""
    missions: MissionConfig = MissionConfig()
    """How missions are drawn (``[missions]``); ``count`` is not used here (the caller lists the missions)."""
    roughness: RoughnessConfig = RoughnessConfig()
    """Roughness classes and closing of the class map (``[roughness]``)."""
    planner: PlannerChoice = PlannerChoice()
    """The planner or policy that drives (``[planner]``; default ``straight``, the paper's)."""
    observation: ObservationConfig = ObservationConfig()
    """What a policy observes (the Gymnasium env's observation)."""

    @classmethod
    def from_tables(cls, tables: Mapping[str, Mapping[str, Any]], where: str = "settings") -> "TrialSettings":
        """Settings from TOML tables by name (:data:`SETTINGS_TABLES`); a missing table takes its defaults.

        Unknown tables and keys are InputErrors naming them (``where`` prefixes the message).
        """
        unknown = sorted(set(tables) - set(SETTINGS_TABLES))
        if unknown:
            raise InputError(f"{where}: unknown table(s) {', '.join(unknown)}; known: {', '.join(SETTINGS_TABLES)}")
        built = {name: SETTINGS_TABLES[name](dict(tables.get(name, {})), f"{where} [{name}]")
                 for name in SETTINGS_TABLES}
        return cls(**built)

    def replace(self, **changes: Any) -> "TrialSettings":
        """A copy with some parts replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Every setting written out as JSON data (offroadbench.config.to_dict: nested configs as
        tables, tuples as lists; the vehicle with its resolved URDF path; the planner as ``name``,
        ``kind``, ``config`` and ``perception``). :meth:`from_dict` reads it back equal; a study
        store keeps it per cell (``meta.cells[i].trial_settings``)."""
        return to_dict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "settings") -> "TrialSettings":
        """The settings :meth:`to_dict` wrote (no defaults filled in, no vehicle file read); a
        part that does not build is an InputError naming it (``where`` prefixes the message)."""
        names = [f.name for f in dataclasses.fields(cls)]
        if not isinstance(data, Mapping) or set(data) != set(names):
            got = sorted(data) if isinstance(data, Mapping) else type(data).__name__
            raise InputError(f"{where}: stored settings must have the parts {', '.join(names)}; got {got}")
        return cls(**{name: settings_part(name, data[name], where) for name in names})


def settings_part(name: str, data: Mapping[str, Any], where: str = "settings") -> Any:
    """Part ``name`` of :class:`TrialSettings` from its :meth:`TrialSettings.to_dict` table (a
    planner or policy through its registry entry's config class)."""
    if not isinstance(data, Mapping):
        raise InputError(f"{where} [{name}]: expected a table, got {data!r:.60}")
    if name == "planner":
        from offroadbench.navigation.drivers import PLANNERS, POLICIES
        from offroadbench.navigation.perception import PerceptionConfig

        data = dict(data)
        unknown = sorted(set(data) - {"name", "kind", "config", "perception"})
        if unknown:
            raise InputError(f"{where} [planner]: unknown key(s) {', '.join(unknown)}")
        name, kind = data.get("name", "straight"), data.get("kind", "planner")
        entry = (POLICIES if kind == "policy" else PLANNERS).get(name)
        perception = data.get("perception")
        return PlannerChoice(name, from_dict(entry.config, dict(data.get("config") or {}), f"{where} [planner]"),
                             kind, None if perception is None else from_dict(PerceptionConfig, dict(perception),
                                                                              f"{where} [planner] perception"))
    cls = typing.get_type_hints(TrialSettings).get(name)
    if cls is None:
        raise InputError(f"{where}: unknown settings part {name!r}")
    data = dict(data)
    if name == "sim":
        data = stored_sim_as_it_ran(data)
    return from_dict(cls, data, f"{where} [{name}]")


def stored_sim_as_it_ran(data: Mapping[str, Any]) -> dict[str, Any]:
    """A stored ``[sim]`` table with the keys that later changed their default set as the run had
    them, so a stored trial replays (and a stored study resumes) as it ran: a ``[sim.mujoco]`` table
    stored before ``hfield_collision`` existed (issue 41) ran MuJoCo's own height-field collision,
    which ``"exact"`` reproduces to the bit (the default is now ``"closed_form"``)."""
    data = dict(data)
    mujoco = data.get("mujoco")
    if isinstance(mujoco, Mapping) and "hfield_collision" not in mujoco:
        data["mujoco"] = {**mujoco, "hfield_collision": "exact"}
    return data
