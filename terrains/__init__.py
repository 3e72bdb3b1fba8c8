"""Terrain presets (``*.toml``) and sample data, shipped as ``offroadbench.data.terrains``."""
