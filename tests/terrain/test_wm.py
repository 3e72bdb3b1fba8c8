"""W-M surfaces: the fast separable evaluation against a literal Eq. (1), Eq. (2), term cuts."""

import dataclasses
import math

import numpy as np
import pytest

from offroadbench import InputError
from offroadbench.terrain.fractal.wm import (
    WMConfig,
    draw_phases,
    generate_wm,
    kept_harmonics,
    n_max_effective,
    wm_amplitude,
    wm_surface,
    wm_surface_direct,
)
from offroadbench.terrain.grid import GridConfig


#: documented agreement of each method with the literal Eq. (1), as a fraction of the surface's size
METHOD_TOL = {"gemm": 1e-9, "nufft": 1e-8}


@pytest.mark.parametrize("method", sorted(METHOD_TOL))
@pytest.mark.parametrize("coordinates", ["pixels", "metres", "span_L"])
@pytest.mark.parametrize("D", [2.2, 2.6])
def test_fast_matches_literal_eq1(coordinates, D, method):
    cfg = WMConfig(M=7, n_max=24, D=D, coordinates=coordinates, amplitude_tol=0.0, method=method)
    grid = GridConfig(rows=23, cols=31, cell_size_m=0.05)
    phases = draw_phases(cfg, grid, np.random.default_rng(3))
    fast = wm_surface(cfg, grid, phases)
    slow = wm_surface_direct(cfg, grid, phases)
    assert np.max(np.abs(fast - slow)) <= METHOD_TOL[method] * np.max(np.abs(slow))


def test_literal_matches_hand_written_single_term():
    cfg = WMConfig(M=1, n_min=1, n_max=1, D=2.5, L=10.0, G=0.01, coordinates="pixels", amplitude_tol=0.0)
    grid = GridConfig(rows=5, cols=6)
    phi = 0.7
    phases = np.array([[phi]])
    x = np.arange(6.0)[None, :]
    y = np.arange(5.0)[:, None]
    r = np.hypot(x, y)
    ang = np.arctan2(y, x)
    A = 10.0 * (0.01 / 10.0) ** 0.5 * math.sqrt(math.log(1.5) / 1)
    expect = A * 1.5 ** (-0.5) * (np.cos(phi) - np.cos(2 * np.pi * 1.5 * r / 10.0 * np.cos(ang - np.pi) + phi))
    np.testing.assert_allclose(wm_surface(dataclasses.replace(cfg, method="gemm"), grid, phases), expect, atol=1e-12)
    np.testing.assert_allclose(wm_surface(cfg, grid, phases), expect, atol=METHOD_TOL["nufft"] * np.ptp(expect))
    np.testing.assert_allclose(wm_surface_direct(cfg, grid, phases), expect, atol=1e-12)


def test_amplitude_eq2():
    cfg = WMConfig(D=2.45, G=1e-8, L=100.9, M=64, gamma=1.5)
    assert wm_amplitude(cfg) == pytest.approx(100.9 * (1e-8 / 100.9) ** 0.45 * math.sqrt(math.log(1.5) / 64))


def test_tolerance_drops_small_terms_and_default_nmax_is_grid_length():
    cfg = WMConfig(D=2.5, amplitude_tol=1e-3)
    grid = GridConfig(rows=50, cols=80)
    assert n_max_effective(cfg, grid) == 80
    n = kept_harmonics(cfg, grid)
    # gamma^((D-3)(n-1)) >= 1e-3  <=>  n - 1 <= ln(1e3) / (0.5 ln 1.5)
    assert n.max() == 1 + math.floor(math.log(1e3) / (0.5 * math.log(1.5)))
    assert kept_harmonics(dataclasses.replace(cfg, amplitude_tol=0.0), grid).size == 80


def test_band_limit_drops_aliased_terms():
    cfg = WMConfig(D=2.5, amplitude_tol=0.0, band_limited=True, coordinates="pixels", L=100.9)
    n = kept_harmonics(cfg, GridConfig(rows=64, cols=64))
    assert np.all(1.5 ** n / 100.9 <= 0.5)
    assert 1.5 ** (n.max() + 1) / 100.9 > 0.5


def test_rougher_with_higher_D():
    """Higher D puts more amplitude in the high harmonics: steeper slopes for the same phases."""
    base = WMConfig(M=16, D=2.2)
    grid = GridConfig(rows=64, cols=64)
    slopes = []
    for D in (2.2, 2.5, 2.8):
        cfg = dataclasses.replace(base, D=D)
        z = wm_surface(cfg, grid, draw_phases(cfg, grid, np.random.default_rng(1)))
        z = (z - z.mean()) / z.std()
        slopes.append(np.abs(np.diff(z, axis=1)).mean())
    assert slopes[0] < slopes[1] < slopes[2]


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("D", 2.0, r"D = 2.0 is out of range; allowed: \(2, 3\)"),
        ("D", 3.0, "D"),
        ("gamma", 1.0, "gamma"),
        ("M", 0, "M"),
        ("n_max", 0, "n_max"),
        ("coordinates", "furlongs", "coordinates"),
        ("method", "fft", r"method = 'fft' is not known; allowed: gemm, nufft"),
    ],
)
def test_bad_config(field, value, match):
    with pytest.raises(InputError, match=match):
        WMConfig(**{field: value})


def test_generator_contract():
    cfg = WMConfig(M=8)
    grid = GridConfig(rows=40, cols=50, cell_size_m=0.1)
    before = dataclasses.asdict(cfg)
    a = generate_wm(cfg, grid, np.random.default_rng(5))
    b = generate_wm(cfg, grid, np.random.default_rng(5))
    c = generate_wm(cfg, grid, np.random.default_rng(6))
    assert a.shape == (40, 50) and a.cell_size_m == 0.1
    assert np.isfinite(a.z).all()
    assert np.array_equal(a.z, b.z)
    assert not np.array_equal(a.z, c.z)
    assert dataclasses.asdict(cfg) == before


def test_bits_do_not_depend_on_blas_threads():
    """Studies run terrains in 1 or many workers: the same seed must give the same bits."""
    import subprocess
    import sys

    code = (
        "import numpy as np, hashlib;"
        "from offroadbench.terrain.fractal.wm import WMConfig, draw_phases, wm_surface;"
        "from offroadbench.terrain.grid import GridConfig;"
        "g = GridConfig(rows=300, cols=290);"
        "cs = [WMConfig(M=32, D=2.6, method=m) for m in ('gemm', 'nufft')];"
        "print([hashlib.sha256(wm_surface(c, g, draw_phases(c, g, np.random.default_rng(3))).tobytes()).hexdigest() for c in cs])"
    )
    import os

    digests = set()
    for threads in ("1", "2", "3"):
        env = dict(os.environ, OPENBLAS_NUM_THREADS=threads, OMP_NUM_THREADS=threads)
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
        digests.add(out.stdout.strip())
    assert len(digests) == 1


def test_origin_offset_matches_literal_and_moves_the_coherent_extreme_off_the_map():
    cfg = WMConfig(M=6, n_max=20, D=2.4, amplitude_tol=0.0, origin_offset_px=37.5)
    grid = GridConfig(rows=21, cols=26)
    phases = draw_phases(cfg, grid, np.random.default_rng(8))
    slow = wm_surface_direct(cfg, grid, phases)
    for method, tol in METHOD_TOL.items():
        fast = wm_surface(dataclasses.replace(cfg, method=method), grid, phases)
        assert np.max(np.abs(fast - slow)) <= tol * np.max(np.abs(slow))
    # with phases in [0, pi] the paper's corner origin is where the terms pile up
    big = WMConfig(M=32, D=2.45)
    big_grid = GridConfig(rows=200, cols=200)
    ph = draw_phases(big, big_grid, np.random.default_rng(2))
    corner = wm_surface(big, big_grid, ph)
    corner = np.abs(corner - corner.mean())
    shifted = wm_surface(dataclasses.replace(big, origin_offset_px=300.0), big_grid, ph)
    shifted = np.abs(shifted - shifted.mean())
    assert corner[:10, :10].max() == pytest.approx(corner.max())
    assert shifted[:10, :10].max() < 0.6 * shifted.max()


@pytest.mark.parametrize("rows, cols, coordinates, offset", [
    (23, 31, "pixels", 0.0), (3, 5, "metres", 0.0), (64, 80, "span_L", 0.0), (50, 41, "pixels", 37.5),
])
def test_nufft_matches_literal_eq1_within_its_tolerance(rows, cols, coordinates, offset):
    """The NUFFT asks finufft for 1e-9 relative accuracy: documented tolerance 1e-8 of the range."""
    cfg = WMConfig(M=7, n_max=24, D=2.5, coordinates=coordinates, amplitude_tol=0.0,
                   origin_offset_px=offset, method="nufft")
    grid = GridConfig(rows=rows, cols=cols, cell_size_m=0.05)
    phases = draw_phases(cfg, grid, np.random.default_rng(4))
    slow = wm_surface_direct(cfg, grid, phases)
    assert np.max(np.abs(wm_surface(cfg, grid, phases) - slow)) <= 1e-8 * np.ptp(slow)


def test_nufft_agrees_with_gemm_on_a_paper_layer():
    """The paper's high layer at D = 2.6 keeps terms up to n ~ 85, whose arguments (~1e13 rad)
    float64 cannot phase: there both methods hold different rounding, ~1e-6 of the range."""
    cfg = WMConfig(M=64, D=2.6, method="gemm")
    grid = GridConfig(rows=257, cols=257)
    phases = draw_phases(cfg, grid, np.random.default_rng(1))
    gemm = wm_surface(cfg, grid, phases)
    nufft = wm_surface(dataclasses.replace(cfg, method="nufft"), grid, phases)
    assert np.max(np.abs(nufft - gemm)) <= 1e-5 * np.ptp(gemm)


def test_nufft_bits_do_not_depend_on_the_thread_count(monkeypatch):
    import offroadbench.terrain.fractal.wm as wm

    cfg = WMConfig(M=16, D=2.45, method="nufft")
    grid = GridConfig(rows=101, cols=90)
    phases = draw_phases(cfg, grid, np.random.default_rng(2))
    out = []
    for threads in (1, 2, 3):
        monkeypatch.setattr(wm, "_threads", lambda t=threads: t)
        out.append(wm_surface(cfg, grid, phases))
    assert all(np.array_equal(out[0], z) for z in out[1:])
