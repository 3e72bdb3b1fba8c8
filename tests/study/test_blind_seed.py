"""Blind seeds (issue 42, Deliver 2): a confirmatory study's root seed from the hash of its plan and design."""

import copy
from pathlib import Path

import pytest

from offroadbench.config import load_toml
from offroadbench.errors import InputError
from offroadbench.study import run_study, study_from_dict
from offroadbench.study.report.markdown import build_report
from offroadbench.study.spec.config import blind_root_seed, plan_cells, study_id

from tests.study.test_stress import STUDY, fake_planner_trials

PLAN = {"comparisons": [{"name": "astar against the line", "treatment": {"planner.name": "astar"},
                         "control": {"planner.name": "straight"}}]}
BLIND = {**STUDY, "study": {**STUDY["study"], "root_seed": "blind", "terrains_per_cell": 2,
                            "missions_per_terrain": 2},
         "grid": {"planner.name": ["straight", "astar"], "recipe.layers.base.D_high": [2.6]}, "analysis": PLAN}


def test_a_blind_seed_is_the_hash_of_the_plan_and_the_design():
    study = study_from_dict(copy.deepcopy(BLIND))
    assert study.blind_seed and study.root_seed == blind_root_seed(BLIND) and 0 <= study.root_seed < 2 ** 63
    assert study_from_dict(copy.deepcopy(BLIND)).root_seed == study.root_seed  # the same plan: the same terrains
    other_plan = copy.deepcopy(BLIND)
    other_plan["analysis"]["alpha"] = 0.01
    more_terrains = copy.deepcopy(BLIND)
    more_terrains["study"]["terrains_per_cell"] = 3
    other_grid = copy.deepcopy(BLIND)
    other_grid["grid"]["recipe.layers.base.D_high"] = [2.9]
    seeds = {study_from_dict(d).root_seed for d in (other_plan, more_terrains, other_grid)}
    assert study.root_seed not in seeds and len(seeds) == 3
    words = copy.deepcopy(BLIND)
    words["study"]["description"] = "another description"
    assert study_from_dict(words).root_seed == study.root_seed
    with pytest.raises(InputError, match=r'root_seed = "blind" needs an \[analysis\] plan'):
        study_from_dict({k: v for k, v in BLIND.items() if k != "analysis"})


def test_the_report_says_whether_the_seed_was_blind(tmp_path):
    for name, data in (("blind", BLIND), ("hand", {**BLIND, "study": {**BLIND["study"], "root_seed": 7}})):
        study = study_from_dict(copy.deepcopy(data))
        run_study(study, plan_cells(study), tmp_path / name, executor="inline", trial_fn=fake_planner_trials)
        text = build_report(tmp_path / name).markdown
        if name == "blind":
            assert f"root seed {study.root_seed} (**blind**" in text
        else:
            assert "root seed 7 (chosen by hand: **not blind**)" in text


def test_a_hand_chosen_seed_keeps_its_study_id():
    # a hand-seeded committed run's id (engines as run at f44a898, study id 4e9dd13b038e in its
    # report.md; its study.toml kept under tests/study/data, since the issue 42 re-runs give every
    # committed study a blind seed), with today's code (blind_seed adds nothing to it)
    folder = Path(__file__).resolve().parent / "data"
    study = study_from_dict(load_toml(folder / "hand_seeded_engines_study.toml"))
    stated = "4e9dd13b038e"
    assert not study.blind_seed and study_id(study, plan_cells(study, base_dir=folder)) == stated
