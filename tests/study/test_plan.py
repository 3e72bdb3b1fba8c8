"""The analysis plan of a study ([analysis], offroadbench.study.stats.plan): validation against the grid,
its expansion into tests, and the confirmatory numbers against hand computations."""

import math

import numpy as np
import pandas as pd
import pytest

from offroadbench.errors import InputError
from offroadbench.study.stats.clustered import holm, sign_flip_power
from offroadbench.study.stats.plan import confirmatory_table, expand, min_p, plan_from_dict
from offroadbench.study.spec.config import study_from_dict

GRID = {"sim.engine": ["pybullet", "mujoco"], "recipe.layers.base.D_high": [2.3, 2.6]}


def _study(analysis, paired=True):
    return study_from_dict({"study": {"name": "s", "recipe": "paper-d2.45", "root_seed": 1,
                                      "paired_terrains": paired}, "grid": GRID, "analysis": analysis})


def _comp(**kw):
    return {"name": "engine", "treatment": {"sim.engine": "mujoco"}, "control": {"sim.engine": "pybullet"}, **kw}


def test_a_plan_is_validated_against_the_grid():
    assert _study({"comparisons": [_comp()]}).analysis.multiplicity == "holm"
    with pytest.raises(InputError, match="is not a grid axis"):
        _study({"comparisons": [_comp(treatment={"sim.gravity_m_s2": 1.62}, control={"sim.gravity_m_s2": 9.81})]})
    with pytest.raises(InputError, match="is not a value of the axis"):
        _study({"comparisons": [_comp(treatment={"sim.engine": "ode"})]})
    with pytest.raises(InputError, match="metric = 'speed' is not known"):
        _study({"comparisons": [_comp(metric="speed")]})
    with pytest.raises(InputError, match="needs paired terrains"):
        _study({"comparisons": [_comp()]}, paired=False)
    with pytest.raises(InputError, match="multiplicity = 'fdr' is not known"):
        _study({"multiplicity": "fdr", "comparisons": [_comp()]})
    with pytest.raises(InputError, match="unknown key"):
        plan_from_dict({"comparisons": [_comp(tails=1)]})
    with pytest.raises(InputError, match="at least one"):
        plan_from_dict({"alpha": 0.05})


def test_expand_strata_and_pooling():
    cells = [{"sim.engine": e, "recipe.layers.base.D_high": d} for e in GRID["sim.engine"] for d in (2.3, 2.6)]
    per_level = expand(plan_from_dict({"comparisons": [_comp()]}), cells)
    assert [(st, t, c) for _, st, t, c in per_level] == [({"recipe.layers.base.D_high": 2.3}, [2], [0]),
                                                         ({"recipe.layers.base.D_high": 2.6}, [3], [1])]
    pooled = expand(plan_from_dict({"comparisons": [_comp(pool=["recipe.layers.base.D_high"])]}), cells)
    assert [(st, t, c) for _, st, t, c in pooled] == [({}, [2, 3], [0, 1])]
    where = expand(plan_from_dict({"comparisons": [_comp(where={"recipe.layers.base.D_high": [2.6]})]}), cells)
    assert [(t, c) for _, _, t, c in where] == [([3], [1])]


def _meta_and_trials(rates, missions=10):
    """rates[cell][terrain] successes out of ``missions``."""
    cells = [{"sim.engine": e, "recipe.layers.base.D_high": d} for e in GRID["sim.engine"] for d in (2.3, 2.6)]
    meta = {"cells": [{"index": i, "values": v} for i, v in enumerate(cells)],
            "columns": {"sim.engine": "engine", "recipe.layers.base.D_high": "D_high"}}
    rows = [{"cell": c, "terrain": j, "mission": m, "success": m < k}
            for c, per in enumerate(rates) for j, k in enumerate(per) for m in range(missions)]
    return meta, pd.DataFrame(rows)


def test_confirmatory_numbers_are_the_planned_tests():
    rates = [[5, 6, 7, 8, 5, 6], [4, 4, 4, 4, 4, 4], [7, 8, 9, 9, 6, 8], [4, 5, 4, 5, 4, 5]]
    meta, trials = _meta_and_trials(rates)
    plan = plan_from_dict({"comparisons": [_comp(), _comp(name="pooled", pool=["recipe.layers.base.D_high"])],
                           "n_boot": 500})
    tab = confirmatory_table(plan, meta, trials, None)
    assert list(tab["stratum"]) == ["D_high = 2.3", "D_high = 2.6", "all; pooled over D_high"]
    d = 10.0 * (np.array(rates[2]) - np.array(rates[0]))
    first = tab.iloc[0]
    assert first["effect"] == pytest.approx(d.mean()) and first["ci_low"] <= d.mean() <= first["ci_high"]
    # 6 terrains, every difference positive: the exact sign-flip p is 2 / 2^6, its floor
    assert first["p"] == pytest.approx(2 / 64) and first["min_p"] == pytest.approx(2 / 64)
    assert list(tab["p_adjusted"]) == pytest.approx(list(holm(tab["p"])))
    pooled = (np.array(rates[2]) + np.array(rates[3]) - np.array(rates[0]) - np.array(rates[1])) * 10 / 2
    assert tab.iloc[2]["effect"] == pytest.approx(pooled.mean())
    # with three tests no p of 6 terrains survives Holm: the floor 2/64 x 3 > 0.05
    assert not tab["reject"].any()
    bonf = confirmatory_table(plan_from_dict({"comparisons": [_comp()], "multiplicity": "bonferroni"}), meta, trials,
                              None)
    assert list(bonf["p_adjusted"]) == pytest.approx(list(np.minimum(1, 2 * bonf["p"])))


def test_a_pooled_cell_without_trials_leaves_its_pair_out_of_both_sides():
    """A planner that refuses a vehicle leaves its cell without trials (faults only): the pooled
    comparison drops that cell's pair on both sides, so treatment and control pool the same levels."""
    rates = [[5, 6, 7, 8, 5, 6], [4, 4, 4, 4, 4, 4], [7, 8, 9, 9, 6, 8], [4, 5, 4, 5, 4, 5]]
    meta, trials = _meta_and_trials(rates)
    trials = trials[trials["cell"] != 3]  # mujoco at D_high 2.6: every trial a fault
    plan = plan_from_dict({"comparisons": [_comp(name="pooled", pool=["recipe.layers.base.D_high"])], "n_boot": 200})
    row = confirmatory_table(plan, meta, trials, None).iloc[0]
    d = 10.0 * (np.array(rates[2]) - np.array(rates[0]))  # D_high 2.3 only, both sides
    assert row["effect"] == pytest.approx(d.mean()) and row["control_mean"] == pytest.approx(10.0 * np.mean(rates[0]))


def test_min_p_and_simulated_power_of_the_sign_flip_test():
    assert min_p("sign_flip", 10) == pytest.approx(2 / 1024)
    assert min_p("permutation", 3, 3) == pytest.approx(2 / 20)
    rng = np.random.default_rng(0)
    # every terrain gains: the exact test reaches its floor 2 / 2^K every time
    assert sign_flip_power([10.0, 20.0], 8, 0.01, rng, n_sim=50) == 1.0
    # below the floor (2 / 2^6 = 0.031 > 0.01) no design of 6 terrains can reject
    assert sign_flip_power([10.0, 20.0], 6, 0.01, rng, n_sim=50) == 0.0
    # no effect (symmetric differences): power near alpha
    power = sign_flip_power([-1.0, 1.0, -2.0, 2.0], 12, 0.05, rng, n_sim=600)
    assert power == pytest.approx(0.05, abs=0.03)
    assert math.isclose(sign_flip_power([], 10, 0.05, rng), 0.0)
