"""Data shipped with offroadbench, read through :mod:`offroadbench.resources` (never by path).

The sub-packages are folders at the top of the repository, mapped here at build time (setup.py):
``offroadbench.data.terrains`` is ``terrains/`` (presets and the sample DEM),
``offroadbench.data.vehicles`` is ``vehicles/`` and ``offroadbench.data.experiments`` is the study
TOMLs of ``experiments/``.
"""
