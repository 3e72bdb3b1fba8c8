"""What a study held fixed: the first screen of its report.

A report must say what ran without the reader opening ``study.toml``: the vehicle, the planner or
policy and its settings, gravity, the physics rate, the tyre model, the failure rules and the
terrain recipe, each marked when it differs from the package default, and marked as a grid axis
where it varied. :func:`held_fixed` reads them from the run's stored metadata (the resolved
settings of each cell), :func:`report_title` names what a reader would otherwise mistake (a
non-default planner, another gravity).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import pandas as pd

from offroadbench.study.spec.inputs import driver_files  # noqa: F401  (re-exported: the report's header shows them)

__all__ = ["cell_engine", "held_fixed", "report_title", "settings_columns", "driver_files", "soil_conditions"]

#: (table, field, label) of the settings every report header lists
_SHOWN = (
    ("sim", "gravity_m_s2", "gravity (m/s^2)"),
    ("sim", "engine", "physics engine"),
    ("sim", "physics_rate_hz", "physics rate (Hz)"),
    ("sim", "tyre_model", "tyre model"),
    ("sim", "soil", "soil (terramechanics tyres)"),
    ("controller", "cruise_speed_m_s", "cruise speed (m/s)"),
    ("controller", "lookahead_m", "pure-pursuit lookahead (m)"),
    ("missions", "length_m", "mission length (m)"),
    ("missions", "border_m", "mission border (m)"),
)


def _sections(meta: dict[str, Any], cell: int = 0) -> dict[str, Any]:
    """The cell's settings by part, as its trials ran: read from the store (CellPlan.from_meta; a
    store made before they were kept rebuilds them from the tables there), the sim on the terrain."""
    from offroadbench.study.spec.config import SECTIONS, CellPlan

    plan = CellPlan.from_meta(meta, cell)
    try:
        settings = plan.trial_settings
        out = {name: getattr(settings, name) for name in SECTIONS}
    except Exception:  # noqa: BLE001  (a vehicle or plug-in of the run missing here: part by part)
        out = {name: _part_or_table(plan, name) for name in SECTIONS}
    out["sim"] = _on_terrain(out["sim"], plan.recipe_data)
    return out


def _part_or_table(plan: Any, name: str) -> Any:
    """One part of a cell's settings, or, where it does not build here, its raw table."""
    try:
        return plan.part(name)
    except Exception:  # noqa: BLE001
        return dict(plan.settings.get(name, {}))


def _on_terrain(sim: Any, recipe: Any) -> Any:
    """The sim settings with the terrain's gravity and soil where the study leaves them open (as a
    trial resolves them)."""
    if not hasattr(sim, "for_terrain"):
        return sim
    from offroadbench.bodies import terrain_gravity_and_soil

    return sim.for_terrain(*terrain_gravity_and_soil(recipe))


def soil_conditions(meta: dict[str, Any], cell: int) -> dict[str, Any]:
    """The soil and gravity a cell's trials ran with, and where each came from: ``study`` (the
    study's ``[sim]`` or grid sets it), ``terrain`` (the recipe's ``[soil]`` / ``[body]``) or
    ``default`` (offroadbench.sim.tyre_laws.terramechanics.DEFAULT_SOIL, Earth's gravity)."""
    from offroadbench.bodies import terrain_gravity_and_soil

    info = meta["cells"][cell]
    raw = info["settings"].get("sim", {})
    sim = _sections(meta, cell)["sim"]
    gravity, soil = terrain_gravity_and_soil(info.get("recipe"))

    def source(key: str, terrain_value: Any) -> str:
        return "study" if raw.get(key) is not None else "terrain" if terrain_value is not None else "default"

    table = (info.get("recipe") or {}).get("soil") or {}
    mapped = raw.get("soil") is None and bool(table.get("regions") or table.get("raster"))  # a soil map applies
    return {"soil": getattr(sim, "soil", None), "soil_source": source("soil", soil),
            "gravity_m_s2": getattr(sim, "gravity_m_s2", None), "gravity_source": source("gravity_m_s2", gravity),
            "soil_map": mapped}


def cell_engine(meta: dict[str, Any], cell: int) -> str | None:
    """The physics engine a cell's trials ran on (``[sim] engine``, a grid axis or fixed), None where
    the store's settings do not say."""
    sim = _sections(meta, cell)["sim"]
    return sim.get("engine") if isinstance(sim, dict) else getattr(sim, "engine", None)


@functools.lru_cache(maxsize=None)
def _default(name: str) -> Any:
    """The package default of a settings part (TrialSettings' field default; sim, controller,
    missions, rules), made once."""
    from offroadbench.sim.trial.pipeline import TrialSettings

    f = {f.name: f for f in dataclasses.fields(TrialSettings)}[name]
    cfg = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    return _on_terrain(cfg, None) if name == "sim" else cfg


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)):
        return ", ".join(map(_fmt, v))
    return str(v)


def stuck_window_text(rules: Any, secs: dict[str, Any]) -> str:
    """The stuck window as the trials applied it: ``30 s``, or, where the mission's timeout caps it
    (offroadbench.navigation.rules.stuck_window_s), ``15.3 s (30 s capped at 0.5 x the 30.6 s timeout)``."""
    from offroadbench.navigation.rules import stuck_window_s, trial_timeout_s

    missions, controller, vehicle = secs.get("missions"), secs.get("controller"), secs.get("vehicle")
    try:
        timeout = trial_timeout_s(rules, missions.length_m, controller.cruise_speed_m_s, vehicle.max_speed_m_s)
    except AttributeError:  # a table that did not build here: the configured window
        return f"{_fmt(rules.stuck_window_s)} s"
    window = stuck_window_s(rules, timeout)
    if window >= rules.stuck_window_s:
        return f"{_fmt(rules.stuck_window_s)} s"
    return (f"{window:.3g} s ({_fmt(rules.stuck_window_s)} s capped at {_fmt(rules.stuck_window_max_fraction)} x the "
            f"{timeout:.3g} s timeout of a {_fmt(missions.length_m)} m mission)")


#: the caveat beside soft-soil results in a gravity other than Earth's
SOFT_SOIL_CAVEAT = ("not validated in this gravity: the Wong-Reece model and the soil's parameters were measured in "
                    "1 g (on Earth soils or lunar simulants; the soil file gives its sources)")


def _body_note(meta: dict[str, Any], field: str, sim: Any, note: str) -> str:
    """The note of the gravity or soil row: the terrain's own body named as such (not "not the
    default"), and soft soil in a gravity other than Earth's given its caveat."""
    from offroadbench.bodies import terrain_gravity_and_soil

    set_in_study = field in meta["study"].get("settings", {}).get("sim", {})
    recipe = meta["cells"][0].get("recipe") if meta.get("cells") else None
    gravity, _ = terrain_gravity_and_soil(recipe)
    earth = _default("sim").gravity_m_s2
    if field == "gravity_m_s2":
        if not set_in_study and gravity is not None and gravity == sim.gravity_m_s2 and gravity != earth:
            body = recipe.get("body", {}).get("name", "its [body]")
            return f"the terrain's own: {body} (a recipe's [body]; Earth's is {_fmt(earth)})"
        return note
    if getattr(sim, "tyre_model", "") == "terramechanics" and sim.gravity_m_s2 != earth:
        return "; ".join(n for n in (note, SOFT_SOIL_CAVEAT) if n)
    return note


def held_fixed(meta: dict[str, Any]) -> pd.DataFrame:
    """One row per setting: ``setting``, ``value`` (of the first cell, or ``grid axis``) and
    ``note`` (``not the default (D)`` where it differs from the package default)."""
    study = meta["study"]
    axes = {a["key"] for a in study["grid"]}
    secs = _sections(meta)
    rows = []

    def add(setting: str, key: str | None, value: Any, default: Any = None) -> None:
        if key is not None and key in axes:
            rows.append({"setting": setting, "value": "grid axis", "note": f"varies: `{key}`"})
            return
        note = "" if default is None or value == default else f"not the default ({_fmt(default)})"
        rows.append({"setting": setting, "value": _fmt(value), "note": note})

    vehicle = secs["vehicle"]
    add("vehicle", "vehicle.name", getattr(vehicle, "name", vehicle.get("name", "husky") if isinstance(vehicle, dict) else vehicle),
        "husky")
    changed = sorted(k for k in study.get("settings", {}).get("vehicle", {}) if k != "name")
    if changed:
        rows.append({"setting": "vehicle figures changed", "value": ", ".join(changed), "note": "not the vehicle's own"})
    planner = secs["planner"]
    name = getattr(planner, "name", "straight")
    add(f"{getattr(planner, 'kind', 'planner')}", "planner.name", name, "straight")
    params = getattr(planner, "params", {})
    if params and "planner.name" not in axes:
        default = dataclasses.asdict(type(planner.config)()) if dataclasses.is_dataclass(planner.config) else {}
        diff = {k: v for k, v in params.items() if default.get(k) != v}
        rows.append({"setting": f"{name} settings", "value": ", ".join(f"{k} = {_fmt(v)}" for k, v in params.items()),
                     "note": ("changed: " + ", ".join(sorted(diff))) if diff else "defaults"})
    for table, field, label in _SHOWN:
        cfg = secs[table]
        if field == "soil" and getattr(cfg, "tyre_model", "") != "terramechanics":
            continue  # the soil acts only through the terramechanics tyres
        if dataclasses.is_dataclass(cfg) and hasattr(cfg, field):
            add(label, f"{table}.{field}", getattr(cfg, field), getattr(_default(table), field))
            if (table, field) in (("sim", "gravity_m_s2"), ("sim", "soil")) and f"{table}.{field}" not in axes:
                rows[-1]["note"] = _body_note(meta, field, cfg, rows[-1]["note"])
    rules = secs["rules"]
    if dataclasses.is_dataclass(rules):
        default = _default("rules")
        grid_rules = sorted(k for k in axes if k.startswith("rules."))
        value = (f"tipped > {_fmt(rules.tip_angle_deg)} deg; stuck < {_fmt(rules.stuck_distance_m)} m in "
                 f"{stuck_window_text(rules, secs)}; timeout {_fmt(rules.timeout_factor)} x nominal; goal within "
                 f"{_fmt(rules.goal_tolerance_m)} m")
        diff = [f.name for f in dataclasses.fields(rules) if getattr(rules, f.name) != getattr(default, f.name)]
        note = (f"varies: {', '.join(grid_rules)}; " if grid_rules else "") + (
            f"not the default: {', '.join(diff)}" if diff else "the paper's (Sec. 2.4)")
        rows.append({"setting": "failure rules", "value": value, "note": note})
    rows += files_rows(meta)
    overrides = study.get("recipe_overrides", {})
    recipe_axes = sorted(k for k in axes if k == "recipe" or k.startswith("recipe."))
    rows.append({"setting": "terrain recipe", "value": study["recipe"]
                 + (f" with {', '.join(f'{k} = {_fmt(v)}' for k, v in overrides.items())}" if overrides else ""),
                 "note": f"varies: {', '.join(recipe_axes)}" if recipe_axes else ""})
    machines = sorted({r.get("machine", "") for r in meta.get("runs", []) if r.get("machine")})
    versions = sorted({r.get("version", "") for r in meta.get("runs", []) if r.get("version")} | {meta.get("version", "")})
    rows.append({"setting": "platform", "value": "; ".join(machines) or "unknown", "note": ""})
    rows.append({"setting": "code version", "value": ", ".join(v for v in versions if v), "note": ""})
    return pd.DataFrame(rows, columns=["setting", "value", "note"])


def report_title(meta: dict[str, Any]) -> str:
    """``Study report: NAME``, plus a non-default planner and gravity held fixed (a planner
    benchmark must not read like a straight-line study)."""
    study = meta["study"]
    axes = {a["key"] for a in study["grid"]}
    secs = _sections(meta)
    extra = []
    planner = secs["planner"]
    if "planner.name" not in axes and getattr(planner, "name", "straight") != "straight":
        extra.append(f"{getattr(planner, 'kind', 'planner')} `{planner.name}`")
    sim = secs["sim"]
    if ("sim.gravity_m_s2" not in axes and dataclasses.is_dataclass(sim)
            and sim.gravity_m_s2 != _default("sim").gravity_m_s2):  # not Earth's (set, or the recipe's body)
        extra.append(f"gravity {sim.gravity_m_s2:g} m/s^2")
    vehicle = secs["vehicle"]
    if "vehicle.name" not in axes and getattr(vehicle, "name", "husky") != "husky":
        extra.append(f"vehicle `{vehicle.name}`")
    return f"Study report: {study['name']}" + (f" ({', '.join(extra)})" if extra else "")


def settings_columns(meta: dict[str, Any]) -> pd.DataFrame:
    """One row per cell: ``cell`` and the settings of the report header as the cell's trials ran
    (``vehicle.name``, ``planner.name``, ``sim.gravity_m_s2``, ``sim.engine``, ... , ``recipe``
    with its fixed overrides), so an exported trial row says what made it without the run's
    metadata. Grid axes are the table's own columns already and are left out here."""
    study = meta["study"]
    overrides = study.get("recipe_overrides", {})
    axes = {a["key"] for a in study["grid"]}
    rows = []
    for info in meta["cells"]:
        cell = int(info["index"])
        secs = _sections(meta, cell)
        row: dict[str, Any] = {"cell": cell}
        for table, field in (("vehicle", "name"), ("planner", "name"), *((t, f) for t, f, _ in _SHOWN)):
            cfg = secs[table]
            value = cfg.get(field) if isinstance(cfg, dict) else getattr(cfg, field, None)
            if field == "soil" and getattr(cfg, "tyre_model", "") != "terramechanics":
                continue
            if f"{table}.{field}" not in axes:
                row[f"{table}.{field}"] = value
        rules = secs["rules"]
        if dataclasses.is_dataclass(rules) and not any(k.startswith("rules.") for k in axes):
            row["rules"] = (f"tipped > {_fmt(rules.tip_angle_deg)} deg; stuck < {_fmt(rules.stuck_distance_m)} m in "
                            f"{stuck_window_text(rules, secs)}; timeout {_fmt(rules.timeout_factor)} x nominal")
        if "recipe" not in axes:
            row["recipe"] = study["recipe"] + (
                f" with {', '.join(f'{k} = {_fmt(v)}' for k, v in overrides.items())}" if overrides else "")
        rows.append(row)
    return pd.DataFrame(rows)


def files_rows(meta: dict[str, Any]) -> list[dict[str, str]]:
    """Header rows for the files the cells' drivers named (driver_files), one per distinct file."""
    seen: dict[tuple[str, str], list[int]] = {}
    for info in meta["cells"]:
        for key, f in (info.get("files") or {}).items():
            seen.setdefault((key, f"{f['path']} ({f['bytes']} bytes, sha256 {f['sha256'][:16]}...)"), []).append(
                int(info["index"]))
    n = len(meta["cells"])
    return [{"setting": f"{key} (file)", "value": text,
             "note": "" if len(cells) == n else f"cells {', '.join(map(str, cells))}"}
            for (key, text), cells in seen.items()]
