"""A study's statistics: terrain-level tests, clustered intervals, stress curves and the [analysis] plan.

The names load lazily (PEP 562): reading a study's ``[analysis]`` plan (offroadbench.study.stats.plan)
does not import pandas, so ``study run`` forks its workers without it (issue 41).
"""

from __future__ import annotations

from offroadbench.lazy import lazy_exports

#: public name -> the submodule that defines it
_EXPORTS = {
    "ENGINE_KEY": "engines",
    "engine_table": "engines",
    "engine_verdict": "engines",
    "LogisticFit": "clustered",
    "breaking_point_logistic": "clustered",
    "cluster_bootstrap": "clustered",
    "durkalski_mcnemar": "clustered",
    "fieller_set": "clustered",
    "fit_logistic": "clustered",
    "holm": "clustered",
    "isotonic_decreasing": "clustered",
    "obuchowski_mcnemar": "clustered",
    "paired_power": "clustered",
    "sign_flip_power": "clustered",
    "sign_flip_test": "clustered",
    "terrains_needed": "clustered",
    "wilcoxon_test": "clustered",
    "AnalysisPlan": "plan",
    "check_plan": "plan",
    "check_unchanged": "plan",
    "confirmatory_table": "plan",
    "expand": "plan",
    "min_p": "plan",
    "plan_from_dict": "plan",
    "stored_plan": "plan",
    "arm_table": "stress",
    "breaking_points": "stress",
    "describe_breaking_point": "stress",
    "first_level_below": "stress",
    "isotonic_crossing": "stress",
    "mcnemar_exact": "stress",
    "paired_table": "stress",
    "wilson_interval": "stress",
    "METRICS": "terrain",
    "box_stats": "terrain",
    "group_summary": "terrain",
    "median_change_intervals": "terrain",
    "median_changes": "terrain",
    "terrain_changes": "terrain",
    "terrain_success": "terrain",
}

__all__ = list(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
