"""Drive-train power limit and rolling resistance: the formulas and the Husky's numbers."""

import math

import pytest

from offroadbench.sim.drive_limits import power_limited_torque, rolling_resistance_force

R = 0.1651  # Husky wheel radius, m


def test_the_sheets_400_w_gives_16_5_nm_per_wheel_at_top_speed():
    omega = 1.0 / R
    assert power_limited_torque(28.0, 400.0, 4, omega) == pytest.approx(400 / 4 / omega)
    assert power_limited_torque(28.0, 400.0, 4, omega) == pytest.approx(16.5, abs=0.05)
    # below the base speed the torque limit holds; either sign of speed
    base = 400 / (4 * 28.0)
    assert power_limited_torque(28.0, 400.0, 4, 0.9 * base) == 28.0
    assert power_limited_torque(28.0, 400.0, 4, -2 * base) == pytest.approx(14.0)
    assert power_limited_torque(28.0, None, 4, 100.0) == 28.0
    assert power_limited_torque(28.0, 400.0, 4, 0.0) == 28.0
    # the power limit is never exceeded: torque x speed x wheels <= P
    for w in (1.0, 5.0, 10.0, 50.0):
        assert 4 * power_limited_torque(28.0, 400.0, 4, w) * w <= 400.0 + 1e-9


def test_rolling_resistance_opposes_rolling_and_vanishes_at_rest():
    n = 56 * 9.81 / 4
    f = rolling_resistance_force(n, 1.0, 0.05)
    assert f < 0 and f == pytest.approx(-0.05 * n, rel=1e-4)
    assert rolling_resistance_force(n, -1.0, 0.05) == pytest.approx(-f)
    assert rolling_resistance_force(n, 0.0, 0.05) == 0.0
    assert rolling_resistance_force(-5.0, 1.0, 0.05) == 0.0
    # on the whole vehicle, C_rr m g: 27 N at 0.05, the drag a 1 m/s drive pays 27 W for
    total = 4 * rolling_resistance_force(n, 1.0, 0.05)
    assert total == pytest.approx(-0.05 * 56 * 9.81, rel=1e-4)
    assert math.isfinite(rolling_resistance_force(n, 1e-9, 0.05))
