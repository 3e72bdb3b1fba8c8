"""Tidy tables of a run directory: one row per trial, one row per terrain.

``load(DIR)`` columns: the grid values (one column per grid axis, named by
``StudyConfig.column_names``), ``cell``, ``terrain``, ``mission``, ``terrain_seed``,
``mission_seed``, then every field of ``TrialResult.as_row()`` (``success``,
``failure_reason``, the metrics, start and goal coordinates, ...). Sorted by cell, terrain,
mission, so two runs of the same study give equal frames whatever the order they ran in.

``load_terrains(DIR)``: grid values, ``cell``, ``terrain``, ``terrain_seed`` and the class area
fractions ``area_low``, ``area_semi``, ``area_high`` (Sec. 2.4: inside the 5 m border, before
the closing).

``load_platforms(DIR)``: one row per platform (:mod:`offroadbench.study.fingerprint`) the stored
trials ran on, with the sessions and the number of trials; ``trial_platform(DIR, cell, terrain,
mission)``: the platform and offroadbench version of the session that ran one trial.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from offroadbench.study.store.store import Store

if TYPE_CHECKING:  # pandas is imported by the functions that build frames: a study's coordinator and
    import pandas as pd  # its forked workers never load it (about 90 MB of each process, issue 41)

__all__ = ["TIMING_COLUMNS", "load", "load_meta", "load_platforms", "load_terrains", "trial_platform"]

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
    import pandas as pd

    columns = meta["columns"]
    rows = [{"cell": c["index"], **{columns[k]: v for k, v in c["values"].items()}} for c in meta["cells"]]
    return pd.DataFrame(rows, columns=["cell", *columns.values()])


def load(run_dir: str | Path) -> pd.DataFrame:
    """One tidy row per stored trial (see the module docstring)."""
    import pandas as pd

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
    import pandas as pd

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


def _trial_runs(store: Store) -> dict[tuple[int, int, int], int | None]:
    return {(c, t, m): rid for c, t, m, _, _, rid in store.trial_telemetry()}


def load_platforms(run_dir: str | Path) -> pd.DataFrame:
    """The platforms the stored trials came from, most trials first: ``platform`` (one line),
    ``sessions`` (their ids), ``trials``, ``fingerprint`` (the dict; None when not recorded, as
    in stores of schema 1) and ``version`` (offroadbench of the first of those sessions)."""
    import pandas as pd

    from offroadbench.study.fingerprint import describe

    with Store(run_dir) as store:
        runs = {r["id"]: r for r in store.runs()}
        trial_runs = _trial_runs(store)
    groups: dict[str, dict[str, Any]] = {}

    def group(fp: dict[str, Any] | None, version: str | None) -> dict[str, Any]:
        return groups.setdefault(json.dumps(fp, sort_keys=True), {
            "platform": describe(fp), "sessions": [], "trials": 0, "fingerprint": fp, "version": version})

    for rid in sorted(runs):
        group(runs[rid]["platform"], runs[rid]["version"])["sessions"].append(rid)
    for rid in trial_runs.values():  # a trial of a schema-1 store has no session: "not recorded"
        r = runs.get(rid)
        group(r["platform"] if r else None, r["version"] if r else None)["trials"] += 1
    rows = [g | {"sessions": ", ".join(map(str, g["sessions"])) or "-"} for g in groups.values() if g["trials"]]
    df = pd.DataFrame(rows, columns=["platform", "sessions", "trials", "fingerprint", "version"])
    return df.sort_values("trials", ascending=False, kind="stable").reset_index(drop=True)


def trial_platform(run_dir: str | Path, cell: int, terrain: int, mission: int
                   ) -> tuple[dict[str, Any] | None, str | None]:
    """(platform fingerprint, offroadbench version) of the session that ran a stored trial;
    (None, None) when that was not recorded (a store of schema 1)."""
    with Store(run_dir) as store:
        rid = _trial_runs(store).get((cell, terrain, mission))
        runs = {r["id"]: r for r in store.runs()}
    if rid not in runs:
        return None, None
    return runs[rid]["platform"], runs[rid]["version"]


def telemetry_paths(run_dir: str | Path, cell: int, terrain: int, mission: int) -> tuple[Path, Path]:
    """(telemetry, planned path) Parquet files of one trial in a run directory."""
    stem = Path(run_dir) / "telemetry" / f"cell{cell}_terrain{terrain}_mission{mission}"
    return stem.with_name(stem.name + ".parquet"), stem.with_name(stem.name + "_path.parquet")
