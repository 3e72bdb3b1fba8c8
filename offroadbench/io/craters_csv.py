"""Crater files: a CSV with one crater per row, kept apart from the elevation model (Parkes & Martin 1999, Sec. 3).

Columns (header required, this order not required): ``x_m, y_m, diameter_m, age, degradation,
profile``. ``age`` or ``degradation`` may be empty (not both): a crater without degradation gets
it from its age when it is stamped (Martin et al. 2014, Eq. 11). The same file can be stamped on any base terrain.

This module knows the file format only: :func:`read_craters` returns the columns, which the
recipe loader turns into a :class:`offroadbench.terrain.craters.CraterTable` (so ``io`` does not
depend on ``terrain``); :func:`write_craters` takes any object with these columns as attributes.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from offroadbench.errors import InputError
from offroadbench.io.atomic import atomic_path
__all__ = ["COLUMNS", "write_craters", "read_craters"]

#: Column order of the crater CSV.
COLUMNS = ("x_m", "y_m", "diameter_m", "age", "degradation", "profile")


def _fmt(v: float) -> str:
    return "" if math.isnan(v) else repr(float(v))


def write_craters(table, path: str | Path) -> Path:
    """Write ``table`` (a CraterTable, or anything with the COLUMNS as attributes) to ``path`` as CSV
    (atomically); returns the path."""
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


def read_craters(path: str | Path) -> dict[str, Any]:
    """Read a crater CSV into {column: values} (arrays of floats, NaN where empty; a tuple of
    profile names); errors name the file, line and column."""
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
    return {
        "x_m": np.array(cols["x_m"]),
        "y_m": np.array(cols["y_m"]),
        "diameter_m": np.array(cols["diameter_m"]),
        "age": np.array(cols["age"]),
        "degradation": np.array(cols["degradation"]),
        "profile": tuple(cols["profile"]),
    }
