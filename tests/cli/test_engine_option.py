"""``--engine`` where a user drives (issue 25): ``drive`` and ``vehicle check`` on MuJoCo."""

import importlib.util
import json

import pandas as pd
import pytest

from offroadbench.cli import main

SMALL = ["--set", "grid.rows=301", "--set", "grid.cols=301", "--length-m", "3", "--seed", "2"]
needs_mujoco = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")


@needs_mujoco
def test_drive_on_mujoco_drives_the_same_missions(tmp_path, capsys):
    for engine in ("pybullet", "mujoco"):
        assert main(["drive", "paper-d2.3", *SMALL, "--missions", "2", "--engine", engine,
                     "--out", str(tmp_path / engine)]) == 0
        assert f"physics {engine} 60 Hz" in capsys.readouterr().out
    a, b = (pd.read_csv(tmp_path / e / "trials.csv") for e in ("pybullet", "mujoco"))
    cols = ["mission_seed", "start_x_m", "start_y_m", "goal_x_m", "goal_y_m"]
    pd.testing.assert_frame_equal(a[cols], b[cols])


def test_unknown_engine_is_one_line_and_exit_2(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["drive", "paper-d2.3", *SMALL, "--engine", "bulet", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "engine" in err[0] and "pybullet" in err[0]
    assert not out.exists()
    assert main(["vehicle", "check", "husky", "--engine", "bulet"]) == 2


@needs_mujoco
def test_vehicle_check_on_mujoco_json(capsys):
    code = main(["vehicle", "check", "jackal", "--engine", "mujoco", "--json"])
    rows = json.loads(capsys.readouterr().out)
    assert code == 0 and rows and all(r["ok"] for r in rows)
