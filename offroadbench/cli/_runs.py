"""What ``study run``, ``search run`` and ``suite run`` share: their executor options and the checks
of them, the run directory, the worker count, SIGTERM ending a run as Ctrl-C does, the progress
bar, and the lines said at the end of a run. Each command keeps only what is its own (its input,
its plan, its summary line's head, its report)."""

from __future__ import annotations

import argparse
import contextlib
import functools
import signal
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

from offroadbench.errors import InputError, RunInterrupted, StudyError

__all__ = ["add_run_options", "trial_timeout_arg", "check_run_args", "run_dir", "run_workers", "run_options",
           "prepare_run", "run_command", "stop_signals", "RunBar", "run_bar", "run_totals", "fault_lines", "say_run",
           "report_due", "write_report_folder"]


# --------------------------------------------------------------------------- options
def trial_timeout_arg(text: str) -> float:
    """The argparse type of ``--trial-timeout-s``: a number of seconds in (0, 30 days]
    (offroadbench.study.execution.check_trial_timeout); otherwise one line saying so."""
    from offroadbench.study.execution import MAX_TRIAL_TIMEOUT_S, check_trial_timeout

    try:
        return check_trial_timeout(float(text))
    except (ValueError, InputError):
        raise argparse.ArgumentTypeError(f"--trial-timeout-s must be a number of seconds > 0 and at most "
                                         f"{MAX_TRIAL_TIMEOUT_S:g} (30 days), got {text!r}") from None


def add_run_options(run: argparse.ArgumentParser, *, out_help: str, goes_on: str, items: str = "trials",
                    fault_note: str = "", force_checks: str = "memory and study-size estimate checks") -> None:
    """Add the options every command that runs trials takes: --out (``out_help``), --workers,
    --executor, --scheduler, --trial-timeout-s (a trial past it is a fault``fault_note`` and
    ``goes_on``: "the study goes on"), --retry-faults (of the stored ``items``) and --force (skips
    the up-front ``force_checks``)."""
    from offroadbench.cli._common import int_at_least
    from offroadbench.study.execution import EXECUTORS

    run.add_argument("--out", help=out_help)
    run.add_argument("--workers", type=int_at_least(1, "--workers"), default=None,
                     help="worker processes (default: as many as both the cores and the memory allow)")
    run.add_argument("--executor", default="local", choices=sorted(EXECUTORS), help="where trials run (default: local)")
    run.add_argument("--scheduler", help="Dask scheduler address (with --executor dask; default: a LocalCluster)")
    run.add_argument("--trial-timeout-s", type=trial_timeout_arg, default=None,
                     help=f"local and dask: a trial running longer than this, s, is stored as a fault{fault_note} "
                          "(its worker replaced where the trial cannot be stopped; on dask a worker silent for this "
                          f"plus 10 s too) and {goes_on} (default: generous against the trials' nominal time; at "
                          "most 30 days; at least the shortest possible trial)")
    run.add_argument("--retry-faults", action="store_true",
                     help=f"run the {items} stored as faults (past their limit, thrown while settling) once more; "
                          "a resume skips them otherwise")
    run.add_argument("--force", action="store_true",
                     help=f"skip the up-front {force_checks} (memory also OFFROADBENCH_NO_MEMORY_CHECK=1)")


def check_run_args(args: argparse.Namespace) -> None:
    """The options that go together only in some ways, refused in one line naming the flag before
    anything is loaded: --scheduler without --executor dask, --trial-timeout-s with --executor
    inline or batched (their executors cannot stop one trial)."""
    if args.scheduler and args.executor != "dask":
        raise InputError(f"--scheduler needs --executor dask, not {args.executor}")
    if args.trial_timeout_s is not None and args.executor in ("inline", "batched"):
        raise InputError(f"--trial-timeout-s applies to --executor local and dask, not {args.executor}")


# --------------------------------------------------------------------------- before the run
def run_dir(out: str | None, parent: Path, name: str, named_by: str) -> Path:
    """The checked run directory: ``--out``, or ``parent/name``. A default ``name`` must be one plain
    path component (not empty, ``.`` or ``..``, no slash, NUL or control character); ``named_by``
    says where it comes from, e.g. ``study.toml: [study] name``."""
    from offroadbench.cli._common import check_output_dir

    if not out:
        bad = name in ("", ".", "..") or any(c in name for c in "/\\") or any(ord(c) < 32 or ord(c) == 127 for c in name)
        if bad:
            raise InputError(f"{named_by} = {name!r} cannot name the run directory {parent}/NAME (it must be one plain "
                             "file name: no slash, control character, '.' or '..'); rename it or give --out")
    return check_output_dir(out if out else parent / name, "--out")


def run_workers(args: argparse.Namespace, plans) -> int | None:
    """--workers, or as many as both the cores and the memory allow for the largest of ``plans``
    (CellPlans); refuse what cannot fit."""
    from offroadbench.memory import check_memory, format_bytes, workers_that_fit
    from offroadbench.study.runner import worker_memory_bytes

    if args.executor == "inline" or (args.executor == "dask" and args.scheduler):
        return args.workers  # one process here, or a cluster whose memory is not ours to judge
    per_worker = worker_memory_bytes(plans)
    workers = args.workers if args.workers is not None else workers_that_fit(per_worker)
    check_memory(workers * per_worker, f"{workers} worker(s) of about {format_bytes(per_worker)} each", args.force,
                 per_process_bytes=per_worker)
    return workers


def prepare_run(args: argparse.Namespace, plans, floor_plans=None) -> dict[str, Any]:
    """After the plan is made and before anything is written: refuse a --trial-timeout-s below the
    shortest possible trial of ``floor_plans`` (default ``plans``; issue 44), choose the workers for
    ``plans``, and return the keyword arguments every runner takes (executor, workers, scheduler,
    executor_options, retry_faults)."""
    from offroadbench.study.execution.common import check_trial_floor

    check_trial_floor(args.trial_timeout_s, plans if floor_plans is None else floor_plans)
    return run_options(args, run_workers(args, plans))


def run_options(args: argparse.Namespace, workers: int | None) -> dict[str, Any]:
    """The keyword arguments of run_study, run_search and run_suite that the options give."""
    options = {} if args.trial_timeout_s is None else {"trial_timeout_s": args.trial_timeout_s}
    return {"executor": args.executor, "workers": workers, "scheduler": args.scheduler, "executor_options": options,
            "retry_faults": args.retry_faults}


def run_command(run: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """A command that runs trials (the ``run`` of study, search and suite): inside stop_signals, so
    Ctrl-C and SIGTERM end it at any moment with one line (what is kept, how to resume)."""

    @functools.wraps(run)
    def command(args: argparse.Namespace) -> int:
        with stop_signals():
            return run(args)

    return command


@contextlib.contextmanager
def stop_signals() -> Iterator[None]:
    """While inside: Ctrl-C and SIGTERM end the run (offroadbench.stop: noted, so never lost;
    workers stopped, the session ``interrupted``, every committed trial kept, the same one line
    said; exit 130 and 143). A stop outside the run's session (resolving the cells, the report)
    says so in the same one line."""
    from offroadbench import stop

    try:
        with stop.handled():
            yield
    except RunInterrupted:
        raise
    except KeyboardInterrupt as exc:
        raise RunInterrupted("every trial stored so far is kept; run the same command again to resume",
                             signum=getattr(exc, "signum", signal.SIGINT)) from None


# --------------------------------------------------------------------------- during the run
class RunBar:
    """The progress bar's callbacks: ``progress(done, total)`` (set by run_bar) and ``on_trial(row)``,
    which counts the stored rows' ``success`` for the success rate shown after the bar (once a row
    is counted; a runner without ``on_trial`` shows none)."""

    def __init__(self) -> None:
        self.progress: Callable[[int, int], None] = lambda done, total: None
        self.new = self.ok = 0

    def on_trial(self, row: Mapping[str, Any]) -> None:
        self.new += 1
        self.ok += bool(row["success"])

    def postfix(self) -> dict:
        return {"success": f"{100.0 * self.ok / self.new:.0f}%"} if self.new else {}


@contextlib.contextmanager
def run_bar(desc: str) -> Iterator[RunBar]:
    """A progress bar of trials on stderr (hidden when stderr is not a terminal)."""
    from offroadbench.cli._common import bar

    callbacks = RunBar()
    with bar(desc, unit="trial", postfix=callbacks.postfix) as progress:
        callbacks.progress = progress
        yield callbacks


# --------------------------------------------------------------------------- after the run
def run_totals(summaries, run_dir: Path):
    """The RunSummary of runs one after another into ``run_dir`` (a suite's categories): trials,
    successes and seconds added, the faults of each kind added (the first example kept, most first)."""
    from offroadbench.study.session import FaultCount, RunSummary

    kinds: dict[str, FaultCount] = {}
    for s in summaries:
        for f in s.new_faults:
            old = kinds.get(f.kind)
            kinds[f.kind] = f if old is None else FaultCount(f.kind, old.count + f.count, old.example)
    added = {k: sum(getattr(s, k) for s in summaries) for k in ("total", "done", "ran", "successes", "wall_s", "faults")}
    return RunSummary(run_dir=run_dir, **added, new_faults=tuple(sorted(kinds.values(), key=lambda f: -f.count)))


def fault_lines(summary, out: Path, outcomes_needed: bool = True) -> list[str]:
    """The lines on the faults a run stored: one per kind with its count. With ``outcomes_needed``
    a run whose every trial faulted (none gave an outcome) is a StudyError saying so in one line
    (exit 1)."""
    if not summary.faulted:
        return []
    kinds = "; ".join(f.describe() for f in summary.new_faults)
    if outcomes_needed and not summary.ran:
        raise StudyError(f"every trial of this run faulted, none gave an outcome ({kinds}); the faults are stored "
                         f"in {out} (--retry-faults runs them again)")
    return [f"faults of this run: {f.describe()}" for f in summary.new_faults]


def say_run(head: str, summary, out: Path, outcomes_needed: bool = True) -> None:
    """Print the end of a run: ``head`` (what is stored, the command's own words), what this run did
    and its rate, then one line per kind of fault (fault_lines: with ``outcomes_needed``, a run of
    faults only is one line and exit 1 instead)."""
    lines = fault_lines(summary, out, outcomes_needed)
    print(f"{head}; this run: {summary.ran} trials in {summary.wall_s:.1f} s ({summary.trials_per_s:.2f} trials/s)")
    for line in lines:
        print(line)


def report_due(args: argparse.Namespace, summary) -> bool:
    """Whether the report is written now: every trial stored (as an outcome or a fault), at least
    one outcome (a run of faults only has no statistics), and no --no-report."""
    return summary.done + summary.faults >= summary.total and summary.done > 0 and not args.no_report


def write_report_folder(report, out: Path, toml: str | None, toml_name: str,
                        html: Callable[[], str] | None = None) -> Path:
    """Write a run's report (a study's or a search's: ``figures``, ``tables``, ``markdown``) into the
    folder ``out`` whole: its figures (PNG), tables (CSV), the run's TOML as ``toml_name``, report.md
    and, with ``html`` (a function giving the page), report.html. All or nothing: the folder is
    written beside its place and swapped in whole, so a killed report never leaves figures without
    report.md, nor a new report.md over old figures. Returns the path of the page written last."""
    from offroadbench.cli._common import created_dirs, save_figure
    from offroadbench.io.export import staged_dir

    with created_dirs(out.parent), staged_dir(out) as stage:
        for name, fig in report.figures.items():
            save_figure(fig, stage / name, dpi=110)
        for name, df in report.tables.items():
            df.to_csv(stage / name, index=False)
        if toml:
            (stage / toml_name).write_text(toml)
        (stage / "report.md").write_text(report.markdown)
        if html is not None:
            (stage / "report.html").write_text(html(), encoding="utf-8")
    return out / ("report.html" if html is not None else "report.md")
