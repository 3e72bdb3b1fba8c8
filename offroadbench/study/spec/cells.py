"""The cells of a study: one :class:`CellPlan` per grid cell, and :func:`plan_cells`, which resolves
and validates them (the grid expansion of offroadbench.study.spec.config).

A cell is plain, picklable data (its recipe as a TOML dict, its settings tables, its seed key) that a
worker anywhere turns back into configs without reading files; a run directory's store keeps each
cell's resolved settings, and :meth:`CellPlan.from_meta` reads a cell back from it. Every grid cell
(the cartesian product of the axes, first axis slowest) is resolved and validated when a study is
loaded, so a bad value is refused before anything runs, with the key named.
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from offroadbench.errors import InputError
from offroadbench.sim.trial.pipeline import SETTINGS_TABLES as SECTIONS, TrialSettings, settings_part
from offroadbench import seeding

if TYPE_CHECKING:
    from offroadbench.study.spec.config import StudyConfig

log = logging.getLogger(__name__)

__all__ = ["CellPlan", "build_section", "plan_cells"]


@dataclass(frozen=True)
class CellPlan:
    """One resolved grid cell: plain, picklable data a worker turns back into configs."""

    index: int
    """Position of the cell in the grid (first axis slowest)."""
    values: Mapping[str, Any]
    """{grid key: value} of this cell."""
    key: int
    """Spawn-key entry of the cell's seeds (0 when terrains are paired)."""
    recipe_data: Mapping[str, Any]
    """The cell's recipe as a TOML dict, overrides and grid values applied."""
    settings: Mapping[str, Mapping[str, Any]]
    """Settings tables with the cell's grid values applied."""
    missions_recipe_data: Mapping[str, Any] | None = None
    """The recipe (TOML dict) of the terrain its missions are drawn on, when that is another cell's
    (``[study] missions_from``); None: its own terrain."""
    stored_settings: Mapping[str, Any] | None = field(default=None, compare=False, repr=False)
    """The cell's TrialSettings as a run's store recorded them when the study was created
    (:meth:`TrialSettings.to_dict`, ``meta.cells[i].trial_settings``; set by :meth:`from_meta`);
    None: built from :attr:`settings` (a study file's plan, or a store made before they were kept)."""

    @classmethod
    def from_meta(cls, meta: Mapping[str, Any], index: int) -> "CellPlan":
        """Cell ``index`` as a run directory's stored meta data holds it (``Store.meta()``), with the
        settings the store recorded, where it did."""
        info = meta["cells"][index]
        return cls(index=index, values=info["values"], key=info["seed_key"], recipe_data=info["recipe"],
                   settings=info["settings"], missions_recipe_data=info.get("missions_recipe"),
                   stored_settings=info.get("trial_settings"))

    def missions_recipe(self):
        """The recipe whose terrain the cell's missions are drawn on (None: the cell's own)."""
        if self.missions_recipe_data is None:
            return None
        from offroadbench.terrain.recipe import recipe_from_dict

        return recipe_from_dict(dict(self.missions_recipe_data), source=f"cell {self.index} (missions)")

    def recipe(self):
        from offroadbench.terrain.recipe import recipe_from_dict

        return recipe_from_dict(dict(self.recipe_data), source=f"cell {self.index}")

    @functools.cached_property
    def trial_settings(self) -> TrialSettings:
        """The cell's :class:`~offroadbench.sim.trial.pipeline.TrialSettings`, made once and kept with
        the plan: read from :attr:`stored_settings` where the store kept them, else built from the
        tables (``vehicle.toml`` read once); :meth:`_stored` decides which."""
        stored = self._stored()
        if stored is not None:
            return TrialSettings.from_dict(stored, where=f"cell {self.index} (stored settings)")
        return TrialSettings.from_tables(self.settings, where=f"cell {self.index}")

    def section(self, name: str):
        """The frozen config of one of the cell's settings tables (a part of :attr:`trial_settings`)."""
        if name not in SECTIONS:
            raise InputError(f"cell {self.index}: unknown settings table {name!r}; known: {', '.join(SECTIONS)}")
        return getattr(self.trial_settings, name)

    def part(self, name: str):
        """One part of the settings alone, read or built as :attr:`trial_settings` would (for a
        report that shows each part that still builds here, e.g. without a run's plug-in)."""
        stored = self._stored()
        if stored is not None:
            return settings_part(name, stored.get(name), where=f"cell {self.index} (stored settings)")
        return build_section(name, self.settings.get(name, {}), where=f"cell {self.index} [{name}]")

    def _stored(self) -> Mapping[str, Any] | None:
        """The stored settings to use, or None to build them from the tables: the one place a
        report falls back to rebuilding. The tables serve a plan without stored settings, and one
        whose recorded vehicle model file is not on this machine (a run directory copied from
        elsewhere: a replay must load the URDF; the tables find the vehicle by name)."""
        stored = self.stored_settings
        if stored is None:
            return None
        urdf = (stored.get("vehicle") or {}).get("urdf")
        if not (isinstance(urdf, str) and Path(urdf).is_file()):
            log.info("cell %d: the stored vehicle model %s is not here; settings built from the study's tables",
                     self.index, urdf)
            return None
        return stored


def build_section(name: str, table: Mapping[str, Any], where: str):
    """The frozen config of settings table ``name`` (VehicleSpec for ``vehicle``)."""
    return SECTIONS[name](dict(table), where)


def _resolve_recipe(ref: str, base_dir: Path | None):
    from offroadbench.terrain.recipe import load_recipe

    if base_dir is not None and ref.endswith(".toml") and not Path(ref).is_absolute():
        candidate = base_dir / ref
        if candidate.exists():
            ref = str(candidate)
    return load_recipe(ref)


def plan_cells(study: StudyConfig, base_dir: Path | None = None, check_sections: bool = True) -> list[CellPlan]:
    """Resolve and validate every grid cell. Raises InputError naming the key on a bad value."""
    from offroadbench.terrain.recipe import apply_overrides

    recipes: dict[str, Any] = {}

    def recipe_for(ref: str):
        if ref not in recipes:
            recipes[ref] = apply_overrides(_resolve_recipe(ref, base_dir), study.recipe_overrides)
        return recipes[ref]

    plans = []
    for index, values in enumerate(study.cell_values()):
        ref = values.get("recipe", study.recipe)
        if not isinstance(ref, str):
            raise InputError(f"grid.recipe: values must be preset names or paths, got {ref!r}")
        recipe = recipe_for(ref)
        rec_over = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("recipe.")}
        try:
            recipe = apply_overrides(recipe, rec_over) if rec_over else recipe
        except InputError as exc:
            raise InputError(f"grid cell {index} ({_fmt(values)}): {exc}") from None
        settings = {name: dict(study.settings.get(name, {})) for name in SECTIONS}
        if "count" in settings["missions"] or "missions.count" in values:
            raise InputError("[missions] count: set the number of missions with study.missions_per_terrain")
        for k, v in values.items():
            target, _, fld = k.partition(".")
            if target in settings:
                settings[target][fld] = v
        missions_recipe = None
        if study.missions_from and any(values.get(k) != v for k, v in study.missions_from.items()):
            ref = {**values, **study.missions_from}
            ref_over = {k.split(".", 1)[1]: v for k, v in ref.items() if k.startswith("recipe.")}
            base = recipe_for(ref.get("recipe", study.recipe))
            missions_recipe = dict(apply_overrides(base, ref_over).data if ref_over else base.data)
        plan = CellPlan(
            index=index,
            values=values,
            key=seeding.cell_key(values, study.paired_terrains),
            recipe_data=dict(recipe.data),
            settings={k: v for k, v in settings.items() if v},
            missions_recipe_data=missions_recipe,
        )
        if check_sections:
            _ = plan.trial_settings  # builds and validates every table once
        plans.append(plan)
    return plans


def _fmt(values: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in values.items()) or "no grid"
