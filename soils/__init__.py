"""Soil parameter sets (``*.toml``, offroadbench.sim.terramechanics), shipped as ``offroadbench.data.soils``."""
