"""A study store is data only (issue 44): a store holding a trigger, a view or any object the
schemas do not make is refused with one line and left byte-identical; every connection runs with
``trusted_schema = OFF``; a value that does not decode makes "a corrupt study store", one line."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from offroadbench.errors import InputError
from offroadbench.study import load, load_meta, load_terrains, run_study
from offroadbench.study.store.store import Store
from tests.study.test_run import fake_trials, study_and_cells


@pytest.fixture
def run_dir(tmp_path) -> Path:
    """A complete small study's run directory (a stand-in for the physics)."""
    study, cells = study_and_cells()
    out = tmp_path / "run"
    run_study(study, cells, out, executor="inline", trial_fn=fake_trials)
    return out


def _tamper(run_dir: Path, *sql: str) -> None:
    con = sqlite3.connect(run_dir / "study.sqlite")
    with con:
        for statement in sql:
            con.execute(statement)
    con.close()


def _files(run_dir: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(run_dir.iterdir()) if p.is_file()}


def _every_reader_refuses(run_dir: Path, match: str) -> None:
    """Opening to run, and each reader (meta, trials, terrains), raise one line matching ``match``."""
    study, cells = study_and_cells()
    for open_ in (lambda: Store(run_dir, create=True), lambda: Store(run_dir), lambda: load(run_dir),
                  lambda: load_meta(run_dir), lambda: load_terrains(run_dir),
                  lambda: run_study(study, cells, run_dir, executor="inline", trial_fn=fake_trials)):
        with pytest.raises(InputError, match=match) as err:
            open_()
        assert "\n" not in str(err.value) and str(run_dir / "study.sqlite") in str(err.value)


# a trigger that rewrites outcomes as they are stored: the audit's 96 of 96 "successful"
TRIGGER = ("CREATE TRIGGER rewrite AFTER INSERT ON trials BEGIN "
           "UPDATE trials SET success = 1 WHERE rowid = NEW.rowid; END")


@pytest.mark.parametrize("sql, match", [
    (TRIGGER, "holds trigger 'rewrite'"),
    ("CREATE VIEW ok AS SELECT * FROM trials WHERE success = 1", "holds view 'ok'"),
    ("CREATE INDEX by_success ON trials (success)", "holds index 'by_success'"),
    ("CREATE TABLE notes (text TEXT)", "holds table 'notes'"),
    ("ALTER TABLE terrains ADD COLUMN area INTEGER GENERATED ALWAYS AS (1) VIRTUAL",
     "table 'terrains' has other columns"),
    ("ALTER TABLE runs ADD COLUMN extra TEXT DEFAULT 'x'", "table 'runs' has other columns"),
])
def test_a_store_holding_more_than_data_is_refused_and_left_byte_identical(run_dir, sql, match):
    _tamper(run_dir, sql)
    before = _files(run_dir)
    _every_reader_refuses(run_dir, match)
    assert _files(run_dir) == before  # no byte changed, no -wal or -shm left


def test_a_trigger_added_to_a_store_never_fires(run_dir):
    """The audit's case end to end: a resume after the trigger was added stores nothing through it."""
    _tamper(run_dir, "DELETE FROM trials WHERE rowid = (SELECT MAX(rowid) FROM trials WHERE success = 0)", TRIGGER)
    study, cells = study_and_cells()
    with pytest.raises(InputError, match="trigger"):
        run_study(study, cells, run_dir, executor="inline", trial_fn=fake_trials)
    con = sqlite3.connect(f"file:{run_dir / 'study.sqlite'}?mode=ro", uri=True)
    assert con.execute("SELECT COUNT(*) FROM trials").fetchone()[0] == study.n_trials - 1
    con.close()


def test_every_store_connection_has_trusted_schema_off(run_dir):
    with Store(run_dir) as store:
        assert store.con.execute("PRAGMA trusted_schema").fetchone() == (0,)


@pytest.mark.parametrize("sql, match", [
    ("UPDATE meta SET value = '{not json' WHERE key = 'study'", r"meta.value of key 'study' cannot be decoded: not JSON"),
    ("UPDATE meta SET value = X'FFFE' WHERE key = 'cells'", "meta.value of key 'cells' cannot be decoded"),
    ("UPDATE trials SET row = '" + "[" * 100_000 + "]" * 100_000 + "' WHERE rowid = 1",
     r"trials.row of rowid 1 cannot be decoded: nested deeper than 64 levels"),
    ("UPDATE trials SET row = '" + "[" * 200 + "]" * 200 + "' WHERE rowid = 2",
     r"trials.row of rowid 2 cannot be decoded: nested deeper than 64 levels"),
    ("UPDATE trials SET row = '[1, 2]' WHERE rowid = 3", "a JSON list, expected a JSON object"),
    ("UPDATE trials SET telemetry = '{\"a\": 1}' WHERE rowid = 1", "trials.telemetry of rowid 1"),
    ("UPDATE terrains SET stats = 'NaN' WHERE rowid = 1", "terrains.stats of rowid 1"),
    ("UPDATE runs SET platform = '{' WHERE rowid = 1", "runs.platform of rowid 1"),
    ("UPDATE trials SET row = 7 WHERE rowid = 1", "a JSON int, expected a JSON object"),  # TEXT affinity: "7"
])
def test_a_value_that_does_not_decode_is_a_corrupt_store(run_dir, sql, match):
    _tamper(run_dir, sql)
    before = _files(run_dir)
    _every_reader_refuses(run_dir, r"is a corrupt study store \(.*" + match)
    assert _files(run_dir) == before


def test_a_store_checked_once_is_checked_again_after_it_changed(run_dir):
    load(run_dir)  # decoded and remembered
    _tamper(run_dir, "UPDATE trials SET row = 'x' WHERE rowid = 1")
    with pytest.raises(InputError, match="corrupt study store"):
        load(run_dir)


def test_a_schema_1_store_passes(run_dir):
    """A store of the previous schema (four columns fewer) is data only too."""
    _tamper(run_dir, "ALTER TABLE trials DROP COLUMN telemetry", "ALTER TABLE trials DROP COLUMN run_id",
            "ALTER TABLE runs DROP COLUMN platform", "ALTER TABLE runs DROP COLUMN error", "DROP TABLE faults")
    assert len(load(run_dir)) > 0


