"""``offroadbench study replay``: a stored trial replays; a replay that differs says where and exits 1."""

from __future__ import annotations

import json
import sqlite3

import pytest

from offroadbench.cli import main


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory, write_tiny_study):
    """A stored run of the tiny study: 2 cells x 1 terrain x 1 mission."""
    tmp = tmp_path_factory.mktemp("replay")
    study = write_tiny_study(tmp, name="replay", root_seed=3, terrains=1, missions=1)
    assert main(["study", "run", str(study), "--out", str(tmp / "run"), "--workers", "1", "--no-report"]) == 0
    return tmp / "run"


def _stored_row(run_dir, cell: int) -> dict:
    with sqlite3.connect(run_dir / "study.sqlite") as con:
        return json.loads(con.execute("SELECT row FROM trials WHERE cell=? AND terrain=0 AND mission=0", (cell,)).fetchone()[0])


def test_replay_of_an_unchanged_row_is_identical(tiny_run, capsys):
    assert main(["study", "replay", str(tiny_run), "--cell", "0", "--terrain", "0", "--mission", "0"]) == 0
    assert "identical to the stored row: yes" in capsys.readouterr().out


def test_replay_that_differs_names_the_fields_and_exits_1(tiny_run, capsys):
    row = _stored_row(tiny_run, 1)
    row["rms_pitch_rate_deg_s"] = row["rms_pitch_rate_deg_s"] + 1.0  # as if the code had changed since the run
    with sqlite3.connect(tiny_run / "study.sqlite") as con:
        con.execute("UPDATE trials SET row=? WHERE cell=1 AND terrain=0 AND mission=0", (json.dumps(row),))
    assert main(["study", "replay", str(tiny_run), "--cell", "1", "--terrain", "0", "--mission", "0"]) == 1
    captured = capsys.readouterr()
    assert "identical to the stored row: NO" in captured.out
    assert captured.err.strip() == "differs in: rms_pitch_rate_deg_s"


def test_a_row_stored_before_a_column_was_added_replays_identical_and_names_the_column(tiny_run, capsys):
    """A run stored before TrialResult gained a column (``dropped_contacts``, 2026-11-29) still replays as
    identical on the fields it has; the newer column is named, not compared. A stored field the new row
    lacks is a difference."""
    original = _stored_row(tiny_run, 0)
    row = dict(original)
    assert "dropped_contacts" in row
    del row["dropped_contacts"]
    with sqlite3.connect(tiny_run / "study.sqlite") as con:
        con.execute("UPDATE trials SET row=? WHERE cell=0 AND terrain=0 AND mission=0", (json.dumps(row),))
    assert main(["study", "replay", str(tiny_run), "--cell", "0", "--terrain", "0", "--mission", "0"]) == 0
    out = capsys.readouterr().out
    assert "identical to the stored row: yes" in out
    assert "not in the stored row (columns newer than the run, not compared): dropped_contacts" in out
    row["a_column_since_removed"] = 1.0
    with sqlite3.connect(tiny_run / "study.sqlite") as con:
        con.execute("UPDATE trials SET row=? WHERE cell=0 AND terrain=0 AND mission=0", (json.dumps(row),))
    assert main(["study", "replay", str(tiny_run), "--cell", "0", "--terrain", "0", "--mission", "0"]) == 1
    assert capsys.readouterr().err.strip() == "differs in: a_column_since_removed"
    with sqlite3.connect(tiny_run / "study.sqlite") as con:  # as stored, for the module's other tests
        con.execute("UPDATE trials SET row=? WHERE cell=0 AND terrain=0 AND mission=0", (json.dumps(original),))


def test_replay_plot_follows_the_output_path_policy(tiny_run, tmp_path, capsys):
    """``--out`` is checked before the replay (a path below a file: exit 2, nothing written) and
    its missing folders are created only when the figure is written."""
    blocker = tmp_path / "file"
    blocker.write_text("x")
    args = ["study", "replay", str(tiny_run), "--cell", "0", "--terrain", "0", "--mission", "0", "--plot"]
    assert main([*args, "--out", str(blocker / "replays")]) == 2
    captured = capsys.readouterr()
    assert "is a file, not a directory" in captured.err and captured.out == ""
    out = tmp_path / "new" / "replays"
    assert main([*args, "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["cell0_terrain0_mission0.parquet", "cell0_terrain0_mission0.png"]
