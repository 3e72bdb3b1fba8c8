"""A versioned task suite: categories of tasks in tiers, each category one study of the pipeline.

A suite file (``suites/<name>.toml``, shipped as ``offroadbench.data.suites``) holds::

    [suite]
    name = "offroadbench-v1"        # the version: every score card carries it
    vehicle = "husky"               # every category's [vehicle] name
    sensor = "oracle"               # every category's [planner] sensor
    nominal_speed_m_s = 1.0         # [controller] cruise_speed_m_s; nominal time = distance / this
    time_clip_factors = [1.0, 3.0]  # the score's clip of the actual time, in nominal times
    tasks_sha256 = "..."            # pinned hash of the task tables (see tasks_sha256)

    [tiers.quick]                   # one table per tier
    description = "..."

    [[categories]]                  # one study per category
    name = "multifractal"
    [categories.study]              # a study TOML without [study] name and planner
    [categories.tiers.quick]        # tables laid over it for that tier

A run chooses only the planner, so score cards of one suite and tier are on the same tasks. The
task tables are hashed (:func:`tasks_sha256`) and the hash is pinned in the file: an edited task
is refused at load until the suite is renamed (a new version) and its hash re-pinned.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from offroadbench.config import check_range, load_toml
from offroadbench.errors import InputError

__all__ = [
    "CategoryConfig",
    "SuiteConfig",
    "TierConfig",
    "category_study",
    "load_suite",
    "suite_from_dict",
    "tasks_sha256",
]

#: study tables the suite itself sets in every category (a category may not set them)
SUITE_OWNED = {"vehicle": ("name",), "planner": ("name", "sensor"), "controller": ("cruise_speed_m_s",),
               "study": ("name",)}
_SUITE_KEYS = ("name", "description", "vehicle", "sensor", "nominal_speed_m_s", "time_clip_factors",
               "tasks_sha256")
_CATEGORY_KEYS = ("name", "description", "study", "tiers")


def _unknown(keys, allowed, where: str) -> None:
    from offroadbench.registry import unknown_name

    for key in keys:
        if key not in allowed:
            raise unknown_name(f"key in {where}", key, allowed)


@dataclass(frozen=True, kw_only=True)
class TierConfig:
    """One tier of a suite (``quick``: minutes on a laptop; ``full``: for a paper)."""

    name: str
    """Tier name, e.g. ``quick``."""
    description: str = ""
    """What the tier's maps and counts are, in words."""


@dataclass(frozen=True, kw_only=True)
class CategoryConfig:
    """One category of tasks: a study TOML (less its name and planner) and its per-tier overlays."""

    name: str
    """Category name, e.g. ``multifractal``; names its run directory."""
    description: str = ""
    """What the terrains are, with their sources."""
    study: Mapping[str, Any] = field(default_factory=dict)
    """The study tables shared by every tier (``study``, ``grid``, ``recipe_overrides``, ``sim``, ...)."""
    tiers: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    """{tier name: study tables laid over :attr:`study`} (counts, map size, mission length)."""


@dataclass(frozen=True, kw_only=True)
class SuiteConfig:
    """A versioned task suite: what every category's study fixes, and how a task is scored."""

    name: str
    """The suite's name and version, e.g. ``offroadbench-v1``; in every score card."""
    description: str = ""
    """The suite in one line."""
    vehicle: str = "husky"
    """Vehicle of every task (``[vehicle] name``)."""
    sensor: str = "oracle"
    """What planners see (``[planner] sensor``: ``oracle`` or ``mast``)."""
    nominal_speed_m_s: float = 1.0
    """Cruise speed of every task, m/s (``[controller] cruise_speed_m_s``); a task's nominal time is its
    start-goal distance over this (the ``timeout`` rule's nominal time, offroadbench.navigation.rules)."""
    time_clip_factors: tuple[float, float] = (1.0, 3.0)
    """(low, high) clip of the actual time in nominal times, in the BARN score
    ``success x nominal / clip(actual, low x nominal, high x nominal)`` (offroadbench.suite.score)."""
    tasks_sha256: str = ""
    """The pinned :func:`tasks_sha256` of the categories; a mismatch is refused at load."""
    tiers: tuple[TierConfig, ...] = ()
    """The tiers, in file order."""
    categories: tuple[CategoryConfig, ...] = ()
    """The categories, in file order."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip() or "/" in self.name:
            raise InputError(f"suite.name = {self.name!r}; must be a non-empty name without '/'")
        check_range(self, "nominal_speed_m_s", self.nominal_speed_m_s, lo=0, lo_open=True)
        lo, hi = self.time_clip_factors
        if not (0 < lo <= hi):
            raise InputError(f"suite.time_clip_factors = {list(self.time_clip_factors)}; needs 0 < low <= high")
        if not self.tiers or not self.categories:
            raise InputError(f"suite {self.name}: needs at least one [tiers.NAME] table and one [[categories]]")
        tier_names = [t.name for t in self.tiers]
        names = [c.name for c in self.categories]
        if len(set(names)) != len(names):
            raise InputError(f"suite {self.name}: category names repeat: {names}")
        for cat in self.categories:
            missing = [t for t in tier_names if t not in cat.tiers]
            extra = [t for t in cat.tiers if t not in tier_names]
            if missing or extra:
                raise InputError(f"suite {self.name}, category {cat.name}: tiers {missing or extra} "
                                 f"{'missing' if missing else 'not declared in [tiers]'}; tiers: {tier_names}")

    @property
    def tier_names(self) -> tuple[str, ...]:
        return tuple(t.name for t in self.tiers)

    def tier(self, name: str) -> TierConfig:
        """The tier called ``name``; an unknown name is an InputError with the closest names."""
        from offroadbench.registry import unknown_name

        for t in self.tiers:
            if t.name == name:
                return t
        raise unknown_name(f"tier of {self.name}", name, self.tier_names)


def tasks_sha256(categories: Mapping[str, Any] | list, vehicle: str, sensor: str, nominal_speed_m_s: float,
                 time_clip_factors) -> str:
    """SHA-256 of what defines the tasks and their scores: the category tables (without their
    descriptions), the vehicle, sensor, nominal speed and clip factors, as canonical JSON."""
    cats = [{k: v for k, v in c.items() if k != "description"} for c in categories]
    payload = {"categories": cats, "vehicle": vehicle, "sensor": sensor,
               "nominal_speed_m_s": float(nominal_speed_m_s), "time_clip_factors": [float(x) for x in time_clip_factors]}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def suite_from_dict(data: Mapping[str, Any], where: str = "suite", *, check_hash: bool = True) -> SuiteConfig:
    """A :class:`SuiteConfig` from a suite TOML dict; unknown keys and a changed task table are refused."""
    _unknown(data, ("suite", "tiers", "categories"), where)
    head = dict(data.get("suite", {}))
    _unknown(head, _SUITE_KEYS, f"{where} [suite]")
    cats_raw = list(data.get("categories", []))
    for i, cat in enumerate(cats_raw):
        _unknown(cat, _CATEGORY_KEYS, f"{where} [[categories]] {i + 1}")
        _check_owned(cat, where)
    tiers = tuple(TierConfig(name=n, **_tier_table(t, f"{where} [tiers.{n}]")) for n, t in data.get("tiers", {}).items())
    clip = tuple(float(x) for x in head.get("time_clip_factors", (1.0, 3.0)))
    if len(clip) != 2:
        raise InputError(f"{where}: suite.time_clip_factors must be [low, high], got {head['time_clip_factors']!r}")
    suite = SuiteConfig(
        name=head.get("name", ""), description=head.get("description", ""), vehicle=head.get("vehicle", "husky"),
        sensor=head.get("sensor", "oracle"), nominal_speed_m_s=head.get("nominal_speed_m_s", 1.0),
        time_clip_factors=clip, tasks_sha256=head.get("tasks_sha256", ""), tiers=tiers,
        categories=tuple(CategoryConfig(name=c.get("name", ""), description=c.get("description", ""),
                                        study=c.get("study", {}), tiers=c.get("tiers", {})) for c in cats_raw))
    actual = tasks_sha256(cats_raw, suite.vehicle, suite.sensor, suite.nominal_speed_m_s, suite.time_clip_factors)
    if check_hash and actual != suite.tasks_sha256:
        raise InputError(f"{where}: the tasks of suite {suite.name} changed (tasks_sha256 {actual}, pinned "
                         f"{suite.tasks_sha256 or 'none'}): changing the tasks needs a new suite version; rename "
                         "the suite and pin the new hash")
    return suite


def _tier_table(table: Mapping[str, Any], where: str) -> dict[str, Any]:
    _unknown(table, ("description",), where)
    return dict(table)


def _check_owned(cat: Mapping[str, Any], where: str) -> None:
    """A category may not set what the suite fixes (vehicle, planner, sensor, cruise speed, study name)."""
    layers = [("", cat.get("study", {}))] + [(f" tier {t}", v) for t, v in cat.get("tiers", {}).items()]
    for label, tables in layers:
        for table, keys in SUITE_OWNED.items():
            for key in keys:
                if key in tables.get(table, {}) or f"{table}.{key}" in tables.get("grid", {}):
                    raise InputError(f"{where}, category {cat.get('name')!r}{label}: [{table}] {key} is set by the "
                                     "suite for every category; remove it")


def load_suite(ref: str | Path, *, check_hash: bool = True) -> tuple[SuiteConfig, Path]:
    """A suite by name (``offroadbench-v1``: ``suites/<name>.toml`` on the search path and shipped)
    or by path to a suite TOML; returns it and its file."""
    from offroadbench import resources

    text = str(ref)
    if text.endswith(".toml") or "/" in text:
        path = Path(text)
    else:
        files = resources.suite_files()
        if text not in files:
            from offroadbench.registry import unknown_name

            raise unknown_name("suite", text, files, extra="(or give a path to a suite .toml)")
        path = files[text]
    return suite_from_dict(load_toml(path), where=str(path), check_hash=check_hash), path


def _merge(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``over`` laid on it, table by table (a table's keys merged, other values replaced)."""
    out = {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in base.items()}
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), Mapping) else v
    return out


def category_study(suite: SuiteConfig, category: CategoryConfig, tier: str, planner: str) -> dict[str, Any]:
    """The study TOML dict of one category in one tier, driven by ``planner``: the category's tables,
    the tier's laid over them, then what the suite fixes (study name, vehicle, planner, sensor, speed)."""
    suite.tier(tier)
    data = _merge(category.study, category.tiers[tier])
    fixed = {
        "study": {"name": f"{suite.name}-{tier}-{category.name}",
                  "description": f"{suite.name} {tier} tier, {category.name}: {category.description}"},
        "vehicle": {"name": suite.vehicle},
        "planner": {"name": planner, "sensor": suite.sensor},
        "controller": {"cruise_speed_m_s": suite.nominal_speed_m_s},
    }
    return _merge(data, fixed)
