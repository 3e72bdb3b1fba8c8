"""``offroadbench drive``: table, summary, CSV and figures; bad input exits 2 with no output."""

import pandas as pd

from offroadbench.cli import main

SMALL = ["--set", "grid.rows=301", "--set", "grid.cols=301", "--length-m", "4", "--seed", "2"]


def test_drive_writes_csv_figures_and_prints_summary(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["drive", "paper-d2.3", *SMALL, "--missions", "2", "--out", str(out), "--plot"]) == 0
    text = capsys.readouterr().out
    assert "success rate" in text and "rms_pitch_rate" in text
    df = pd.read_csv(out / "trials.csv")
    assert list(df["mission_index"]) == [0, 1]
    # the seeds of terrain 0 of root seed 2 (offroadbench.seeding), shown for every trial
    from offroadbench.seeding import mission_seed, terrain_seed

    assert list(df["terrain_seed"]) == [terrain_seed(2, 0)] * 2
    assert list(df["mission_seed"]) == [mission_seed(2, 0, 0), mission_seed(2, 0, 1)]
    # the label names the preset with its --set overrides (issue 33): a changed terrain is not the preset
    assert f"paper-d2.3 + grid.rows=301, grid.cols=301 seed {terrain_seed(2, 0)}" in text
    assert {"success", "failure_reason", "traversal_time_s", "rms_vertical_accel_m_s2"} <= set(df.columns)
    for name in ("missions.png", "trajectories.png", "timeseries.png", "telemetry/mission_000.parquet"):
        assert (out / name).stat().st_size > 0
    # units in every header of the per-mission table
    header = next(line for line in text.splitlines() if line.split()[:2] == ["mission", "outcome"])
    assert header.split()[2:] == ["time_s", "path_m", "max_roll_deg", "max_pitch_deg", "rms_az_m_s2",
                                  "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s", "max_pen_mm"]
    from offroadbench.io.telemetry import load_telemetry

    assert len(load_telemetry(out / "telemetry/mission_000.parquet")["t_s"]) > 10


def test_drive_same_seed_same_table(tmp_path):
    for name in ("a", "b"):
        assert main(["drive", "paper-d2.3", *SMALL, "--missions", "2", "--out", str(tmp_path / name)]) == 0
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "a/trials.csv"), pd.read_csv(tmp_path / "b/trials.csv"))


def test_drive_bad_input_exits_2_without_output(tmp_path, capsys):
    out = tmp_path / "run"
    # 35 m missions cannot fit a 10 m map
    assert main(["drive", "paper-d2.3", "--set", "grid.rows=201", "--set", "grid.cols=201", "--out", str(out)]) == 2
    assert "too small" in capsys.readouterr().err
    assert not out.exists()
    assert main(["drive", "paper-d2.3", *SMALL, "--plot"]) == 2
    assert main(["drive", "paper-d2.3", *SMALL, "--vehicle", "tank", "--out", str(out)]) == 2
    assert "unknown vehicle 'tank'" in capsys.readouterr().err
    assert not out.exists()


def test_drive_animate_writes_a_gif_of_one_trial(tmp_path, capsys):
    from PIL import Image

    gif = tmp_path / "anim" / "trial.gif"
    assert main(["drive", "paper-d2.3", *SMALL, "--missions", "1", "--animate", str(gif)]) == 0
    assert f"wrote {gif} (mission 0)" in capsys.readouterr().out
    with Image.open(gif) as im:
        assert im.n_frames > 15 and im.size[0] > im.size[1]  # map beside the strip
    # a wrong suffix is refused before any work, leaving nothing
    bad = tmp_path / "bad" / "trial.avi"
    assert main(["drive", "paper-d2.3", *SMALL, "--missions", "1", "--animate", str(bad)]) == 2
    assert ".gif or .mp4" in capsys.readouterr().err and not bad.parent.exists()


def test_drive_on_a_small_map_under_lunar_gravity_with_plot_path(tmp_path, capsys):
    """A 12.8 m map (the smoke study's) with a 2 m border; gravity from --gravity or --set sim.*;
    --plot PATH writes the figures without --out."""
    small = ["--set", "grid.rows=257", "--set", "grid.cols=257", "--length-m", "6", "--seed", "1", "--missions", "1"]
    fig = tmp_path / "figs" / "drive.png"
    assert main(["drive", "paper-d2.3", *small, "--border-m", "2", "--gravity", "1.62", "--plot", str(fig)]) == 0
    text = capsys.readouterr().out
    assert "gravity 1.62 m/s^2" in text
    assert sorted(p.name for p in fig.parent.iterdir()) == ["drive.png", "drive_missions.png", "drive_timeseries.png"]
    assert main(["drive", "paper-d2.3", *small, "--border-m", "2", "--set", "sim.gravity_m_s2=1.62",
                 "--set", "rules.tip_angle_deg=60", "--set", "controller.cruise_speed_m_s=0.5"]) == 0
    assert "gravity 1.62 m/s^2" in capsys.readouterr().out
    # the paper's 5 m border leaves 2.8 m of a 12.8 m map: too small for 6 m missions
    assert main(["drive", "paper-d2.3", *small]) == 2
    assert "too small" in capsys.readouterr().err
    assert main(["drive", "paper-d2.3", *small, "--border-m", "2", "--set", "sim.gravity=1"]) == 2
    assert "unknown key(s) gravity" in capsys.readouterr().err
    assert main(["drive", "paper-d2.3", *small, "--border-m", "2", "--set", "sim.a.b=1"]) == 2


def test_drive_out_keeps_its_settings_platform_and_code_version(tmp_path):
    """Issue 33 item 1 / issue 35 item 2: drive --out writes settings.json beside trials.csv: the
    TrialSettings the missions were driven with (the terrain's gravity and soil filled in), the
    seeds, the platform and the code version."""
    import json

    out = tmp_path / "run"
    assert main(["drive", "lunar-mare", *SMALL, "--missions", "1", "--border-m", "2", "--out", str(out),
                 "--set", "controller.cruise_speed_m_s=0.5", "--engine", "mujoco"]) == 0
    rec = json.loads((out / "settings.json").read_text())
    assert {"options", "terrain", "terrain_seed", "mission_seeds", "settings", "platform", "code_version"} <= set(rec)
    s = rec["settings"]
    assert s["sim"]["gravity_m_s2"] == 1.62 and s["sim"]["soil"] == "lunar-regolith"  # the preset's [body], [soil]
    assert s["sim"]["engine"] == "mujoco" and s["controller"]["cruise_speed_m_s"] == 0.5
    assert s["missions"] == {**s["missions"], "count": 1, "length_m": 4.0, "border_m": 2.0}
    assert s["vehicle"]["name"] == "husky" and s["planner"]["name"] == "straight"
    assert rec["mission_seeds"] == list(pd.read_csv(out / "trials.csv")["mission_seed"])
    assert rec["platform"]["arch"] and rec["code_version"].startswith("0.")
    from offroadbench.sim.trial.settings import TrialSettings

    back = TrialSettings.from_dict(rec["settings"])  # the settings a study store keeps, read back whole
    assert back.sim.gravity_m_s2 == 1.62 and back.sim.engine == "mujoco" and back.to_dict() == s


def test_the_footprint_is_measured_by_the_trials_engine(monkeypatch):
    """Issue 35: drive --animate and study replay measure the footprint with the trials' engine;
    under MuJoCo no PyBullet world is built."""
    import importlib.util

    import pytest

    from offroadbench.cli.drive import vehicle_footprint
    from offroadbench.sim import SimConfig, load_vehicle
    from offroadbench.sim.engines.pybullet import world as pybullet_world

    if importlib.util.find_spec("mujoco") is None:
        pytest.skip("mujoco not installed")
    spec = load_vehicle("husky")
    expected = vehicle_footprint(spec, SimConfig())

    def refuse(*args, **kwargs):
        raise AssertionError("a PyBullet world was built under MuJoCo")

    monkeypatch.setattr(pybullet_world.World, "__init__", refuse)
    # the engines measure the same shapes (PyBullet's bounding boxes carry a small margin)
    assert vehicle_footprint(spec, SimConfig(engine="mujoco")) == pytest.approx(expected, abs=3e-3)
