"""The metrics a study's statistics and its ``[analysis]`` plan name (Majhor & Bos 2023, Fig. 7), with
their titles and units; kept apart from the statistics (offroadbench.study.stats.terrain, which
re-exports them) so that reading a plan does not import pandas (issue 41: ``study run`` forks its
workers without it)."""

from __future__ import annotations

from offroadbench.analysis.roughness import CLASS_NAMES

__all__ = ["CLASSES", "METRICS", "SOIL_METRICS"]

#: Fig. 7 metrics (successful trials only): column -> (title, unit)
METRICS: dict[str, tuple[str, str]] = {
    "rms_vertical_accel_m_s2": ("RMS vertical acceleration", "m/s²"),
    "rms_pitch_rate_deg_s": ("RMS pitch rate", "deg/s"),
    "rms_roll_rate_deg_s": ("RMS roll rate", "deg/s"),
    "traversal_time_s": ("Traversal time", "s"),
}
#: the roughness classes (Sec. 2.4), lowest first
CLASSES = CLASS_NAMES

#: soft-soil metrics (every trial of a cell driven on soil, ``terramechanics`` tyre model): column -> (title, unit)
SOIL_METRICS: dict[str, tuple[str, str]] = {
    "mean_slip": ("Mean wheel slip (moving)", "-"),
    "sinkage_median_m": ("Median wheel sinkage (moving)", "m"),
    "sinkage_p95_m": ("95th percentile wheel sinkage (moving)", "m"),
}
