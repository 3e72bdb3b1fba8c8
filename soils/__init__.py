"""Soil parameter sets (``*.toml``, offroadbench.sim.tyre_laws.terramechanics), shipped as ``offroadbench.data.soils``."""
