"""Each planned test on each engine with the cross-engine verdict (issue 42, Deliver 3)."""

import itertools

import numpy as np
import pandas as pd
import pytest

from offroadbench.study.stats.engines import engine_table
from offroadbench.study.stats.plan import confirmatory_table, plan_from_dict

PLAN = plan_from_dict({"comparisons": [{"name": "astar against the line", "treatment": {"planner.name": "astar"},
                                        "control": {"planner.name": "straight"}}]})


def _meta(engines=("pybullet", "mujoco")):
    grid = [{"key": "planner.name", "values": ["straight", "astar"]}, {"key": "sim.engine", "values": list(engines)}]
    cells = [dict(zip(["planner.name", "sim.engine"], v, strict=True))
             for v in itertools.product(grid[0]["values"], grid[1]["values"])]
    return {"study": {"grid": grid}, "columns": {"planner.name": "planner", "sim.engine": "engine"},
            "cells": [{"index": i, "values": v} for i, v in enumerate(cells)]}


def _trials(meta, rate):
    """``rate(planner, engine, terrain)`` -> successes of 4 missions."""
    rows = []
    for c in meta["cells"]:
        p, e = c["values"]["planner.name"], c["values"]["sim.engine"]
        for j in range(10):
            k = rate(p, e, j)
            rows += [{"cell": c["index"], "terrain": j, "mission": m, "success": m < k} for m in range(4)]
    return pd.DataFrame(rows)


def test_a_test_that_holds_on_one_engine_only_says_which():
    meta = _meta()
    # PyBullet: astar 4 of 4, the line 0 of 4 on every terrain; MuJoCo: both 2 of 4
    trials = _trials(meta, lambda p, e, j: (4 if p == "astar" else 0) if e == "pybullet" else 2)
    confirm = confirmatory_table(PLAN, meta, trials, None)
    eng = engine_table(PLAN, meta, trials, None, confirm)
    assert list(eng["engine"]) == ["pybullet", "mujoco"] and (eng["verdict"] == "holds on pybullet only").all()
    assert eng.set_index("engine").loc["pybullet", "effect"] == 100 and eng.set_index("engine").loc["mujoco", "effect"] == 0
    # the engine difference: per terrain (0 - 100) on mujoco minus pybullet
    r = eng.iloc[0]
    assert r["engines"] == "mujoco - pybullet" and r["engine_difference"] == -100
    assert r["engine_difference_low"] == r["engine_difference_high"] == -100 and r["engine_difference_terrains"] == 10


def test_verdicts_both_neither_and_opposite():
    meta = _meta()
    both = _trials(meta, lambda p, e, j: 4 if p == "astar" else j % 2)
    confirm = confirmatory_table(PLAN, meta, both, None)
    eng = engine_table(PLAN, meta, both, None, confirm)
    assert (eng["verdict"] == "holds on both").all()
    assert eng["engine_difference"].iloc[0] == pytest.approx(0.0)
    neither = _trials(meta, lambda p, e, j: 2)
    eng = engine_table(PLAN, meta, neither, None, confirmatory_table(PLAN, meta, neither, None))
    assert (eng["verdict"] == "holds on neither").all()
    opposite = _trials(meta, lambda p, e, j: (4 if p == "astar" else 0) if e == "pybullet" else (0 if p == "astar" else 4))
    eng = engine_table(PLAN, meta, opposite, None, confirmatory_table(PLAN, meta, opposite, None))
    assert (eng["verdict"] == "opposite directions").all() and eng["engine_difference"].iloc[0] == -200


def test_one_engine_gives_no_table():
    meta = _meta(("pybullet",))
    trials = _trials(meta, lambda p, e, j: 2)
    assert engine_table(PLAN, meta, trials, None, confirmatory_table(PLAN, meta, trials, None)) is None


def test_engine_difference_interval_is_a_terrain_bootstrap():
    meta = _meta()
    rng = np.random.default_rng(0)
    shift = rng.integers(0, 3, 10)
    trials = _trials(meta, lambda p, e, j: (1 + (shift[j] if e == "mujoco" else 0)) if p == "astar" else 1)
    eng = engine_table(PLAN, meta, trials, None, confirmatory_table(PLAN, meta, trials, None))
    d = 25.0 * shift  # per terrain, points
    r = eng.iloc[0]
    assert r["engine_difference"] == pytest.approx(d.mean())
    assert r["engine_difference_low"] <= d.mean() <= r["engine_difference_high"]
    assert r["engine_difference_low"] >= d.min() and r["engine_difference_high"] <= d.max()


def test_the_report_gives_the_plan_on_each_engine(tmp_path):
    import copy

    from offroadbench.study import run_study, study_from_dict
    from offroadbench.study.report.markdown import build_report
    from offroadbench.study.spec.config import plan_cells

    from tests.study.test_stress import STUDY, fake_planner_trials

    data = copy.deepcopy(STUDY)
    data["study"].update(terrains_per_cell=3, missions_per_terrain=2)
    data["grid"] = {"planner.name": ["straight", "astar"], "recipe.layers.base.D_high": [2.9],
                    "sim.engine": ["pybullet", "mujoco"]}
    data["analysis"] = {"comparisons": [{"name": "astar against the line", "treatment": {"planner.name": "astar"},
                                         "control": {"planner.name": "straight"}}]}
    study = study_from_dict(data)
    run_study(study, plan_cells(study), tmp_path, executor="inline", trial_fn=fake_planner_trials)
    rep = build_report(tmp_path)
    eng = rep.tables["engine_verdicts.csv"]
    assert sorted(eng["engine"]) == ["mujoco", "pybullet"] and eng["verdict"].nunique() == 1
    assert "### The plan on each engine" in rep.markdown
    assert f"- **astar against the line** (D_high = 2.9): {eng['verdict'].iloc[0]}." in rep.markdown
    # the fake trials ignore the engine: the same outcomes on both, no engine difference
    assert eng["engine_difference"].iloc[0] == 0
    assert len(rep.tables["confirmatory.csv"]) == 2 and "power" in rep.tables["confirmatory.csv"]
