"""Cratered terrain: crater profiles, stamping, populations and the crater-list model.

Importing the package registers the ``craters`` terrain modifier.
"""

from offroadbench.terrain.craters.layer import CraterConfig, apply_craters, crater_table_for, recipe_craters
from offroadbench.terrain.craters.population import (
    PopulationConfig,
    cumulative_density,
    degradation_from_age,
    expected_count,
    inverse_cdf_diameters,
    kth_largest_diameters,
    sample_diameters_inversion,
    sample_population,
)
from offroadbench.terrain.craters.profiles import (
    PROFILES,
    CraterProfile,
    get_profile,
    melosh_depth_m,
    melosh_rim_height_m,
    profile_height,
)
from offroadbench.terrain.craters.stamp import StampOptions, stamp_craters, stamp_one
from offroadbench.terrain.craters.table import CraterTable

__all__ = [
    "PROFILES",
    "CraterConfig",
    "CraterProfile",
    "CraterTable",
    "PopulationConfig",
    "StampOptions",
    "apply_craters",
    "crater_table_for",
    "cumulative_density",
    "degradation_from_age",
    "expected_count",
    "get_profile",
    "inverse_cdf_diameters",
    "kth_largest_diameters",
    "melosh_depth_m",
    "melosh_rim_height_m",
    "profile_height",
    "recipe_craters",
    "sample_diameters_inversion",
    "sample_population",
    "stamp_craters",
    "stamp_one",
]
