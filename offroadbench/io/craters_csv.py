"""Crater files: a CSV with one crater per row, kept apart from the elevation model (Parkes & Martin 1999, Sec. 3).

Columns (header required, this order not required): ``x_m, y_m, diameter_m, age, degradation,
profile``. ``age`` or ``degradation`` may be empty (not both): a crater without degradation gets
it from its age when it is stamped (Martin et al. 2014, Eq. 11). The same file can be stamped on any base terrain.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from offroadbench.errors import InputError
from offroadbench.io.atomic import atomic_path
from offroadbench.terrain.craters.table import COLUMNS, CraterTable

__all__ = ["write_craters", "read_craters"]


def _fmt(v: float) -> str:
    return "" if math.isnan(v) else repr(float(v))


def write_craters(table: CraterTable, path: str | Path) -> Path:
    """Write ``table`` to ``path`` as CSV (atomically); returns the path."""
    with atomic_path(path) as tmp:
        with tmp.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(COLUMNS)
            for i in range(len(table)):
                w.writerow(
                    [
                        repr(float(table.x_m[i])),
                        repr(float(table.y_m[i])),
                        repr(float(table.diameter_m[i])),
                        _fmt(table.age[i]),
                        _fmt(table.degradation[i]),
                        table.profile[i],
                    ]
                )
    return Path(path)


def _number(text: str, col: str, line: int, path: Path, allow_empty: bool) -> float:
    text = text.strip()
    if text == "":
        if allow_empty:
            return math.nan
        raise InputError(f"{path}:{line}: column {col} is empty")
    try:
        return float(text)
    except ValueError:
        raise InputError(f"{path}:{line}: column {col} = {text!r} is not a number") from None


def read_craters(path: str | Path) -> CraterTable:
    """Read a crater CSV; errors name the file, line and column."""
    p = Path(path)
    try:
        fh = p.open(newline="")
    except FileNotFoundError:
        raise InputError(f"crater file {p} does not exist") from None
    with fh:
        reader = csv.DictReader(fh)
        header = [h.strip() for h in (reader.fieldnames or [])]
        missing = [c for c in COLUMNS if c not in header]
        if missing:
            raise InputError(f"{p}: missing column(s) {', '.join(missing)}; expected header {','.join(COLUMNS)}")
        cols: dict[str, list] = {c: [] for c in COLUMNS}
        for line, row in enumerate(reader, start=2):
            row = {(k or "").strip(): (v or "") for k, v in row.items()}
            for c in ("x_m", "y_m", "diameter_m"):
                cols[c].append(_number(row[c], c, line, p, allow_empty=False))
            age = _number(row["age"], "age", line, p, allow_empty=True)
            deg = _number(row["degradation"], "degradation", line, p, allow_empty=True)
            if math.isnan(age) and math.isnan(deg):
                raise InputError(f"{p}:{line}: give age or degradation (both are empty)")
            cols["age"].append(age)
            cols["degradation"].append(deg)
            cols["profile"].append(row["profile"].strip())
    try:
        return CraterTable(
            x_m=np.array(cols["x_m"]),
            y_m=np.array(cols["y_m"]),
            diameter_m=np.array(cols["diameter_m"]),
            age=np.array(cols["age"]),
            degradation=np.array(cols["degradation"]),
            profile=tuple(cols["profile"]),
        )
    except InputError as exc:
        raise InputError(f"{p}: {exc}") from None
