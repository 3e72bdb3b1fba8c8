"""Vehicles (one folder each: ``vehicle.toml`` + URDF), shipped as ``offroadbench.data.vehicles``."""
