"""Crater profiles and stamping: formulas checked on stamped terrain (Martin et al. 2014, Eq. 1-10, Yoshikawa & Nishiguchi 2001, Eq. 10-11, Li et al. 2022, Eq. 3-16)."""

import numpy as np
import pytest

from offroadbench.terrain.grid import GridConfig
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.terrain.craters import (
    PROFILES,
    CraterTable,
    StampOptions,
    get_profile,
    melosh_depth_m,
    melosh_rim_height_m,
    profile_height,
    stamp_craters,
)
from offroadbench.terrain.fractal.fbm import FBMConfig, generate_fbm

CELL = 0.02


def one_crater(x, y, d, s=0.0, profile="martin2014"):
    return CraterTable(x_m=[x], y_m=[y], diameter_m=[d], age=[np.nan], degradation=[s], profile=(profile,))


def stamped_flat(d=4.0, s=0.0, profile="martin2014", n=401, z0=1.0, options=StampOptions()):
    hm = Heightmap.flat(n, n, CELL, z_m=z0)
    c = (n - 1) * CELL / 2
    return stamp_craters(hm, one_crater(c, c, d, s, profile), np.random.default_rng(0), options), c


@pytest.mark.parametrize("d", [0.5, 4.0, 7.0])
def test_fresh_martin_crater_on_flat_ground_matches_melosh(d):
    # Martin et al. 2014, Eq. (1)-(2): depth (rim crest to floor) H0 = 0.196 D^1.01, rim height Hr0 = 0.036 D^1.01
    n = int(2.2 * d / CELL) | 1
    out, _ = stamped_flat(d=d, n=n)
    rim = out.z.max() - 1.0
    depth = out.z.max() - out.z.min()
    assert rim == pytest.approx(melosh_rim_height_m(d), rel=0.05)
    assert depth == pytest.approx(melosh_depth_m(d), rel=0.05)


def test_fresh_martin_crater_on_a_tilted_plane_keeps_melosh_shape():
    n = 251
    y, x = np.mgrid[0:n, 0:n] * CELL
    base = Heightmap(0.2 * x + 0.1 * y, CELL)
    c = (n - 1) * CELL / 2
    d = 3.0
    out = stamp_craters(base, one_crater(c, c, d), np.random.default_rng(0))
    rel = out.z - base.z  # height above the undisturbed plane
    assert rel.max() == pytest.approx(melosh_rim_height_m(d), rel=0.05)
    assert -rel.min() == pytest.approx(melosh_depth_m(d) - melosh_rim_height_m(d), rel=0.05)


def test_degradation_makes_craters_shallower_with_lower_rims():
    rims, depths = [], []
    for s in (0.0, 0.3, 0.6, 1.0):
        out, _ = stamped_flat(d=4.0, s=s)
        rims.append(out.z.max() - 1.0)
        depths.append(1.0 - out.z.min())
    # each value with the next (strict=False: the pairs are one fewer than the values)
    assert all(a > b for a, b in zip(depths, depths[1:], strict=False))
    assert all(a > b for a, b in zip(rims, rims[1:], strict=False))
    assert rims[-1] == pytest.approx(0.0, abs=1e-3)  # fully degraded: a depression with no rim


def test_pixels_beyond_the_ejecta_are_untouched():
    out, c = stamped_flat(d=4.0)
    y, x = np.mgrid[0 : out.rows, 0 : out.cols] * CELL
    r = np.hypot(x - c, y - c)
    assert np.all(out.z[r >= 4.0] == 1.0)  # ejecta ends at x = 1, r = D (Martin et al. 2014, Eq. 3)
    assert np.any(out.z[(r > 2.1) & (r < 3.5)] > 1.0)  # the ejecta blanket is there


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_profiles_are_continuous_and_vanish_at_the_window_edge(name):
    prof = get_profile(name)
    d = 10.0
    rho = np.linspace(0.0, prof.extent, 4001)
    for s in (0.0, 0.5, 1.0):
        h = profile_height(name, rho * d / 2, d, s)
        assert np.isfinite(h).all()
        assert np.max(np.abs(np.diff(h))) < 0.02 * d * 0.05  # no jumps between samples 0.0005 R apart
        assert abs(h[-1]) < 2e-3 * d


def test_martin_joins_rim_and_ejecta_with_zero_slope_at_the_rim():
    d = 6.0
    eps = 1e-4
    for s in (0.0, 0.5):
        h = profile_height("martin2014", np.array([1 - eps, 1.0, 1 + eps]) * d / 2, d, s)
        assert h[0] == pytest.approx(h[1], abs=1e-6 * d) or s == 0.0
        assert h[2] == pytest.approx(h[1], abs=1e-3 * d)


def test_yoshikawa_profile_matches_the_fitted_numbers():
    # Yoshikawa & Nishiguchi 2001, Eq. (10): depth h0 = 0.367 r1 below the surroundings, rim height h1 = 0.038 r1 at r1
    r1 = 850.0
    h = profile_height("yoshikawa", np.array([0.0, r1, 0.844 * r1]), 2 * r1, 0.0)
    assert h[0] == pytest.approx(-0.367 * r1, rel=1e-6)
    assert h[1] == pytest.approx(0.038 * r1, rel=1e-6)
    assert h[2] == pytest.approx(0.0, abs=1e-3 * r1)  # central part ends at the surface level


def test_li_kernels_add_onto_the_terrain():
    # Li et al. 2022, Eq. (2): spot noise sums the kernel onto the surface; kernel 1 depth a at the centre
    n = 201
    y, x = np.mgrid[0:n, 0:n] * CELL
    base = Heightmap(0.05 * np.sin(x) + 0.3, CELL)
    c = (n - 1) * CELL / 2
    d = 1.5
    out = stamp_craters(base, one_crater(c, c, d, 0.0, "li_gaussian"), np.random.default_rng(0))
    r = np.hypot(x - c, y - c)
    expect = base.z + profile_height("li_gaussian", r, d, 0.0) * (r < d)
    np.testing.assert_allclose(out.z, expect, atol=1e-12)
    assert profile_height("li_gaussian", 0.0, d, 0.0) == pytest.approx(-0.2 * d)


def test_li_fresh_rim_diameter_and_degradation_vector():
    # Li et al. 2022, Eq. (9): D_rim = 2 / sqrt(gamma); degradation lowers gamma (rim moves out) and the depth
    d = 300.0
    r = np.linspace(1.0, d, 30000)
    fresh = profile_height("li_fresh", r, d, 0.0)
    old = profile_height("li_fresh", r, d, 1.0)
    assert r[np.argmax(fresh)] == pytest.approx(d / 2, rel=0.05)
    assert r[np.argmax(old)] > r[np.argmax(fresh)]
    assert old.min() > fresh.min()


def test_li_complex_has_a_central_uplift():
    d = 2000.0
    h = profile_height("li_complex", np.array([0.0, 0.3 * d, 0.5 * d]), d, 0.0)
    assert h[0] > h[1] and h[2] > h[1]


def test_new_crater_rim_meets_rough_terrain_without_a_step():
    # the interior sits on a plane, the ejecta on the terrain; T_r - P_r (Martin et al. 2014, Eq. 5-8) joins them
    n = 201
    base = generate_fbm(FBMConfig(D=2.3, relief_m=0.4), GridConfig(rows=n, cols=n, cell_size_m=CELL), np.random.default_rng(3))
    c = (n - 1) * CELL / 2
    d = 2.0
    out = stamp_craters(base, one_crater(c, c, d, 0.4), np.random.default_rng(0))
    th = np.linspace(0, 2 * np.pi, 90, endpoint=False)

    def ring(hm, k):
        return hm.height_at(c + k * d / 2 * np.cos(th), c + k * d / 2 * np.sin(th))

    step = np.abs(ring(out, 0.99) - ring(out, 1.01)).max()
    base_step = np.abs(ring(base, 0.99) - ring(base, 1.01)).max()
    bound = 2 * base_step + 0.05 * melosh_rim_height_m(d)
    assert step < bound
    # without the T_r - P_r term the step would be the terrain's departure from the plane at the rim
    rim_terrain = ring(base, 1.0)
    assert np.abs(rim_terrain - rim_terrain.mean()).max() > 3 * bound


def test_irregular_rims_and_roughness_change_the_crater_but_not_beyond_its_window():
    plain, c = stamped_flat(d=3.0, n=301)
    opts = StampOptions(rim_irregularity=0.08, roughness=0.05)
    rough, _ = stamped_flat(d=3.0, n=301, options=opts)
    assert not np.array_equal(plain.z, rough.z)
    y, x = np.mgrid[0:301, 0:301] * CELL
    far = np.hypot(x - c, y - c) > 3.0 * (1 + 0.5)
    assert np.all(rough.z[far] == 1.0)
    # the rim crest radius varies with direction
    th = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    radii = np.linspace(0.5, 2.5, 400)
    crest = []
    for t in th:
        prof = rough.height_at(c + radii * np.cos(t), c + radii * np.sin(t))
        crest.append(radii[np.argmax(prof)])
    assert np.std(crest) > 0.03 * 1.5


def test_stamping_refuses_unknown_degradation():
    hm = Heightmap.flat(31, 31, CELL)
    with pytest.raises(InputError, match="degradation"):
        stamp_craters(hm, one_crater(0.3, 0.3, 0.2, np.nan), np.random.default_rng(0))


def test_craters_below_the_minimum_size_are_skipped():
    hm = Heightmap.flat(51, 51, CELL)
    out = stamp_craters(hm, one_crater(0.5, 0.5, 1.5 * CELL), np.random.default_rng(0))
    assert np.array_equal(out.z, hm.z)


def test_unknown_profile_lists_the_known_ones():
    with pytest.raises(InputError, match="martin2014"):
        get_profile("bowl")
