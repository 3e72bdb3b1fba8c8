"""Multifractal product of three W-M DEMs (paper Sec. 2.1, Table 1)."""

import dataclasses

import numpy as np
import pytest

from offroadbench import InputError
from offroadbench.terrain.fractal.wm import n_max_effective
from offroadbench.terrain.grid import GridConfig
from offroadbench.terrain.fractal.multifractal import (
    MultifractalConfig,
    generate_multifractal,
    layer_configs,
    multifractal_layers,
    normalise_layer,
    PAPER_WM,
)

SMALL = GridConfig(rows=96, cols=96)
PAPER_GRID = GridConfig()


def test_table1_defaults():
    low, mid, high = layer_configs(MultifractalConfig())
    assert (low.M, mid.M, high.M) == (16, 32, 64)
    assert (low.D, mid.D, high.D) == (2.2, 2.45, 2.45)
    assert (low.G, mid.G, high.G) == (1e-6, 8e-8, 1e-8)
    for c in (low, mid, high):
        assert c.gamma == 1.5 and c.L == 100.9 and n_max_effective(c, PAPER_GRID) == 1009
        assert c.phase_min == 0.0 and c.phase_max == pytest.approx(np.pi)
        assert c.smoothing_sigma_px == 0.5 and c.coordinates == "pixels"
    assert (PAPER_GRID.rows, PAPER_GRID.cols, PAPER_GRID.cell_size_m) == (1009, 1009, 0.05)


def test_layers_zero_mean_same_range_and_product():
    cfg = MultifractalConfig(D_high=2.6)
    layers = multifractal_layers(cfg, SMALL, np.random.default_rng(2))
    for z in layers:
        assert abs(z.mean()) < 1e-12
        assert np.abs(z).max() == pytest.approx(1.0)
    hm = generate_multifractal(cfg, SMALL, np.random.default_rng(2))
    prod = layers[0] * layers[1] * layers[2]
    expect = (prod - prod.min()) / (prod.max() - prod.min()) * 3.84
    np.testing.assert_allclose(hm.z, expect, atol=1e-12)
    assert hm.relief_m == pytest.approx(3.84)
    assert hm.cell_size_m == 0.05


def test_amplitudes_A_and_G_do_not_change_the_result():
    cfg = MultifractalConfig()
    a = generate_multifractal(cfg, SMALL, np.random.default_rng(4))
    b = generate_multifractal(dataclasses.replace(cfg, G=(1e-3, 1e-5, 1e-2)), SMALL, np.random.default_rng(4))
    np.testing.assert_allclose(a.z, b.z, atol=1e-9)


def test_contract_and_d_high_changes_only_the_high_layer():
    cfg = MultifractalConfig()
    before = dataclasses.asdict(cfg)
    a = generate_multifractal(cfg, SMALL, np.random.default_rng(9))
    assert np.array_equal(a.z, generate_multifractal(cfg, SMALL, np.random.default_rng(9)).z)
    assert not np.array_equal(a.z, generate_multifractal(cfg, SMALL, np.random.default_rng(10)).z)
    assert dataclasses.asdict(cfg) == before
    la = multifractal_layers(cfg, SMALL, np.random.default_rng(9))
    lb = multifractal_layers(dataclasses.replace(cfg, D_high=2.6), SMALL, np.random.default_rng(9))
    assert np.array_equal(la[0], lb[0]) and np.array_equal(la[1], lb[1])
    assert not np.array_equal(la[2], lb[2])


def test_higher_d_high_is_rougher_in_gradient_classes():
    """The paper's claim (Sec. 3.1) on small maps, same phases: less low-roughness area as D rises."""
    from offroadbench.analysis import class_fractions, classify

    lows = []
    for D in (2.3, 2.6):
        fr = []
        for s in range(3):
            hm = generate_multifractal(MultifractalConfig(D_high=D), GridConfig(rows=201, cols=201), np.random.default_rng(s))
            fr.append(class_fractions(classify(hm), hm.cell_size_m, 0.5)["low"])
        lows.append(np.median(fr))
    assert lows[1] < lows[0]


def test_normalise_flat_layer_is_safe():
    assert np.array_equal(normalise_layer(np.ones((3, 3))), np.zeros((3, 3)))


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(D_high=3.2), "D_high = 3.2"),
        (dict(D_low=2.0), "D_low = 2.0"),
        (dict(M=(16, 32)), "M and .G must each list 3"),
        (dict(M=(16, 0, 64)), r"M\[1\] = 0"),
        (dict(relief_m=0.0), "relief_m"),
        (dict(wm=dataclasses.replace(PAPER_WM, M=8)), "wm.M = 8 is not used"),
    ],
)
def test_bad_config(kw, match):
    with pytest.raises(InputError, match=match):
        MultifractalConfig(**kw)


def test_layers_share_the_wm_settings_and_differ_by_m_d_g():
    cfg = MultifractalConfig(wm=dataclasses.replace(PAPER_WM, L=50.0, origin_offset_px=7.0), D_high=2.6)
    low, mid, high = layer_configs(cfg)
    for c, m, d, g in zip((low, mid, high), cfg.M, (2.2, 2.45, 2.6), cfg.G, strict=True):
        assert c == dataclasses.replace(cfg.wm, M=m, D=d, G=g)


def test_nufft_method_reaches_every_layer_and_matches_gemm():
    cfg = MultifractalConfig(D_high=2.6)  # nufft is the default
    assert {c.method for c in layer_configs(cfg)} == {"nufft"}
    fast = generate_multifractal(cfg, SMALL, np.random.default_rng(3))
    ref = generate_multifractal(
        MultifractalConfig(wm=dataclasses.replace(PAPER_WM, method="gemm"), D_high=2.6), SMALL, np.random.default_rng(3)
    )
    assert np.max(np.abs(fast.z - ref.z)) <= 1e-5 * ref.relief_m
