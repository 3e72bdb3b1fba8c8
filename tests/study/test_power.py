"""Power of a plan's tests before the run (offroadbench.study.stats.power), against closed forms."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binom

from offroadbench.errors import InputError
from offroadbench.study.spec.config import study_from_dict
from offroadbench.study.stats.clustered import holm
from offroadbench.study.stats.power import adjust_rows, check_power, family_power, plan_power


def sign_test_power(k: int, q: float, level: float) -> float:
    """Closed form: the sign-flip test of K differences of +1 or -1 is the two-sided sign test; with
    P(+1) = q its power at ``level`` is the binomial mass of the counts whose p is under the level."""
    x = np.arange(k + 1)
    null = binom.pmf(x, k, 0.5)
    dev = np.abs(2 * x - k)
    p = np.array([null[dev >= d].sum() for d in dev])
    return float(binom.pmf(x, k, q)[p < level].sum())


@pytest.mark.parametrize("k,q", [(10, 0.8), (12, 0.75), (8, 0.9)])
def test_a_single_sign_flip_test_has_the_sign_tests_power(k, q):
    pilot = np.array([1.0] * int(round(100 * q)) + [-1.0] * int(round(100 * (1 - q))))
    n = 6000
    got = family_power([pilot], [k], 0.05, np.random.default_rng(1), n_sim=n)[0]
    want = sign_test_power(k, q, 0.05)
    assert abs(got - want) < 4 * math.sqrt(want * (1 - want) / n) + 1e-9


def test_constant_differences_reject_exactly_when_the_smallest_p_is_under_the_holm_level():
    rng = np.random.default_rng(0)
    # one test: p = 2 / 2^K; K = 6 gives 0.031 < 0.05, K = 5 gives 0.0625
    assert family_power([np.full(3, 5.0)], [6], 0.05, rng, n_sim=200)[0] == 1.0
    assert family_power([np.full(3, 5.0)], [5], 0.05, rng, n_sim=200)[0] == 0.0
    # two such tests under Holm: the first step is at 0.025, which 2 / 2^6 misses and 2 / 2^7 passes
    assert family_power([np.full(3, 5.0)] * 2, [6, 6], 0.05, rng, n_sim=200).tolist() == [0.0, 0.0]
    assert family_power([np.full(3, 5.0)] * 2, [7, 7], 0.05, rng, n_sim=200).tolist() == [1.0, 1.0]
    # beyond exact enumeration (Monte Carlo sign patterns): still certain
    assert family_power([np.full(3, 5.0)], [20], 0.05, rng, n_sim=100)[0] == 1.0


def test_a_test_faces_the_holm_step_it_will_face():
    # test A always rejects first (constant, 12 terrains, p = 0.0005); test B then faces Holm's second
    # step, alpha / 1: its power is the single test's at 0.05, not at the first step's 0.025
    pilot_b = np.array([1.0] * 80 + [-1.0] * 20)
    n = 6000
    got = family_power([np.full(4, 3.0), pilot_b], [12, 12], 0.05, np.random.default_rng(2), n_sim=n)
    assert got[0] == 1.0
    want = sign_test_power(12, 0.8, 0.05)
    assert abs(got[1] - want) < 4 * math.sqrt(want * (1 - want) / n)
    assert want > sign_test_power(12, 0.8, 0.025) + 0.05  # the step matters here
    bonf = family_power([np.full(4, 3.0), pilot_b], [12, 12], 0.05, np.random.default_rng(2), n_sim=n,
                        multiplicity="bonferroni")[1]
    want_b = sign_test_power(12, 0.8, 0.025)
    assert abs(bonf - want_b) < 4 * math.sqrt(want_b * (1 - want_b) / n)


def test_the_stated_effect_shifts_the_pilot():
    pilot = np.array([-10.0, -5.0, 0.0, 5.0, 10.0])  # centred on 0: power at most alpha
    null = family_power([pilot], [12], 0.05, np.random.default_rng(3), n_sim=3000)[0]
    assert null <= 0.05 + 4 * math.sqrt(0.05 * 0.95 / 3000)
    big = family_power([pilot], [12], 0.05, np.random.default_rng(3), n_sim=1000, effects=[20.0])[0]
    assert big == 1.0


def test_vectorised_holm_is_holm():
    p = np.random.default_rng(4).random((50, 6)) ** 3
    assert np.allclose(adjust_rows(p, "holm"), np.array([holm(r) for r in p]))


def _pilot(n_terrains: int, rates: dict[str, float], seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = []
    for j in range(n_terrains):
        bump = rng.normal(0, 0.1)
        for planner, r in rates.items():
            for m in range(3):
                rows.append({"planner": planner, "D_high": 2.95, "terrain": j, "mission": m,
                             "success": bool(rng.random() < min(1, max(0, r + bump)))})
    return pd.DataFrame(rows)


STUDY = {"study": {"name": "p", "recipe": "paper-d2.45", "root_seed": 1, "terrains_per_cell": 20,
                   "missions_per_terrain": 3},
         "grid": {"planner.name": ["straight", "astar"], "recipe.layers.base.D_high": [2.95, 2.99]}}


def _plan(effect: float, exploratory: bool = False, pilot: str = "pilot.csv") -> dict:
    return {"pilot": pilot, "comparisons": [{
        "name": "astar against the line", "treatment": {"planner.name": "astar"},
        "control": {"planner.name": "straight"}, "effect": effect, "exploratory": exploratory,
        "pilot_where": {"recipe.layers.base.D_high": 2.95}}]}


def test_plan_power_reads_each_test_from_the_pilot_and_run_refuses_an_underpowered_plan(tmp_path):
    _pilot(10, {"straight": 0.3, "astar": 0.6}).to_csv(tmp_path / "pilot.csv", index=False)
    strong = study_from_dict({**STUDY, "analysis": _plan(45.0)})
    table = check_power(strong, tmp_path)
    assert list(table["stratum"]) == ["D_high = 2.95", "D_high = 2.99"]
    assert (table["pilot_terrains"] == 10).all() and (table["power"] >= 0.8).all()
    # the pilot's per-terrain differences of the test, from its trials
    t = pd.read_csv(tmp_path / "pilot.csv")
    d = t.groupby(["planner", "terrain"])["success"].mean().mul(100)
    assert table["pilot_mean"].iloc[0] == pytest.approx((d["astar"] - d["straight"]).mean())
    weak = study_from_dict({**STUDY, "study": {**STUDY["study"], "terrains_per_cell": 6}, "analysis": _plan(5.0)})
    with pytest.raises(InputError, match=r"planned test 'astar against the line' \(D_high = 2.95\) has power 0\.\d\d < 0.8"):
        check_power(weak, tmp_path)
    marked = study_from_dict({**STUDY, "study": {**STUDY["study"], "terrains_per_cell": 6},
                              "analysis": _plan(5.0, exploratory=True)})
    assert (check_power(marked, tmp_path)["power"] < 0.8).all()
    # no pilot: nothing to check; a pilot that is not there: refused
    assert check_power(study_from_dict({**STUDY, "analysis": {**_plan(5.0), "pilot": ""}}), tmp_path) is None
    with pytest.raises(InputError, match="no such file"):
        check_power(study_from_dict({**STUDY, "analysis": _plan(5.0, pilot="missing.csv")}), tmp_path)


def test_plan_power_is_the_same_number_every_time(tmp_path):
    pilot = _pilot(10, {"straight": 0.3, "astar": 0.5})
    study = study_from_dict({**STUDY, "analysis": _plan(15.0)})
    a = plan_power(study.analysis, study.cell_values(), study.column_names(), 20, pilot)
    b = plan_power(study.analysis, study.cell_values(), study.column_names(), 20, pilot)
    assert a["power"].tolist() == b["power"].tolist() and 0 < a["power"].iloc[0] < 1


def test_confirmatory_table_gains_power_and_the_other_summary():
    from offroadbench.study.stats.plan import confirmatory_table, plan_from_dict

    rng = np.random.default_rng(7)
    cells = [{"planner.name": "straight"}, {"planner.name": "astar"}]
    meta = {"columns": {"planner.name": "planner"}, "cells": [{"index": i, "values": v} for i, v in enumerate(cells)]}
    rows = []
    for j in range(8):
        for c in (0, 1):
            for m in range(5):
                rows.append({"cell": c, "terrain": j, "mission": m, "success": True,
                             "rms_roll_rate_deg_s": float(rng.gamma(2.0, 3.0) + 2 * c)})
    trials = pd.DataFrame(rows)
    plan = plan_from_dict({"comparisons": [{"name": "roll", "metric": "rms_roll_rate_deg_s", "summary": "mean",
                                            "treatment": {"planner.name": "astar"},
                                            "control": {"planner.name": "straight"}, "effect": 2.0}]})
    power = pd.DataFrame({"power": [0.9]})
    tab = confirmatory_table(plan, meta, trials, None, power)
    per = trials.groupby(["cell", "terrain"])["rms_roll_rate_deg_s"]
    mean_d = (per.mean()[1] - per.mean()[0]).mean()
    median_d = (per.median()[1] - per.median()[0]).mean()
    r = tab.iloc[0]
    assert r["summary"] == "mean" and r["effect"] == pytest.approx(mean_d)
    assert r["effect_other"] == pytest.approx(median_d) and 0 < r["p_other"] <= 1
    assert r["power"] == 0.9 and not r["exploratory"]
    # without a power table the column is there, empty
    assert math.isnan(confirmatory_table(plan, meta, trials, None)["power"].iloc[0])


def test_study_run_refuses_an_underpowered_plan_in_one_line(tmp_path, capsys):
    from offroadbench.cli import main

    _pilot(10, {"straight": 0.3, "astar": 0.6}).to_csv(tmp_path / "pilot.csv", index=False)
    toml = tmp_path / "weak.toml"
    toml.write_text('[study]\nname = "weak"\nrecipe = "paper-d2.45"\nroot_seed = 1\nterrains_per_cell = 6\n'
                    'missions_per_terrain = 3\n[grid]\n"planner.name" = ["straight", "astar"]\n'
                    '"recipe.layers.base.D_high" = [2.95]\n[analysis]\npilot = "pilot.csv"\n'
                    '[[analysis.comparisons]]\nname = "astar against the line"\n'
                    'treatment = { "planner.name" = "astar" }\ncontrol = { "planner.name" = "straight" }\n'
                    'effect = 5.0\n')
    code = main(["study", "run", str(toml), "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "has power" in err and "exploratory" in err
    assert not (tmp_path / "run").exists()


def test_a_pooled_axis_pools_only_the_studys_values_in_the_pilot():
    from offroadbench.study.stats.power import within_design

    pilot = pd.DataFrame({"vehicle": ["husky", "jackal", "hunter"], "D_high": [2.95, 2.95, 2.6], "terrain": 0})
    cells = [{"vehicle.name": v, "recipe.layers.base.D_high": 2.95} for v in ("husky", "jackal")]
    cols = {"vehicle.name": "vehicle", "recipe.layers.base.D_high": "D_high"}
    assert list(within_design(pilot, cells, cols)["vehicle"]) == ["husky", "jackal"]
    # an axis read at the pilot's own value (pilot_where) is not restricted
    cells99 = [{"vehicle.name": "husky", "recipe.layers.base.D_high": 2.99}]
    assert list(within_design(pilot, cells99, cols, keep=["recipe.layers.base.D_high"])["vehicle"]) == ["husky"]
    assert within_design(pilot, cells99, cols).empty


def test_pilot_select_keeps_the_pilots_rows_of_a_fixed_setting(tmp_path):
    pilot = pd.concat([_pilot(10, {"straight": 0.3, "astar": 0.9}, seed=1).assign(sensor="oracle"),
                       _pilot(10, {"straight": 0.3, "astar": 0.3}, seed=2).assign(sensor="mast")])
    data = {**STUDY, "analysis": {**_plan(20.0), "pilot_select": {"sensor": "mast"}}}
    study = study_from_dict(data)
    t = plan_power(study.analysis, study.cell_values(), study.column_names(), 20, pilot)
    mast = pilot[pilot["sensor"] == "mast"].groupby(["planner", "terrain"])["success"].mean().mul(100)
    assert t["pilot_mean"].iloc[0] == pytest.approx((mast["astar"] - mast["straight"]).mean())
    with pytest.raises(InputError, match="no column 'lidar'"):
        bad = study_from_dict({**STUDY, "analysis": {**_plan(20.0), "pilot_select": {"lidar": 1}}})
        plan_power(bad.analysis, bad.cell_values(), bad.column_names(), 20, pilot)
