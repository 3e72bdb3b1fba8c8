"""Pure analysis functions: Heightmap -> arrays and tables."""

from offroadbench.analysis.roughness import (
    CLASS_NAMES,
    HIGH,
    LOW,
    SEMI,
    RoughnessConfig,
    class_fractions,
    classify,
    close_rough,
    gradient_map,
    paper_gradient_to_slope,
)

__all__ = [
    "CLASS_NAMES",
    "HIGH",
    "LOW",
    "SEMI",
    "RoughnessConfig",
    "class_fractions",
    "classify",
    "close_rough",
    "gradient_map",
    "paper_gradient_to_slope",
]
