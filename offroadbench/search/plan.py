"""A search file read and resolved: its study part, its grid cells (the groups searched) and, for
each proposal, the study cell a worker drives (:class:`~offroadbench.study.spec.config.CellPlan`).

A proposal becomes a cell like a grid value does: ``recipe.<key>`` values go into the recipe,
``<table>.<field>`` values into the settings tables, on top of the group's own grid values. So a
search trial is a study trial: the same executors run it, the same store keeps it, and ``study
replay DIR --cell C --terrain 0 --mission 0`` drives it again from the run directory alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench.config import config_id, load_toml, to_dict
from offroadbench.errors import InputError
from offroadbench.search.analysis import SearchAnalysis, analysis_from_dict
from offroadbench.search.space import SearchConfig, search_from_dict
from offroadbench.study.spec.config import CellPlan, StudyConfig, plan_cells, study_from_dict

__all__ = ["SearchPlan", "load_search", "search_from_data", "trial_cell"]

#: [study] keys a search file may not set (a search draws its own trials)
_STUDY_ONLY = ("terrains_per_cell", "missions_per_terrain", "missions_from")


@dataclass(frozen=True, eq=False)
class SearchPlan:
    """A validated search: the ``[search]`` table, the study part and the grid cells searched."""

    search: SearchConfig
    study: StudyConfig
    groups: tuple[CellPlan, ...]
    """The study's grid cells (one when there is no ``[grid]``); each is searched on its own."""
    analysis: SearchAnalysis | None = None
    """The ``[analysis]`` plan (offroadbench.search.analysis), or None."""

    @property
    def search_id(self) -> str:
        """Stable id of the search: its config, the study part, every group's resolved recipe and
        the analysis plan where there is one (so a plan changed after trials were stored is refused
        like a changed search)."""
        data = {"search": to_dict(self.search), "study": to_dict(self.study),
                "recipes": [dict(g.recipe_data) for g in self.groups]}
        if self.analysis is not None:
            data["analysis"] = to_dict(self.analysis)
        return config_id(data)


def search_from_data(data: Mapping[str, Any], where: str = "search", base_dir: Path | None = None) -> SearchPlan:
    """A SearchPlan from a search TOML dict; every group is checked at the corners and the middle
    of the space, so a bad key or value fails here, naming it, not in a worker."""
    if not isinstance(data, Mapping) or "search" not in data:
        raise InputError(f"{where}: no [search] table (a search file is a study file with a [search] table)")
    data = dict(data)
    search = search_from_dict(data.pop("search"), where=f"{where}: [search]")
    analysis = analysis_from_dict(data.pop("analysis", None), search.keys, where=f"{where}: [analysis]")
    head = data.get("study", {})
    if isinstance(head, Mapping):
        bad = [k for k in _STUDY_ONLY if k in head]
        if bad:
            raise InputError(f"{where}: [study] {', '.join(bad)}: not for a search (it draws one terrain and "
                             "mission per trial; [search] budget sets the number of trials)")
        data["study"] = {**head, "terrains_per_cell": 1, "missions_per_terrain": 1}
    study = study_from_dict(data, where=where)
    try:
        groups = plan_cells(study, base_dir=base_dir)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    grid_keys = {a.key for a in study.grid}
    clash = sorted(grid_keys & set(search.keys))
    if clash:
        raise InputError(f"{where}: {', '.join(clash)} is both a [grid] axis and a searched key")
    plan = SearchPlan(search=search, study=study, groups=tuple(groups), analysis=analysis)
    lo = np.array([p.low for p in search.params])
    hi = np.array([p.high for p in search.params])
    for g in plan.groups:
        for x in (lo, hi, (lo + hi) / 2):
            try:
                _ = trial_cell(plan, g, 0, x).trial_settings  # builds and validates every table
            except InputError as exc:
                raise InputError(f"{where}: [search] with {search.values(x)}: {exc}") from None
    return plan


def load_search(path: str | Path) -> SearchPlan:
    """Read and fully validate a search TOML."""
    p = Path(path)
    return search_from_data(load_toml(p), where=str(p), base_dir=p.parent)


def trial_cell(plan: SearchPlan, group: CellPlan, index: int, x: np.ndarray) -> CellPlan:
    """The study cell of one proposal ``x`` (values of the searched keys) in ``group``; ``index``
    is its cell index in the run directory."""
    from offroadbench.terrain.recipe import apply_overrides, recipe_from_dict

    values = plan.search.values(x)
    rec = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("recipe.")}
    recipe_data = dict(group.recipe_data)
    if rec:
        recipe_data = dict(apply_overrides(recipe_from_dict(recipe_data, source=f"search cell {index}"), rec).data)
    settings = {k: dict(v) for k, v in group.settings.items()}
    for k, v in values.items():
        target, _, fld = k.partition(".")
        if target != "recipe":
            settings.setdefault(target, {})[fld] = v
    return CellPlan(index=index, values={**dict(group.values), **values}, key=group.key, recipe_data=recipe_data,
                    settings=settings)
