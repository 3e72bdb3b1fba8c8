"""``offroadbench suite list|run|leaderboard``: a versioned task suite and its score cards (offroadbench.suite)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from offroadbench.cli._runs import run_command
from offroadbench.errors import InputError

DEFAULT_SUITE = "offroadbench-v1"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``suite`` command group."""
    from offroadbench.cli._runs import add_run_options

    p = subparsers.add_parser("suite", help="run a versioned task suite and score a planner against the baselines")
    sub = p.add_subparsers(dest="suite_command", required=True, parser_class=subparsers._parser_class)

    ls = sub.add_parser("list", help="the suites, their tiers and tasks, and the committed score cards")
    ls.add_argument("--suite", default=None, help="one suite (name or path; default: every suite)")
    ls.set_defaults(func=cmd_list)

    run = sub.add_parser("run", help="run (or resume) a suite tier with a planner and write its score card")
    run.add_argument("--planner", required=True, help="a registered planner or policy (plug-ins included), e.g. astar")
    run.add_argument("--tier", default="quick", help="the tier (default: quick; `suite list` shows them)")
    run.add_argument("--suite", default=DEFAULT_SUITE, help=f"suite name or suite TOML (default: {DEFAULT_SUITE})")
    add_run_options(run, out_help="run folder: one study run directory per category (default: "
                                   "runs/suite/<suite>-<tier>-<planner>); the same command again resumes",
                    goes_on="the suite goes on", fault_note=" (scored 0)",
                    force_checks="memory and size estimate checks")
    run.add_argument("--card-out", help="folder of the score card (score.json, score.md, score.html, profile.png; "
                                        "default: --out)")
    run.add_argument("--baselines", metavar="DIR", help="folder of the score cards set beside this one "
                                                          "(<suite>/<tier>/<planner>/score.json; default: the shipped "
                                                          "suites/scores)")
    run.set_defaults(func=cmd_run)

    sc = sub.add_parser("score", help="write the score card of a finished suite run again (against the current "
                                      "baselines), running nothing")
    sc.add_argument("--planner", required=True, help="the planner the run drove")
    sc.add_argument("--tier", default="quick", help="the run's tier (default: quick)")
    sc.add_argument("--suite", default=DEFAULT_SUITE, help=f"suite name or suite TOML (default: {DEFAULT_SUITE})")
    sc.add_argument("--out", required=True, help="the run folder (suite run --out)")
    sc.add_argument("--card-out", help="folder of the score card (default: --out)")
    sc.add_argument("--baselines", metavar="DIR", help="folder of the cards set beside it (default: the shipped ones)")
    sc.set_defaults(func=cmd_score)

    lb = sub.add_parser("leaderboard", help="the leaderboard page from every committed score card")
    lb.add_argument("--write", metavar="PATH", help="write the page here (e.g. docs/leaderboard.md) instead of printing it")
    lb.add_argument("--scores", metavar="DIR", help="folder of committed cards (default: the shipped suites/scores)")
    lb.set_defaults(func=cmd_leaderboard)


def cmd_list(args: argparse.Namespace) -> int:
    from offroadbench import resources
    from offroadbench.suite import load_suite, shipped_cards

    refs = [args.suite] if args.suite else list(resources.suite_files())
    if not refs:
        raise InputError("no suite found (suites/*.toml on OFFROADBENCH_PATH or shipped)")
    for ref in refs:
        suite, path = load_suite(ref)
        print(f"{suite.name}: {suite.description}")
        print(f"  file {path}; tasks sha256 {suite.tasks_sha256[:12]}; vehicle {suite.vehicle}, sensor {suite.sensor}")
        for tier in suite.tiers:
            print(f"  tier {tier.name}: {tier.description}")
            for cat in suite.categories:
                print(f"    {cat.name:<14} {_tier_size(suite, cat, tier.name)}  {cat.description}")
            cards = shipped_cards(suite.name, tier.name)
            print(f"    score cards: {', '.join(c['planner'] for c in cards) or 'none committed'}")
    return 0


def _tier_size(suite, cat, tier: str) -> str:
    """``3 cells x 6 terrains x 2 missions = 36 tasks`` of a category in a tier."""
    from offroadbench.suite.spec import category_study

    data = category_study(suite, cat, tier, "straight")
    cells = 1
    for values in data.get("grid", {}).values():
        cells *= len(values)
    t, m = data["study"].get("terrains_per_cell", 20), data["study"].get("missions_per_terrain", 20)
    return f"{cells} x {t} terrains x {m} missions = {cells * t * m:>3} tasks"


@run_command
def cmd_run(args: argparse.Namespace) -> int:
    """``suite run`` (Ctrl-C and SIGTERM end it with one line: offroadbench.cli._runs.run_command)."""
    from offroadbench.cli._common import check_output_dir
    from offroadbench.cli._runs import check_run_args, prepare_run, run_bar, run_dir, run_totals, say_run
    from offroadbench.study.runner import check_study_size
    from offroadbench.suite import load_suite, plan_suite, run_suite, suite_trials

    check_run_args(args)
    suite, path = load_suite(args.suite)
    suite.tier(args.tier)
    planned = plan_suite(suite, args.tier, args.planner)
    for p in planned:
        check_study_size(p.study, args.force)
    out = run_dir(args.out, Path("runs") / "suite", f"{suite.name}-{args.tier}-{args.planner}",
                  f"{path}: the suite run's name SUITE-TIER-PLANNER")
    card_out = check_output_dir(args.card_out, "--card-out") if args.card_out else out
    options = prepare_run(args, [cell for p in planned for cell in p.plans])  # every category's cells
    with run_bar(f"{suite.name} {args.tier} {args.planner}") as bar:
        runs = run_suite(planned, out, **options, progress=bar.progress, on_trial=bar.on_trial)
    # a fault is a task scored 0, so a run of faults only still has its card
    say_run(f"{suite.name} {args.tier} tier, planner {args.planner}: {suite_trials(planned)} tasks in {out}",
            run_totals([r.summary for r in runs], out), out, outcomes_needed=False)
    incomplete = [r.category for r in runs if not r.summary.complete]
    if incomplete:  # pragma: no cover - run_study raises before leaving a category incomplete
        sys.stderr.write(f"offroadbench: categories not complete: {', '.join(incomplete)}; run again to resume\n")
        return 1
    _write_and_print(suite, path, args, out, card_out)
    return 0


def cmd_score(args: argparse.Namespace) -> int:
    from offroadbench.cli._common import check_output_dir
    from offroadbench.suite import load_suite

    suite, path = load_suite(args.suite)
    suite.tier(args.tier)
    out = Path(args.out)
    card_out = check_output_dir(args.card_out, "--card-out") if args.card_out else out
    _write_and_print(suite, path, args, out, card_out)
    return 0


def _write_and_print(suite, path: Path, args: argparse.Namespace, out: Path, card_out: Path) -> None:
    """Score the run in ``out``, write its card into ``card_out`` beside the baselines, say what it holds."""
    from offroadbench.suite import score_run, shipped_cards, write_card

    card = score_run(suite, path.name, args.tier, args.planner, out)
    baselines = shipped_cards(suite.name, args.tier, root=Path(args.baselines) if args.baselines else None)
    paths, card = write_card(card_out, card, baselines)
    o = card["overall"]
    lo, hi = o["score_iqm_ci"]
    print(f"IQM score {o['score_iqm']:.3f} [{lo:.3f}, {hi:.3f}] over {o['terrains']} terrains; "
          f"{o['successes']} of {o['tasks']} tasks succeeded")
    for c in card["comparisons"]:
        if c["comparable"]:
            print(f"  against {c['baseline']}: score {c['score_diff']:+.3f} per terrain "
                  f"[{c['score_diff_ci'][0]:+.3f}, {c['score_diff_ci'][1]:+.3f}], p = {c['p_sign_flip']:.2g}")
    print(f"score card: {', '.join(str(p) for p in paths)}")


def cmd_leaderboard(args: argparse.Namespace) -> int:
    from offroadbench.suite.leaderboard import write_or_render

    text = write_or_render(args.write, args.scores)
    if args.write:
        print(f"leaderboard: {args.write}")
    else:
        sys.stdout.write(text)
    return 0
