"""Running a suite: each category is one study of the pipeline, run (or resumed) in its own folder.

``OUT/<category>/`` is an ordinary study run directory (``study report``, ``study replay`` and
``study export`` work on it); running the same command again resumes every category where it
stopped, and a category already complete costs nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

from offroadbench.suite.spec import CategoryConfig, SuiteConfig, category_study

__all__ = ["CategoryPlan", "CategoryRun", "plan_suite", "run_suite", "suite_trials"]


@dataclass(frozen=True)
class CategoryPlan:
    """One category, resolved: its study config and cells, and the study TOML dict they came from."""

    category: CategoryConfig
    study: Any
    """The category's :class:`offroadbench.study.StudyConfig`."""
    plans: tuple
    """Its resolved cells (:class:`offroadbench.study.CellPlan`)."""
    data: Mapping[str, Any]
    """The study TOML dict (what ``study run`` would read from a file)."""


@dataclass(frozen=True)
class CategoryRun:
    """What running one category did (:class:`offroadbench.study.RunSummary` and its folder)."""

    category: str
    run_dir: Path
    summary: Any


def plan_suite(suite: SuiteConfig, tier: str, planner: str) -> list[CategoryPlan]:
    """Every category's study for ``tier`` driven by ``planner``, validated (a bad planner name is
    an InputError with the closest names, before anything runs)."""
    from offroadbench.errors import InputError
    from offroadbench.study import study_from_dict
    from offroadbench.study.spec import plan_cells

    out = []
    for cat in suite.categories:
        data = category_study(suite, cat, tier, planner)
        where = f"{suite.name} {tier} tier, category {cat.name}"
        study = study_from_dict(data, where=where)
        try:
            plans = plan_cells(study)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        out.append(CategoryPlan(category=cat, study=study, plans=tuple(plans), data=data))
    return out


def suite_trials(planned: list[CategoryPlan]) -> int:
    """Trials of the whole suite run (every category's study)."""
    return sum(p.study.n_trials for p in planned)


def run_suite(
    planned: list[CategoryPlan],
    out: str | Path,
    *,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    executor_options: Mapping[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
    on_trial: Callable[[Mapping[str, Any]], None] | None = None,
    retry_faults: bool = False,
) -> list[CategoryRun]:
    """Run (or resume) every category of a planned suite into ``out/<category>``, one after another.

    ``progress(done, total)`` counts stored trials over the whole suite. A category's study stops
    the suite as it stops ``study run`` (an error naming it; what was committed stays)."""
    from offroadbench.study import run_study

    total = suite_trials(planned)
    runs: list[CategoryRun] = []
    offset = 0
    for plan in planned:
        def part(done: int, _n: int, _offset: int = offset) -> None:
            if progress is not None:
                progress(_offset + done, total)

        summary = run_study(plan.study, list(plan.plans), Path(out) / plan.category.name, executor=executor,
                            workers=workers, scheduler=scheduler, executor_options=executor_options,
                            source_text=_toml_text(plan.data), progress=part, on_trial=on_trial,
                            retry_faults=retry_faults)
        runs.append(CategoryRun(category=plan.category.name, run_dir=Path(out) / plan.category.name, summary=summary))
        offset += plan.study.n_trials
    return runs


def _toml_text(data: Mapping[str, Any]) -> str:
    """The study dict as the store's ``study_toml`` text (JSON: a subset of what a reader needs)."""
    import json

    return "# a suite category's study, as a JSON table\n# " + json.dumps(data, sort_keys=True)


def score_run(suite: SuiteConfig, suite_file: str, tier: str, planner: str, out: str | Path) -> dict[str, Any]:
    """The score card (:func:`offroadbench.suite.score.make_card`) of a suite run in ``out``: every
    category's task rows, and what ran (code versions, machines, sessions' wall time, trials)."""
    from offroadbench.errors import InputError
    from offroadbench.study import load_meta
    from offroadbench.suite.score import make_card, task_rows

    tasks: list[dict[str, Any]] = []
    versions, machines, wall_s, created = set(), set(), 0.0, []
    for cat in suite.categories:
        run_dir = Path(out) / cat.name
        if not (run_dir / "study.sqlite").is_file():
            raise InputError(f"{run_dir}: category {cat.name} has not run (no study.sqlite); run the suite first")
        meta = load_meta(run_dir)
        expected = f"{suite.name}-{tier}-{cat.name}"
        stored = (meta["study"]["name"], meta["cells"][0]["settings"].get("planner", {}).get("name"))
        if stored != (expected, planner):
            raise InputError(f"{run_dir}: holds study {stored[0]} with planner {stored[1]}, not {expected} with {planner}")
        tasks += task_rows(suite, cat.name, run_dir)
        for session in meta["runs"]:  # the sessions that ran trials (a resume of a complete run runs none)
            if not session.get("trials_run"):
                continue
            versions.add(session.get("version") or meta["version"])
            machines.add(session.get("machine", "?"))
            if session.get("finished"):
                wall_s += session["finished"] - session["started"]
        created.append(meta["created"])
    run = {"code_version": ", ".join(sorted(versions)), "machines": sorted(machines), "created": max(created),
           "wall_s": round(wall_s, 1)}
    return make_card(suite, suite_file, tier, planner, tasks, run)
