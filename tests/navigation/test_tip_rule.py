"""The tip-over rule checks the tilt of the body z axis as well as roll and pitch."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from offroadbench.navigation.rules import FailureRules, end_reason

BOUNDS = (10.0, 10.0, 0.0)


def _reason(roll_deg, pitch_deg):
    return end_reason(FailureRules(), BOUNDS, (9.0, 9.0), (5.0, 5.0, 0.3), math.radians(roll_deg),
                      math.radians(pitch_deg), [(5.0, 5.0)], 600)


@pytest.mark.parametrize("roll,pitch,tipped", [(0, 0, False), (74, 0, False), (0, -76, True), (76, 0, True),
                                               (60, 60, True), (50, 50, False), (-62, 62, True), (-55, 55, False)])
def test_tipped_by_roll_pitch_or_the_tilt_of_the_body_z_axis(roll, pitch, tipped):
    # tilt of the body z axis from the vertical, from the rotation matrix itself
    z_axis = Rotation.from_euler("ZYX", [0.3, math.radians(pitch), math.radians(roll)]).as_matrix()[:, 2]
    tilt = math.degrees(math.acos(np.clip(z_axis[2], -1, 1)))
    assert (tilt > 75 or abs(roll) > 75 or abs(pitch) > 75) == tipped
    assert (_reason(roll, pitch) == "tipped") == tipped
