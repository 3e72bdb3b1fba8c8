"""Crater populations: power-law sizes, uniform positions, linear ages, degradation by age.

Size-frequency distribution (Martin et al. 2014, Eq. 12, Parkes & Martin 1999): the cumulative number of craters per square
metre with diameter >= D (metres) is ``N_cum(D) = c D^-k``; k ~ 1.8 for the lunar mare and
2.0 for a saturated ("dimensionless") surface. The expected number on an area A within
[D_min, D_max] is ``A (N_cum(D_min) - N_cum(D_max))`` (Martin et al. 2014, Eq. 12).

Two ways to draw the diameters:

* ``inversion`` (Li et al. 2022, Li et al. 2022, Eq. 17-21): the range is split into log-spaced size bins;
  each bin gets a Poisson number of craters with the power law's expectation, and diameters
  are drawn by inverting the bin's CDF, Eq. (21):
  ``D = [(D_R^-k - D_L^-k) u + D_L^-k]^(-1/k)``, u uniform in [0, 1).
* ``kth_largest`` (Yoshikawa & Nishiguchi, Yoshikawa & Nishiguchi 2001, Eq. 9): deterministic sizes. The n-th largest
  crater is the one with ``A N_cum(d_n) = n``: ``d_n = (c A / n)^(1/k)`` (for k = 2 this is
  Yoshikawa & Nishiguchi 2001's ``d_k = sqrt(10^-1.42 A / n)``).

Dated populations (``age_ga``). Instead of (k, c), a population can take a surface age: the
cumulative density is the lunar production function of Neukum, Ivanov & Hartmann 2001 (Space Sci.
Rev. 96, 55-87; their 11th-degree polynomial in log10 D, D in km, valid 0.01-300 km) scaled to the
age by the lunar chronology function of the same paper, ``N(1 km) = 5.44e-14 (exp(6.93 T) - 1) +
8.38e-4 T`` per km^2 (T in Ga): ``N(D, T) = N_PF(D) / N_PF(1 km) * N(1 km, T)``. Rover-scale craters
lie below the polynomial's range; below 10 m the production is continued as a power law with the
polynomial's slope at 10 m (-3.16), and at every size the density is capped at the lunar
equilibrium of Trask 1966, ``N_eq = 10^-1.1 D^-2`` (any length unit, per unit area): old mare
surfaces are saturated at these sizes, as observed. The coefficients are those the ``craterstats``
package ships for "Moon, Neukum et al. (2001)"; that package is not a dependency here (its 3.6
release imports ``scipy.integrate.simps``, which scipy 1.14 removed).

Positions are uniform over the map (overlaps allowed, Yoshikawa & Nishiguchi 2001, Sec. 5.1), ages are uniform in
[0, max_age] (Martin et al. 2014's "simple linear age distribution": a constant impact rate), and the
craters are returned oldest first (Martin et al. 2014, Sec. III.C). Degradation follows Martin et al. 2014, Eq. (11).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from offroadbench.config import check_choice, check_int, check_range
from offroadbench.errors import InputError
from offroadbench.terrain.craters.profiles import get_profile
from offroadbench.terrain.craters.table import CraterTable

__all__ = [
    "PopulationConfig",
    "SAMPLINGS",
    "cumulative_density",
    "expected_count",
    "size_bins",
    "inverse_cdf_diameters",
    "sample_diameters_inversion",
    "kth_largest_diameters",
    "degradation_from_age",
    "sample_population",
    "neukum_production_km2",
    "neukum_chronology_n1_km2",
    "dated_cumulative_density",
]

#: Neukum et al. 2001 lunar production function: log10 N = sum a_j (log10 D)^j, D km, N per km^2
#: (a0 as published; it cancels in the scaling to an age)
NEUKUM_2001_PF = (-3.0876, -3.557528, 0.781027, 1.021521, -0.156012, -0.444058, 0.019977, 0.086850,
                  -0.005874, -0.006809, 8.25e-4, 5.54e-5)
#: smallest diameter of the production polynomial's validity, km (Ivanov, Neukum & Wagner 2001)
NEUKUM_PF_D_MIN_KM = 0.01
#: lunar equilibrium (Trask 1966): N_eq = EQUILIBRIUM_C D^-2, per unit area in the same length unit
EQUILIBRIUM_C = 10.0 ** -1.1

SAMPLINGS = ("inversion", "kth_largest")
#: Above this many expected craters a population is refused (memory and time guard).
MAX_CRATERS = 5_000_000


@dataclass(frozen=True, kw_only=True)
class PopulationConfig:
    """A crater population on a map. Defaults: lunar mare slope at rover scale."""

    k: float = 1.8
    """Cumulative power-law slope: N_cum(D) = c D^-k (Martin et al. 2014, Eq. 12); mare 1.8, saturated 2.0."""
    c: float = 0.03
    """Cumulative density coefficient: craters per m^2 with D >= 1 m (D in metres)."""
    d_min_m: float = 0.3
    """Smallest crater diameter, metres."""
    d_max_m: float = 10.0
    """Largest crater diameter, metres."""
    sampling: str = "inversion"
    """How diameters are drawn: one of SAMPLINGS."""
    size_bins: int = 3
    """Number of log-spaced size bins for inversion sampling (Li et al. 2022, Sec. 4.1 uses 3)."""
    max_age: float = 1.0
    """Ages are uniform in [0, max_age], in units of the baseline crater's full-degradation time."""
    baseline_diameter_m: float = 1.0
    """D_b of Martin et al. 2014, Eq. (11): the crater whose degradation is linear in age (degradation = T_b)."""
    erosion_exponent: float = 1.1
    """P of Martin et al. 2014, Eq. (11); Soderblom: 1.0 - 1.2."""
    density_ratio: float = 1.0
    """sigma_b / sigma_x of Martin et al. 2014, Eq. (11), relative surface density; 1 unless materials differ."""
    profile: str = "martin2014"
    """Crater profile name (a key of offroadbench.terrain.craters.PROFILES)."""
    age_ga: float | None = None
    """Surface age, Ga: sizes from the lunar production and chronology functions (Neukum et al.
    2001) capped at the lunar equilibrium (Trask 1966) instead of (k, c); None uses (k, c)."""

    def __post_init__(self) -> None:
        if self.age_ga is not None:
            check_range(self, "age_ga", self.age_ga, lo=0, lo_open=True, hi=4.5)
        check_range(self, "k", self.k, lo=0, lo_open=True, hi=6)
        check_range(self, "c", self.c, lo=0)
        check_range(self, "d_min_m", self.d_min_m, lo=0, lo_open=True)
        check_range(self, "d_max_m", self.d_max_m, lo=self.d_min_m)
        check_choice(self, "sampling", self.sampling, SAMPLINGS)
        check_int(self, "size_bins", self.size_bins, lo=1, hi=1000)
        check_range(self, "max_age", self.max_age, lo=0)
        check_range(self, "baseline_diameter_m", self.baseline_diameter_m, lo=0, lo_open=True)
        check_range(self, "erosion_exponent", self.erosion_exponent, lo=0)
        check_range(self, "density_ratio", self.density_ratio, lo=0, lo_open=True)
        get_profile(self.profile)


def neukum_production_km2(diameter_km) -> np.ndarray:
    """Neukum et al. 2001 lunar production polynomial: craters >= D per km^2 (D km; its 1 Ga-scale
    form, N(1 km) = 10^a0). Below 0.01 km continued with the polynomial's slope there."""
    d = np.asarray(diameter_km, dtype=float)
    x0 = math.log10(NEUKUM_PF_D_MIN_KM)
    x = np.log10(np.maximum(d, NEUKUM_PF_D_MIN_KM))
    log_n = sum(a * x**j for j, a in enumerate(NEUKUM_2001_PF))
    slope = sum(j * a * x0 ** (j - 1) for j, a in enumerate(NEUKUM_2001_PF) if j > 0)
    log_n = np.where(d < NEUKUM_PF_D_MIN_KM, log_n + slope * (np.log10(d) - x0), log_n)
    return np.power(10.0, log_n)


def neukum_chronology_n1_km2(age_ga) -> np.ndarray:
    """Neukum et al. 2001 lunar chronology: craters >= 1 km per km^2 on a surface of age T (Ga)."""
    t = np.asarray(age_ga, dtype=float)
    return 5.44e-14 * np.expm1(6.93 * t) + 8.38e-4 * t


def dated_cumulative_density(age_ga: float, diameter_m) -> np.ndarray:
    """Craters >= D per m^2 on a lunar surface of age ``age_ga`` (module docstring), D in metres."""
    d_km = np.asarray(diameter_m, dtype=float) / 1000.0
    production = neukum_production_km2(d_km) * (neukum_chronology_n1_km2(age_ga) / neukum_production_km2(1.0))
    equilibrium = EQUILIBRIUM_C * np.power(d_km, -2.0)
    return np.minimum(production, equilibrium) * 1e-6  # per km^2 -> per m^2


def cumulative_density(cfg: PopulationConfig, diameter_m) -> np.ndarray:
    """N_cum(D): craters per m^2 with diameter >= D: c D^-k (Martin et al. 2014, Eq. 12), or the
    dated density of ``age_ga`` (:func:`dated_cumulative_density`)."""
    if cfg.age_ga is not None:
        return dated_cumulative_density(cfg.age_ga, diameter_m)
    return cfg.c * np.power(np.asarray(diameter_m, dtype=float), -cfg.k)


def _inverse_cumulative(cfg: PopulationConfig, n_per_m2) -> np.ndarray:
    """Diameter D in [d_min, d_max] with N_cum(D) = n (log-log interpolation on a fine grid), m."""
    d = np.geomspace(cfg.d_min_m, cfg.d_max_m, 512)
    log_n = np.log(cumulative_density(cfg, d))
    return np.exp(np.interp(-np.log(np.asarray(n_per_m2, dtype=float)), -log_n, np.log(d)))


def expected_count(cfg: PopulationConfig, area_m2: float) -> float:
    """Expected craters in [d_min, d_max] on ``area_m2``: A (N_cum(D_min) - N_cum(D_max)), Martin et al. 2014, Eq. (12)."""
    return float(area_m2 * (cumulative_density(cfg, cfg.d_min_m) - cumulative_density(cfg, cfg.d_max_m)))


def size_bins(cfg: PopulationConfig) -> np.ndarray:
    """Log-spaced bin edges from d_min to d_max (size_bins + 1 values)."""
    return np.geomspace(cfg.d_min_m, cfg.d_max_m, cfg.size_bins + 1)


def inverse_cdf_diameters(u: np.ndarray, d_left_m: float, d_right_m: float, k: float) -> np.ndarray:
    """Li et al. 2022, Eq. (21): D = [(D_R^-k - D_L^-k) u + D_L^-k]^(-1/k) for u in [0, 1)."""
    lo, hi = d_left_m ** (-k), d_right_m ** (-k)
    return np.power((hi - lo) * np.asarray(u, dtype=float) + lo, -1.0 / k)


def _check_count(n: float, what: str) -> None:
    if n > MAX_CRATERS:
        raise InputError(f"crater population: {what} is {n:.3g} craters, above the limit {MAX_CRATERS}; lower c or raise d_min_m")


def sample_diameters_inversion(cfg: PopulationConfig, area_m2: float, rng: np.random.Generator) -> np.ndarray:
    """Per-bin Poisson counts and inversion sampling (Li et al. 2022, Eq. 17-21), largest bin first."""
    _check_count(expected_count(cfg, area_m2), "the expected count")
    if cfg.age_ga is not None:  # one Poisson count, diameters by inverting the dated N_cum
        n_lo, n_hi = cumulative_density(cfg, [cfg.d_max_m, cfg.d_min_m])
        n = int(rng.poisson(area_m2 * (n_hi - n_lo)))
        return np.sort(_inverse_cumulative(cfg, n_lo + (n_hi - n_lo) * rng.random(n)))[::-1]
    edges = size_bins(cfg)
    out = []
    for lo, hi in zip(edges[:-1][::-1], edges[1:][::-1], strict=True):
        mean = area_m2 * cfg.c * (lo ** (-cfg.k) - hi ** (-cfg.k))
        n = int(rng.poisson(mean))
        out.append(inverse_cdf_diameters(rng.random(n), lo, hi, cfg.k))
    return np.concatenate(out) if out else np.zeros(0)


def kth_largest_diameters(cfg: PopulationConfig, area_m2: float) -> np.ndarray:
    """Yoshikawa & Nishiguchi 2001, Eq. (9) for slope k: d_n = (c A / n)^(1/k), keeping d_min <= d_n <= d_max, largest first."""
    if cfg.age_ga is not None:  # the n-th largest has A N_cum(d_n) = n
        n_lo, n_hi = (area_m2 * float(v) for v in cumulative_density(cfg, [cfg.d_max_m, cfg.d_min_m]))
        _check_count(n_hi, "the count")
        n = np.arange(max(1, math.ceil(n_lo * (1 - 1e-12))), math.floor(n_hi * (1 + 1e-12)) + 1, dtype=float)
        return _inverse_cumulative(cfg, n / area_m2)
    ca = cfg.c * area_m2
    n_max = math.floor(ca * cfg.d_min_m ** (-cfg.k) * (1 + 1e-12))
    _check_count(n_max, "the count")
    n_first = max(1, math.ceil(ca * cfg.d_max_m ** (-cfg.k) * (1 - 1e-12)))
    n = np.arange(n_first, n_max + 1, dtype=float)
    d = np.power(ca / n, 1.0 / cfg.k)
    return d[(d >= cfg.d_min_m * (1 - 1e-12)) & (d <= cfg.d_max_m * (1 + 1e-12))]


def degradation_from_age(cfg: PopulationConfig, age, diameter_m) -> np.ndarray:
    """Martin et al. 2014, Eq. (11): T_b = T_x (sigma_b / sigma_x) (D_b / D_x)^P, degradation = min(T_b, 1).

    The baseline crater (``baseline_diameter_m``) degrades linearly with age and is fully
    degraded at age 1; Martin et al. 2014 read the baseline curves off Ross's figures, which it does not give.
    Smaller craters reach the same state sooner (P > 0).
    """
    t_b = (
        np.asarray(age, dtype=float)
        * cfg.density_ratio
        * np.power(cfg.baseline_diameter_m / np.asarray(diameter_m, dtype=float), cfg.erosion_exponent)
    )
    return np.clip(t_b, 0.0, 1.0)


def sample_population(
    cfg: PopulationConfig, width_m: float, height_m: float, rng: np.random.Generator
) -> CraterTable:
    """Craters on a width x height map (origin at 0, 0), oldest first, with degradation from age."""
    area = float(width_m) * float(height_m)
    if cfg.sampling == "inversion":
        d = sample_diameters_inversion(cfg, area, rng)
    else:
        d = kth_largest_diameters(cfg, area)
    n = d.size
    x = rng.uniform(0.0, width_m, n)
    y = rng.uniform(0.0, height_m, n)
    age = rng.uniform(0.0, cfg.max_age, n)
    table = CraterTable(
        x_m=x, y_m=y, diameter_m=d, age=age, degradation=degradation_from_age(cfg, age, d), profile=(cfg.profile,) * n
    )
    return table.oldest_first()
