"""Crater populations (Martin et al. 2014, Eq. 11-12, Yoshikawa & Nishiguchi 2001, Eq. 9, Li et al. 2022, Eq. 17-21), crater files, the craters modifier."""

import math

import numpy as np
import pytest

from offroadbench.analysis.surface import fit_sfd_slope
from offroadbench.config import from_dict
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.craters_csv import read_craters, write_craters
from offroadbench.terrain.recipe import generate_terrain, recipe_from_dict
from offroadbench.terrain.craters import (
    CraterConfig,
    CraterTable,
    PopulationConfig,
    StampOptions,
    apply_craters,
    degradation_from_age,
    expected_count,
    inverse_cdf_diameters,
    kth_largest_diameters,
    sample_population,
)


@pytest.mark.parametrize("k", [1.8, 2.0, 3.0])
def test_sampled_population_has_the_requested_power_law_slope(k):
    cfg = PopulationConfig(k=k, c=0.05, d_min_m=0.2, d_max_m=20.0, size_bins=3)
    slopes = []
    for seed in range(3):
        t = sample_population(cfg, 100.0, 100.0, np.random.default_rng(seed))
        slopes.append(fit_sfd_slope(t.diameter_m, cfg.d_min_m, cfg.d_max_m))
    assert np.mean(slopes) == pytest.approx(k, abs=0.1)


def test_expected_count_is_eq12_and_the_sampled_count_matches_it():
    cfg = PopulationConfig(k=1.8, c=0.03, d_min_m=0.3, d_max_m=10.0)
    area = 50.0 * 40.0
    expect = area * 0.03 * (0.3**-1.8 - 10.0**-1.8)
    assert expected_count(cfg, area) == pytest.approx(expect)
    counts = [len(sample_population(cfg, 50.0, 40.0, np.random.default_rng(s))) for s in range(20)]
    assert np.mean(counts) == pytest.approx(expect, rel=3 / math.sqrt(20 * expect))
    t = sample_population(cfg, 50.0, 40.0, np.random.default_rng(0))
    assert t.diameter_m.min() >= 0.3 and t.diameter_m.max() <= 10.0
    assert t.x_m.min() >= 0 and t.x_m.max() <= 50 and t.y_m.max() <= 40


def test_inverse_cdf_maps_the_unit_interval_onto_the_bin():
    # Li et al. 2022, Eq. (21) at u = 0 and u -> 1 gives the bin ends; the median splits the bin's D^-k range in half
    d = inverse_cdf_diameters(np.array([0.0, 0.5, 1.0]), 1.0, 4.0, 2.0)
    assert d[0] == pytest.approx(1.0)
    assert d[2] == pytest.approx(4.0)
    assert d[1] ** -2 == pytest.approx(0.5 * (1.0 + 4.0**-2))


def test_kth_largest_diameters_follow_yoshikawa_eq9():
    # Yoshikawa & Nishiguchi 2001, Eq. (8)-(9): log n = -2 log d - 1.42 (n per km^2, d in km); d_k = sqrt(10^-1.42 A / k)
    # for k = 2 the law is scale free: c = 10^-1.42 per m^2 with D in metres.
    area_km2 = 30.0 * 30.0
    cfg = PopulationConfig(k=2.0, c=10**-1.42, d_min_m=58.0 * 15 / 10, d_max_m=870.0, sampling="kth_largest")
    d = kth_largest_diameters(cfg, area_km2 * 1e6)
    n = np.arange(1, 10000)
    ref = np.sqrt(10**-1.42 * area_km2 / n) * 1000.0  # metres
    ref = ref[(ref >= cfg.d_min_m) & (ref <= cfg.d_max_m)]
    np.testing.assert_allclose(d, ref, rtol=1e-12)
    assert np.all(np.diff(d) < 0)


def test_degradation_from_age_follows_eq11():
    # Martin et al. 2014, Eq. (11): T_b = T_x (sigma_b / sigma_x) (D_b / D_x)^P
    cfg = PopulationConfig(baseline_diameter_m=2.0, erosion_exponent=1.2, density_ratio=1.0)
    s = degradation_from_age(cfg, np.array([0.2, 0.2, 0.2, 0.0]), np.array([2.0, 4.0, 1.0, 1.0]))
    assert s[0] == pytest.approx(0.2)
    assert s[1] == pytest.approx(0.2 * 0.5**1.2)
    assert s[2] == pytest.approx(min(1.0, 0.2 * 2**1.2))
    assert s[3] == 0.0
    assert degradation_from_age(cfg, 5.0, 1.0) == 1.0


def test_population_is_oldest_first():
    t = sample_population(PopulationConfig(c=0.1), 20.0, 20.0, np.random.default_rng(1))
    assert len(t) > 10
    assert np.all(np.diff(t.age) <= 0)


def test_crater_csv_round_trip(tmp_path):
    t = CraterTable(
        x_m=[1.0, 2.5], y_m=[3.0, 0.1], diameter_m=[0.7, 2.0], age=[0.3, np.nan],
        degradation=[np.nan, 0.4], profile=("martin2014", "li_fresh"),
    )
    p = write_craters(t, tmp_path / "c.csv")
    back = CraterTable(**read_craters(p))
    for col in ("x_m", "y_m", "diameter_m", "age", "degradation"):
        np.testing.assert_array_equal(getattr(back, col), getattr(t, col))
    assert back.profile == t.profile


@pytest.mark.parametrize(
    "body, match",
    [
        ("x_m,y_m,diameter_m,age,degradation\n1,1,1,0,0\n", "missing column"),
        ("x_m,y_m,diameter_m,age,degradation,profile\n1,1,-1,0,0,martin2014\n", "diameter_m"),
        ("x_m,y_m,diameter_m,age,degradation,profile\n1,1,1,,,martin2014\n", ":2: give age or degradation"),
        ("x_m,y_m,diameter_m,age,degradation,profile\n1,one,1,0,0,martin2014\n", ":2: column y_m"),
        ("x_m,y_m,diameter_m,age,degradation,profile\n1,1,1,0,0,bowl\n", "known: "),
        ("x_m,y_m,diameter_m,age,degradation,profile\n1,1,1,0,1.5,martin2014\n", "degradation"),
    ],
)
def test_bad_crater_files_are_input_errors(tmp_path, body, match):
    p = tmp_path / "bad.csv"
    p.write_text(body)
    layers = {"base": {"generator": "fbm"}, "cr": {"generator": "craters", "crater_file": str(p)}}
    with pytest.raises(InputError, match=match) as err:
        recipe_from_dict({"grid": {"rows": 9, "cols": 9, "cell_size_m": 0.5}, "layers": layers})
    assert "bad.csv" in str(err.value)


def test_same_crater_file_goes_on_different_base_terrains(tmp_path):
    t = CraterTable(x_m=[2.0], y_m=[2.0], diameter_m=[1.5], age=[0.0], degradation=[np.nan], profile=("martin2014",))
    path = write_craters(t, tmp_path / "one.csv")
    cfg = CraterConfig(craters=CraterTable(**read_craters(path)))
    flat = Heightmap.flat(201, 201, 0.02)
    y, x = np.mgrid[0:201, 0:201] * 0.02
    tilted = Heightmap(0.1 * x, 0.02)
    a = apply_craters(cfg, flat, np.random.default_rng(0))
    b = apply_craters(cfg, tilted, np.random.default_rng(5))
    # the crater is at the same place with the same shape relative to each base
    np.testing.assert_allclose(a.z - flat.z, b.z - tilted.z, atol=1e-9)
    assert np.unravel_index(np.argmin(a.z), a.shape) == (100, 100)


def test_crater_config_from_toml_table_and_errors():
    cfg = from_dict(CraterConfig, {"population": {"profile": "li_fresh", "k": 2, "c": 0.1, "d_max_m": 5}})
    assert cfg.population == PopulationConfig(profile="li_fresh", k=2.0, c=0.1, d_max_m=5.0)
    assert cfg.stamp == StampOptions()
    with pytest.raises(InputError, match=r"unknown key\(s\) craters_per_m2; known keys: craters, degradation, population, stamp"):
        from_dict(CraterConfig, {"craters_per_m2": 1})
    with pytest.raises(InputError, match=r"unknown key\(s\) population\.kk; known keys of population: .*d_max_m"):
        from_dict(CraterConfig, {"population": {"kk": 1}})
    with pytest.raises(InputError, match=r"population\.d_max_m = 1\.0 is out of range"):
        from_dict(CraterConfig, {"population": {"d_min_m": 2.0, "d_max_m": 1.0}})
    with pytest.raises(InputError, match="profile"):
        from_dict(CraterConfig, {"population": {"profile": "nope"}})
    with pytest.raises(InputError, match=r"stamp\.rim_irregularity = 0\.9 is out of range"):
        from_dict(CraterConfig, {"stamp": {"rim_irregularity": 0.9}})


def test_more_density_means_more_crater_area_in_a_recipe():
    def recipe(c):
        return recipe_from_dict(
            {
                "grid": {"rows": 161, "cols": 161, "cell_size_m": 0.05},
                "layers": {
                    "base": {"generator": "fbm", "D": 2.2, "relief_m": 0.2},
                    "craters": {"generator": "craters", "population": {"c": c, "d_min_m": 0.3, "d_max_m": 3.0}},
                },
            }
        )

    from offroadbench.analysis.surface import horn_slope_deg

    steep = [float((horn_slope_deg(generate_terrain(recipe(c), 7)) > 15).mean()) for c in (0.0, 0.05, 0.3)]
    assert steep[0] < steep[1] < steep[2]


def test_recipe_craters_are_the_craters_in_the_generated_terrain():
    from offroadbench.terrain.recipe import apply_overrides, load_recipe
    from offroadbench.terrain.craters import recipe_craters, stamp_craters

    full = apply_overrides(
        load_recipe("lunar-mare"),
        {"grid.rows": 161, "grid.cols": 161, "grid.quantise": "none",  # compare the float64 layers themselves
         "layers.craters.stamp.rim_irregularity": 0.0, "layers.craters.stamp.roughness": 0.0},
    )
    data = dict(full.data)
    data["layers"] = {"base": data["layers"]["base"]}
    base_only = recipe_from_dict(data)
    tables = recipe_craters(full, 11)
    assert list(tables) == ["craters"] and len(tables["craters"]) > 10
    expect = stamp_craters(generate_terrain(base_only, 11), tables["craters"], np.random.default_rng(0))
    np.testing.assert_array_equal(generate_terrain(full, 11).z, expect.z)
