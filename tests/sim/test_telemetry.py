"""Telemetry files (NPZ / Parquet) and the consistency of recorded angles with the metrics module."""

import numpy as np
import pytest

from offroadbench.navigation import metrics
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.telemetry import load_telemetry, save_telemetry
from offroadbench.navigation.missions import Mission
from offroadbench.sim import World, run_mission


@pytest.fixture(scope="module")
def telemetry():
    # a bumpy strip: sine waves across and along the path so roll and pitch both move
    y, x = np.mgrid[0:81, 0:241] * 0.05
    hm = Heightmap(0.05 * np.sin(2 * np.pi * x / 1.3) + 0.04 * np.sin(2 * np.pi * (x + y) / 0.9), 0.05)
    with World(hm) as world:
        return run_mission(world, Mission.between(0, (2, 2), (9, 2)))


@pytest.mark.parametrize("suffix", [".npz", ".parquet"])
def test_round_trip(telemetry, tmp_path, suffix):
    _, tel = telemetry
    path = save_telemetry(tel, tmp_path / f"trial{suffix}")
    back = load_telemetry(path)
    assert set(back) == set(tel)
    for k in tel:
        np.testing.assert_array_equal(back[k], tel[k])


def test_bad_files(tmp_path):
    with pytest.raises(InputError, match="unknown suffix"):
        save_telemetry({"t_s": np.zeros(3)}, tmp_path / "t.csv")
    with pytest.raises(InputError, match="one length"):
        save_telemetry({"a": np.zeros(3), "b": np.zeros(4)}, tmp_path / "t.npz")
    assert not (tmp_path / "t.npz").exists()
    with pytest.raises(InputError, match="no such file"):
        load_telemetry(tmp_path / "missing.npz")


def test_recorded_angles_and_metrics_follow_the_metrics_module(telemetry):
    result, tel = telemetry
    quat = np.column_stack([tel["qx"], tel["qy"], tel["qz"], tel["qw"]])
    roll, pitch, yaw = metrics.roll_pitch_yaw_from_quat(quat)
    np.testing.assert_allclose(tel["roll_rad"], roll, atol=1e-9)
    np.testing.assert_allclose(tel["pitch_rad"], pitch, atol=1e-9)
    np.testing.assert_allclose(tel["yaw_rad"], yaw, atol=1e-9)
    assert result.rms_vertical_accel_m_s2 == metrics.rms_vertical_acceleration(tel["z_m"], 0.05)
    assert result.rms_pitch_rate_deg_s == metrics.rms_angle_rate_deg_s(tel["pitch_rad"], 0.05)
    assert result.rms_roll_rate_deg_s == metrics.rms_angle_rate_deg_s(tel["roll_rad"], 0.05)
    assert result.rms_pitch_rate_deg_s > 3 and result.rms_roll_rate_deg_s > 1  # the bumps are felt
    # body pitch rate and the derivative of pitch agree in RMS (small roll): nose-up positive
    d_pitch = np.degrees(metrics.angle_rate(tel["pitch_rad"], 0.05))
    body = -np.degrees(tel["pitch_rate_body_rad_s"][1:] + tel["pitch_rate_body_rad_s"][:-1]) / 2
    assert np.corrcoef(d_pitch, body)[0, 1] > 0.8
