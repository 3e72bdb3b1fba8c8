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
    assert f"paper-d2.3 seed {terrain_seed(2, 0)}" in text
    assert {"success", "failure_reason", "traversal_time_s", "rms_vertical_accel_m_s2"} <= set(df.columns)
    for name in ("missions.png", "trajectories.png", "timeseries.png", "telemetry/mission_000.npz"):
        assert (out / name).stat().st_size > 0


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
