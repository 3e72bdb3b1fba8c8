"""`offroadbench vehicle check`: table and JSON output, exit status from the rows."""

from __future__ import annotations

import json

import pytest

from offroadbench.cli import main
from offroadbench.sim.rigs.vehicle_check import CheckResult

ROWS = [CheckResult("yaw rate in place, heading 0 deg, command 1 rad/s", 0.98, 1.0, "rad/s", True, "0.85-1.1 x expected"),
        CheckResult("static tip angle (tilt table)", 56.0, 56.7, "deg", True, "within 2 deg", "geometric"),
        CheckResult("steepest grade climbed from rest", 37.5, 38.7, "deg", True, "within 4 deg",
                    "the sheet's 45 deg assumes more grip", sheet=45.0)]


@pytest.fixture
def fake_check(monkeypatch):
    calls = []

    def check(spec, sim, progress=None):
        calls.append((spec.name, sim.tyre_model))
        return list(ROWS)

    monkeypatch.setattr("offroadbench.sim.rigs.vehicle_check.check_vehicle", check)
    return calls


def test_json_lists_the_rows(fake_check, capsys):
    assert main(["vehicle", "check", "jackal", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [d["name"] for d in out] == [r.name for r in ROWS]
    assert {"name", "measured", "expected", "sheet", "unit", "ok"} <= set(out[0]) and out[1]["measured"] == 56.0
    assert out[2]["sheet"] == 45.0 and out[0]["sheet"] is None
    assert fake_check == [("jackal", "coulomb")]


def test_table_and_failing_row_exit_status(fake_check, monkeypatch, capsys):
    ROWS.append(CheckResult("highest step climbed at cruise speed", 0.05, 0.13, "m", False, "0.6-1.05 x expected"))
    try:
        assert main(["vehicle", "check", "husky", "--tyre-model", "bullet"]) == 1
    finally:
        ROWS.pop()
    out = capsys.readouterr().out
    assert "static tip angle" in out and "FAIL" in out and "3 of 4 figures within tolerance" in out
    climb = next(line for line in out.splitlines() if line.startswith("steepest grade"))
    assert "38.700" in climb and " 45 " in climb and " ok " in climb
    assert fake_check == [("husky", "bullet")]


def test_unknown_vehicle_is_an_input_error(capsys):
    assert main(["vehicle", "check", "tank"]) == 2
    assert "tank" in capsys.readouterr().err
