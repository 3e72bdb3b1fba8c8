"""A study store is data only: the check that an existing ``study.sqlite`` holds nothing that runs
(issue 44), and that every value it keeps as JSON decodes.

A store can be handed over (a run directory copied from a colleague, downloaded with a paper). An
SQLite file can carry more than tables: a trigger runs SQL on every insert (one that rewrites
outcomes as they are stored reported 96 of 96 trials successful, 88 in truth), a view can stand
in for a table, a generated column computes what a reader sees, and a table default can call a
function. None of these is written by offroadbench, so :func:`check_store` refuses a store holding
any object the schemas do not make (a trigger, a view, an index or table of its own, a virtual
table, a table whose columns differ from ours: generated ones, other defaults), before anything is
written to it, and leaves the file byte-identical. Every connection that then uses a store sets
``PRAGMA trusted_schema = OFF`` (:data:`TRUSTED_SCHEMA_OFF`), so that no function with side
effects could run from the schema even so.

Every JSON value (the ``meta`` values, terrain stats, trial rows and telemetry lists, the sessions'
platforms, a search's points) must decode to its kind of value and be nested at most
:data:`MAX_DEPTH` levels deep: a value that is not JSON, or one nested so deeply that decoding it
recurses past Python's limit (RecursionError), makes the store "a corrupt store", one line, from
every command that opens it, rather than a traceback later in whichever reader meets it first.
Decoding costs about 70 us per stored trial (0.7 s for 10,000 trials, once per process: a store
already checked in this process and unchanged since, its file's and write-ahead log's size and
time equal, is not decoded again).

:func:`check_store` is called once, where a store is opened (offroadbench.study.store.store.Store).
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from typing import Any, Callable

from offroadbench.errors import InputError

__all__ = ["MAX_DEPTH", "TRUSTED_SCHEMA_OFF", "check_store"]

#: the statement every store connection runs first: no function the schema names may have side effects
TRUSTED_SCHEMA_OFF = "PRAGMA trusted_schema = OFF"

#: the deepest nesting of a stored JSON value (the store's own are below 10: a cell's settings)
MAX_DEPTH = 64

#: table -> {column: kind of its decoded JSON ("dict", "list", "any"; "?": NULL allowed)}
_JSON_COLUMNS: dict[str, dict[str, str]] = {
    "meta": {"value": "any"},
    "terrains": {"stats": "dict"},
    "trials": {"row": "dict", "telemetry": "list?"},
    "runs": {"platform": "dict?"},
    "search_trials": {"x": "list", "z": "list"},
}


_SEARCH_TABLES = ("search_trials",)

#: (path, stat of the file and its write-ahead log) of the stores whose values decoded
_decoded: set[tuple] = set()


def check_store(path: str | Path) -> None:
    """Refuse (InputError, one line naming ``path``) a store holding an object the schemas do not
    make, or a JSON value that does not decode; read-only, and the side files (``-wal``, ``-shm``)
    that reading creates are removed, so a refused store is left byte-identical. Call after the
    file is known to be an SQLite store (offroadbench.study.store.file._check_existing)."""
    path = Path(path)
    sides = [path.with_name(path.name + suffix) for suffix in ("-wal", "-shm")]
    existed = [q.exists() for q in sides]
    key = _state(path)  # before reading, which may create the side files
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=30.0)
        try:
            con.execute(TRUSTED_SCHEMA_OFF)
            _check_objects(con, path)
            if key not in _decoded:
                _check_values(con, path)
                _decoded.add(key)
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{path}: is a corrupt study store ({exc}); restore it from a copy or use another "
                         "directory") from None
    finally:
        for q, was in zip(sides, existed, strict=True):
            if not was:
                q.unlink(missing_ok=True)


def _state(path: Path) -> tuple:
    def stat(p: Path) -> tuple:
        try:
            st = p.stat()
        except OSError:
            return ()
        return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns

    return str(path.resolve()), stat(path), stat(path.with_name(path.name + "-wal"))


def _reference(search: bool) -> sqlite3.Connection:
    """An in-memory database of the schemas: the objects and columns a store may have."""
    from offroadbench.study.store.file import SCHEMA_SQL, SEARCH_TABLE

    ref = sqlite3.connect(":memory:")
    ref.executescript(SCHEMA_SQL)
    if search:
        ref.executescript(SEARCH_TABLE)
    return ref


def _objects(con: sqlite3.Connection) -> dict[str, tuple[str, str, str]]:
    return {name: (kind, table, sql or "") for kind, name, table, sql in
            con.execute("SELECT type, name, tbl_name, sql FROM sqlite_master")}


def _columns(con: sqlite3.Connection, table: str) -> list[tuple]:
    """(name, declared type, not null, default, primary key position, hidden) of each column."""
    return [tuple(r[1:]) for r in con.execute(f'PRAGMA table_xinfo("{table}")')]


def _check_objects(con: sqlite3.Connection, path: Path) -> None:
    from offroadbench.study.store.file import SCHEMA2_COLUMNS

    have = _objects(con)
    ref = _reference(search=any(name in have for name in _SEARCH_TABLES))
    try:
        allowed = _objects(ref)
        # a store's tables are ours or missing (older stores lack faults, a study lacks a search's)
        stray = [(kind, name) for name, (kind, table, _) in have.items()
                 if name not in allowed or allowed[name][:2] != (kind, table)]
        if stray:
            what = ", ".join(f"{k} {n!r}" for k, n in sorted(stray)[:3]) + (
                f" and {len(stray) - 3} more" if len(stray) > 3 else "")
            raise InputError(f"{path}: holds {what}, which no offroadbench store has (a store is data only: "
                             "triggers, views and other objects could change what is stored or read); refused and "
                             "left as it is")
        for name, (kind, _, sql) in have.items():
            if kind != "table" or name.startswith("sqlite_"):
                continue
            if not sql.lstrip().upper().startswith("CREATE TABLE"):
                raise InputError(f"{path}: its table {name!r} is not a plain table ({sql.split('(')[0].strip()}); "
                                 "a store is data only; refused and left as it is")
            optional = {c for c, _ in SCHEMA2_COLUMNS.get(name, ())}
            got = _columns(con, name)
            names = {c[0] for c in got}
            want = [c for c in _columns(ref, name) if c[0] in names or c[0] not in optional]
            if got != want:
                raise InputError(f"{path}: its table {name!r} has other columns than a study store's (got "
                                 f"{', '.join(c[0] for c in got)}; generated columns and other defaults are not "
                                 "data); refused and left as it is")
    finally:
        ref.close()


def _check_values(con: sqlite3.Connection, path: Path) -> None:
    tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    for table, columns in _JSON_COLUMNS.items():
        if table not in tables:
            continue
        present = {c[0] for c in _columns(con, table)}
        for column, kind in columns.items():
            if column not in present:
                continue  # a schema-1 store
            label = "key" if table == "meta" else "rowid"
            for key, text in con.execute(f'SELECT {label}, "{column}" FROM "{table}"'):
                if text is None and kind.endswith("?"):
                    continue
                why = _undecodable(text, kind.rstrip("?"))
                if why:
                    where = f"{table}.{column} of {label} {key!r}"
                    raise InputError(f"{path}: is a corrupt study store ({where} cannot be decoded: {why}); restore "
                                     "it from a copy or use another directory")


_KINDS: dict[str, Callable[[Any], bool]] = {
    "dict": lambda v: isinstance(v, dict),
    "list": lambda v: isinstance(v, list),
    "any": lambda v: True,
}


def _undecodable(text: Any, kind: str) -> str:
    """Why ``text`` is not a stored JSON value of ``kind`` ("" if it is)."""
    if not isinstance(text, (str, bytes)):
        return f"a {type(text).__name__}, not JSON text"
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError:
            return "not UTF-8 text"
    try:
        value = json.loads(text)
    except RecursionError:
        return f"nested deeper than {MAX_DEPTH} levels"
    except ValueError as exc:
        return f"not JSON ({' '.join(str(exc).split())[:80]})"
    if text.count("[") + text.count("{") > MAX_DEPTH and _depth(value) > MAX_DEPTH:
        return f"nested deeper than {MAX_DEPTH} levels"
    if not _KINDS[kind](value):
        return f"a JSON {type(value).__name__}, expected a JSON {'object' if kind == 'dict' else 'array'}"
    return ""


def _depth(value: Any) -> int:
    """How deeply lists and dicts nest in a decoded JSON value (without recursion)."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, (list, dict)):
            deepest = max(deepest, d)
            if d > MAX_DEPTH:
                return d
            stack.extend((x, d + 1) for x in (v.values() if isinstance(v, dict) else v))
    return deepest

