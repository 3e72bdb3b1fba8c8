"""The writes of a study's store that are not one result's: making a new ``study.sqlite`` complete or
not at all (:func:`create_store`), bringing a schema-1 store to the current schema (:func:`migrate`),
and the rollback every failed write of :class:`~offroadbench.study.store.store.Store` ends in
(:func:`rollback`: it never masks why the write failed; a full disk is one OSError naming the store).

The schema itself (tables, versions, the columns schema 2 added) is offroadbench.study.store.file;
the guarantees these keep are stated in offroadbench.study.store.store.
"""

from __future__ import annotations

import errno
import logging
import os
import sqlite3
import tempfile
from pathlib import Path

from offroadbench.errors import InputError, StudyError
from offroadbench.io.atomic import current_umask
from offroadbench.study.store.file import APPLICATION_ID, SCHEMA_SQL, SCHEMA_VERSION, SCHEMA2_COLUMNS
from offroadbench.study.store.lock import error_reason

log = logging.getLogger(__name__)

__all__ = ["create_store", "migrate", "rollback"]


def rollback(con: sqlite3.Connection, exc: BaseException, path: Path) -> None:
    """Roll back after ``exc`` and raise it, never masking it: SQLite may have rolled the
    transaction back itself (on SQLITE_FULL), and a ROLLBACK's own "cannot rollback - no
    transaction is active" must not replace "database or disk is full". A full disk becomes an
    OSError(ENOSPC) naming the store (the CLI's one line); other errors are re-raised."""
    try:
        if con.in_transaction:
            con.execute("ROLLBACK")
    except sqlite3.Error as rexc:
        log.info("%s: rollback after %s failed: %s", path, exc, rexc)
    if isinstance(exc, sqlite3.DatabaseError):
        text = str(exc).lower()
        if "full" in text:
            raise OSError(errno.ENOSPC, "No space left on device", str(path)) from None
        if "disk i/o" in text:  # e.g. a file-size limit, or a failing device
            raise StudyError(f"{path}: the study store could not be written (disk I/O error: a full disk, a "
                             "file-size limit or a failing device); what was committed before is kept") from None
    raise exc


def create_store(path: Path) -> bool:
    """Build an empty store of the current schema under a temporary name beside ``path`` and link
    it into place. Returns False if ``path`` appeared meanwhile (it is left alone). A failure (a
    full disk) raises an InputError naming the path and leaves no file behind."""
    tmp = None
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        os.close(fd)
        tmp = Path(name)
        con = sqlite3.connect(tmp, isolation_level=None)
        try:
            con.execute(f"PRAGMA application_id={APPLICATION_ID}")
            con.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
            con.execute("PRAGMA journal_mode=WAL")  # kept in the file header
            con.executescript(SCHEMA_SQL)
        finally:
            con.close()  # checkpoints and removes the temporary -wal/-shm
        os.chmod(tmp, 0o666 & ~current_umask())
        try:
            os.link(tmp, path)  # never replaces: a store made meanwhile by someone else wins
        except FileExistsError:
            return False
        return True
    except OSError as exc:
        raise InputError(f"{path}: cannot create the study store ({error_reason(exc)})") from None
    except sqlite3.DatabaseError as exc:
        if "full" in str(exc).lower():
            raise InputError(f"{path}: cannot create the study store (no space left on the device)") from None
        raise InputError(f"{path}: cannot create the study store ({exc})") from None
    finally:
        if tmp is not None:
            for q in (tmp, tmp.with_name(tmp.name + "-wal"), tmp.with_name(tmp.name + "-shm"),
                      tmp.with_name(tmp.name + "-journal")):
                q.unlink(missing_ok=True)


def migrate(con: sqlite3.Connection, path: Path) -> None:
    """Bring a schema-1 store to schema 2 (new nullable columns), in one transaction."""
    (version,) = con.execute("PRAGMA user_version").fetchone()
    if version >= SCHEMA_VERSION:
        return
    con.execute("BEGIN IMMEDIATE")
    try:
        for table, columns in SCHEMA2_COLUMNS.items():
            have = {r[1] for r in con.execute(f"PRAGMA table_info({table})")}
            for name, kind in columns:
                if name not in have:
                    con.execute(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")
        con.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        con.execute("COMMIT")
    except BaseException as exc:
        rollback(con, exc, path)
    log.info("%s: store schema %d migrated to %d", path, version, SCHEMA_VERSION)
