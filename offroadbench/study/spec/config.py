"""Study configs: one TOML file describes a whole Monte Carlo study (Majhor & Bos 2023, Sec. 2.4).

File layout (every table but ``[study]`` is optional)::

    [study]
    name = "majhor2023"
    recipe = "paper-d2.45"          # terrain preset name, or a recipe .toml (relative to this file)
    root_seed = 2023
    terrains_per_cell = 20
    missions_per_terrain = 20
    paired_terrains = true          # see offroadbench.seeding
    telemetry = "failed"            # keep telemetry of: none | failed | all trials (Parquet)
    missions_from = { "recipe.layers.base.wm.band_limited" = false }   # optional: draw every cell's
                                    # missions on that cell's terrain (same seed): arms share missions

    [grid]                          # axes of the parameter grid: dotted key = [values]
    "recipe.layers.base.D_high" = [2.3, 2.45, 2.6]

    [recipe_overrides]              # fixed dotted-key changes of the recipe (e.g. small maps)
    "grid.rows" = 201

    [planner]     # name = a planner or policy (offroadbench.navigation), plus its config's fields
    [roughness]   # offroadbench.analysis.roughness.RoughnessConfig fields
    [missions]    # offroadbench.navigation.missions.MissionConfig fields
    [vehicle]     # vehicle name and fields (offroadbench.sim)
    [controller]  # offroadbench.sim.ControllerConfig fields
    [sim]         # offroadbench.sim.SimConfig fields
    [rules]       # offroadbench.sim.FailureRules fields
    [reference]   # published numbers to set beside ours in the report (see offroadbench.study.report.markdown)
    [analysis]    # the confirmatory analysis plan, fixed before the run (offroadbench.study.stats.plan)

Grid keys. ``recipe`` varies the recipe itself (values: preset names or paths);
``recipe.<dotted key>`` a key of the recipe TOML; ``<section>.<field>`` a field of one of the
settings tables above (``vehicle.name`` picks the vehicle, ``planner.name`` the planner or policy;
their table columns are ``vehicle`` and ``planner``). Every grid cell (the cartesian
product of the axes, first axis slowest) is resolved and validated when the study is loaded,
so a bad value is refused before anything runs, with the key named.

Each resolved cell is a :class:`CellPlan`: plain data (recipe dict, settings tables) that a
worker anywhere can turn back into configs without reading files. The cells and their resolution
(:func:`plan_cells`) are offroadbench.study.spec.cells, imported here too.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from offroadbench.config import check_int, config_id, did_you_mean, load_toml, to_dict
from offroadbench.errors import InputError
from offroadbench.sim.trial.pipeline import SETTINGS_TABLES
from offroadbench.study.spec.cells import CellPlan, build_section, plan_cells

__all__ = [
    "SECTIONS",
    "StudyConfig",
    "GridAxis",
    "CellPlan",
    "study_from_dict",
    "load_study",
    "build_section",
    "blind_root_seed",
]


#: settings tables of a study -> fn(table, where) that builds and validates their config (the
#: parts of :class:`offroadbench.sim.trial.pipeline.TrialSettings`)
SECTIONS: Mapping[str, Callable[[dict, str], Any]] = SETTINGS_TABLES

#: what ``[study] telemetry`` may keep
TELEMETRY_CHOICES = ("none", "failed", "all")

_STUDY_KEYS = (
    "name",
    "description",
    "recipe",
    "root_seed",
    "terrains_per_cell",
    "missions_per_terrain",
    "paired_terrains",
    "telemetry",
    "missions_from",
)
_TOP_KEYS = ("study", "grid", "recipe_overrides", "reference", "analysis", *SECTIONS)

#: columns of the trial table that a grid axis may not be named after
#: grid keys whose column is named after their table (``planner.name`` -> ``planner``)
_NAME_KEYS = ("planner.name", "vehicle.name")

RESERVED_COLUMNS = frozenset(
    {"cell", "terrain", "mission", "terrain_seed", "mission_seed", "success", "failure_reason"}
)


@dataclass(frozen=True)
class GridAxis:
    """One axis of the parameter grid: a dotted key and the values it takes."""

    key: str
    values: tuple[Any, ...]

    @property
    def target(self) -> str:
        """``recipe`` or the settings table the key points into."""
        return self.key.split(".", 1)[0]


@dataclass(frozen=True, kw_only=True)
class StudyConfig:
    """A whole study: recipe, parameter grid, counts, settings tables and root seed."""

    name: str
    """Study name: names the default run directory ``runs/<name>``."""
    recipe: str
    """Terrain recipe: a preset name (``terrains/*.toml``) or a path to a recipe TOML."""
    root_seed: int
    """Root of every seed of the study (``SeedSequence(root_seed)``). ``"blind"`` in a study TOML with an
    ``[analysis]`` plan: the seed is the hash of the plan and the design (:func:`blind_root_seed`), so no
    terrain of the study exists before its plan is fixed."""
    terrains_per_cell: int = 20
    """Terrains generated per grid cell (paper: 20 per D)."""
    missions_per_terrain: int = 20
    """Missions (trials) per terrain (paper: 20)."""
    description: str = ""
    """Free text shown in the report."""
    paired_terrains: bool = True
    """Terrain j of every cell comes from the same seed (common random numbers); see offroadbench.seeding."""
    telemetry: str = "failed"
    """Trials whose telemetry (20 Hz, Parquet, with the planned path) the run directory keeps:
    ``none``, ``failed`` (for ``study replay`` forensics) or ``all``."""
    grid: tuple[GridAxis, ...] = ()
    """Axes of the parameter grid, in file order (first axis varies slowest)."""
    recipe_overrides: Mapping[str, Any] = field(default_factory=dict)
    """Dotted recipe keys set for every cell (before the grid values)."""
    settings: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    """Raw settings tables by section name (roughness, missions, vehicle, controller, sim, rules)."""
    reference: Mapping[str, Any] = field(default_factory=dict)
    """Published numbers shown beside this study's in the report (free-form, see report)."""
    missions_from: Mapping[str, Any] = field(default_factory=dict)
    """Grid key -> value: every cell draws its missions on the terrain of the cell with these grid
    values (same terrain seed), e.g. ``{"recipe.layers.base.wm.band_limited" = false}`` gives a
    band-limited arm exactly the aliased arm's starts and goals, so the arms are paired mission by
    mission. Empty: each cell draws on its own terrain."""
    analysis: Any = None
    """The confirmatory analysis plan (:class:`offroadbench.study.stats.plan.AnalysisPlan`, the
    ``[analysis]`` table), or None."""
    blind_seed: bool = False
    """Whether ``root_seed`` came from the plan (``root_seed = "blind"``), not from a hand; set by the loader."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip() or "/" in self.name:
            raise InputError(f"study.name = {self.name!r}; must be a non-empty name without '/'")
        if not isinstance(self.recipe, str) or not self.recipe:
            raise InputError(f"study.recipe = {self.recipe!r}; must be a preset name or a .toml path")
        check_int(self, "root_seed", self.root_seed, lo=0)
        check_int(self, "terrains_per_cell", self.terrains_per_cell, lo=1)
        check_int(self, "missions_per_terrain", self.missions_per_terrain, lo=1)
        if not isinstance(self.paired_terrains, bool):
            raise InputError(f"study.paired_terrains = {self.paired_terrains!r}; must be true or false")
        if self.telemetry not in TELEMETRY_CHOICES:
            raise InputError(f"study.telemetry = {self.telemetry!r}; allowed: {', '.join(TELEMETRY_CHOICES)}")
        unknown = sorted(set(self.settings) - set(SECTIONS))
        if unknown:
            raise InputError(f"study settings: unknown table(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
        keys = [a.key for a in self.grid]
        for axis in self.grid:
            _check_axis(axis)
            if keys.count(axis.key) > 1:
                raise InputError(f"grid: key {axis.key!r} appears twice")
        if not isinstance(self.missions_from, Mapping):
            raise InputError(f"study.missions_from = {self.missions_from!r}; must be a table of grid key = value")
        axes = {a.key: a.values for a in self.grid}
        for key, value in self.missions_from.items():
            if key not in axes or not key.startswith("recipe"):
                raise InputError(f"study.missions_from: {key!r} must be a recipe grid axis; recipe axes: "
                                 f"{', '.join(k for k in axes if k.startswith('recipe')) or 'none'}")
            if value not in axes[key]:
                raise InputError(f"study.missions_from: {key} = {value!r} is not a value of the axis {list(axes[key])}")
        if self.missions_from and not self.paired_terrains:
            raise InputError("study.missions_from needs paired terrains (paired_terrains = true)")
        if not isinstance(self.blind_seed, bool):
            raise InputError(f"study.blind_seed = {self.blind_seed!r}; must be true or false")
        if self.blind_seed and self.analysis is None:
            raise InputError('study.root_seed = "blind" needs an [analysis] plan: the seed is the plan\'s hash')
        if self.analysis is not None:
            from offroadbench.study.stats.plan import AnalysisPlan, check_plan

            if not isinstance(self.analysis, AnalysisPlan):
                raise InputError(f"study.analysis must be an AnalysisPlan, got {type(self.analysis).__name__}")
            check_plan(self.analysis, self.grid, self.paired_terrains)

    # ------------------------------------------------------------------ derived
    @property
    def n_cells(self) -> int:
        n = 1
        for axis in self.grid:
            n *= len(axis.values)
        return n

    @property
    def n_trials(self) -> int:
        return self.n_cells * self.terrains_per_cell * self.missions_per_terrain

    def column_names(self) -> dict[str, str]:
        """Table column of each grid key: its last part, or the full key if that is ambiguous."""
        lasts = [a.key.split(".", 1)[0] if a.key in _NAME_KEYS else a.key.rsplit(".", 1)[-1] for a in self.grid]
        out = {}
        for axis, last in zip(self.grid, lasts, strict=True):
            ok = lasts.count(last) == 1 and last not in RESERVED_COLUMNS
            out[axis.key] = last if ok else axis.key
        return out

    def cell_values(self) -> list[dict[str, Any]]:
        """Grid values of every cell ({grid key: value}), first axis slowest."""
        keys = [a.key for a in self.grid]
        return [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*(a.values for a in self.grid))]


def _check_axis(axis: GridAxis) -> None:
    if not isinstance(axis.values, tuple) or not axis.values:
        raise InputError(f"grid.{axis.key}: needs a non-empty list of values, got {axis.values!r}")
    target = axis.target
    if target not in ("recipe", *SECTIONS):
        raise InputError(
            f"grid key {axis.key!r}: must start with recipe or a settings table ({', '.join(SECTIONS)})"
        )
    if target != "recipe" and "." not in axis.key:
        raise InputError(f"grid key {axis.key!r}: name a field, e.g. {target}.FIELD")
    if target in SECTIONS and axis.key.count(".") > 1:
        raise InputError(f"grid key {axis.key!r}: settings fields are one level deep ({target}.FIELD)")


def study_id(study: StudyConfig, plans: list[CellPlan]) -> str:
    """Stable id of a study: its config plus every cell's resolved recipe (a changed preset changes it).

    The analysis plan is not part of it (a changed plan is refused on its own, with its own message:
    offroadbench.study.stats.plan.check_unchanged), nor is an empty ``missions_from`` (ids of studies
    made before it existed stay the same)."""
    data = to_dict(study)
    data.pop("analysis", None)
    if not data.get("missions_from"):
        data.pop("missions_from", None)
    if not data.get("blind_seed"):  # ids of studies with a hand-chosen seed stay what they were
        data.pop("blind_seed", None)
    return config_id({"study": data, "recipes": [dict(p.recipe_data) for p in plans]})


# ---------------------------------------------------------------------------- loading
def _flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


#: keys of a study TOML left out of a blind seed's hash: words, not design
_BLIND_COSMETIC = ("description",)


def blind_root_seed(data: Mapping[str, Any]) -> int:
    """The root seed of a study TOML (as a dict) with ``root_seed = "blind"``: the first 63 bits of the
    SHA-256 of its ``[analysis]`` table and its design (every other table, and ``[study]`` without its
    root seed and description), as canonical JSON. Any change of the plan or the design gives other
    terrains; a terrain of the study cannot exist before the plan that it is drawn from."""
    import hashlib
    import json

    head = {k: v for k, v in dict(data.get("study", {})).items() if k not in ("root_seed", *_BLIND_COSMETIC)}
    design = {**{k: v for k, v in data.items() if k not in ("study", "analysis", "reference")}, "study": head}
    text = json.dumps({"analysis": data.get("analysis"), "design": design}, sort_keys=True, default=str)
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "big") >> 1


def study_from_dict(data: Mapping[str, Any], where: str = "study") -> StudyConfig:
    """Build a StudyConfig from a TOML dict, refusing unknown tables and keys."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a TOML table")
    unknown = sorted(set(data) - set(_TOP_KEYS))
    if unknown:
        raise InputError(f"{where}: unknown table(s) {', '.join(unknown)}; known: {', '.join(_TOP_KEYS)}"
                         f"{did_you_mean(unknown, _TOP_KEYS)}")
    if "study" not in data or not isinstance(data["study"], dict):
        raise InputError(f"{where}: missing [study] table (keys: {', '.join(_STUDY_KEYS)})")
    head = dict(data["study"])
    bad = sorted(set(head) - set(_STUDY_KEYS))
    if bad:
        raise InputError(f"{where}: [study]: unknown key(s) {', '.join(bad)}; known keys: {', '.join(_STUDY_KEYS)}"
                         f"{did_you_mean(bad, _STUDY_KEYS)}")
    missing = [k for k in ("name", "recipe", "root_seed") if k not in head]
    if missing:
        raise InputError(f"{where}: [study] is missing {', '.join(missing)} (required: name, recipe, root_seed; "
                         "e.g. root_seed = 0; `offroadbench config study` prints a [study] table to start from)")
    if head.get("root_seed") == "blind":
        if not data.get("analysis"):
            raise InputError(f'{where}: [study] root_seed = "blind" needs an [analysis] plan (the seed is the hash '
                             "of the plan and the design)")
        head["root_seed"] = blind_root_seed(data)
        head["blind_seed"] = True
    for name in ("grid", "recipe_overrides", "reference"):
        if not isinstance(data.get(name, {}), dict):
            raise InputError(f"{where}: [{name}] must be a table")
    grid = []
    for key, values in _flatten(data.get("grid", {})).items():
        if not isinstance(values, list):
            raise InputError(f"{where}: grid.{key} must be a list of values, got {values!r}")
        grid.append(GridAxis(key=key, values=tuple(values)))
    overrides = _flatten(data.get("recipe_overrides", {}))
    settings = {}
    for name in SECTIONS:
        if name in data:
            if not isinstance(data[name], dict):
                raise InputError(f"{where}: [{name}] must be a table")
            settings[name] = dict(data[name])
    reference = data.get("reference", {})
    from offroadbench.study.stats.plan import plan_from_dict

    try:
        analysis = plan_from_dict(data.get("analysis"), where=where)
        return StudyConfig(
            **head, grid=tuple(grid), recipe_overrides=overrides, settings=settings, reference=dict(reference),
            analysis=analysis,
        )
    except TypeError as exc:  # a missing required key
        raise InputError(f"{where}: [study]: {exc}") from None
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def load_study(path: str | Path, check_sections: bool = True) -> tuple[StudyConfig, list[CellPlan]]:
    """Read and fully validate a study TOML: the config and its resolved cells."""
    p = Path(path)
    study = study_from_dict(load_toml(p), where=str(p))
    try:
        plans = plan_cells(study, base_dir=p.parent, check_sections=check_sections)
    except InputError as exc:
        raise InputError(f"{p}: {exc}") from None
    return study, plans

