"""Crater populations dated by a surface age: the lunar production and chronology functions of
Neukum et al. 2001, capped at the Trask 1966 equilibrium."""

import math

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.terrain.craters.population import (
    PopulationConfig,
    dated_cumulative_density,
    kth_largest_diameters,
    neukum_chronology_n1_km2,
    neukum_production_km2,
    sample_diameters_inversion,
)
from offroadbench.terrain.recipe import load_recipe

#: published coefficients (Neukum, Ivanov & Hartmann 2001), typed here again for the check
A = [-3.0876, -3.557528, 0.781027, 1.021521, -0.156012, -0.444058, 0.019977, 0.086850, -0.005874, -0.006809,
     8.25e-4, 5.54e-5]


def _n_ref(d_m, age_ga):
    """Craters >= D per m^2 from the papers' formulas, computed directly (D >= 10 m, in the polynomial's range)."""
    x = math.log10(d_m / 1000.0)
    pf = 10 ** sum(a * x**j for j, a in enumerate(A))
    n1 = 5.44e-14 * (math.exp(6.93 * age_ga) - 1) + 8.38e-4 * age_ga
    return min(pf * n1 / 10 ** A[0], 10 ** -1.1 * (d_m / 1000.0) ** -2) * 1e-6


def test_production_and_chronology_functions():
    assert float(neukum_production_km2(1.0)) == pytest.approx(10 ** A[0])
    # chronology: linear (8.38e-4 per Ga) for young surfaces, exponential before ~3 Ga
    assert float(neukum_chronology_n1_km2(1.0)) == pytest.approx(8.38e-4, rel=1e-3)
    assert float(neukum_chronology_n1_km2(3.5)) == pytest.approx(4.79e-3, rel=0.01)
    for d in (10.0, 30.0, 100.0, 1000.0):
        for age in (0.01, 1.0, 3.5):
            assert float(dated_cumulative_density(age, d)) == pytest.approx(_n_ref(d, age), rel=1e-9)


def test_density_is_monotone_continuous_below_10_m_and_capped_at_equilibrium():
    d = np.geomspace(0.1, 50.0, 400)
    for age in (0.001, 0.1, 3.5):
        n = dated_cumulative_density(age, d)
        assert np.all(np.diff(n) < 0)
        assert np.all(n <= 10 ** -1.1 * d**-2 * (1 + 1e-12))
    assert float(dated_cumulative_density(3.5, 1.0)) == pytest.approx(10 ** -1.1)  # old mare: saturated
    assert float(dated_cumulative_density(0.001, 1.0)) < 0.5 * 10 ** -1.1  # young surface: production


@pytest.mark.parametrize("age", [0.01, 0.1, 3.5])
def test_sampled_cumulative_sfd_matches_n_of_d_at_that_age(age):
    cfg = PopulationConfig(age_ga=age, d_min_m=0.5, d_max_m=20.0)
    area = 200.0 * 200.0
    d = sample_diameters_inversion(cfg, area, np.random.default_rng(7))
    assert d.min() >= 0.5 and d.max() <= 20.0
    n_max = float(dated_cumulative_density(age, 20.0))
    for size in (0.5, 1.0, 2.0, 5.0, 10.0):
        expected = area * (float(dated_cumulative_density(age, size)) - n_max)
        got = int((d >= size).sum())
        assert abs(got - expected) <= 4.0 * math.sqrt(expected) + 2.0, (age, size, got, expected)
    kth = kth_largest_diameters(cfg, area)
    assert abs(len(kth) - area * (float(dated_cumulative_density(age, 0.5)) - n_max)) <= 1.5


def test_dated_preset_and_age_validation():
    recipe = load_recipe("lunar-mare-3.5ga")
    (layer,) = [la for la in recipe.layers if la.generator == "craters"]
    assert layer.config.population.age_ga == 3.5
    assert recipe.body == "moon"
    with pytest.raises(InputError, match="age_ga"):
        PopulationConfig(age_ga=5.0)
