"""``offroadbench search run|report``: failure searches (the work is in offroadbench.search)."""

from __future__ import annotations

import argparse
from pathlib import Path

from offroadbench.cli._runs import run_command
from offroadbench.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``search`` command group."""
    from offroadbench.cli._common import int_at_least
    from offroadbench.cli._runs import add_run_options

    p = subparsers.add_parser("search", help="search for failures and estimate P(failure) (falsifier, importance sampling)")
    sub = p.add_subparsers(dest="search_command", required=True)

    run = sub.add_parser("run", help="run (or resume) a search TOML: a study file with a [search] table")
    run.add_argument("search", help="search TOML, e.g. experiments/failure-search.toml")
    run.add_argument("--budget", type=int_at_least(1, "--budget"), default=None,
                     help="trials per method and grid cell, every method alike (default: [search] budget, mc_budget, ce_budget)")
    add_run_options(run, out_help="run directory (default: runs/<study name>)", goes_on="the search goes on",
                    items="proposals", force_checks="memory check")
    run.add_argument("--no-report", action="store_true", help="do not write the report at the end")
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
    from offroadbench.cli._runs import write_report_folder
    from offroadbench.search.report import build_search_report
    from offroadbench.study.store.results import load_meta

    report = build_search_report(run_dir)
    page = None
    if html:
        from offroadbench.search.report import search_report_html

        def page() -> str:
            return search_report_html(run_dir, report)

    return write_report_folder(report, out, load_meta(run_dir).get("study_toml"), "search.toml", page)


@run_command
def cmd_run(args: argparse.Namespace) -> int:
    """``search run`` (Ctrl-C and SIGTERM end it with one line: offroadbench.cli._runs.run_command)."""
    from offroadbench.cli._runs import check_run_args, prepare_run, report_due, run_bar, run_dir, say_run
    from offroadbench.io.inputs import check_input_file
    from offroadbench.search import load_search, run_search
    from offroadbench.search.plan import trial_cell

    check_run_args(args)
    path = check_input_file(args.search, "search TOML")
    plan = load_search(path)
    out = run_dir(args.out, Path("runs"), plan.study.name, f"{path}: [study] name")
    lo, hi = [p.low for p in plan.search.params], [p.high for p in plan.search.params]
    options = prepare_run(args, [trial_cell(plan, g, 0, hi) for g in plan.groups],  # the floor: either end of every range
                          floor_plans=[trial_cell(plan, g, 0, x) for g in plan.groups for x in (lo, hi)])
    with run_bar(plan.study.name) as bar:
        summary = run_search(plan, out, budget=args.budget, **options, source_text=path.read_text(),
                             progress=bar.progress)
    faults = f", {summary.faults} fault(s) without an outcome" if summary.faults else ""
    say_run(f"{summary.done} / {summary.total} trials in {out} ({summary.failures} failed{faults})", summary, out)
    if report_due(args, summary):
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
