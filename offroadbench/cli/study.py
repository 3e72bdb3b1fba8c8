"""``offroadbench study run|export|report``: Monte Carlo studies (the work is in offroadbench.study)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from offroadbench.cli._runs import run_command
from offroadbench.errors import InputError
from offroadbench.io.atomic import atomic_path, atomic_paths

EXPORT_FORMATS = ("parquet", "csv")


def _power_refusal(study, base_dir: Path) -> str | None:
    """check_power's refusal (its one line), or None when every planned test has the power."""
    from offroadbench.study.stats.power import check_power

    try:
        check_power(study, base_dir)
    except InputError as exc:
        return str(exc)
    return None


def _check_power_apart(study, base_dir: Path) -> None:
    """check_power in a forked child: it needs pandas, and this process's workers fork from it (issue
    41: workers hold no pandas or pyarrow). Where fork is not available, here. The child ignores
    Ctrl-C (this process stops; the child's ~1 s of work ends on its own) and leaves by returning,
    never by a signal, so it prints nothing of its own."""
    import multiprocessing
    import signal

    if "fork" not in multiprocessing.get_all_start_methods():  # pragma: no cover - not on Linux
        refusal = _power_refusal(study, base_dir)
    else:
        ctx = multiprocessing.get_context("fork")
        recv, send = ctx.Pipe(duplex=False)

        def child() -> None:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            try:
                send.send(("ok", _power_refusal(study, base_dir)))
            except Exception as exc:  # noqa: BLE001 - handed to the parent
                send.send(("error", f"{type(exc).__name__}: {exc}"))

        proc = ctx.Process(target=child, daemon=True, name="offroadbench-power-check")
        proc.start()
        send.close()
        try:
            kind, refusal = recv.recv()
        except EOFError:
            raise RuntimeError(f"the plan's power check ended without an answer (exit {proc.exitcode})") from None
        finally:
            proc.join()
        if kind == "error":
            raise RuntimeError(f"the plan's power check failed: {refusal}")
    if refusal is not None:
        raise InputError(refusal)

def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``study`` command group."""
    from offroadbench.cli._runs import add_run_options

    p = subparsers.add_parser("study", help="run, export and report Monte Carlo studies")
    sub = p.add_subparsers(dest="study_command", required=True)

    run = sub.add_parser("run", help="run (or resume) a study TOML; finished trials are skipped")
    run.add_argument("study", help="study TOML, e.g. experiments/smoke.toml")
    add_run_options(run, out_help="run directory (default: runs/<study name>)", goes_on="the study goes on")
    run.add_argument("--no-report", action="store_true", help="do not write the report when the study is complete")
    run.add_argument("--set", action="append", metavar="KEY=VALUE",
                     help="change the study before it runs (a new study id, so use a new --out): study.FIELD "
                          "([study]), SECTION.FIELD for the settings tables (sim, controller, rules, roughness, "
                          "vehicle, planner, missions), SECTION.TABLE.FIELD for a nested one (sim.mujoco, sim.mujoco_warp), "
                          "any other key is a recipe override (as drive --set), e.g. --set study.terrains_per_cell=2 "
                          "--set sim.engine=mujoco --set sim.mujoco.hfield_collision=exact; repeatable")
    run.set_defaults(func=cmd_run)

    exp = sub.add_parser("export", help="write the trial and terrain tables of a run directory")
    exp.add_argument("run_dir", help="run directory of a study")
    exp.add_argument("--format", default="parquet", choices=EXPORT_FORMATS)
    exp.add_argument("--out", help="output folder (default: the run directory)")
    exp.set_defaults(func=cmd_export)

    rep = sub.add_parser("report", help="write the Markdown report with figures of a run directory")
    rep.add_argument("run_dir", help="run directory of a study")
    rep.add_argument("--out", help="report folder (default: RUN_DIR/report)")
    rep.add_argument("--html", action="store_true",
                     help="also write report.html: one self-contained file (figures inline, sortable per-trial "
                     "table, the replay animations found in RUN_DIR/replays inline and linked from their trials)")
    rep.add_argument("--fig4", help="CELL:TERRAIN shown in Fig. 4 (default: the middle cell's first terrain)")
    rep.set_defaults(func=cmd_report)

    rpl = sub.add_parser("replay", help="re-run one stored trial bit for bit and draw it")
    rpl.add_argument("run_dir", help="run directory of a study")
    rpl.add_argument("--cell", type=int, required=True, help="grid cell index")
    rpl.add_argument("--terrain", type=int, required=True, help="terrain index within the cell")
    rpl.add_argument("--mission", type=int, required=True, help="mission index on the terrain")
    rpl.add_argument("--plot", nargs="?", const=True, default=None, metavar="PATH",
                     help="write the figure (class map, paths, time series) to PATH, or with a bare --plot to "
                     "--out/cell<C>_terrain<T>_mission<M>.png; the telemetry (Parquet) goes beside it")
    rpl.add_argument("--out", help="folder for the figure and telemetry (default: RUN_DIR/replays)")
    rpl.add_argument("--animate", metavar="OUT.gif|OUT.mp4", default=None,
                     help="write an animation of the trial: the footprint moving over the hillshade and class "
                     "map along its planned and driven paths, with speed, pitch, roll and vertical acceleration "
                     "against time and the failure marked (.mp4 needs ffmpeg)")
    rpl.set_defaults(func=cmd_replay)


def _run_dir(path: str) -> Path:
    p = Path(path)
    if not (p / "study.sqlite").is_file():
        raise InputError(f"{p}: not a study run directory (no study.sqlite)")
    return p


def apply_sets(data: dict, sets: list[str] | None) -> dict:
    """The study TOML dict with ``--set KEY=VALUE`` applied: ``study.FIELD`` into ``[study]``,
    ``SECTION.FIELD`` into a settings table and ``SECTION.TABLE.FIELD`` into a nested one
    (``sim.mujoco.hfield_collision``: ``[sim.mujoco]``), other (recipe) keys into
    ``[recipe_overrides]``. A key that a grid axis varies is refused (it would be overwritten in
    every cell)."""
    from offroadbench.cli._common import parse_sets, put_setting
    from offroadbench.study.spec.config import SECTIONS

    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    grid = set(_flat_keys(out.get("grid", {})))
    for item in sets or []:
        key = item.partition("=")[0].strip()
        head, dot, rest = key.partition(".")
        if key in grid or f"recipe.{key}" in grid:
            raise InputError(f"--set {item!r}: {key} is a grid axis of this study; change the grid in the file")
        (value,) = parse_sets([item]).values()
        if head in SECTIONS:
            put_setting(out, item)  # SECTION.FIELD, or SECTION.TABLE.FIELD for [sim.mujoco] and the like
        elif head == "study":
            if not dot or not rest or "." in rest:
                raise InputError(f"--set {item!r}: a study key is study.FIELD=VALUE")
            out.setdefault(head, {})[rest] = value
        else:
            out.setdefault("recipe_overrides", {})[key] = value
    return out


def _flat_keys(table: dict, prefix: str = "") -> list[str]:
    keys = []
    for k, v in table.items():
        keys += _flat_keys(v, f"{prefix}{k}.") if isinstance(v, dict) else [f"{prefix}{k}"]
    return keys


@run_command
def cmd_run(args: argparse.Namespace) -> int:
    """``study run`` (Ctrl-C and SIGTERM end it with one line: offroadbench.cli._runs.run_command)."""
    from offroadbench.cli._runs import check_run_args, prepare_run, report_due, run_bar, run_dir, say_run
    from offroadbench.config import load_toml
    from offroadbench.io.inputs import check_input_file
    from offroadbench.study import run_study
    from offroadbench.study.runner import check_study_size
    from offroadbench.study.spec.config import plan_cells, study_from_dict

    check_run_args(args)
    path = check_input_file(args.study, "study TOML")
    study = study_from_dict(apply_sets(load_toml(path), args.set), where=str(path))
    check_study_size(study, args.force)  # before the cells are resolved: a huge grid takes long to load
    if study.analysis is not None and study.analysis.pilot:
        _check_power_apart(study, path.parent)  # a planned test under the plan's min_power is refused (issue 42)
    try:
        plans = plan_cells(study, base_dir=path.parent)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    out = run_dir(args.out, Path("runs"), study.name, f"{path}: [study] name")
    options = prepare_run(args, plans)  # a --trial-timeout-s no trial can meet is refused here (issue 44)
    text = path.read_text() + "".join(f"\n# run with: study run --set {item}" for item in args.set or [])
    with run_bar(study.name) as bar:
        summary = run_study(study, plans, out, **options, source_text=text, progress=bar.progress,
                            on_trial=bar.on_trial)
    faults = (f"; {summary.faults} fault(s), excluded from the statistics (see the report; --retry-faults runs "
              "them again)") if summary.faults else ""
    say_run(f"{summary.done} / {summary.total} trials in {out} ({summary.successes} successful){faults}", summary, out)
    if report_due(args, summary):
        print(f"report: {write_report(out, out / 'report')}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from offroadbench.study import load, load_terrains

    from offroadbench.cli._common import check_output_dir, created_dirs

    run_dir = _run_dir(args.run_dir)
    out = check_output_dir(args.out if args.out else run_dir, "--out")
    from offroadbench.study.stats.terrain import terrain_success

    trials = load(run_dir)
    if len(trials):  # each row says what made it: the fixed settings beside the grid axes
        from offroadbench.study.report.header import settings_columns
        from offroadbench.study.store.results import load_meta

        fixed = settings_columns(load_meta(run_dir))
        fixed = fixed[["cell", *(c for c in fixed.columns if c not in trials.columns)]]
        trials = trials.merge(fixed, on="cell", how="left")
    terrains = load_terrains(run_dir)  # with trials, successes and success rate, as the report's terrains.csv
    terrains = terrains.merge(terrain_success(trials), on=["cell", "terrain"], how="left") if len(trials) else terrains
    tables = (("trials", trials), ("terrains", terrains))
    paths = [out / f"{name}.{args.format}" for name, _ in tables]
    # all or nothing: both tables replace the old ones together (io.atomic.atomic_paths), so a
    # killed export never leaves a new trials table beside an old terrains table
    with created_dirs(out), atomic_paths(paths) as temps:
        for (_, df), tmp in zip(tables, temps, strict=True):
            if args.format == "csv":
                df.to_csv(tmp, index=False)
            else:
                df.to_parquet(tmp, index=False)
    for path, (_, df) in zip(paths, tables, strict=True):
        print(f"{path} ({len(df)} rows)")
    return 0


def _parse_fig4(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    try:
        cell, terrain = (int(x) for x in text.split(":"))
    except ValueError:
        raise InputError(f"--fig4 {text!r}: expected CELL:TERRAIN, e.g. 1:0") from None
    return cell, terrain


def write_report(run_dir: Path, out: Path, fig4: tuple[int, int] | None = None, html: bool = False) -> Path:
    """Build the report of ``run_dir`` and write it (Markdown, PNGs, CSVs, the study TOML; with
    ``html`` also the self-contained report.html) to ``out``."""
    from offroadbench.cli._runs import write_report_folder
    from offroadbench.study.report.markdown import build_report
    from offroadbench.study.store.results import load_meta

    report = build_report(run_dir, fig4=fig4)
    page = None
    if html:
        from offroadbench.study.report.html import report_html

        def page() -> str:
            return report_html(run_dir, report)

    return write_report_folder(report, out, load_meta(run_dir).get("study_toml"), "study.toml", page)


def cmd_report(args: argparse.Namespace) -> int:
    from offroadbench.cli._common import check_output_dir

    run_dir = _run_dir(args.run_dir)
    out = check_output_dir(args.out if args.out else run_dir / "report", "--out")
    path = write_report(run_dir, out, _parse_fig4(args.fig4), html=args.html)
    print(f"report: {path}")
    return 0


def _platform_note(run_dir: Path, cell: int, terrain: int, mission: int, quantise: str) -> str:
    """A line when the stored trial ran on another platform or offroadbench, saying whether
    bit-identity is promised here (offroadbench.study.fingerprint); "" when it ran on this one."""
    from offroadbench.study.fingerprint import describe, identity_promise, platform_fingerprint
    from offroadbench.study.store.results import trial_platform
    from offroadbench.study.session import code_version

    stored, stored_version = trial_platform(run_dir, cell, terrain, mission)
    here, version = platform_fingerprint(), code_version()
    if stored == here and stored_version == version:
        return ""
    ok, why = identity_promise(stored, here, quantise, stored_version, version)
    where = "on another platform" if stored != here else "on this platform"
    if stored is None:
        where = "on a platform that was not recorded"
    elif stored != here:
        where += f" ({describe(stored)})"
    verdict = {True: "promised", False: "not promised", None: "not known to be promised"}[ok]
    return f"the stored trial ran {where}; bit-identity with it is {verdict} here: {why}"


def cmd_replay(args: argparse.Namespace) -> int:
    """Replay one trial; exit 1 if it does not reproduce the stored row."""
    from offroadbench.cli._common import check_output_dir, check_output_file, created_dirs
    from offroadbench.study.execution.tasks import replay_trial

    run_dir = _run_dir(args.run_dir)
    png = None
    if args.plot is True:  # a bare --plot: the figure and telemetry into --out (default RUN_DIR/replays)
        out = check_output_dir(args.out if args.out else run_dir / "replays", "--out")
        png = out / f"cell{args.cell}_terrain{args.terrain}_mission{args.mission}.png"
    elif args.plot:
        png = check_output_file(args.plot, "--plot", suffixes=(".png",))
    if args.animate:
        from offroadbench.io.animation import check_animation_path

        check_animation_path(args.animate)
        check_output_file(args.animate, "--animate")
    rep = replay_trial(run_dir, args.cell, args.terrain, args.mission)
    r = rep.record.result
    name = f"cell{args.cell}_terrain{args.terrain}_mission{args.mission}"
    print(f"{name}: {r.failure_reason or 'success'} after {r.sim_time_s:.2f} s, {r.final_distance_to_goal_m:.2f} m from the goal; "
          f"identical to the stored row: {'yes' if rep.identical else 'NO'}")
    if not rep.identical:
        diff = [k for k in rep.stored if str(rep.stored[k]) != str(r.as_row().get(k))]
        print(f"differs in: {', '.join(diff)}", file=sys.stderr)
    if rep.unrecorded:
        print(f"not in the stored row (columns newer than the run, not compared): {', '.join(rep.unrecorded)}")
    note = _platform_note(run_dir, args.cell, args.terrain, args.mission, rep.cell.recipe().grid.quantise)
    if note:
        print(note)
    if args.plot:
        from offroadbench.io.telemetry import save_telemetry
        from offroadbench.plots.study import fig_replay

        from offroadbench.cli._common import run_caption

        caption = run_caption(rep.prepared.sim_for(rep.cell.section("sim")))  # the engine and gravity it drove
        title = (f"{run_dir.name} {name}: {rep.cell.section('planner').name}, {caption}, "
                 f"{r.failure_reason or 'success'} at t = {r.sim_time_s:.1f} s")
        fig = fig_replay(rep.hm, rep.classes, rep.cell.section("missions").border_m, rep.record.path_xy,
                         rep.record.telemetry, title=title)
        tel = png.with_suffix(".parquet")
        with created_dirs(png.parent):  # the output-path policy: missing folders made now, removed on failure
            with atomic_path(png) as tmp:
                fig.savefig(tmp, format="png", dpi=110)
            save_telemetry(rep.record.telemetry, tel)
        print(f"wrote {png}, {tel}")
    if args.animate:
        from offroadbench.cli.drive import vehicle_footprint, write_trial_animation

        from offroadbench.cli._common import run_caption

        caption = run_caption(rep.prepared.sim_for(rep.cell.section("sim")))
        title = f"{run_dir.name} {name}: {rep.cell.section('planner').name}, {caption}, {r.failure_reason or 'success'}"
        footprint = vehicle_footprint(rep.cell.section("vehicle"), rep.cell.section("sim"))
        path = write_trial_animation(Path(args.animate), rep.hm, rep.classes, rep.record.path_xy, rep.record.telemetry,
                                     r.failure_reason, footprint, title)
        print(f"wrote {path}")
    return 0 if rep.identical else 1
