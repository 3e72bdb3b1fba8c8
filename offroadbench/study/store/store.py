"""Crash-safe, resumable result store of a study: one SQLite file in the run directory.

Tables (``study.sqlite``):

* ``meta(key, value)``: the study config (JSON and the TOML text it came from), the study id,
  the resolved grid cells (recipe data, settings tables, seed keys, and each cell's resolved
  ``trial_settings``: offroadbench.sim.trial.pipeline.TrialSettings.to_dict, recorded when the
  store is made, read by the report through ``CellPlan.from_meta``; a store made before they were
  kept has none, and its cells' settings are built from the tables), the package version that
  created the store.
* ``terrains(cell, terrain, terrain_seed, stats)``: one row per built terrain; ``stats`` is JSON
  (class area fractions of Sec. 2.4, missions sampled, build time).
* ``trials(cell, terrain, mission, terrain_seed, mission_seed, success, row, telemetry, run_id)``:
  one row per finished trial; ``row`` is the JSON of ``TrialResult.as_row()``; ``telemetry`` is
  the JSON list of the trial's telemetry files (relative to the run directory; ``[]`` when none
  was kept; NULL in stores of schema 1); ``run_id`` is the session that ran it.
* ``runs``: one row per ``study run`` session (start, end, executor, workers, trials run, host,
  version, and since schema 2 the ``platform`` fingerprint of :mod:`offroadbench.study.fingerprint`
  as JSON): the wall time of the study, and the platforms its trials came from, are read here.

Schema versions. 1: the tables above without ``trials.telemetry``, ``trials.run_id`` and
``runs.platform`` and ``runs.error``. 2: with them (``error``: the one-line reason a failed
session stopped, e.g. a plug-in fault). A run (``Store(..., create=True)``) migrates a schema-1 store in
place (three ``ALTER TABLE ... ADD COLUMN``, in one transaction); readers accept both. The
cells' ``trial_settings`` are a meta value, not a schema change: any schema-2 reader opens a store
with or without them.

Safety. Only the coordinating process writes, and only while it holds the run directory's lock
(:class:`RunLock`: ``fcntl.flock`` on ``study.lock``, released by the kernel when the process
dies), so two runs never share a store. A new store is built under a temporary name and linked
into place complete (a killed or failed creation leaves no ``study.sqlite``). Every trial is its
own transaction, committed the moment its result arrives, after its telemetry files are written
(the row names them), so a stored trial's telemetry exists; the primary key (cell, terrain,
mission) makes a second copy impossible. WAL journal with ``synchronous=NORMAL``: a killed process (SIGKILL included)
loses no committed row and leaves a consistent database; only a power cut may lose the last
few commits. A trial that was in flight when the process died has no row, so the next run
does it again.

The lock is :mod:`offroadbench.study.store.lock`; the file (schema, checks, removal) is
:mod:`offroadbench.study.store.file`; its creation, migration and rollback are
:mod:`offroadbench.study.store.writes`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import platform
import sqlite3
import time
from pathlib import Path
from typing import Any, Mapping

from offroadbench.errors import InputError
from offroadbench.study.store.integrity import TRUSTED_SCHEMA_OFF, check_store
from offroadbench.study.store.lock import LOCK_NAME, RunDirLocked, RunLock, lock_holder_alive
from offroadbench.study.store.file import (SCHEMA_VERSION, STORE_NAME, FAULTS_SQL, check_existing, make_reserve,
                                           nearly_full, release_reserve, remove_stale_temp_files, remove_store,
                                           store_path)
from offroadbench.study.store.writes import create_store, migrate, rollback

log = logging.getLogger(__name__)

__all__ = ["LOCK_NAME", "SCHEMA_VERSION", "STORE_NAME", "RunDirLocked", "RunLock", "Store", "remove_stale_temp_files",
           "remove_store", "store_path"]


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
        if create and path.is_file() and path.stat().st_size == 0:
            # left by an offroadbench older than atomic creation: it holds nothing; a run (which
            # holds the directory's lock) replaces it
            log.warning("%s: is empty (a store whose creation failed); making a new one", path)
            path.unlink()
        if not path.exists():
            if not create:
                raise InputError(f"{self.run_dir}: no study results here (no {STORE_NAME})")
            if self.run_dir.exists() and not self.run_dir.is_dir():
                raise InputError(f"--out {self.run_dir} is a file; give a directory")
            self.run_dir.mkdir(parents=True, exist_ok=True)
            self.created = create_store(path)
            if not self.created:  # another process linked its store in first
                check_existing(path)
        else:
            check_existing(path)
        check_store(path)  # data only, every value decodes (issue 44); read-only, before any write
        try:
            self.con = sqlite3.connect(path, timeout=30.0, isolation_level=None)
            self.con.execute(TRUSTED_SCHEMA_OFF)
            self.con.execute("PRAGMA synchronous=NORMAL")
            if create:
                migrate(self.con, self.path)
            self.columns = {t: {r[1] for r in self.con.execute(f"PRAGMA table_info({t})")} for t in ("trials", "runs")}
        except sqlite3.DatabaseError as exc:
            if self.created:  # ours and empty: a failure here is the device's (a full disk), not the file's
                con = getattr(self, "con", None)
                if con is not None:
                    with contextlib.suppress(sqlite3.Error):
                        con.close()
                remove_store(self.run_dir)
                why = "no space left on the device" if nearly_full(self.run_dir) else str(exc)
                raise InputError(f"{path}: cannot create the study store ({why})") from None
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

    def init_meta(self, values: Mapping[str, Any]) -> list[str]:
        """Write the study's metadata once; a store of another configuration refuses to be reused.

        ``values["trial_inputs"]`` (:func:`offroadbench.study.spec.inputs.trial_inputs`) decides: a
        resume whose resolved inputs differ from the stored ones is refused with one line naming
        what changed (a soil, the vehicle or its URDF, a plug-in's version, the engine ...). A
        store made before trial inputs were recorded falls back to the study id, and a refusal
        names the study keys that differ. A change that leaves every input equal (a description,
        a comment, a ``[reference]`` table, a default written out) is accepted: the new study
        config replaces the stored one and ``meta.amendments`` records when and what changed.
        Returns those changed keys ([] when nothing changed)."""
        from offroadbench.study.spec.inputs import COSMETIC_STUDY_KEYS, changed_inputs, changed_study_keys

        old = self.meta()
        if not old:
            self._write_meta(values)
            return []
        from offroadbench.study.stats.plan import check_unchanged

        # the [analysis] plan (issue 29) is fixed once a trial is stored; before, it may change
        check_unchanged(old, values, self.counts()[0], str(self.run_dir))
        keys = changed_study_keys(old.get("study") or {}, values.get("study") or {})
        if "trial_inputs" in old and "trial_inputs" in values:
            diffs = changed_inputs(old["trial_inputs"], values["trial_inputs"])
            if diffs:
                raise InputError(f"{self.run_dir} holds another study (its trials ran with another configuration; "
                                 f"changed: {'; '.join(diffs)}); undo the change to resume, or use another --out "
                                 "directory")
        elif old.get("study_id") != values["study_id"]:
            real = [k for k in keys if k.split(".")[0] not in (*COSMETIC_STUDY_KEYS, "analysis")]
            old_recipes = [c.get("recipe") for c in old.get("cells", [])]
            new_recipes = [c.get("recipe") for c in values.get("cells", [])]
            if real or old_recipes != new_recipes:
                what = ", ".join(real[:5]) + (f" and {len(real) - 5} more" if len(real) > 5 else "")
                if old_recipes != new_recipes:
                    what = f"{what}, the resolved recipe" if what else "the resolved recipe (a preset or recipe file changed)"
                raise InputError(
                    f"{self.run_dir} holds another study (id {old.get('study_id')}, this one is {values['study_id']}; "
                    f"changed: {what}); use another --out directory")
        if old.get("version") != values.get("version"):
            log.warning("%s was started with offroadbench %s, resuming with %s", self.run_dir,
                        old.get("version"), values.get("version"))
        update: dict[str, Any] = {}
        if "trial_inputs" not in old and "trial_inputs" in values:
            update["trial_inputs"] = values["trial_inputs"]  # recorded from this run on
        changed = keys or (["the study TOML's text (comments, layout)"]
                           if old.get("study_toml") != values.get("study_toml") else [])
        if changed:
            log.warning("%s: the study changed only cosmetically (%s); resuming and recording the change",
                        self.run_dir, ", ".join(changed))
            amendments = list(old.get("amendments") or [])
            amendments.append({"time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "changed": changed,
                               "previous_study_id": old.get("study_id")})
            update.update({k: values[k] for k in ("study", "study_toml", "study_id") if k in values})
            update["amendments"] = amendments
        if update:
            self._write_meta(update)
        return changed

    def _write_meta(self, values: Mapping[str, Any]) -> None:
        self.con.execute("BEGIN IMMEDIATE")
        try:
            self.con.executemany("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)",
                                 [(k, json.dumps(v, sort_keys=True)) for k, v in values.items()])
            self.con.execute("COMMIT")
        except BaseException as exc:
            rollback(self.con, exc, self.path)

    # ------------------------------------------------------------------ results
    def add_terrain(self, cell: int, terrain: int, terrain_seed: int, stats: Mapping[str, Any]) -> None:
        self._write("INSERT OR IGNORE INTO terrains (cell, terrain, terrain_seed, stats) VALUES (?, ?, ?, ?)",
                    (cell, terrain, terrain_seed, json.dumps(dict(stats), sort_keys=True)))

    @contextlib.contextmanager
    def transaction(self):
        """``with store.transaction() as con:`` the statements run on ``con`` commit together, or none
        does (rolled back on any error; a full disk is an OSError naming the store)."""
        self.con.execute("BEGIN IMMEDIATE")
        try:
            yield self.con
            self.con.execute("COMMIT")
        except BaseException as exc:
            rollback(self.con, exc, self.path)

    def _write(self, sql: str, params: tuple = ()) -> sqlite3.Cursor:
        """One statement in its own transaction; a full disk is an OSError naming the store."""
        try:
            return self.con.execute(sql, params)
        except sqlite3.DatabaseError as exc:
            rollback(self.con, exc, self.path)
            raise  # pragma: no cover - rollback always raises

    def add_trial(self, cell: int, terrain: int, mission: int, terrain_seed: int, mission_seed: int, row: Mapping,
                  run_id: int | None = None, telemetry: list[str] | None = None) -> bool:
        """Commit one trial at once. Returns False (and stores nothing) if it was already there.

        ``telemetry`` lists the trial's telemetry files, relative to the run directory, which the
        caller has written completely before (``[]``: none kept). With ``run_id`` the session's
        ``trials_run`` counter is raised in the same transaction, so a process killed at any
        instant leaves the counters summing to the stored trials.
        """
        text = json.dumps(dict(row))
        files = json.dumps(list(telemetry or []))
        self.con.execute("BEGIN IMMEDIATE")
        try:
            cur = self.con.execute(
                "INSERT OR IGNORE INTO trials (cell, terrain, mission, terrain_seed, mission_seed, success, row, "
                "telemetry, run_id) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (cell, terrain, mission, terrain_seed, mission_seed, int(bool(row["success"])), text, files, run_id),
            )
            if cur.rowcount and run_id is not None:
                self.con.execute("UPDATE runs SET finished=?, trials_run=trials_run+1 WHERE id=?", (time.time(), run_id))
            self.con.execute("COMMIT")
        except BaseException as exc:
            rollback(self.con, exc, self.path)
        if cur.rowcount == 0:
            (old,) = self.con.execute(
                "SELECT row FROM trials WHERE cell=? AND terrain=? AND mission=?", (cell, terrain, mission)
            ).fetchone()
            if old != text:
                log.warning("trial (%d, %d, %d) ran twice with different results", cell, terrain, mission)
            return False
        return True

    def trial(self, cell: int, terrain: int, mission: int) -> tuple[int, int, dict[str, Any]] | None:
        """(terrain seed, mission seed, row) of one stored trial; None if it is not stored."""
        hit = self.con.execute("SELECT terrain_seed, mission_seed, row FROM trials WHERE cell=? AND terrain=? AND "
                               "mission=?", (cell, terrain, mission)).fetchone()
        return None if hit is None else (hit[0], hit[1], json.loads(hit[2]))

    def has_trial(self, cell: int, terrain: int, mission: int) -> bool:
        return self.con.execute("SELECT 1 FROM trials WHERE cell=? AND terrain=? AND mission=?",
                                (cell, terrain, mission)).fetchone() is not None

    def trial_telemetry(self) -> list[tuple[int, int, int, bool, list[str] | None, int | None]]:
        """(cell, terrain, mission, success, telemetry files or None in a schema-1 row, run_id) of every trial."""
        tel = "telemetry" if "telemetry" in self.columns["trials"] else "NULL"
        rid = "run_id" if "run_id" in self.columns["trials"] else "NULL"
        out = []
        for cell, terrain, mission, success, files, run_id in self.con.execute(
                f"SELECT cell, terrain, mission, success, {tel}, {rid} FROM trials ORDER BY cell, terrain, mission"):
            out.append((cell, terrain, mission, bool(success), None if files is None else json.loads(files), run_id))
        return out

    def drop_trials(self, keys: list[tuple[int, int, int, int | None]]) -> None:
        """Delete trials ((cell, terrain, mission, run_id)) so the next run does them again; the
        sessions that ran them count them no more. One transaction."""
        if not keys:
            return
        self.con.execute("BEGIN IMMEDIATE")
        try:
            for cell, terrain, mission, run_id in keys:
                cur = self.con.execute("DELETE FROM trials WHERE cell=? AND terrain=? AND mission=?", (cell, terrain, mission))
                if cur.rowcount and run_id is not None:
                    self.con.execute("UPDATE runs SET trials_run=MAX(trials_run-1, 0) WHERE id=?", (run_id,))
            self.con.execute("COMMIT")
        except BaseException as exc:
            rollback(self.con, exc, self.path)

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
    def start_run(self, executor: str, workers: int, version: str, fingerprint: Mapping[str, Any] | None = None) -> int:
        """Open a session; ``fingerprint`` is the platform the trials of this session run on. The run
        directory's reserve is set aside for :meth:`finish_run`."""
        make_reserve(self.run_dir)
        cur = self._write(
            "INSERT INTO runs (started, executor, workers, status, host, machine, version, platform) "
            "VALUES (?, ?, ?, 'running', ?, ?, ?, ?)",
            (time.time(), executor, workers, platform.node(), machine_description(), version,
             None if fingerprint is None else json.dumps(dict(fingerprint), sort_keys=True)),
        )
        return int(cur.lastrowid)

    def finish_run(self, run_id: int, status: str, error: str | None = None) -> None:
        """Close a session (``error``: why it failed, one line). Its ``trials_run`` was counted by
        :meth:`add_trial`, trial by trial. On a full disk the reserve :meth:`start_run` set aside is
        freed and the write tried once more; if that fails too the session stays open (shown as
        ``killed`` later) and the error that stopped the run is still the one reported."""
        if error is not None and "error" in self.columns["runs"]:
            sql, params = ("UPDATE runs SET finished=?, status=?, error=? WHERE id=?",
                           (time.time(), status, " ".join(error.split())[:2000], run_id))
        else:
            sql, params = "UPDATE runs SET finished=?, status=? WHERE id=?", (time.time(), status, run_id)
        for last in (False, True):
            try:
                self._write(sql, params)
                break
            except (OSError, sqlite3.DatabaseError) as exc:
                if last or not release_reserve(self.run_dir):
                    log.info("%s: could not record the end of session %d (%s)", self.path, run_id, exc)
                    break
        release_reserve(self.run_dir)

    def mark_killed_sessions(self) -> int:
        """Mark every session still ``running`` as ``killed``: call only while holding the run
        directory's lock (no other session can be running then). Returns how many."""
        return self._write("UPDATE runs SET status='killed' WHERE status='running'").rowcount

    def runs(self) -> list[dict[str, Any]]:
        """Every session, oldest first. A session whose process is gone (SIGKILL, power cut) but
        whose row still says ``running`` is shown as ``killed``: when it is not the last session,
        or when it ran on this host and the run directory's lock names no live process."""
        cur = self.con.execute("SELECT * FROM runs ORDER BY id")
        names = [d[0] for d in cur.description]
        out = [dict(zip(names, r, strict=True)) for r in cur.fetchall()]
        for r in out:  # the fingerprint as a dict (None in sessions of schema-1 stores)
            r["platform"] = json.loads(r["platform"]) if r.get("platform") else None
        for i, r in enumerate(out):
            if r.get("status") == "running" and (i < len(out) - 1 or (r.get("host") == platform.node()
                                                                     and not lock_holder_alive(self.run_dir))):
                r["status"] = "killed"
        return out

    # ------------------------------------------------------------------ faults (issue 30)
    def ensure_faults_table(self) -> None:
        """Add the ``faults`` table to a store made before it existed (a run does this)."""
        self._write(FAULTS_SQL.strip().rstrip(";"))

    def add_fault(self, cell: int, terrain: int, mission: int, terrain_seed: int, mission_seed: int, reason: str,
                  run_id: int | None = None) -> bool:
        """Store a trial that could not give an outcome (it ran past its limit, the vehicle was
        thrown while settling, its terrain admits no mission): not a trial row, so no statistic sees it. Returns False if the
        trial is already stored (as a trial or a fault)."""
        if self.has_trial(cell, terrain, mission):
            return False
        cur = self._write(
            "INSERT OR IGNORE INTO faults (cell, terrain, mission, terrain_seed, mission_seed, reason, run_id, time) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            (cell, terrain, mission, terrain_seed, mission_seed, " ".join(str(reason).split())[:2000], run_id,
             time.time()))
        return bool(cur.rowcount)

    def has_faults_table(self) -> bool:
        return self.con.execute("SELECT 1 FROM sqlite_master WHERE type='table' AND name='faults'").fetchone() is not None

    def fault_rows(self) -> list[tuple]:
        """(cell, terrain, mission, terrain_seed, mission_seed, reason, run_id) of every fault."""
        if not self.has_faults_table():
            return []
        return self.con.execute("SELECT cell, terrain, mission, terrain_seed, mission_seed, reason, run_id FROM faults "
                                "ORDER BY cell, terrain, mission").fetchall()

    def faulted_trials(self) -> set[tuple[int, int, int]]:
        return {tuple(r[:3]) for r in self.fault_rows()}

    def clear_faults(self) -> int:
        """Forget every fault, so the next run tries those trials again (``--retry-faults``)."""
        if not self.has_faults_table():
            return 0
        return self._write("DELETE FROM faults").rowcount


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

