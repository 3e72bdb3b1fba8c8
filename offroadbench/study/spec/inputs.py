"""What a study's trials depend on, resolved, so a resume never mixes two configurations.

The study id (:func:`offroadbench.study.spec.config.study_id`) hashes the study TOML's tables and the
cells' recipes. A resumed run also needs to know that what those names *point at* is unchanged:
a soil TOML or a ``vehicle.toml`` found on ``OFFROADBENCH_PATH`` may be edited between a killed
run and its resume, a planner plug-in upgraded, the engine replaced. :func:`trial_inputs` resolves
every input of a trial into plain JSON data, by component:

* ``design``: root seed, terrains and missions per cell, pairing, telemetry kept, and each cell's
  grid values and seed key (which trials exist and their seeds);
* ``recipes``: each cell's resolved recipe (the terrain), and ``recipe_files`` the SHA-256 of the
  files its layers read (a ``crater_file``, a DEM ``path``);
* ``settings``: each cell's settings after defaults are filled in (``[sim]``, ``[controller]``,
  ``[rules]``, ``[missions]``, ``[roughness]``, the observation): a default written out changes
  nothing here;
* ``vehicle``: the resolved vehicle table and the SHA-256 of its model file (URDF);
* ``soil``: the resolved parameters of the soil a ``terramechanics`` trial drives on (the study's
  ``[sim] soil``, else the terrain's, else the default soil);
* ``planner``: the planner or policy, its config, and the package and version it comes from;
* ``engine``: the physics engine and its package version.

The store keeps this (``meta.trial_inputs``); a resume compares it with what the same study
resolves to now (:func:`changed_inputs`): a difference is refused with one line naming it, while
a change of the study TOML that leaves every component equal (a description, a comment, a
``[reference]`` table, a default written out) is cosmetic, accepted and recorded.
"""

from __future__ import annotations

import functools
import hashlib
import json
from pathlib import Path
from typing import Any, Mapping, Sequence

from offroadbench.config import to_dict

__all__ = ["COSMETIC_STUDY_KEYS", "changed_inputs", "changed_study_keys", "trial_inputs"]

#: keys of the study's own table whose change cannot change a trial
COSMETIC_STUDY_KEYS = ("name", "description", "reference")


def _sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
    except OSError as exc:
        return f"unreadable ({exc.strerror})"
    return h.hexdigest()


@functools.lru_cache(maxsize=None)
def _distribution(module: str | None) -> str:
    """``package version`` of the installed distribution holding ``module``; built-in entries
    (offroadbench's own) say ``offroadbench (built in)``: their code is the package's, whose
    version a resume already reports."""
    from importlib.metadata import PackageNotFoundError, packages_distributions, version

    top = (module or "").split(".")[0]
    if not top:
        return "unknown"
    if top == "offroadbench":
        return "offroadbench (built in)"
    names = packages_distributions().get(top) or [top]
    for name in names:
        try:
            return f"{name} {version(name)}"
        except PackageNotFoundError:
            continue
    return f"{top} (no installed distribution)"


def _planner(choice: Any) -> dict[str, Any]:
    from offroadbench.navigation.drivers import PLANNERS, POLICIES

    registry = POLICIES if choice.kind == "policy" else PLANNERS
    module = None
    try:
        spec = registry.get(choice.name)
        fn = getattr(spec, "plan", None) or getattr(spec, "make", None)
        module = getattr(fn, "__module__", None)
    except Exception:  # noqa: BLE001 - an unknown name was refused when the study was loaded
        pass
    return {"name": choice.name, "kind": choice.kind, "config": to_dict(choice), "package": _distribution(module)}


def _engine(name: str) -> dict[str, Any]:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return {"name": name, "package": f"{name} {version(name)}"}
    except PackageNotFoundError:
        pass
    from offroadbench.sim.engine import ENGINES

    try:
        entry = ENGINES.get(name)
        module = getattr(entry, "module", None) or getattr(entry, "__module__", None)
    except Exception:  # noqa: BLE001
        module = None
    return {"name": name, "package": _distribution(module)}


def _soil(sim: Any, recipe_soil: str | None) -> dict[str, Any] | None:
    if sim.tyre_model != "terramechanics":
        return None  # no soil enters such a trial
    from offroadbench.sim.tyre_laws.terramechanics import DEFAULT_SOIL, load_soil

    name = sim.soil or recipe_soil or DEFAULT_SOIL
    return to_dict(load_soil(name))


#: keys of a recipe layer that name a file the layer reads (offroadbench.terrain.recipe)
_FILE_KEYS = ("crater_file", "path")


def _recipe_files(recipe: Mapping[str, Any]) -> dict[str, str]:
    """{layer.key = path: SHA-256} of the files a recipe's layers read (relative paths from the
    working directory, as the recipe reads them)."""
    out = {}
    for lname, layer in (recipe.get("layers") or {}).items():
        if not isinstance(layer, dict):
            continue
        for key in _FILE_KEYS:
            value = layer.get(key)
            if isinstance(value, str):
                out[f"{lname}.{key} = {value}"] = _sha256(value)
    return out


def _distinct(values: Sequence[Any]) -> list[Any]:
    """The distinct values in first-seen order (a grid repeats most components in every cell)."""
    seen, out = set(), []
    for v in values:
        key = json.dumps(v, sort_keys=True, default=repr)
        if key not in seen:
            seen.add(key)
            out.append(v)
    return out


def trial_inputs(study: Any, plans: Sequence[Any]) -> dict[str, Any]:
    """Every input of the study's trials, resolved, by component (module docstring); JSON data.

    Component values that repeat across cells are kept once (``recipes`` and ``settings`` stay per
    cell, in cell order)."""
    design = {"root_seed": study.root_seed, "terrains_per_cell": study.terrains_per_cell,
              "missions_per_terrain": study.missions_per_terrain, "paired_terrains": study.paired_terrains,
              "telemetry": study.telemetry, "cells": [[dict(p.values), p.key] for p in plans]}
    recipes, settings, vehicles, soils, planners, engines = [], [], [], [], [], []
    sha = functools.lru_cache(maxsize=None)(_sha256)  # a grid of 10,000 cells reads each file once
    engine = functools.lru_cache(maxsize=None)(_engine)
    for p in plans:
        ts = p.trial_settings
        recipes.append(dict(p.recipe_data))
        plain = to_dict(ts)
        vehicle = plain.pop("vehicle")
        plain.pop("planner")
        settings.append(plain)
        vehicle["urdf"] = Path(ts.vehicle.urdf).name
        vehicle["urdf_sha256"] = sha(ts.vehicle.urdf)
        vehicles.append(vehicle)
        soils.append(_soil(ts.sim, (p.recipe_data.get("soil") or {}).get("name")
                           if isinstance(p.recipe_data.get("soil"), dict) else None))
        planners.append(_planner(ts.planner))
        engines.append(engine(ts.sim.engine))
    files = _distinct([_recipe_files(r) for r in recipes])
    out = {"design": design, "recipes": recipes, "recipe_files": files, "settings": settings,
           "vehicle": _distinct(vehicles), "soil": _distinct(soils), "planner": _distinct(planners),
           "engine": _distinct(engines)}
    return json.loads(json.dumps(out, default=repr))  # as the store will hold it (tuples as lists, ...)


def _flat(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for k, v in value.items():
            out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        out = {}
        for i, v in enumerate(value):
            out.update(_flat(v, f"{prefix}[{i}]"))
        return out
    return {prefix: value}


def _short(value: Any) -> str:
    text = json.dumps(value, sort_keys=True, default=repr) if not isinstance(value, str) else value
    return text if len(text) <= 40 else text[:37] + "..."


def _first_differences(old: Any, new: Any, limit: int = 3) -> list[str]:
    a, b = _flat(old), _flat(new)
    keys = [k for k in list(a) + [k for k in b if k not in a] if a.get(k, "<absent>") != b.get(k, "<absent>")]
    out = [f"{k or 'value'} {_short(a.get(k, '<absent>'))} -> {_short(b.get(k, '<absent>'))}" for k in keys[:limit]]
    if len(keys) > limit:
        out.append(f"and {len(keys) - limit} more")
    return out


_WHAT = {"design": "the study design", "recipes": "the terrain recipe", "recipe_files": "a file the recipe reads", "settings": "the trial settings",
         "vehicle": "the vehicle (its table or model file)", "soil": "the soil parameters",
         "planner": "the planner or policy (or its package version)", "engine": "the physics engine or its version"}


def changed_inputs(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """One phrase per component that differs between two :func:`trial_inputs`, naming the first
    fields that changed, e.g. ``the vehicle (its table or model file): [0].wheel_torque_limit_nm 28.0 -> 12.0``."""
    out = []
    for comp in new:
        if comp in old and old[comp] != new[comp]:
            out.append(f"{_WHAT.get(comp, comp)}: {', '.join(_first_differences(old[comp], new[comp]))}")
    return out


def changed_study_keys(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """The dotted keys of the study config (``to_dict(StudyConfig)``) that differ."""
    a, b = _flat(dict(old)), _flat(dict(new))
    return sorted(k for k in set(a) | set(b) if a.get(k, "<absent>") != b.get(k, "<absent>"))
