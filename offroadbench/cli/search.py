"""``offroadbench search run|report``: failure searches (the work is in offroadbench.search)."""

from __future__ import annotations

import argparse
from pathlib import Path

from offroadbench.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``search`` command group."""
    from offroadbench.cli._common import float_at_least, int_at_least
    from offroadbench.study.execution.executors import EXECUTORS

    p = subparsers.add_parser("search", help="search for failures and estimate P(failure) (falsifier, importance sampling)")
    sub = p.add_subparsers(dest="search_command", required=True)

    run = sub.add_parser("run", help="run (or resume) a search TOML: a study file with a [search] table")
    run.add_argument("search", help="search TOML, e.g. experiments/failure-search.toml")
    run.add_argument("--out", help="run directory (default: runs/<study name>)")
    run.add_argument("--budget", type=int_at_least(1, "--budget"), default=None,
                     help="trials per method and grid cell, every method alike (default: [search] budget, mc_budget, ce_budget)")
    run.add_argument("--workers", type=int_at_least(1, "--workers"), default=None,
                     help="worker processes (default: as many as both the cores and the memory allow)")
    run.add_argument("--executor", default="local", choices=sorted(EXECUTORS), help="where trials run (default: local)")
    run.add_argument("--scheduler", help="Dask scheduler address (with --executor dask; default: a LocalCluster)")
    run.add_argument("--trial-timeout-s", type=float_at_least(0, "--trial-timeout-s", open_=True), default=None,
                     help="local and dask: a trial running longer than this, s, is stored as a fault (its worker "
                          "replaced) and the search goes on (default: generous against the trials' nominal time)")
    run.add_argument("--retry-faults", action="store_true",
                     help="run the proposals stored as faults (past their limit, thrown while settling) once more; "
                          "a resume skips them otherwise")
    run.add_argument("--no-report", action="store_true", help="do not write the report at the end")
    run.add_argument("--force", action="store_true", help="skip the up-front memory check")
    run.set_defaults(func=cmd_run)

    rep = sub.add_parser("report", help="write the Markdown report with figures of a search run directory")
    rep.add_argument("run_dir", help="run directory of a search")
    rep.add_argument("--out", help="report folder (default: RUN_DIR/report)")
    rep.add_argument("--html", action="store_true",
                     help="also write report.html: one self-contained file (figures inline, the sortable per-trial "
                          "table with each failure's replay command)")
    rep.set_defaults(func=cmd_report)


def write_search_report(run_dir: Path, out: Path, html: bool = False) -> Path:
    """Build the report of a search run directory and write it whole (Markdown, PNGs, CSVs, the TOML;
    ``html`` also the self-contained report.html)."""
    from offroadbench.cli._common import created_dirs, save_figure
    from offroadbench.io.export import staged_dir
    from offroadbench.search.report import build_search_report
    from offroadbench.study.store.results import load_meta

    report = build_search_report(run_dir)
    toml = load_meta(run_dir).get("study_toml")
    with created_dirs(out.parent), staged_dir(out) as stage:
        for name, fig in report.figures.items():
            save_figure(fig, stage / name, dpi=110)
        for name, df in report.tables.items():
            df.to_csv(stage / name, index=False)
        if toml:
            (stage / "search.toml").write_text(toml)
        (stage / "report.md").write_text(report.markdown)
        if html:
            from offroadbench.search.report import search_report_html

            (stage / "report.html").write_text(search_report_html(run_dir, report), encoding="utf-8")
    return out / ("report.html" if html else "report.md")


def cmd_run(args: argparse.Namespace) -> int:
    """``search run``: Ctrl-C and SIGTERM end it at any moment with one line (what is kept, how to resume)."""
    from offroadbench.cli._runs import stop_on_sigterm

    with stop_on_sigterm():
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    from offroadbench.cli._common import bar, check_output_dir
    from offroadbench.cli._runs import check_dir_name, fault_lines, run_workers
    from offroadbench.io.inputs import check_input_file
    from offroadbench.search import load_search, run_search
    from offroadbench.search.plan import trial_cell

    path = check_input_file(args.search, "search TOML")
    if args.scheduler and args.executor != "dask":
        raise InputError("--scheduler needs --executor dask")
    if args.trial_timeout_s is not None and args.executor == "inline":
        raise InputError("--trial-timeout-s applies to --executor local and dask, not inline")
    plan = load_search(path)
    if not args.out:
        check_dir_name(plan.study.name, path)
    out = check_output_dir(args.out if args.out else Path("runs") / plan.study.name, "--out")
    hi = [p.high for p in plan.search.params]
    from offroadbench.study.execution.common import check_trial_floor

    lo = [p.low for p in plan.search.params]  # the floor at either end of every searched range
    check_trial_floor(args.trial_timeout_s, [trial_cell(plan, g, 0, x) for g in plan.groups for x in (lo, hi)])
    workers = run_workers(args, [trial_cell(plan, g, 0, hi) for g in plan.groups])
    options = {} if args.trial_timeout_s is None else {"trial_timeout_s": args.trial_timeout_s}
    with bar(plan.study.name, unit="trial") as progress:
        summary = run_search(plan, out, budget=args.budget, executor=args.executor, workers=workers,
                             scheduler=args.scheduler, executor_options=options, source_text=path.read_text(),
                             progress=progress, retry_faults=args.retry_faults)
    lines = fault_lines(summary, out)  # every trial of this run faulted: one line, exit 1
    faults = f", {summary.faults} fault(s) without an outcome" if summary.faults else ""
    print(f"{summary.done} / {summary.total} trials in {out} ({summary.failures} failed{faults}); "
          f"this run: {summary.ran} trials in {summary.wall_s:.1f} s ({summary.trials_per_s:.2f} trials/s)")
    for line in lines:
        print(line)
    if summary.done + summary.faults >= summary.total and summary.done and not args.no_report:
        print(f"report: {write_search_report(out, out / 'report')}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from offroadbench.cli._common import check_output_dir

    run_dir = Path(args.run_dir)
    if not (run_dir / "study.sqlite").is_file():
        raise InputError(f"{run_dir}: not a search run directory (no study.sqlite)")
    out = check_output_dir(args.out if args.out else run_dir / "report", "--out")
    print(f"report: {write_search_report(run_dir, out, html=args.html)}")
    return 0
