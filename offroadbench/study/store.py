"""Crash-safe, resumable result store of a study: one SQLite file in the run directory.

Tables (``study.sqlite``):

* ``meta(key, value)``: the study config (JSON and the TOML text it came from), the study id,
  the resolved grid cells (recipe data, settings, seed keys), the package version that created
  the store.
* ``terrains(cell, terrain, terrain_seed, stats)``: one row per built terrain; ``stats`` is JSON
  (class area fractions of Sec. 2.4, missions sampled, build time).
* ``trials(cell, terrain, mission, terrain_seed, mission_seed, success, row)``: one row per
  finished trial; ``row`` is the JSON of ``TrialResult.as_row()``.
* ``runs``: one row per ``study run`` session (start, end, executor, workers, trials run, host,
  version): the wall time of the study is read from here.

Safety. Only the coordinating process writes. Every trial is its own transaction, committed
the moment its result arrives; the primary key (cell, terrain, mission) makes a second copy
impossible. WAL journal with ``synchronous=NORMAL``: a killed process (SIGKILL included)
loses no committed row and leaves a consistent database; only a power cut may lose the last
few commits. A trial that was in flight when the process died has no row, so the next run
does it again.
"""

from __future__ import annotations

import json
import logging
import os
import platform
import sqlite3
import time
from pathlib import Path
from typing import Any, Mapping

from offroadbench.errors import InputError

log = logging.getLogger(__name__)

__all__ = ["STORE_NAME", "SCHEMA_VERSION", "Store", "store_path", "remove_store"]

STORE_NAME = "study.sqlite"

#: schema version written to ``PRAGMA user_version``; a store with a higher one is refused
SCHEMA_VERSION = 1
#: ``PRAGMA application_id`` of an offroadbench store ("ORB1"); stores made before it was set have 0
APPLICATION_ID = 0x4F524231
_TABLES = ("meta", "terrains", "trials", "runs")
_SQLITE_MAGIC = b"SQLite format 3\x00"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS terrains (
    cell INTEGER NOT NULL, terrain INTEGER NOT NULL, terrain_seed INTEGER NOT NULL,
    stats TEXT NOT NULL, PRIMARY KEY (cell, terrain));
CREATE TABLE IF NOT EXISTS trials (
    cell INTEGER NOT NULL, terrain INTEGER NOT NULL, mission INTEGER NOT NULL,
    terrain_seed INTEGER NOT NULL, mission_seed INTEGER NOT NULL, success INTEGER NOT NULL,
    row TEXT NOT NULL, PRIMARY KEY (cell, terrain, mission));
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY AUTOINCREMENT, started REAL NOT NULL, finished REAL,
    executor TEXT, workers INTEGER, trials_run INTEGER DEFAULT 0, status TEXT,
    host TEXT, machine TEXT, version TEXT);
"""


def store_path(run_dir: str | Path) -> Path:
    return Path(run_dir) / STORE_NAME


class Store:
    """The SQLite store of one run directory. Use as a context manager.

    An existing ``study.sqlite`` is checked before anything is written to it: a file that is not
    an SQLite database, a corrupt one, an SQLite database of some other program and a store
    written by a newer schema are each refused with one InputError, and the file is left as it
    was. ``created`` tells whether this object made the file (see :func:`remove_store`).
    """

    def __init__(self, run_dir: str | Path, *, create: bool = False) -> None:
        self.run_dir = Path(run_dir)
        path = store_path(self.run_dir)
        self.path = path
        self.created = False
        if path.is_dir():
            raise InputError(f"{path}: is a directory, not a study store")
        if not path.exists():
            if not create:
                raise InputError(f"{self.run_dir}: no study results here (no {STORE_NAME})")
            if self.run_dir.exists() and not self.run_dir.is_dir():
                raise InputError(f"--out {self.run_dir} is a file; give a directory")
            self.run_dir.mkdir(parents=True, exist_ok=True)
            self.created = True
        else:
            _check_existing(path)
        try:
            self.con = sqlite3.connect(path, timeout=30.0, isolation_level=None)
            if self.created:
                self.con.execute(f"PRAGMA application_id={APPLICATION_ID}")
                self.con.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
                self.con.execute("PRAGMA journal_mode=WAL")
                self.con.executescript(_SCHEMA)
            self.con.execute("PRAGMA synchronous=NORMAL")
        except sqlite3.DatabaseError as exc:
            raise InputError(f"{path}: cannot be opened as a study store ({exc})") from None

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self.con.close()

    # ------------------------------------------------------------------ meta
    def meta(self) -> dict[str, Any]:
        return {k: json.loads(v) for k, v in self.con.execute("SELECT key, value FROM meta")}

    def init_meta(self, values: Mapping[str, Any]) -> None:
        """Write the study's metadata once; a store of another study refuses to be reused."""
        old = self.meta()
        if old and old.get("study_id") != values["study_id"]:
            raise InputError(
                f"{self.run_dir} holds another study (id {old.get('study_id')}, this one is {values['study_id']}); "
                "use another --out directory"
            )
        if old:
            if old.get("version") != values.get("version"):
                log.warning(
                    "%s was started with offroadbench %s, resuming with %s",
                    self.run_dir,
                    old.get("version"),
                    values.get("version"),
                )
            return
        with self.con:
            self.con.execute("BEGIN")
            self.con.executemany(
                "INSERT INTO meta (key, value) VALUES (?, ?)",
                [(k, json.dumps(v, sort_keys=True)) for k, v in values.items()],
            )

    # ------------------------------------------------------------------ results
    def add_terrain(self, cell: int, terrain: int, terrain_seed: int, stats: Mapping[str, Any]) -> None:
        self.con.execute(
            "INSERT OR IGNORE INTO terrains (cell, terrain, terrain_seed, stats) VALUES (?, ?, ?, ?)",
            (cell, terrain, terrain_seed, json.dumps(dict(stats), sort_keys=True)),
        )

    def add_trial(self, cell: int, terrain: int, mission: int, terrain_seed: int, mission_seed: int, row: Mapping,
                  run_id: int | None = None) -> bool:
        """Commit one trial at once. Returns False (and stores nothing) if it was already there.

        With ``run_id`` the session's ``trials_run`` counter is raised in the same transaction, so
        a process killed at any instant leaves the counters summing to the stored trials.
        """
        text = json.dumps(dict(row))
        self.con.execute("BEGIN IMMEDIATE")
        try:
            cur = self.con.execute(
                "INSERT OR IGNORE INTO trials (cell, terrain, mission, terrain_seed, mission_seed, success, row) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                (cell, terrain, mission, terrain_seed, mission_seed, int(bool(row["success"])), text),
            )
            if cur.rowcount and run_id is not None:
                self.con.execute("UPDATE runs SET finished=?, trials_run=trials_run+1 WHERE id=?", (time.time(), run_id))
            self.con.execute("COMMIT")
        except BaseException:
            self.con.execute("ROLLBACK")
            raise
        if cur.rowcount == 0:
            (old,) = self.con.execute(
                "SELECT row FROM trials WHERE cell=? AND terrain=? AND mission=?", (cell, terrain, mission)
            ).fetchone()
            if old != text:
                log.warning("trial (%d, %d, %d) ran twice with different results", cell, terrain, mission)
            return False
        return True

    def done_trials(self) -> set[tuple[int, int, int]]:
        return {tuple(r) for r in self.con.execute("SELECT cell, terrain, mission FROM trials")}

    def trial_rows(self) -> list[tuple]:
        return self.con.execute(
            "SELECT cell, terrain, mission, terrain_seed, mission_seed, row FROM trials ORDER BY cell, terrain, mission"
        ).fetchall()

    def terrain_rows(self) -> list[tuple]:
        return self.con.execute(
            "SELECT cell, terrain, terrain_seed, stats FROM terrains ORDER BY cell, terrain"
        ).fetchall()

    def counts(self) -> tuple[int, int]:
        """(trials stored, successes among them)."""
        n, s = self.con.execute("SELECT COUNT(*), COALESCE(SUM(success), 0) FROM trials").fetchone()
        return int(n), int(s)

    # ------------------------------------------------------------------ run sessions
    def start_run(self, executor: str, workers: int, version: str) -> int:
        cur = self.con.execute(
            "INSERT INTO runs (started, executor, workers, status, host, machine, version) "
            "VALUES (?, ?, ?, 'running', ?, ?, ?)",
            (time.time(), executor, workers, platform.node(), machine_description(), version),
        )
        return int(cur.lastrowid)

    def finish_run(self, run_id: int, status: str) -> None:
        """Close a session. Its ``trials_run`` was counted by :meth:`add_trial`, trial by trial."""
        self.con.execute("UPDATE runs SET finished=?, status=? WHERE id=?", (time.time(), status, run_id))

    def runs(self) -> list[dict[str, Any]]:
        cur = self.con.execute("SELECT * FROM runs ORDER BY id")
        names = [d[0] for d in cur.description]
        return [dict(zip(names, r)) for r in cur.fetchall()]


def _check_existing(path: Path) -> None:
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
        for q, was in zip(sides, existed):
            if not was:
                q.unlink(missing_ok=True)


def remove_store(run_dir: str | Path) -> None:
    """Delete ``study.sqlite`` and its WAL files (for a study that failed before any trial)."""
    p = store_path(run_dir)
    for q in (p, p.with_name(p.name + "-wal"), p.with_name(p.name + "-shm"), p.with_name(p.name + "-journal")):
        q.unlink(missing_ok=True)


def machine_description() -> str:
    """CPU model, core count and OS of this machine, e.g. ``AMD EPYC, 2 cores, Linux 6.1``."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"

