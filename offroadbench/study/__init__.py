"""Monte Carlo studies: study configs, seeds, executors, result store, reports.

Typical use::

    from offroadbench.study import load_study, run_study, load
    study, cells = load_study("experiments/smoke.toml")
    run_study(study, cells, "runs/smoke", workers=2)
    df = load("runs/smoke")          # one tidy row per trial
"""

from offroadbench.study.spec.config import CellPlan, GridAxis, StudyConfig, load_study, study_from_dict
from offroadbench.study.store.results import load, load_meta, load_terrains
from offroadbench.study.runner import run_study
from offroadbench.study.session import RunSession, RunSummary

__all__ = [
    "StudyConfig",
    "GridAxis",
    "CellPlan",
    "load_study",
    "study_from_dict",
    "run_study",
    "RunSummary",
    "RunSession",
    "load",
    "load_terrains",
    "load_meta",
]
