"""The file of a study's store: its name and schema, the checks that an existing ``study.sqlite`` is
a store this version can use, and its removal (see offroadbench.study.store.store for the tables)."""

from __future__ import annotations

import contextlib
import logging
import os
import sqlite3
from pathlib import Path

from offroadbench.errors import InputError

log = logging.getLogger(__name__)


STORE_NAME = "study.sqlite"


#: schema version written to ``PRAGMA user_version``; a store with a higher one is refused
SCHEMA_VERSION = 2


#: ``PRAGMA application_id`` of an offroadbench store ("ORB1"); stores made before it was set have 0
APPLICATION_ID = 0x4F524231


_TABLES = ("meta", "terrains", "trials", "runs")


_SQLITE_MAGIC = b"SQLite format 3\x00"


SCHEMA_SQL = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS terrains (
    cell INTEGER NOT NULL, terrain INTEGER NOT NULL, terrain_seed INTEGER NOT NULL,
    stats TEXT NOT NULL, PRIMARY KEY (cell, terrain));
CREATE TABLE IF NOT EXISTS trials (
    cell INTEGER NOT NULL, terrain INTEGER NOT NULL, mission INTEGER NOT NULL,
    terrain_seed INTEGER NOT NULL, mission_seed INTEGER NOT NULL, success INTEGER NOT NULL,
    row TEXT NOT NULL, telemetry TEXT, run_id INTEGER, PRIMARY KEY (cell, terrain, mission));
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY AUTOINCREMENT, started REAL NOT NULL, finished REAL,
    executor TEXT, workers INTEGER, trials_run INTEGER DEFAULT 0, status TEXT,
    host TEXT, machine TEXT, version TEXT, platform TEXT, error TEXT);
CREATE TABLE IF NOT EXISTS faults (
    cell INTEGER NOT NULL, terrain INTEGER NOT NULL, mission INTEGER NOT NULL,
    terrain_seed INTEGER NOT NULL, mission_seed INTEGER NOT NULL, reason TEXT NOT NULL,
    run_id INTEGER, time REAL, PRIMARY KEY (cell, terrain, mission));
"""


#: the faults table (issue 30), made by a run in a store that lacks it (older stores are read without it)
FAULTS_SQL = SCHEMA_SQL[SCHEMA_SQL.index("CREATE TABLE IF NOT EXISTS faults"):]

#: the table a failure search adds to a study's store (offroadbench.study.store.search)
SEARCH_TABLE = """
CREATE TABLE IF NOT EXISTS search_trials (
    cell INTEGER PRIMARY KEY, grp INTEGER NOT NULL, method TEXT NOT NULL, batch INTEGER NOT NULL,
    slot INTEGER NOT NULL, stage TEXT NOT NULL, x TEXT NOT NULL, z TEXT NOT NULL, log_w REAL,
    UNIQUE (grp, method, batch, slot));
"""


#: columns added by schema 2, per table: (name, SQL type)
SCHEMA2_COLUMNS = {"trials": (("telemetry", "TEXT"), ("run_id", "INTEGER")),
                    "runs": (("platform", "TEXT"), ("error", "TEXT"))}


#: space set aside in the run directory while a session runs (``make_reserve``): a session stopped by a
#: full disk frees it to record how it ended (``failed``, with the error) instead of being found ``killed``
RESERVE_NAME = "study.reserve"
RESERVE_BYTES = 256 << 10


def make_reserve(run_dir: str | Path) -> None:
    """Set aside :data:`RESERVE_BYTES` on the run directory's file system (blocks allocated, not a
    sparse file), so that a session that meets a full disk can still write its own end. Best effort:
    a disk already too full to hold it is left as it is (logged)."""
    path = Path(run_dir) / RESERVE_NAME
    try:
        if path.is_file() and path.stat().st_size >= RESERVE_BYTES:
            return
        fd = os.open(path, os.O_WRONLY | os.O_CREAT, 0o644)
        try:
            try:
                os.posix_fallocate(fd, 0, RESERVE_BYTES)
            except (AttributeError, OSError):  # a file system without fallocate: write the bytes
                os.pwrite(fd, bytes(RESERVE_BYTES), 0)
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError as exc:
        log.info("%s: could not set aside %d bytes (%s)", path, RESERVE_BYTES, exc)
        with contextlib.suppress(OSError):
            path.unlink()


def release_reserve(run_dir: str | Path) -> bool:
    """Remove the run directory's reserve; True if there was one to free."""
    try:
        (Path(run_dir) / RESERVE_NAME).unlink()
    except FileNotFoundError:
        return False
    return True


def store_path(run_dir: str | Path) -> Path:
    return Path(run_dir) / STORE_NAME


def nearly_full(directory: Path, margin: int = 1 << 20) -> bool:
    """Whether the device of ``directory`` has less than ``margin`` bytes free (1 MiB)."""
    try:
        st = os.statvfs(directory)
    except OSError:
        return False
    return st.f_bavail * st.f_frsize < margin


def remove_stale_temp_files(run_dir: str | Path) -> list[Path]:
    """Remove the temporary files a killed run left in ``run_dir`` and its ``telemetry`` folder
    (``.NAME.XXXX.tmp`` of :func:`offroadbench.io.atomic.atomic_path` and of store creation).
    Call only while holding the directory's :class:`RunLock`. Returns what was removed."""
    removed = []
    for d in (Path(run_dir), Path(run_dir) / "telemetry"):
        if not d.is_dir():
            continue
        for q in d.iterdir():
            name = q.name
            if name.startswith(".") and (name.endswith(".tmp") or ".tmp-" in name) and q.is_file():
                q.unlink(missing_ok=True)
                removed.append(q)
    if removed:
        log.info("%s: removed %d temporary file(s) of an earlier run", run_dir, len(removed))
    return removed


def check_existing(path: Path) -> None:
    """Refuse, without writing to it, a ``study.sqlite`` that is not a readable store of ours.

    The schema version and application id are read from the file header (SQLite file format:
    big-endian integers at offsets 60 and 68), so a newer or foreign store is refused without
    opening it. The tables and a quick integrity check need a read-only connection, which may
    create the ``-wal``/``-shm`` side files; those it created are removed again.
    """
    try:
        with path.open("rb") as fh:
            head = fh.read(100)
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror})") from None
    if not head:
        raise InputError(f"{path}: is empty, not a study store; remove it or use another --out directory")
    if not head.startswith(_SQLITE_MAGIC):
        raise InputError(f"{path}: is not an SQLite database, so not a study store; use another --out directory")
    if len(head) < 100:
        raise InputError(f"{path}: is a truncated SQLite database; restore it or use another --out directory")
    version = int.from_bytes(head[60:64], "big")
    app_id = int.from_bytes(head[68:72], "big")
    if app_id not in (0, APPLICATION_ID):
        raise InputError(f"{path}: is an SQLite database of another program, not a study store; use another --out directory")
    if version > SCHEMA_VERSION:
        raise InputError(
            f"{path}: was written by a newer offroadbench (store schema {version}; this one reads up to "
            f"{SCHEMA_VERSION}); upgrade offroadbench to use it"
        )
    sides = [path.with_name(path.name + suffix) for suffix in ("-wal", "-shm")]
    existed = [q.exists() for q in sides]
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=30.0)
        try:
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if not set(_TABLES) <= tables:
                raise InputError(
                    f"{path}: is an SQLite database of another program (tables: {', '.join(sorted(tables)) or 'none'}), "
                    "not a study store; use another --out directory"
                )
            check = con.execute("PRAGMA quick_check").fetchone()[0]
            if check != "ok":
                raise InputError(f"{path}: is corrupt ({check}); restore it or use another --out directory")
            con.execute("SELECT COUNT(*) FROM trials").fetchone()
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{path}: is corrupt or not a study store ({exc})") from None
    finally:
        for q, was in zip(sides, existed, strict=True):
            if not was:
                q.unlink(missing_ok=True)


def remove_store(run_dir: str | Path) -> None:
    """Delete ``study.sqlite`` and its WAL files (for a study that failed before any trial)."""
    p = store_path(run_dir)
    for q in (p, p.with_name(p.name + "-wal"), p.with_name(p.name + "-shm"), p.with_name(p.name + "-journal")):
        q.unlink(missing_ok=True)
