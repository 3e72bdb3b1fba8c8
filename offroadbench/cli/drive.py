"""``offroadbench drive TERRAIN.png|PRESET``: run random missions on one terrain with a planner or policy.

The work is :func:`offroadbench.sim.trial.batch.drive_missions`; this module parses, checks the
output directory, formats the :class:`~offroadbench.sim.trial.batch.DriveRun` and writes its files.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from offroadbench.cli._common import (
    bar,
    check_output_dir,
    check_output_file,
    created_dirs,
    format_table,
    load_heightmap_arg,
    positive_float,
    nonnegative_float,
    positive_int,
    save_figure,
    seed_arg,
)
from offroadbench.errors import InputError

#: columns of the printed per-mission table: (TrialResult field, header)
_TABLE = (
    ("mission_index", "mission"),
    ("outcome", "outcome"),
    ("traversal_time_s", "time_s"),
    ("path_length_m", "path_m"),
    ("max_abs_roll_deg", "max_roll_deg"),
    ("max_abs_pitch_deg", "max_pitch_deg"),
    ("rms_vertical_accel_m_s2", "rms_az_m_s2"),
    ("rms_pitch_rate_deg_s", "rms_pitch_rate_deg_s"),
    ("rms_roll_rate_deg_s", "rms_roll_rate_deg_s"),
    ("max_penetration_mm", "max_pen_mm"),
)

#: ``--set`` prefixes that reach a settings table (a study's tables of the same name); other keys
#: are recipe keys
SET_SECTIONS = ("sim", "controller", "rules", "roughness", "vehicle", "planner")


def format_drive_run(run, label: str) -> str:
    """The per-mission table and the summary of a DriveRun."""
    import pandas as pd

    from offroadbench.cli._common import count_text, medians_text

    df = pd.DataFrame(run.rows())
    df["outcome"] = df["failure_reason"].replace("", "success")
    df["max_penetration_mm"] = 1000 * df["max_penetration_m"]
    s = run.summary
    return "\n".join([
        f"{label}: {count_text(len(run.missions), 'mission')} of {run.mission_config.length_m:g} m, vehicle {run.vehicle_name}, "
        f"planner {run.planner}, physics {run.sim.engine} {run.sim.physics_rate_hz} Hz, "
        f"gravity {run.sim.gravity_m_s2:g} m/s^2",
        format_table(df[[c for c, _ in _TABLE]].rename(columns=dict(_TABLE))),
        "",
        f"success rate {s['success_rate_pct']:.1f} % ({int(s['successes'])}/{int(s['trials'])}); " + medians_text(s),
    ])


def _plot_paths(out: Path | None, plot: str | bool) -> dict[str, Path]:
    """The figure files of ``--plot``: bare, in the ``--out`` directory; ``--plot PATH``, the
    trajectories figure at PATH and the missions and time-series figures beside it."""
    if plot is True:
        return {k: out / f"{k}.png" for k in ("missions", "trajectories", "timeseries")}
    p = Path(plot)
    return {"trajectories": p, "missions": p.with_name(f"{p.stem}_missions{p.suffix}"),
            "timeseries": p.with_name(f"{p.stem}_timeseries{p.suffix}")}


def write_drive_figures(run, label: str, paths: dict[str, Path]) -> list[Path]:
    """The missions, trajectories and time-series figures of a DriveRun."""
    from offroadbench.plots.traversal import plot_missions, plot_timeseries, plot_trajectories

    from offroadbench.cli._common import run_caption

    hm, closed, border = run.heightmap, run.closed, run.mission_config.border_m
    shown = next((r for r in run.results if r.success), run.results[0])
    label = f"{label} ({run_caption(run.sim)})"  # every figure names the gravity and the engine
    with created_dirs(*{p.parent for p in paths.values()}):
        save_figure(plot_missions(hm, closed, run.missions, border_m=border, title=f"{label}: missions"),
                    paths["missions"])
        save_figure(plot_trajectories(hm, closed, run.missions, run.telemetry, run.results, border_m=border,
                                      paths=run.paths, beliefs=run.beliefs,
                                      title=f"{label}: trajectories ({run.planner})"),
                    paths["trajectories"])
        save_figure(plot_timeseries(run.telemetry[shown.mission_index], title=f"{label}: mission "
                                    f"{shown.mission_index} ({shown.failure_reason or 'success'})"),
                    paths["timeseries"])
    return list(paths.values())


def drive_record(run, label: str = "", options: dict | None = None) -> dict:
    """What ``drive --out`` keeps beside trials.csv (``settings.json``): the command's options, the terrain
    and seeds, every setting the missions were driven with (the TrialSettings, the terrain's gravity
    and soil filled in), the platform (offroadbench.study.fingerprint) and the code version."""
    from offroadbench.study.fingerprint import platform_fingerprint
    from offroadbench.study.session import code_version

    return {
        "options": _plain(options or {}),
        "terrain": label,
        "terrain_seed": run.terrain_seed,
        "mission_seeds": list(run.mission_seeds),
        "settings": run.settings.to_dict(),  # what a study store keeps per cell; TrialSettings.from_dict reads it
        "platform": platform_fingerprint(),
        "code_version": code_version(),
    }


def _plain(value):
    """The command's options as JSON data (tuples as lists, paths as strings)."""
    import dataclasses

    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


def write_drive_run(run, out: Path, label: str = "", options: dict | None = None) -> list[str]:
    """trials.csv, telemetry/mission_NNN.parquet (the studies' telemetry format; ``.npz`` files of
    older runs still load with offroadbench.io.telemetry.load_telemetry) and settings.json (what
    drove them: :func:`drive_record`), all or nothing; returns what was written."""
    import json

    import pandas as pd

    from offroadbench.io.export import staged_dir
    from offroadbench.io.telemetry import save_telemetry

    # all or nothing (the export transaction): a full disk leaves no trials.csv without its telemetry
    with staged_dir(out) as stage:
        (stage / "telemetry").mkdir()
        pd.DataFrame(run.rows()).to_csv(stage / "trials.csv", index=False)
        for index, tel in run.telemetry.items():
            save_telemetry(tel, stage / "telemetry" / f"mission_{index:03d}.parquet", sweep=False)
        (stage / "settings.json").write_text(json.dumps(drive_record(run, label, options), indent=1, allow_nan=True) + "\n")
    return ["trials.csv", "telemetry/mission_*.parquet", "settings.json"]


def _drive_settings(args: argparse.Namespace) -> tuple[dict, list[str]]:
    """The settings tables of ``--set SECTION.KEY=VALUE`` and ``SECTION.TABLE.KEY=VALUE`` (plus ``--physics-rate-hz``, ``--engine``,
    ``--gravity``, ``--border-m``) and the remaining recipe overrides."""
    from offroadbench.cli._common import put_setting

    tables: dict[str, dict] = {name: {} for name in SET_SECTIONS}
    recipe_sets = []
    for item in args.set or []:
        head = item.partition("=")[0].strip().partition(".")[0]
        if head in SET_SECTIONS:
            put_setting(tables, item)  # SECTION.FIELD, or SECTION.TABLE.FIELD for [sim.mujoco] and the like
        else:
            recipe_sets.append(item)
    if args.physics_rate_hz is not None:
        tables["sim"]["physics_rate_hz"] = args.physics_rate_hz
    if args.engine is not None:
        tables["sim"]["engine"] = args.engine
    if args.gravity is not None:
        tables["sim"]["gravity_m_s2"] = args.gravity
    if args.border_m is not None:
        tables["roughness"]["border_m"] = args.border_m
    return tables, recipe_sets


def vehicle_footprint(spec, sim) -> tuple[float, float]:
    """(length, width) of the vehicle's footprint in metres, as the trials' engine (``sim.engine``)
    measures it (offroadbench.sim.engine.VehicleGeometry, on a small flat world)."""
    from offroadbench.heightmap import Heightmap
    from offroadbench.sim import open_world

    with open_world(Heightmap.flat(9, 9, 0.5), spec, sim) as world:
        geo = world.geometry
    return geo.length_m, geo.width_m


def write_trial_animation(path: Path, hm, classes, path_xy, tel, failure_reason: str, footprint_m, title: str,
                          fps: float = 10.0) -> Path:
    """One trial as a GIF or MP4 (offroadbench.plots.animate): the footprint moving over the
    hillshade and class map, beside speed, pitch, roll and vertical acceleration; the failure marked."""
    import numpy as np

    from offroadbench.io.animation import save_animation
    from offroadbench.plots.animate import TrialView, frame_indices

    view = TrialView(hm, classes, path_xy, footprint_m=footprint_m,
                     region_xy=np.column_stack([tel["x_m"], tel["y_m"]]), title=title)
    t = np.asarray(tel["t_s"], float)
    rate = 1.0 / float(np.median(np.diff(t))) if len(t) > 1 else 20.0
    frames = frame_indices(len(t), rate, fps=fps)
    with created_dirs(path.parent), bar(f"writing {path.name}", unit="frame") as progress:
        return save_animation(view.fig, lambda i: view.draw(tel, i, failure_reason=failure_reason), frames, path,
                              fps=fps, progress=progress)


def drive_settings(args: argparse.Namespace, tables: dict):
    """The TrialSettings of a ``drive`` command, built from its tables as a study builds a cell's
    (offroadbench.sim.trial.pipeline.TrialSettings.from_tables)."""
    from offroadbench.analysis.roughness import RoughnessConfig
    from offroadbench.sim.trial.pipeline import TrialSettings

    border = tables["roughness"].get("border_m", RoughnessConfig().border_m)
    return TrialSettings.from_tables({
        **{k: v for k, v in tables.items() if k not in ("vehicle", "planner")},
        "vehicle": {"name": args.vehicle, **tables["vehicle"]},
        "planner": {"name": args.planner, **tables["planner"]},
        "missions": {"count": args.missions, "length_m": args.length_m, "border_m": border},
    }, where="drive (--vehicle, --planner, --border-m, --set)")


def _png_seed(path: str) -> int | None:
    """A PNG heightmap's own terrain seed, as ``generate --seed N`` recorded it in the sidecar (None:
    a PNG from elsewhere, or with no seed)."""
    from offroadbench.io.png16 import read_png16_metadata

    seed = read_png16_metadata(path).get("seed")
    return seed if isinstance(seed, int) and not isinstance(seed, bool) else None


def cmd_drive(args: argparse.Namespace) -> int:
    from offroadbench.seeding import terrain_seed
    from offroadbench.sim import drive_missions
    from offroadbench.sim.trial.pipeline import terrain_body

    if args.plot is True and args.out is None:
        raise InputError("--plot needs --out DIR to write the figures into (or give --plot PATH.png)")
    out = check_output_dir(args.out, "--out") if args.out else None
    plots = _plot_paths(out, args.plot) if args.plot else {}
    for path in plots.values():
        check_output_file(path, "--plot", suffixes=(".png", ".pdf", ".svg"))
    if args.animate:
        from offroadbench.io.animation import check_animation_path

        check_animation_path(args.animate)
        check_output_file(args.animate, "--animate")
    tables, recipe_sets = _drive_settings(args)
    settings = drive_settings(args, tables)

    from offroadbench.study.runner import check_drive_size

    # the same size limit as a study's (1e7 m missions would run for days): --force to run anyway
    check_drive_size(args.missions, args.length_m,
                     min(settings.controller.cruise_speed_m_s, settings.vehicle.max_speed_m_s), args.force)
    tseed = terrain_seed(args.seed, 0)  # drive --seed s is terrain 0 of root seed s (offroadbench.seeding)
    hm, label, recipe = load_heightmap_arg(args.terrain, tseed, sets=recipe_sets, force=args.force)
    if recipe is not None:
        from offroadbench.cli.terrain import CLIP_ELSEWHERE, warn_relief_tails

        warn_relief_tails(hm, label, CLIP_ELSEWHERE)
    gravity, soil = terrain_body(args.terrain, recipe)  # where --gravity / --set sim.* leave them open
    from offroadbench.terrain.soil_map import soil_map_for

    soil_map = soil_map_for(recipe, hm, tseed) if recipe is not None else None  # the recipe's [[soil.regions]]
    with bar("missions", unit="mission") as progress:
        run = drive_missions(hm, args.missions, args.seed, terrain_seed=tseed if recipe is not None else _png_seed(args.terrain),
                             settings=settings, gravity_m_s2=gravity, soil=soil, progress=progress,
                             soil_map=soil_map)
    print(format_drive_run(run, label))
    written = []
    if out is not None:
        written += [f"{out}/{w}" for w in write_drive_run(run, out, label=label,
                                                                   options={k: v for k, v in vars(args).items()
                                                                            if k != "func"})]
    if plots:
        written += [str(p) for p in write_drive_figures(run, label, plots)]
    if written:
        print(f"\nwrote {', '.join(written)}")
    if args.animate:
        shown = next((r for r in run.results if not r.success), run.results[0])
        k = shown.mission_index
        from offroadbench.cli._common import run_caption

        title = f"{label}: mission {k}, {run.planner}, {run_caption(run.sim)}, {shown.failure_reason or 'success'}"
        path = write_trial_animation(Path(args.animate), run.heightmap, run.closed, run.paths[k], run.telemetry[k],
                                     shown.failure_reason, vehicle_footprint(run.settings.vehicle, run.sim), title)
        print(f"wrote {path} (mission {k})")
    return 0


def register(sub) -> None:
    p = sub.add_parser("drive", help="drive random straight-line missions on one terrain (PyBullet or MuJoCo: --engine)",
                       description="Sample missions on one terrain (paper Sec. 2.3), drive them with the "
                       "vehicle and print a per-mission table and a summary.")
    p.add_argument("terrain", help="a 16-bit PNG heightmap (with its .json sidecar) or a preset / recipe TOML")
    p.add_argument("--seed", type=seed_arg, default=0,
                   help="ROOT seed (default 0), as a study's root_seed: the terrain is terrain 0 of it, whose own "
                   "seed terrain_seed(seed, 0) is printed as 'seed N' (generate --seed N rebuilds it), and "
                   "mission k has seed mission_seed(seed, 0, k) (offroadbench.seeding)")
    p.add_argument("--missions", type=positive_int, default=20, help="number of missions (default 20)")
    p.add_argument("--length-m", type=positive_float, default=35.0, help="start-goal distance, m (default 35, paper)")
    p.add_argument("--out", help="directory for trials.csv, telemetry/ (Parquet) and settings.json (every setting, the "
                   "platform and code version) (created if missing)")
    p.add_argument("--plot", nargs="?", const=True, default=None, metavar="PATH",
                   help="write the figures: --plot PATH.png writes the trajectories at PATH and PATH_missions.png, "
                   "PATH_timeseries.png beside it; a bare --plot writes missions.png, trajectories.png and "
                   "timeseries.png into --out")
    p.add_argument("--border-m", type=nonnegative_float, default=None,
                   help="no mission start or goal closer than this to the map edge, m (default 5, the paper's; "
                   "smaller maps need less, e.g. 2 on a 12.8 m map)")
    p.add_argument("--gravity", type=positive_float, default=None, metavar="M_S2",
                   help="magnitude of gravity, m/s^2 (default: the terrain recipe's body, else Earth's 9.81; the Moon: "
                   "1.62); same as --set sim.gravity_m_s2=G")
    p.add_argument("--animate", metavar="OUT.gif|OUT.mp4", default=None,
                   help="write an animation of one trial (the first that failed, else mission 0): the "
                   "footprint moving over the hillshade and class map along its planned and driven paths, "
                   "with speed, pitch, roll and vertical acceleration against time and the failure marked "
                   "(.mp4 needs ffmpeg)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="a setting, repeatable: sim.KEY, controller.KEY, rules.KEY, roughness.KEY, vehicle.KEY or "
                   "planner.KEY (a study's tables; `offroadbench config SECTION` lists the keys), e.g. "
                   "sim.gravity_m_s2=1.62, and sim.mujoco.KEY, sim.mujoco_warp.KEY for the nested tables, e.g. "
                   "sim.mujoco.hfield_collision=exact; any other key is a recipe override, e.g. layers.base.D_high=2.6")
    p.add_argument("--vehicle", default="husky", help="vehicle name or vehicle.toml path (default husky)")
    p.add_argument("--planner", default="straight",
                   help="planner or policy (built-in: straight, astar, lattice, reactive, mppi, ppo; installed plug-ins too)")
    p.add_argument("--physics-rate-hz", type=positive_int, default=None, help="override SimConfig.physics_rate_hz")
    p.add_argument("--engine", default=None, help="physics engine (SimConfig.engine: pybullet, the default, or mujoco)")
    p.add_argument("--force", action="store_true",
                   help="skip the up-front memory and work estimate checks (memory also OFFROADBENCH_NO_MEMORY_CHECK=1)")
    p.set_defaults(func=cmd_drive)
