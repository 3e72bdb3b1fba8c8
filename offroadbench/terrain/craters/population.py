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
]

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

    def __post_init__(self) -> None:
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


def cumulative_density(cfg: PopulationConfig, diameter_m) -> np.ndarray:
    """N_cum(D) = c D^-k: craters per m^2 with diameter >= D (Martin et al. 2014, Eq. 12)."""
    return cfg.c * np.power(np.asarray(diameter_m, dtype=float), -cfg.k)


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
    edges = size_bins(cfg)
    out = []
    for lo, hi in zip(edges[:-1][::-1], edges[1:][::-1]):
        mean = area_m2 * cfg.c * (lo ** (-cfg.k) - hi ** (-cfg.k))
        n = int(rng.poisson(mean))
        out.append(inverse_cdf_diameters(rng.random(n), lo, hi, cfg.k))
    return np.concatenate(out) if out else np.zeros(0)


def kth_largest_diameters(cfg: PopulationConfig, area_m2: float) -> np.ndarray:
    """Yoshikawa & Nishiguchi 2001, Eq. (9) for slope k: d_n = (c A / n)^(1/k), keeping d_min <= d_n <= d_max, largest first."""
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
