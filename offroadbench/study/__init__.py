"""Monte Carlo studies: study configs, seeds, executors, result store, reports.

Typical use::

    from offroadbench.study import load_study, run_study, load
    study, cells = load_study("experiments/smoke.toml")
    run_study(study, cells, "runs/smoke", workers=2)
    df = load("runs/smoke")          # one tidy row per trial

The names load lazily (PEP 562), so importing a submodule (the spec, the runner) does not import
pandas or matplotlib: a study's coordinator loads them only for the report, after its workers are
done, and the forked workers never do (about 90 MB of each process; issue 41).
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> the submodule that defines it
_EXPORTS = {
    "StudyConfig": "spec.config",
    "GridAxis": "spec.config",
    "CellPlan": "spec.config",
    "load_study": "spec.config",
    "study_from_dict": "spec.config",
    "run_study": "runner",
    "RunSummary": "session",
    "RunSession": "session",
    "load": "store.results",
    "load_terrains": "store.results",
    "load_meta": "store.results",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'offroadbench.study' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"offroadbench.study.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
