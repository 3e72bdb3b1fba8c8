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
* ``vehicle``: the resolved vehicle table and the SHA-256 of its model file (URDF): of its bytes
  (``urdf_sha256``) and of its content (``urdf_content_sha256``: the canonical XML, C14N 2.0
  without comments or whitespace between elements, so that a comment or a re-indentation of the
  model is no change);
* ``soil``: the resolved parameters of the soil a ``terramechanics`` trial drives on (the study's
  ``[sim] soil``, else the terrain's, else the default soil);
* ``planner``: the planner or policy, its config, and the package and version it comes from, and
  for a plug-in (an entry outside offroadbench) ``code_sha256``: a hash of its entry point's
  module file and, where cheap (at most :data:`CODE_MAX_FILES` files and :data:`CODE_MAX_BYTES`),
  of every ``.py`` file of its top-level package, so that code changed without a version bump is
  named on resume;
* ``engine``: the physics engine and its package version (with ``code_sha256`` as above for an
  engine plug-in).

The store keeps this (``meta.trial_inputs``); a resume compares it with what the same study
resolves to now (:func:`changed_inputs`): a difference is refused with one line naming it, while
a change of the study TOML that leaves every component equal (a description, a comment, a
``[reference]`` table, a default written out) is cosmetic, accepted and recorded. What cannot
change a trial is left out of the comparison: a soil's ``description``, and the URDF's bytes where
both records hold its content hash (a comment in it). What an older store did not record (the
content hash, a plug-in's code hash) is not compared either: such a store is resumed as before.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import importlib
import json
import sys
from pathlib import Path
from typing import Any, Mapping, Sequence

from offroadbench.config import to_dict

__all__ = ["COSMETIC_STUDY_KEYS", "changed_inputs", "changed_study_keys", "driver_files", "trial_inputs",
           "vehicle_changed", "vehicle_entry"]

#: keys of the study's own table whose change cannot change a trial
COSMETIC_STUDY_KEYS = ("name", "description", "reference")

#: a plug-in's package is hashed whole (``code_sha256``) up to this many ``.py`` files ...
CODE_MAX_FILES = 500
#: ... and this many bytes of them; a larger package is represented by its entry point's module alone
CODE_MAX_BYTES = 20_000_000


def _sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
    except OSError as exc:
        return f"unreadable ({exc.strerror})"
    return h.hexdigest()


def _urdf_content_sha256(path: str | Path) -> str:
    """SHA-256 of a URDF's content: its canonical XML (C14N 2.0) without comments and without the
    whitespace between elements; of its bytes where it is not XML."""
    import xml.etree.ElementTree as ET

    try:
        text = ET.canonicalize(from_file=str(path), with_comments=False, strip_text=True)
    except (ET.ParseError, OSError, ValueError):
        return _sha256(path)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@functools.lru_cache(maxsize=None)
def _code_sha256(module: str | None) -> str | None:
    """SHA-256 of a plug-in's code: its entry point's module file, then (where cheap: at most
    CODE_MAX_FILES files of CODE_MAX_BYTES in all) every ``.py`` file of its top-level package,
    each with its path relative to the package; None for offroadbench's own entries (their code is
    the package's) and where no file can be found (a module built into the interpreter)."""
    top = (module or "").split(".")[0]
    if not top or top == "offroadbench":
        return None
    try:
        mod = sys.modules.get(module) or importlib.import_module(module)
    except Exception:  # noqa: BLE001 - a plug-in that does not import was refused when the study was loaded
        return None
    file = inspect.getfile(mod) if hasattr(mod, "__spec__") and getattr(mod.__spec__, "has_location", False) else None
    if not file:
        return None
    h = hashlib.sha256()
    h.update(f"{module}\0".encode())
    h.update(Path(file).read_bytes())
    package = sys.modules.get(top)
    roots = [Path(p) for p in getattr(package, "__path__", [])]
    files = sorted({q for r in roots for q in r.rglob("*.py") if "__pycache__" not in q.parts})
    if files and len(files) <= CODE_MAX_FILES and sum(q.stat().st_size for q in files) <= CODE_MAX_BYTES:
        for q in files:
            root = next(r for r in roots if q.is_relative_to(r))
            h.update(f"\0{q.relative_to(root).as_posix()}\0".encode())
            h.update(q.read_bytes())
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
    out = {"name": choice.name, "kind": choice.kind, "config": to_dict(choice), "package": _distribution(module)}
    code = _code_sha256(module)
    if code is not None:
        out["code_sha256"] = code
    return out


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
    out = {"name": name, "package": _distribution(module)}
    code = _code_sha256(module)
    if code is not None:
        out["code_sha256"] = code
    return out


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


def vehicle_entry(ts: Any, sha: Any = _sha256, content: Any = _urdf_content_sha256) -> dict[str, Any]:
    """The ``vehicle`` component of one cell's trial settings ``ts``: its table, its URDF's file name
    and the SHA-256 of the URDF's bytes and of its content."""
    vehicle = to_dict(ts.vehicle)
    vehicle["urdf"] = Path(ts.vehicle.urdf).name
    vehicle["urdf_sha256"] = sha(ts.vehicle.urdf)
    vehicle["urdf_content_sha256"] = content(ts.vehicle.urdf)
    return json.loads(json.dumps(vehicle, default=repr))


def vehicle_changed(stored: Mapping[str, Any], ts: Any) -> str | None:
    """Why the vehicle of trial settings ``ts`` is not one the run recorded (``stored``: the run's
    :func:`trial_inputs`), e.g. its URDF replaced since the run; None when it is, or when the run
    recorded no trial inputs. Compared as a resume compares them (cosmetic keys left out)."""
    if "vehicle" not in stored:
        return None
    now = vehicle_entry(ts)
    recorded = _entries(stored["vehicle"])
    if any(a == b for a, b in (_comparable("vehicle", r, now) for r in recorded)):
        return None
    diffs = [", ".join(_first_differences(*_comparable("vehicle", r, now))) for r in recorded]
    return f"{_WHAT['vehicle']} changed since the run: {min(diffs, key=len)}"


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
    content = functools.lru_cache(maxsize=None)(_urdf_content_sha256)
    for p in plans:
        ts = p.trial_settings
        recipes.append(dict(p.recipe_data))
        plain = to_dict(ts)
        plain.pop("vehicle")
        plain.pop("planner")
        settings.append(plain)
        vehicles.append(vehicle_entry(ts, sha, content))
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
         "planner": "the planner or policy (its package version or code)",
         "engine": "the physics engine or its version"}

#: per component, keys (dotted: inside nested tables) whose change cannot change a trial, so a
#: store made before such a key existed resumes: ``sim.mujoco_warp.cuda_graph`` runs the same
#: kernels on the same arrays in the same order, captured or not
_COSMETIC_INPUT_KEYS = {"soil": ("description",), "settings": ("sim.mujoco_warp.cuda_graph",)}


def _without(value: Any, keys: Sequence[str]) -> Any:
    """A component's value (a dict or a list of dicts) without ``keys`` in its dicts; a dotted key
    ``a.b`` is ``b`` inside the table ``a``."""
    if isinstance(value, list):
        return [_without(v, keys) if isinstance(v, dict) else v for v in value]
    if not isinstance(value, dict):
        return value
    out = dict(value)
    for key in keys:
        head, _, rest = key.partition(".")
        if head not in out:
            continue
        if not rest:
            del out[head]
        elif isinstance(out[head], dict):
            out[head] = _without(out[head], (rest,))
    return out


def _entries(value: Any) -> list:
    return [v for v in (value if isinstance(value, list) else [value]) if isinstance(v, dict)]


def _comparable(comp: str, old: Any, new: Any) -> tuple[Any, Any]:
    """(old, new) of one component as compared on resume (module docstring): cosmetic keys left
    out, the URDF compared by content where both records hold it, keys an older store lacks left out."""
    drop = list(_COSMETIC_INPUT_KEYS.get(comp, ()))
    if comp == "vehicle":
        both = all("urdf_content_sha256" in v for v in _entries(old) + _entries(new))
        drop.append("urdf_sha256" if both else "urdf_content_sha256")
    elif comp in ("planner", "engine") and not any("code_sha256" in v for v in _entries(old)):
        drop.append("code_sha256")
    return _without(old, drop), _without(new, drop)


def changed_inputs(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """One phrase per component that differs between two :func:`trial_inputs`, naming the first
    fields that changed, e.g. ``the vehicle (its table or model file): [0].wheel_torque_limit_nm 28.0 -> 12.0``.
    What cannot change a trial is not compared (:func:`_comparable`)."""
    out = []
    for comp in new:
        if comp not in old:
            continue
        a, b = _comparable(comp, old[comp], new[comp])
        if a != b:
            out.append(f"{_WHAT.get(comp, comp)}: {', '.join(_first_differences(a, b))}")
    return out


def changed_study_keys(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """The dotted keys of the study config (``to_dict(StudyConfig)``) that differ."""
    a, b = _flat(dict(old)), _flat(dict(new))
    return sorted(k for k in set(a) | set(b) if a.get(k, "<absent>") != b.get(k, "<absent>"))


def driver_files(planner: Any) -> dict[str, dict[str, Any]]:
    """The files a planner's or policy's config names (a trained model: the sb3 example's ``model``),
    as the study found them when it was created: ``{"planner.FIELD": {"path", "bytes", "sha256"}}``.
    Stored with the run (``cells[i]["files"]``) and shown in the report's header, so a report says
    which model drove, not only its (possibly relative, since overwritten) name."""
    cfg = getattr(planner, "config", None)
    out: dict[str, dict[str, Any]] = {}
    if not dataclasses.is_dataclass(cfg):
        return out
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        if not isinstance(value, str) or not Path(value).suffix or not Path(value).is_file():
            continue
        path = Path(value).resolve()
        digest = hashlib.sha256()
        with path.open("rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
        out[f"planner.{f.name}"] = {"path": str(path), "bytes": path.stat().st_size, "sha256": digest.hexdigest()}
    return out
