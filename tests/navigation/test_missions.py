"""Mission sampler (Majhor & Bos 2023, Sec. 2.3): constraints, determinism, impossible requests."""

import dataclasses
import math

import numpy as np
import pytest

from offroadbench.analysis.roughness import HIGH, LOW, SEMI
from offroadbench.config import from_dict
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission, MissionConfig, sample_missions

CELL = 0.05


def _map(n=1009):
    return Heightmap.flat(n, n, CELL)


def _patchy_classes(shape, rng):
    """A class map with low, semi and high blobs (coarse random field, nearest-upsampled)."""
    coarse = rng.choice([LOW, LOW, SEMI, HIGH], size=(shape[0] // 20 + 1, shape[1] // 20 + 1)).astype(np.uint8)
    return np.kron(coarse, np.ones((20, 20), np.uint8))[: shape[0], : shape[1]]


def _cls_at(classes, xy):
    return classes[int(round(xy[1] / CELL)), int(round(xy[0] / CELL))]


def test_missions_respect_every_constraint():
    hm = _map()
    classes = _patchy_classes(hm.shape, np.random.default_rng(0))
    cfg = MissionConfig()  # paper: 20 missions, 35 m, 5 m border, start low, goal low/semi
    missions = sample_missions(hm, classes, cfg, np.random.default_rng(1))
    assert len(missions) == 20
    assert [m.index for m in missions] == list(range(20))
    for m in missions:
        assert m.length_m == pytest.approx(35.0, abs=1e-9)
        assert 0.0 <= m.heading_rad < 2 * math.pi
        assert math.atan2(m.goal_xy_m[1] - m.start_xy_m[1], m.goal_xy_m[0] - m.start_xy_m[0]) % (2 * math.pi) == \
            pytest.approx(m.heading_rad)
        for xy in (m.start_xy_m, m.goal_xy_m):
            assert hm.contains(xy[0], xy[1], margin_m=5.0 - 1e-9)
        assert _cls_at(classes, m.start_xy_m) == LOW
        assert _cls_at(classes, m.goal_xy_m) in (LOW, SEMI)
    headings = np.degrees([m.heading_rad for m in missions])
    assert headings.max() - headings.min() > 90  # headings are spread, not a constant


def test_same_seed_same_missions_other_seed_other_missions():
    hm = _map()
    classes = _patchy_classes(hm.shape, np.random.default_rng(0))
    cfg = MissionConfig(count=5)
    a = sample_missions(hm, classes, cfg, np.random.default_rng(7))
    b = sample_missions(hm, classes, cfg, np.random.default_rng(7))
    c = sample_missions(hm, classes, cfg, np.random.default_rng(8))
    assert a == b
    assert a != c


def test_configurable_classes_length_and_border():
    hm = _map(401)  # 20 m
    classes = np.full(hm.shape, SEMI, np.uint8)
    classes[:, :200] = LOW
    cfg = MissionConfig(count=10, length_m=6.0, border_m=2.0, start_classes=("semi",), goal_classes=("low",))
    for m in sample_missions(hm, classes, cfg, np.random.default_rng(3)):
        assert _cls_at(classes, m.start_xy_m) == SEMI and _cls_at(classes, m.goal_xy_m) == LOW
        assert m.length_m == pytest.approx(6.0)
        assert hm.contains(*m.goal_xy_m, margin_m=2.0 - 1e-9)


def test_impossible_requests_raise_clear_errors():
    rng = np.random.default_rng(0)
    small = _map(201)  # 10 m map: the 5 m border leaves nothing
    with pytest.raises(InputError, match="too small for 35 m missions"):
        sample_missions(small, np.zeros(small.shape, np.uint8), MissionConfig(), rng)
    hm = _map(401)
    with pytest.raises(InputError, match="no start cell"):
        sample_missions(hm, np.full(hm.shape, SEMI, np.uint8), MissionConfig(length_m=5, border_m=1), rng)
    # starts exist, but every goal 5 m away is high roughness: bounded number of tries
    classes = np.full(hm.shape, HIGH, np.uint8)
    classes[195:206, 195:206] = LOW
    with pytest.raises(InputError, match="after 500 tries"):
        sample_missions(hm, classes, MissionConfig(length_m=5, border_m=1, max_tries=500), rng)
    with pytest.raises(InputError, match="does not match"):
        sample_missions(hm, np.zeros((10, 10), np.uint8), MissionConfig(), rng)


def test_config_validation_and_toml():
    with pytest.raises(InputError, match="start_classes"):
        MissionConfig(start_classes=("smooth",))
    with pytest.raises(InputError, match="count"):
        MissionConfig(count=0)
    cfg = from_dict(MissionConfig, {"count": 3, "length_m": 10, "goal_classes": ["low"]})
    assert cfg.goal_classes == ("low",) and cfg.length_m == 10.0
    with pytest.raises(InputError, match="unknown key"):
        from_dict(MissionConfig, {"lenght_m": 3})
    assert dataclasses.replace(cfg, count=4).count == 4


def test_mission_between():
    m = Mission.between(3, (1, 1), (1, -2))
    assert m.length_m == 3.0
    assert math.degrees(m.heading_rad) == pytest.approx(270.0)


def test_sites_computed_once_draw_the_same_missions():
    """A terrain's start cells and goal map computed once (mission_sites, as prepare_terrain does for
    a study's 20 missions) give each seeded mission exactly as computing them per mission does; the
    sites are np.isin's class masks inside the border."""
    from offroadbench.analysis.roughness import border_mask
    from offroadbench.navigation.missions import mission_sites, sample_mission

    hm = _map(401)
    classes = _patchy_classes(hm.shape, np.random.default_rng(5))
    for start, goal in [(("low",), ("low", "semi")), (("semi",), ("semi", "high")), (("low", "semi"), ("low", "semi", "high"))]:
        cfg = MissionConfig(length_m=12.0, border_m=2.0, start_classes=start, goal_classes=goal)
        sites = mission_sites(hm, classes, cfg)
        inside = border_mask(hm.shape, cfg.border_m, CELL)
        names = ("low", "semi", "high")
        assert np.array_equal(sites.starts, np.flatnonzero(np.isin(classes, [names.index(n) for n in start]) & inside))
        assert np.array_equal(sites.goal_ok, np.isin(classes, [names.index(n) for n in goal]) & inside)
        for k in range(6):
            assert sample_mission(hm, classes, cfg, k, 1000 + k, sites) == sample_mission(hm, classes, cfg, k, 1000 + k)
