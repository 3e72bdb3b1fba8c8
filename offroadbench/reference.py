"""The settings reference: every key a study TOML accepts, and every column a study writes.

Everything here is read from the code, so the reference cannot drift from it:

* the settings tables are the config dataclasses behind ``offroadbench.study.spec.config.SECTIONS``
  (a table built by ``from_dict(SomeConfig, ...)`` is found automatically, so a new section or
  field appears in the reference by itself);
* a key's meaning (with its unit and the paper or source behind it) is the field's docstring,
  read from the source with :mod:`ast`; its allowed range is read from the ``check_range`` /
  ``check_int`` / ``check_choice`` calls of the config's ``__post_init__``;
* the trial columns are the fields of :class:`offroadbench.sim.trial.runner.TrialResult` with their
  docstrings, after the key columns of :func:`offroadbench.study.store.results.load`.

``offroadbench config --write-reference docs/reference.md`` rewrites the committed reference
(``tests/test_reference.py`` fails while it differs from :func:`render_reference`), and
``offroadbench config [SECTION]`` prints a table's defaults as TOML a study can start from.

Reading a config's source lives in :mod:`offroadbench.reference_fields`, the terrain recipe
sections in :mod:`offroadbench.reference_recipes`; this module gathers and renders.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import math
import re
from pathlib import Path
from typing import Any
from offroadbench.reference_fields import REQUIRED, FieldDoc, SectionDoc, first_line, qualname, field_docs, unit_of
from offroadbench.reference_recipes import FILE_KEYS, nested_sections, recipe_sections  # noqa: F401  (FILE_KEYS re-exported)

__all__ = [
    "REFERENCE_PATH",
    "FieldDoc",
    "SectionDoc",
    "recipe_sections",
    "field_docs",
    "render_reference",
    "render_section_toml",
    "section_names",
    "study_sections",
    "trial_columns",
    "unit_of",
]

#: where the reference lives in the repository
REFERENCE_PATH = Path("docs") / "reference.md"


# ---------------------------------------------------------------------------- the study's tables
def _builder_class(builder: Any) -> type | None:
    """The config class a ``SECTIONS`` builder fills (``_config_builder(cls)``'s closure)."""
    for cell in getattr(builder, "__closure__", None) or ():
        value = cell.cell_contents
        if isinstance(value, type) and dataclasses.is_dataclass(value):
            return value
    return None


def _study_section() -> SectionDoc:
    from offroadbench.study.spec.config import StudyConfig

    skip = ("grid", "recipe_overrides", "settings", "reference", "analysis", "blind_seed")  # blind_seed: set by root_seed = "blind"
    notes = (
        ("`[grid]`: axes of the parameter grid, `\"dotted.key\" = [values]`: `recipe` (preset names or paths), "
        "`recipe.<key of the recipe TOML>`, or `<table>.<key>` of any table below (`planner.name`, "
        "`vehicle.name`). Every cell is the cartesian product of the axes, first axis slowest."),
        ("`[recipe_overrides]`: fixed `\"dotted.key\" = value` changes of the recipe, for every cell "
        "(the keys of `offroadbench generate --set`)."),
        ("`[reference]`: published numbers the report sets beside the study's (free-form; "
        "`offroadbench.study.report.markdown`)."),
        ("`[analysis]`: the confirmatory analysis plan, fixed before the run (below, `Analysis plan`)."),
    )
    return SectionDoc("study", qualname(StudyConfig), first_line(StudyConfig), field_docs(StudyConfig, skip=skip),
                      notes)


def _vehicle_section() -> SectionDoc:
    from offroadbench.sim.trial.vehicle import VehicleSpec, list_vehicles, load_vehicle

    husky = load_vehicle("husky")
    name = FieldDoc("name", "str", "husky", "", f"a vehicle name ({', '.join(list_vehicles())}) or a vehicle.toml path",
                    "The vehicle; the other keys change single figures of it.")
    fields = (name, *field_docs(VehicleSpec, skip=("name", "urdf"), defaults=husky))
    notes = (("Defaults shown are the Husky's (`vehicles/husky/vehicle.toml`, every figure with its source "
             "beside it); another `name` brings that vehicle's own values."),)
    return SectionDoc("vehicle", qualname(VehicleSpec), first_line(VehicleSpec), fields, notes)


def _driver_entries() -> list[tuple[str, str, Any]]:
    """(kind, name, spec) of the built-in planners and policies (installed plug-ins left out, so the
    reference does not depend on what else is installed)."""
    from offroadbench.navigation.planners import PLANNERS
    from offroadbench.navigation.policies import POLICIES

    out = []
    for kind, reg in (("planner", PLANNERS), ("policy", POLICIES)):
        for name in reg.names():
            spec = reg.get(name)
            fn = getattr(spec, "plan", None) or getattr(spec, "make", None)
            if getattr(fn, "__module__", "").startswith("offroadbench."):
                out.append((kind, name, spec))
    return out


def _planner_sections() -> list[SectionDoc]:
    from offroadbench.navigation.perception import PerceptionConfig
    from offroadbench.navigation.planners import NoConfig, PlannerChoice

    entries = _driver_entries()
    names = ", ".join(f"`{n}`" for _, n, _ in entries)
    head = SectionDoc(
        "planner", qualname(PlannerChoice), first_line(PlannerChoice),
        (FieldDoc("name", "str", "straight", "", f"one of {names} (and installed plug-ins)",
                  "The planner (pure pursuit follows its path) or closed-loop policy that drives every trial; "
                  "the table's other keys are what it perceives (the keys after `name`, "
                  "offroadbench.navigation.perception.PerceptionConfig) and that entry's settings, below."),
         *field_docs(PerceptionConfig)),
        ("The keys after `name` apply to every planner and policy: the map-error keys, or `sensor = \"mast\"` "
         "(offroadbench.navigation.sensor); `sensor = \"oracle\"` with the map-error keys at 0 is the true "
         "map and pose.",),
    )
    out = [head]
    for kind, name, spec in entries:
        cfg = spec.config
        fields = () if cfg is NoConfig else field_docs(cfg)
        summary = f"{kind} `{name}`: {spec.summary}" if spec.summary else f"{kind} `{name}`"
        out.append(SectionDoc(f"planner.{name}", qualname(cfg), summary, fields,
                              ("No settings.",) if not fields else ()))
    return out


def study_sections() -> list[SectionDoc]:
    """Every table a study TOML accepts, in the order of the file: ``[study]``, then the settings
    tables of ``offroadbench.study.spec.config.SECTIONS`` (planners' settings as ``planner.NAME``)."""
    from offroadbench.study.spec.config import SECTIONS

    out = [_study_section()]
    for name, builder in SECTIONS.items():
        if name == "vehicle":
            out.append(_vehicle_section())
        elif name == "planner":
            out.extend(_planner_sections())
        else:
            cls = _builder_class(builder)
            if cls is None:
                raise RuntimeError(f"study section [{name}]: no config class found for the reference; "
                                   "teach offroadbench.reference about it")
            skip = ("count",) if name == "missions" else ()
            notes = ("`count` is not a study key: `[study] missions_per_terrain` sets it.",) if skip else ()
            out.append(SectionDoc(name, qualname(cls), first_line(cls), field_docs(cls, skip=skip), notes))
            out += nested_sections(name, cls, "", "table")[1:]  # e.g. [sim.mujoco], an engine's own table
    return out


def search_sections() -> list[tuple[str, SectionDoc]]:
    """(title, table) of the failure search's ``[search]``, ``[[search.params]]`` and ``[analysis]`` tables."""
    from offroadbench.search.analysis import SearchAnalysis
    from offroadbench.search.space import SearchConfig, SearchParam

    notes = ("A search file is a study file plus these tables (`offroadbench search run SEARCH.toml`); "
             "`[study]` takes no `terrains_per_cell` or `missions_per_terrain` (one terrain and mission per "
             "trial), and a `[grid]`, if any, lists the cells searched one after another. "
             "Source of the estimators: `offroadbench.search.estimators`.",)
    return [("`[search]`", SectionDoc("search", qualname(SearchConfig), "What a failure search runs and on which budget",
                                      field_docs(SearchConfig, skip=("params",)), notes)),
            ("`[[search.params]]`", SectionDoc("search.params", qualname(SearchParam),
                                               "One searched key, with its range and nominal distribution "
                                               "(one table per key)", field_docs(SearchParam))),
            ("`[analysis]` of a search file", SectionDoc("analysis", qualname(SearchAnalysis),
                                                         "A search's analysis plan, fixed before the run and stored with it",
                                                         field_docs(SearchAnalysis),
                                                         ("Source: `offroadbench.search.analysis`; the report computes "
                                                          "these figures first (`offroadbench.search.evaluate`).",)))]


def section_names() -> list[str]:
    return [s.name for s in study_sections()]


# ---------------------------------------------------------------------------- the tables a study writes
#: the key columns of a study's trial table (offroadbench.study.store.results.load), before the TrialResult fields
KEY_COLUMNS = (
    ("(grid columns)", "", ("One column per grid axis, named by its last key part (`D_high`), `planner` for "
     "`planner.name`, `vehicle` for `vehicle.name`, or the full key where the last part is ambiguous.")),
    ("cell", "", "Index of the grid cell (first axis slowest)."),
    ("terrain", "", "Index j of the terrain within its cell."),
    ("mission", "", "Index k of the mission on its terrain (the mission sampler's order)."),
    ("terrain_seed", "", ("Integer seed of the terrain: `offroadbench generate --seed <it>` rebuilds it "
     "(offroadbench.seeding.terrain_seed).")),
    ("mission_seed", "", "Integer seed the mission was drawn from (offroadbench.seeding.mission_seed)."),
)

#: columns of the terrain table (offroadbench.study.store.results.load_terrains) after the grid columns and keys
TERRAIN_COLUMNS = (
    ("area_low", "", ("Fraction of the map inside the border whose Moore gradient is low (Majhor & Bos 2023, "
     "Eq. 3-4, Sec. 2.4; before the morphological closing).")),
    ("area_semi", "", "Fraction inside the border that is semi-rough (as above)."),
    ("area_high", "", "Fraction inside the border that is highly rough (as above)."),
    ("twin_unexplained_var", "", "Only in cells with `[study] missions_from` whose missions come from another cell's "
     "terrain: 1 - r^2 of this terrain's heights against that terrain's (same seed); for a band-limited arm against "
     "its aliased twin, the share of the surface's variance carried by the W-M terms above the grid's Nyquist "
     "frequency (offroadbench.study.execution.tasks.prepare_cell)."),
)

#: meaning of each telemetry column (offroadbench.sim.trial.runner.TELEMETRY_COLUMNS)
TELEMETRY_DOCS = {
    "t_s": "Time since the clock started (after settling).",
    "x_m": "Base position x on the map.", "y_m": "Base position y on the map.", "z_m": "Base height.",
    "qx": "Base orientation quaternion, x.", "qy": "Quaternion y.", "qz": "Quaternion z.", "qw": "Quaternion w.",
    "roll_rad": "Roll (Z-Y-X Euler angles).", "pitch_rad": "Pitch.", "yaw_rad": "Yaw, counter-clockwise from +x.",
    "vx_m_s": "Base velocity x (world).", "vy_m_s": "Base velocity y (world).", "vz_m_s": "Base velocity z (world).",
    "roll_rate_body_rad_s": "Angular rate about the body x axis.",
    "pitch_rate_body_rad_s": "Angular rate about the body y axis.",
    "yaw_rate_body_rad_s": "Angular rate about the body z axis.",
    "cmd_v_m_s": "Commanded forward speed.", "cmd_omega_rad_s": "Commanded yaw rate.",
    "progress_m": "Distance gained toward the goal since the start.",
    "penetration_m": "Deepest wheel-terrain penetration at this sample.",
}


def trial_columns() -> list[FieldDoc]:
    """The columns of a study's trial table (``offroadbench.study.load``): keys, then every
    TrialResult field (``mission_index`` is the ``mission`` key)."""
    from offroadbench.sim.trial.runner import TrialResult

    keys = [FieldDoc(n, "", None, u, "", d) for n, u, d in KEY_COLUMNS]
    return keys + [f for f in field_docs(TrialResult) if f.name != "mission_index"]


# ---------------------------------------------------------------------------- rendering
def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    return json.dumps(str(v))


def _md_default(f: FieldDoc) -> str:
    if f.default is REQUIRED:
        return "required"
    if dataclasses.is_dataclass(f.default):
        return "table below"
    if f.default is None:
        return "none"
    if isinstance(f.default, dict) and not f.default:
        return ""
    return f"`{_toml_value(f.default)}`"


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _md_table(fields: tuple[FieldDoc, ...] | list[FieldDoc], *, columns: bool = False) -> list[str]:
    if columns:
        lines = ["| column | unit | meaning |", "|---|---|---|"]
        lines += [f"| `{f.name}` | {f.unit} | {_md_cell(f.doc)} |" for f in fields]
        return lines
    lines = ["| key | type | default | unit | allowed | meaning |", "|---|---|---|---|---|---|"]
    for f in fields:
        lines.append(f"| `{f.name}` | {_md_cell(f.type)} | {_md_cell(_md_default(f))} | {f.unit} | {_md_cell(f.allowed)} | "
                     f"{_md_cell(f.doc)} |")
    return lines


def _analysis_lines() -> list[str]:
    """The ``[analysis]`` table and its ``[[analysis.comparisons]]`` (offroadbench.study.stats.plan)."""
    from offroadbench.study.stats import plan

    doc = inspect.getdoc(plan) or ""
    tail = " ".join(doc.split("\n\n")[-1].split())  # the module docstring's last paragraph: what is computed
    return ["### `[analysis]`", "", f"{_md_cell(first_line(plan.AnalysisPlan))} Source: "
            f"`{qualname(plan.AnalysisPlan)}`. The store keeps the plan with the run; the report computes it "
            "in its Confirmatory section and marks every other number exploratory; a plan changed after "
            "trials were stored is refused.", "", *_md_table(field_docs(plan.AnalysisPlan, skip=("comparisons",))),
            "", "### `[[analysis.comparisons]]`", "", f"{_md_cell(first_line(plan.Comparison))} Source: "
            f"`{qualname(plan.Comparison)}`.", "", *_md_table(field_docs(plan.Comparison)), "", _md_cell(tail), ""]


def render_reference() -> str:
    """The whole reference as Markdown (the text of ``docs/reference.md``)."""
    from offroadbench.sim.trial.runner import TELEMETRY_COLUMNS

    lines = [
        "# offroadbench settings reference",
        "",
        ("<!-- Generated from the code by `offroadbench config --write-reference docs/reference.md`; do not edit by hand. "
        "tests/test_reference.py fails while this file is stale. -->"),
        "",
        ("Every key a study TOML accepts (`offroadbench study run STUDY.toml`), with its type, default, "
        "unit, allowed values and meaning (the field's docstring: the paper or measurement behind the "
        "default is cited there), and every column of the tables a study writes. "
        "`offroadbench config [SECTION]` prints a table's defaults as TOML to start a study from. "
        "Units are SI and are carried by the key's name (`_m`, `_s`, `_hz`, `_deg`, ...)."),
        "",
        "## Study TOML",
        "",
    ]
    for s in study_sections():
        top, _, entry = s.name.partition(".")
        title = f'`[{top}]` with `name = "{entry}"`' if entry and s.generator != "table" else f"`[{s.name}]`"
        summary = s.summary if s.summary.endswith(".") else s.summary + "."
        lines += [f"### {title}", "", f"{_md_cell(summary)} Source: `{s.source}`.", ""]
        if s.fields:
            lines += _md_table(s.fields) + [""]
        for note in s.notes:
            lines += [note, ""]
    lines += _analysis_lines()
    for title, s in search_sections():
        lines += [f"### {title}", "", f"{_md_cell(s.summary)}. Source: `{s.source}`.", "", *_md_table(s.fields), ""]
        lines += [line for note in s.notes for line in (note, "")]
    from offroadbench.bounds import reference_lines

    lines += reference_lines()
    lines += [
        "## Terrain recipes",
        "",
        "The keys a study reaches through `[recipe_overrides]` and `recipe.<key>` grid axes, and "
        "`generate --set` / `drive --set` through dotted keys (e.g. `layers.base.D_high`). A recipe "
        "also has `[recipe]` (`name`, `description`, `relief_m`, `crs`), `[body]` (`name`: the "
        "trials' gravity, offroadbench.bodies) and `[soil]` (`name`: the terramechanics tyre model's "
        "soil; a soil map with `[[soil.regions]]`, each a `soil` and conditions among `slope_min_deg`, "
        "`slope_max_deg`, `height_min_m`, `height_max_m`, `in_crater` (with `crater_radius_fraction`, "
        "`crater_min_diameter_m`), a disc `centre_m` + `radius_m` or a rectangle `x_range_m` + "
        "`y_range_m`, and/or `raster` (a PNG of soil indices, one pixel per height sample) with "
        "`raster_soils`: offroadbench.terrain.soil_map) tables. A layer table holds its generator's keys below; a key that is itself a table "
        "(`layers.craters.population`) is written as `[layers.NAME.KEY]`.",
        "",
    ]
    for s in recipe_sections():
        summary = s.summary if s.summary.endswith(".") else s.summary + "."
        title = f"`[{s.name}]`" + (f' with `generator = "{s.generator}"`' if s.generator else "")
        lines += [f"### {title}", "", f"{_md_cell(summary)} Source: `{s.source}`.", ""]
        lines += _md_table(s.fields) + [""]
    lines += [
        "## Tables a study writes",
        "",
        "### Trials (`offroadbench.study.load(DIR)`, `study export`'s `trials.parquet` or `trials.csv`)",
        "",
        ("One row per trial. Metrics are computed for every trial; the paper analyses them for successful "
        "trials only. Source: `offroadbench.sim.trial.runner.TrialResult`. `study export` adds, after these, the "
        "settings the cell held fixed (`vehicle.name`, `planner.name`, `sim.gravity_m_s2`, `sim.engine`, ..., "
        "`rules`, `recipe`; `offroadbench.study.report.header.settings_columns`), so an exported row says what made it."),
        "",
        *_md_table(trial_columns(), columns=True),
        "",
        "### Terrains (`offroadbench.study.load_terrains(DIR)`)",
        "",
        "One row per terrain: the grid columns, `cell`, `terrain`, `terrain_seed`, then:",
        "",
        *_md_table([FieldDoc(n, "", None, u, "", d) for n, u, d in TERRAIN_COLUMNS], columns=True),
        "",
        "### Telemetry (`telemetry/` of a run directory or of `drive --out`)",
        "",
        ("One row per telemetry sample (`[sim] telemetry_rate_hz`, 20 Hz by default). "
        "Source: `offroadbench.sim.trial.runner.TELEMETRY_COLUMNS`."),
        "",
        *_md_table([FieldDoc(c, "", None, unit_of(c), "", TELEMETRY_DOCS.get(c, "")) for c in TELEMETRY_COLUMNS],
                   columns=True),
        "",
    ]
    return "\n".join(lines)


_SENTENCE_END = re.compile(r"(?<!Sec)(?<!Eq)(?<!Fig)(?<!al)(?<!e\.g)(?<!i\.e)\.\s+(?=[A-Z(`])")


def _first_sentence(text: str) -> str:
    return _SENTENCE_END.split(text, maxsplit=1)[0].rstrip(".")


def _toml_block(s: SectionDoc, *, commented_from: int | None = None) -> list[str]:
    """``key = default`` lines, each after a comment; keys from index ``commented_from`` on (and
    keys without a default) are commented out."""
    lines = []
    for i, f in enumerate(s.fields):
        if dataclasses.is_dataclass(f.default):
            continue  # a nested table, printed as its own [table.key] (render_section_toml)
        info = "; ".join(t for t in (f.unit, f.allowed) if t)
        lines.append(f"# {_first_sentence(f.doc)}" + (f" ({info})" if info else ""))
        pre = "# " if commented_from is not None and i >= commented_from else ""
        if f.default is REQUIRED:
            lines.append(f"# {f.name} = ...   (required)")
        elif f.default is None:
            lines.append(f"# {f.name} = ...   (default: none)")
        else:
            lines.append(f"{pre}{f.name} = {_toml_value(f.default)}")
    return lines


#: what a freshly printed ``[study]`` table holds for its required keys
_STUDY_EXAMPLE = {"name": "my-study", "recipe": "paper-d2.45", "root_seed": 0}


#: the study's free-form tables, printed after ``[study]``: (name, comment lines, example lines)
_FREE_TABLES = (
    ("grid", (
        "Axes of the parameter grid: \"dotted.key\" = [values], one cell per combination (first axis slowest).",
        "Keys: recipe (preset names or paths), recipe.<key of the recipe TOML>, <table>.<key> of a table below.",
        "No axis: one cell. Uncomment or write your own:",
    ), (
        '# "recipe.layers.base.D_high" = [2.3, 2.45, 2.6]',
        '# "planner.name" = ["straight", "astar"]',
    )),
    ("recipe_overrides", (
        "Fixed \"dotted.key\" = value changes of the recipe, for every cell (the keys of generate --set;",
        "the recipe's own [grid] and [layers.*] tables: docs/reference.md, Terrain recipes).",
    ), (
        '# "grid.rows" = 257',
        '# "grid.cols" = 257',
    )),
)


def _free_table(name: str) -> list[str]:
    for table, comments, examples in _FREE_TABLES:
        if table == name:
            return [f"[{table}]", *(f"# {c}" for c in comments), *examples, ""]
    raise KeyError(name)


def render_section_toml(section: str | None = None) -> str:
    """A study table (or, with ``section=None``, every table) with its defaults, as TOML with a
    comment per key. The output loads as it is; keys without a default are commented out (in
    ``[study]`` the required keys get example values; ``[grid]`` and ``[recipe_overrides]`` are
    printed empty, with commented examples)."""
    sections = study_sections()
    names = [s.name for s in sections if "." not in s.name]
    free = [t for t, _, _ in _FREE_TABLES]
    if section in free:
        return "\n".join(_free_table(section)).rstrip() + "\n"
    if section is not None and section not in names:
        from offroadbench.registry import unknown_name

        raise unknown_name("study table", section, names[:1] + free + names[1:])
    lines: list[str] = []
    for s in sections:
        top = s.name.split(".", 1)[0]
        if section is not None and top != section:
            continue
        if s.generator == "table":  # a nested table of the one above, e.g. [sim.mujoco]
            lines += [f"[{s.name}]", f"# {s.summary} ({s.source})"] + _toml_block(s) + [""]
            continue
        if "." in s.name:
            if s.fields:
                lines += [f"# with name = \"{s.name.split('.', 1)[1]}\": {s.summary}"]
                lines += _toml_block(s, commented_from=0) + [""]
            continue
        lines += [f"[{s.name}]", f"# {s.summary} ({s.source})"]
        if s.name == "study":
            s = dataclasses.replace(s, fields=tuple(
                dataclasses.replace(f, default=_STUDY_EXAMPLE[f.name]) if f.name in _STUDY_EXAMPLE else f
                for f in s.fields))
        # a vehicle's figures stay commented: set here, they would override another vehicle's own
        lines += _toml_block(s, commented_from=1 if s.name == "vehicle" else None) + [""]
        if s.name == "study" and section is None:
            for table in free:
                lines += _free_table(table)
    return "\n".join(lines).rstrip() + "\n"
