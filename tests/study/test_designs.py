"""The committed study designs: the number of terrains of planner-stress follows from the power
of its planned tests, simulated on the previous run's per-terrain differences."""

from pathlib import Path

import pandas as pd
import pytest

from offroadbench.study.clustered import paired_power, terrains_needed

ROOT = Path(__file__).resolve().parents[2]

#: the pilot (planner-stress before issue 22: 6 terrains x 8 missions, root_seed 11): per-terrain
#: success difference planner - straight, in points, mean and sd over the 6 terrains
PILOT = {("astar", 2.6): (6.25, 17.23), ("astar", 2.9): (27.08, 30.02), ("astar", 2.95): (37.5, 15.81),
         ("astar", 2.99): (62.5, 23.72), ("lattice", 2.6): (6.25, 17.23), ("lattice", 2.9): (27.08, 30.02),
         ("lattice", 2.95): (35.42, 12.29), ("lattice", 2.99): (43.75, 32.36)}


def test_pilot_numbers_recompute_from_its_committed_table():
    # the pilot's per-terrain table as committed at 4da30e4 (experiments/results/planner-stress/
    # terrains.csv before the re-designed run replaced it), kept here so the check still runs
    t = pd.read_csv(Path(__file__).parent / "data" / "planner_stress_pilot_terrains.csv")
    assert t["terrain"].nunique() == 6 and len(t) == 120
    p = t.pivot_table(index=["D_high", "terrain"], columns="planner", values="success_rate_pct")
    for (planner, level), (mean, sd) in PILOT.items():
        d = (p[planner] - p["straight"]).loc[level]
        assert d.mean() == pytest.approx(mean, abs=0.01) and d.std(ddof=1) == pytest.approx(sd, abs=0.01)


def test_the_first_pilots_power_calculation_as_its_toml_stated_it():
    # issue 22's design (t-test approximation at the Bonferroni bound over 32 comparisons): 25 terrains
    # for the 2.9 effect; the smooth level's advantage out of reach
    alpha = 0.05 / 32
    assert max(terrains_needed(*PILOT[(p, lv)], alpha, 0.8) for p in ("astar", "lattice") for lv in (2.9, 2.95, 2.99)) == 25
    m, s = PILOT[("astar", 2.6)]
    assert paired_power(12, m, s, alpha) < 0.1 and 120 <= terrains_needed(m, s, alpha, 0.8) <= 140


def test_planner_stress_has_the_terrains_its_planned_tests_need():
    """Issue 29: the plan's tests, their power by simulation of the exact sign-flip test actually
    used (experiments/power.py), fresh terrains and missions shared between the surfaces."""
    import numpy as np

    from offroadbench.study import load_study
    from offroadbench.study.clustered import sign_flip_power

    study, _ = load_study(ROOT / "experiments" / "planner-stress.toml", check_sections=False)
    assert study.root_seed != 11  # not the pilots' terrains
    assert study.missions_from == {"recipe.layers.base.wm.band_limited": False}
    plan = study.analysis
    cells = [dict(v) for v in study.cell_values()]
    from offroadbench.study.plan import expand

    tests = expand(plan, cells)
    assert len(tests) == 6 and plan.multiplicity == "holm"
    import sys

    sys.path.insert(0, str(ROOT / "experiments"))
    from power import TESTS, load_pilot, per_terrain

    t = load_pilot()
    assert t["terrain"].nunique() == 12 and (t["missions"] == 8).all()  # the pilot: 12 terrains x 8 missions

    assert len(TESTS) == len(tests)
    rng = np.random.default_rng(1)
    level = plan.alpha / len(tests)
    for _, tr, co in TESTS:
        d = (per_terrain(t, tr) - per_terrain(t, co)).dropna().to_numpy()
        assert sign_flip_power(d, study.terrains_per_cell, level, rng, n_sim=200) >= 0.75
    # 12 terrains (the pilot's own design) fall short for the aliasing effect at 2.95
    _, tr, co = TESTS[4]
    d = (per_terrain(t, tr) - per_terrain(t, co)).dropna().to_numpy()
    assert sign_flip_power(d, 12, level, rng, n_sim=200) < 0.5


@pytest.mark.parametrize(("name", "cells", "trials"), [("planner-stress", 36, 5760), ("vehicle-sensitivity", 6, 1200)])
def test_the_designed_studies_load_with_every_cell_checked(name, cells, trials):
    from offroadbench.study import load_study

    study, plans = load_study(ROOT / "experiments" / f"{name}.toml")
    assert len(plans) == cells
    assert cells * study.terrains_per_cell * study.missions_per_terrain == trials
    if name == "planner-stress":
        noisy = [p for p in plans if p.values["planner.map_noise_m"] > 0 and p.values["planner.name"] != "straight"]
        assert noisy and all(p.section("planner").perception.map_noise_corr_m == 0.25 for p in noisy)
        clean = [p for p in plans if p.values["planner.map_noise_m"] == 0]
        assert all(p.section("planner").perception is None for p in clean)
    else:
        first = plans[0].section("vehicle")
        assert (first.wheel_torque_limit_nm, first.wheel_spin_inertia_kg_m2) == (28.0, 1.0)


def test_power_script_prints_every_planned_test(monkeypatch, capsys):
    import sys

    sys.path.insert(0, str(ROOT / "experiments"))
    import power

    monkeypatch.setattr(sys, "argv", ["power.py", "--n-sim", "5"])
    power.main()
    out = capsys.readouterr().out
    assert "alpha / m = 0.05 / 6" in out
    assert all(name in out for name, _, _ in power.TESTS + power.NOT_PLANNED)
