"""Saving and loading trial telemetry: a dict of equally long 1-D columns (offroadbench.sim's
TELEMETRY_COLUMNS), as NPZ (``.npz``) or Parquet (``.parquet``), chosen by the file suffix."""

from __future__ import annotations

from pathlib import Path
from typing import Mapping

import numpy as np

from offroadbench.errors import InputError
from offroadbench.io.atomic import atomic_path

__all__ = ["save_telemetry", "load_telemetry", "TELEMETRY_SUFFIXES"]

TELEMETRY_SUFFIXES = (".npz", ".parquet")


def _suffix(path: Path) -> str:
    if path.suffix not in TELEMETRY_SUFFIXES:
        raise InputError(f"telemetry file {path}: unknown suffix {path.suffix!r}; allowed: {', '.join(TELEMETRY_SUFFIXES)}")
    return path.suffix


def save_telemetry(columns: Mapping[str, np.ndarray], path: str | Path, *, sweep: bool = True) -> Path:
    """Write the columns atomically; all must be 1-D and of one length. ``sweep`` as in
    :func:`offroadbench.io.atomic.atomic_path`."""
    p = Path(path)
    kind = _suffix(p)
    arrays = {k: np.asarray(v) for k, v in columns.items()}
    lengths = {a.shape for a in arrays.values()}
    if len(lengths) > 1 or any(len(s) != 1 for s in lengths):
        raise InputError(f"telemetry columns must be 1-D arrays of one length, got shapes {sorted(lengths)}")
    with atomic_path(p, sweep=sweep) as tmp:
        if kind == ".npz":
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, **arrays)
        else:
            import pyarrow as pa
            import pyarrow.parquet as pq

            with open(tmp, "wb") as fh:  # a file object: pyarrow cannot encode a non-UTF-8 path itself
                pq.write_table(pa.table(arrays), fh)
    return p


def load_telemetry(path: str | Path) -> dict[str, np.ndarray]:
    """Read columns written by :func:`save_telemetry`."""
    p = Path(path)
    kind = _suffix(p)
    if not p.is_file():
        raise InputError(f"telemetry file {p}: no such file")
    if kind == ".npz":
        with np.load(p, allow_pickle=False) as data:  # data only, never a pickle
            return {k: data[k] for k in data.files}
    import pyarrow.parquet as pq

    with open(p, "rb") as fh:
        table = pq.read_table(fh)
    return {name: table.column(name).to_numpy() for name in table.column_names}
