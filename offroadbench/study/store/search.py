"""A failure search's own table in a run directory's store (offroadbench.search.runner)::

    search_trials(cell, grp, method, batch, slot, stage, x, z, log_w)

says which stream (grid cell ``grp``, ``method``) and batch each proposal belongs to, where it lies
in the parameter space (``x`` and the standard-normal ``z``, JSON lists) and its log likelihood
ratio for the estimators (NULL for the falsifier). Every proposal is a study cell of its own (cell
c, terrain 0, mission 0) whose trial lands in the study's ``trials`` table, or in ``faults``.
"""

from __future__ import annotations

import json
import math
from typing import Any, Mapping, Sequence

from offroadbench.errors import StudyError
from offroadbench.study.store.file import SEARCH_TABLE
from offroadbench.study.store.store import Store

__all__ = ["SEARCH_TABLE", "add_search_batch", "ensure_search_table", "next_search_cell", "search_rows",
           "stream_trials"]



def ensure_search_table(store: Store) -> None:
    """Make the ``search_trials`` table if the store has none yet."""
    store.con.executescript(SEARCH_TABLE)


def stream_trials(store: Store, grp: int, method: str) -> list[dict[str, Any]]:
    """The stored proposals of one stream in order, each with its trial row (None if not run yet or
    faulted), its seeds (None if not run yet) and its fault's reason (None unless stored as a fault)."""
    cur = store.con.execute(
        "SELECT s.cell, s.batch, s.slot, s.stage, s.x, s.z, s.log_w, t.row, "
        "COALESCE(t.terrain_seed, f.terrain_seed), COALESCE(t.mission_seed, f.mission_seed), f.reason "
        "FROM search_trials s LEFT JOIN trials t ON t.cell = s.cell AND t.terrain = 0 AND t.mission = 0 "
        "LEFT JOIN faults f ON f.cell = s.cell AND f.terrain = 0 AND f.mission = 0 "
        "WHERE s.grp = ? AND s.method = ? ORDER BY s.batch, s.slot", (grp, method))
    out = []
    for cell, batch, slot, stage, x, z, log_w, row, tseed, mseed, fault in cur.fetchall():
        out.append({"cell": cell, "batch": batch, "slot": slot, "stage": stage, "x": json.loads(x), "z": json.loads(z),
                    "log_w": float("nan") if log_w is None else log_w,
                    "row": None if row is None else json.loads(row), "terrain_seed": tseed, "mission_seed": mseed,
                    "fault": fault})
    return out


def search_rows(store: Store) -> list[tuple]:
    """(cell, grp, method, batch, slot, stage, x JSON, log_w, row JSON or None, terrain seed, mission seed)
    of every stored proposal, by group, method, batch and slot (the search report's table)."""
    return store.con.execute(
        "SELECT s.cell, s.grp, s.method, s.batch, s.slot, s.stage, s.x, s.log_w, t.row, t.terrain_seed, "
        "t.mission_seed FROM search_trials s LEFT JOIN trials t ON t.cell = s.cell "
        "ORDER BY s.grp, s.method, s.batch, s.slot").fetchall()


def next_search_cell(store: Store) -> int:
    """The cell index of the next proposal (one past the last stored; 0 in a new search)."""
    return int(store.con.execute("SELECT COALESCE(MAX(cell) + 1, 0) FROM search_trials").fetchone()[0])


def _json_list(values: Sequence[float]) -> str:
    return json.dumps([float(v) for v in values])


def add_search_batch(store: Store, grp: int, method: str, batch: int, stage: str,
                     proposals: Sequence[tuple[Sequence[float], Sequence[float], float]],
                     cells: Sequence[Mapping[str, Any]]) -> None:
    """Commit one batch in one transaction: its ``proposals`` ((x, z, log_w) per slot; a NaN
    ``log_w`` is stored as NULL) and their ``cells`` (appended to the meta ``cells``, whose
    ``index`` must continue it). A batch that does not continue the stored cells is a StudyError."""
    all_cells = list(store.meta().get("cells", []))
    if not cells or len(all_cells) != cells[0]["index"]:
        raise StudyError(f"{store.run_dir}: the store's cells ({len(all_cells)}) and search trials disagree")
    all_cells.extend(cells)
    with store.transaction() as con:
        for slot, ((x, z, log_w), c) in enumerate(zip(proposals, cells, strict=True)):
            lw = float(log_w)
            con.execute("INSERT INTO search_trials (cell, grp, method, batch, slot, stage, x, z, log_w) "
                        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                        (c["index"], grp, method, batch, slot, stage, _json_list(x), _json_list(z),
                         None if math.isnan(lw) else lw))
        con.execute("UPDATE meta SET value = ? WHERE key = 'cells'", (json.dumps(all_cells, sort_keys=True),))
