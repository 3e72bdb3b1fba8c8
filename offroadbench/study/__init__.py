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

from offroadbench.lazy import lazy_exports

#: public name -> the submodule that defines it
_EXPORTS = {
    "StudyConfig": "spec.config",
    "GridAxis": "spec.config",
    "CellPlan": "spec.cells",
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


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
