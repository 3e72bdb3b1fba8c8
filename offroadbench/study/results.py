"""Tidy tables of a run directory: one row per trial, one row per terrain.

``load(DIR)`` columns: the grid values (one column per grid axis, named by
``StudyConfig.column_names``), ``cell``, ``terrain``, ``mission``, ``terrain_seed``,
``mission_seed``, then every field of ``TrialResult.as_row()`` (``success``,
``failure_reason``, the metrics, start and goal coordinates, ...). Sorted by cell, terrain,
mission, so two runs of the same study give equal frames whatever the order they ran in.

``load_terrains(DIR)``: grid values, ``cell``, ``terrain``, ``terrain_seed`` and the class area
fractions ``area_low``, ``area_semi``, ``area_high`` (Sec. 2.4: inside the 5 m border, before
the closing).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd

from offroadbench.study.store import Store

__all__ = ["load", "load_terrains", "load_meta", "TIMING_COLUMNS"]

#: per-run timings kept in the store but left out of the tidy tables (they differ between runs)
TIMING_COLUMNS = ("build_s",)

_KEYS = ["cell", "terrain", "mission", "terrain_seed", "mission_seed"]


def load_meta(run_dir: str | Path) -> dict[str, Any]:
    """The study metadata of a run directory (config, cells, version, ...) plus its run sessions."""
    with Store(run_dir) as store:
        meta = store.meta()
        meta["runs"] = store.runs()
    return meta


def _grid_frame(meta: dict[str, Any]) -> pd.DataFrame:
    columns = meta["columns"]
    rows = [{"cell": c["index"], **{columns[k]: v for k, v in c["values"].items()}} for c in meta["cells"]]
    return pd.DataFrame(rows, columns=["cell", *columns.values()])


def load(run_dir: str | Path) -> pd.DataFrame:
    """One tidy row per stored trial (see the module docstring)."""
    with Store(run_dir) as store:
        meta = store.meta()
        raw = store.trial_rows()
    records = []
    for cell, terrain, mission, tseed, mseed, text in raw:
        row = json.loads(text)
        row.pop("mission_index", None)
        records.append({"cell": cell, "terrain": terrain, "mission": mission, "terrain_seed": tseed, "mission_seed": mseed, **row})
    trials = pd.DataFrame.from_records(records)
    if trials.empty:
        trials = pd.DataFrame(columns=_KEYS)
    grid = _grid_frame(meta)
    out = grid.merge(trials, on="cell", how="inner")
    return out.sort_values(["cell", "terrain", "mission"], kind="stable").reset_index(drop=True)


def load_terrains(run_dir: str | Path) -> pd.DataFrame:
    """One row per built terrain: grid values, seeds and class area fractions."""
    with Store(run_dir) as store:
        meta = store.meta()
        raw = store.terrain_rows()
    records = []
    for cell, terrain, tseed, text in raw:
        stats = {k: v for k, v in json.loads(text).items() if k not in TIMING_COLUMNS}
        records.append({"cell": cell, "terrain": terrain, "terrain_seed": tseed, **stats})
    terrains = pd.DataFrame.from_records(records)
    if terrains.empty:
        terrains = pd.DataFrame(columns=["cell", "terrain", "terrain_seed"])
    out = _grid_frame(meta).merge(terrains, on="cell", how="inner")
    return out.sort_values(["cell", "terrain"], kind="stable").reset_index(drop=True)
