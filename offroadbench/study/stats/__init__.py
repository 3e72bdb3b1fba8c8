"""A study's statistics: terrain-level tests, clustered intervals, stress curves and the [analysis] plan."""

from offroadbench.study.stats.clustered import LogisticFit, breaking_point_logistic, cluster_bootstrap, durkalski_mcnemar, fieller_set, fit_logistic, holm, isotonic_decreasing, obuchowski_mcnemar, paired_power, sign_flip_power, sign_flip_test, terrains_needed, wilcoxon_test
from offroadbench.study.stats.engines import ENGINE_KEY, engine_table, engine_verdict
from offroadbench.study.stats.plan import AnalysisPlan, check_plan, check_unchanged, confirmatory_table, expand, min_p, plan_from_dict, stored_plan
from offroadbench.study.stats.stress import arm_table, breaking_points, describe_breaking_point, first_level_below, isotonic_crossing, mcnemar_exact, paired_table, wilson_interval
from offroadbench.study.stats.terrain import METRICS, box_stats, group_summary, median_change_intervals, median_changes, terrain_changes, terrain_success

__all__ = ['ENGINE_KEY', 'engine_table', 'engine_verdict', 'LogisticFit', 'breaking_point_logistic', 'cluster_bootstrap', 'durkalski_mcnemar', 'fieller_set', 'fit_logistic', 'holm', 'isotonic_decreasing', 'obuchowski_mcnemar', 'paired_power', 'sign_flip_power', 'sign_flip_test', 'terrains_needed', 'wilcoxon_test', 'AnalysisPlan', 'check_plan', 'check_unchanged', 'confirmatory_table', 'expand', 'min_p', 'plan_from_dict', 'stored_plan', 'arm_table', 'breaking_points', 'describe_breaking_point', 'first_level_below', 'isotonic_crossing', 'mcnemar_exact', 'paired_table', 'wilson_interval', 'METRICS', 'box_stats', 'group_summary', 'median_change_intervals', 'median_changes', 'terrain_changes', 'terrain_success']
