"""Contract over every registered crater profile: what a profile promises to the stamper.

Heights are finite, a crater changes the ground by an amount that scales with its diameter (the
profiles are self-similar; Melosh's depth law of Martin et al. 2014, Eq. 1, is D^1.01), degrading it
never makes its centre more extreme, and it leaves the ground untouched from its window's edge on
(``extent`` radii), so stamping only the window loses nothing.
"""

import numpy as np
import pytest

from offroadbench.terrain.craters.profiles import PROFILES, MODES, profile_height


@pytest.mark.parametrize("name", PROFILES.names())
def test_profile_contract(name):
    prof = PROFILES.get(name)
    assert prof.name == name and prof.mode in MODES and prof.extent >= 1.0 and prof.summary
    rho = np.linspace(0.0, 3.0 * prof.extent, 3001)
    for d in (0.5, 4.0):
        for s in (0.0, 0.5, 1.0):
            h = profile_height(name, rho * d / 2, d, s)
            assert np.isfinite(h).all()
            assert h.min() < -0.01 * d or h[0] > 0.01 * d, "a crater is a depression (or a central uplift)"
            outside = rho >= prof.extent
            assert np.abs(h[outside]).max() < 1e-3 * d, "zero from the window's edge on"
        centre = [profile_height(name, 0.0, d, s) for s in (0.0, 0.5, 1.0)]
        assert abs(centre[0]) > 0.01 * d
        assert abs(centre[0]) >= abs(centre[1]) >= abs(centre[2]), "degradation softens the centre"
    # self-similar: twice the diameter, twice the height at the same rho (within D^0.01)
    for r in (0.0, 0.5, 0.9):
        a = profile_height(name, r * 1.0 / 2, 1.0, 0.0)
        b = profile_height(name, r * 2.0 / 2, 2.0, 0.0)
        assert b == pytest.approx(2.0 * a, rel=0.02, abs=1e-9)


def test_unknown_profile_suggests_the_closest():
    from offroadbench.errors import InputError

    with pytest.raises(InputError, match=r"unknown crater profile 'martin2041'; did you mean 'martin2014'"):
        PROFILES.get("martin2041")
