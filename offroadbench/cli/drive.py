"""``offroadbench drive TERRAIN.png|PRESET``: run random missions on one terrain with a planner or policy.

The work is :func:`offroadbench.sim.batch.drive_missions`; this module parses, checks the
output directory, formats the :class:`~offroadbench.sim.batch.DriveRun` and writes its files.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from offroadbench.cli._common import (
    bar,
    check_output_dir,
    check_output_file,
    created_dirs,
    format_table,
    load_heightmap_arg,
    positive_float,
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
    ("max_abs_roll_deg", "max_roll"),
    ("max_abs_pitch_deg", "max_pitch"),
    ("rms_vertical_accel_m_s2", "rms_az"),
    ("rms_pitch_rate_deg_s", "rms_pitch_rate"),
    ("rms_roll_rate_deg_s", "rms_roll_rate"),
    ("max_penetration_mm", "pen_mm"),
)


def format_drive_run(run, label: str) -> str:
    """The per-mission table and the summary of a DriveRun."""
    df = pd.DataFrame(run.rows())
    df["outcome"] = df["failure_reason"].replace("", "success")
    df["max_penetration_mm"] = 1000 * df["max_penetration_m"]
    s = run.summary
    medians = ", ".join(f"{k[len('median_'):]} {v:.3f}" for k, v in s.items() if k.startswith("median_"))
    return "\n".join([
        f"{label}: {len(run.missions)} missions of {run.mission_config.length_m:g} m, vehicle {run.vehicle_name}, "
        f"planner {run.planner}, physics {run.sim.physics_rate_hz} Hz",
        format_table(df[[c for c, _ in _TABLE]].rename(columns=dict(_TABLE))),
        "",
        f"success rate {s['success_rate_pct']:.1f} % ({int(s['successes'])}/{int(s['trials'])}); medians of successful trials:",
        "  " + medians,
    ])


def write_drive_run(run, out: Path, label: str, plot: bool) -> list[str]:
    """trials.csv, telemetry/mission_NNN.npz and (with ``plot``) the figures; returns what was written."""
    from offroadbench.io.atomic import atomic_path
    from offroadbench.io.telemetry import save_telemetry

    tel_dir = out / "telemetry"
    with created_dirs(out, tel_dir):
        with atomic_path(out / "trials.csv") as tmp:
            pd.DataFrame(run.rows()).to_csv(tmp, index=False)
        for index, tel in run.telemetry.items():
            save_telemetry(tel, tel_dir / f"mission_{index:03d}.npz")
        written = ["trials.csv", "telemetry/mission_*.npz"]
        if plot:
            from offroadbench.plots.traversal import (
                plot_missions,
                plot_timeseries,
                plot_trajectories,
            )

            hm, closed, border = run.heightmap, run.closed, run.mission_config.border_m
            save_figure(plot_missions(hm, closed, run.missions, border_m=border, title=f"{label}: missions"),
                        out / "missions.png")
            save_figure(plot_trajectories(hm, closed, run.missions, run.telemetry, run.results, border_m=border,
                                          paths=run.paths, title=f"{label}: trajectories ({run.planner})"),
                        out / "trajectories.png")
            shown = next((r for r in run.results if r.success), run.results[0])
            save_figure(plot_timeseries(run.telemetry[shown.mission_index], title=f"{label}: mission "
                                        f"{shown.mission_index} ({shown.failure_reason or 'success'})"),
                        out / "timeseries.png")
            written += ["missions.png", "trajectories.png", "timeseries.png"]
    return written


def vehicle_footprint(spec, sim) -> tuple[float, float]:
    """(length, width) of the vehicle's footprint in metres, from its links' bounding boxes at rest
    (offroadbench.sim.runner.vehicle_envelope, on a small flat world)."""
    from offroadbench.heightmap import Heightmap
    from offroadbench.sim import World
    from offroadbench.sim.runner import vehicle_envelope

    with World(Heightmap.flat(9, 9, 0.5), spec, sim) as world:
        env = vehicle_envelope(world)
    return env.length_m, env.width_m


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
    with created_dirs(path.parent):
        return save_animation(view.fig, lambda i: view.draw(tel, i, failure_reason=failure_reason), frames, path,
                              fps=fps)


def cmd_drive(args: argparse.Namespace) -> int:
    from offroadbench.sim import SimConfig, drive_missions, load_vehicle

    if args.plot and args.out is None:
        raise InputError("--plot needs --out DIR to write the figures into")
    out = check_output_dir(args.out, "--out") if args.out else None
    if args.animate:
        from offroadbench.io.animation import check_animation_path

        check_animation_path(args.animate)
        check_output_file(args.animate, "--animate")
    vehicle = load_vehicle(args.vehicle)
    sim = SimConfig() if args.physics_rate_hz is None else SimConfig(physics_rate_hz=args.physics_rate_hz)
    from offroadbench.seeding import terrain_seed

    tseed = terrain_seed(args.seed, 0)  # drive --seed s is terrain 0 of root seed s (offroadbench.seeding)
    hm, label, recipe = load_heightmap_arg(args.terrain, tseed, sets=args.set, force=args.force)
    with bar("missions", unit="mission") as progress:
        run = drive_missions(hm, args.missions, args.seed, terrain_seed=tseed if recipe is not None else None,
                             length_m=args.length_m, vehicle=vehicle, sim=sim, planner=args.planner, progress=progress)
    print(format_drive_run(run, label))
    if out is not None:
        written = write_drive_run(run, out, label, args.plot)
        print(f"\nwrote {', '.join(f'{out}/{w}' for w in written)}")
    if args.animate:
        shown = next((r for r in run.results if not r.success), run.results[0])
        k = shown.mission_index
        title = f"{label}: mission {k}, {run.planner}, {shown.failure_reason or 'success'}"
        path = write_trial_animation(Path(args.animate), run.heightmap, run.closed, run.paths[k], run.telemetry[k],
                                     shown.failure_reason, vehicle_footprint(vehicle, sim), title)
        print(f"wrote {path} (mission {k})")
    return 0


def register(sub) -> None:
    p = sub.add_parser("drive", help="drive random straight-line missions on one terrain (PyBullet)",
                       description="Sample missions on one terrain (paper Sec. 2.3), drive them with the "
                       "vehicle and print a per-mission table and a summary.")
    p.add_argument("terrain", help="a 16-bit PNG heightmap (with its .json sidecar) or a preset / recipe TOML")
    p.add_argument("--seed", type=seed_arg, default=0,
                   help="root seed (default 0): a preset's terrain is terrain 0 of it, shown as 'seed N' "
                   "(generate --seed N rebuilds it), and mission k has seed mission_seed(seed, 0, k)")
    p.add_argument("--missions", type=positive_int, default=20, help="number of missions (default 20)")
    p.add_argument("--length-m", type=positive_float, default=35.0, help="start-goal distance, m (default 35, paper)")
    p.add_argument("--out", help="directory for trials.csv, telemetry/ and figures (created if missing)")
    p.add_argument("--plot", action="store_true", help="write missions.png, trajectories.png, timeseries.png")
    p.add_argument("--animate", metavar="OUT.gif|OUT.mp4", default=None,
                   help="write an animation of one trial (the first that failed, else mission 0): the "
                   "footprint moving over the hillshade and class map along its planned and driven paths, "
                   "with speed, pitch, roll and vertical acceleration against time and the failure marked "
                   "(.mp4 needs ffmpeg)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="recipe override, e.g. layers.base.D_high=2.6")
    p.add_argument("--vehicle", default="husky", help="vehicle name or vehicle.toml path (default husky)")
    p.add_argument("--planner", default="straight",
                   help="planner or policy (built-in: straight, astar, lattice, reactive; installed plug-ins too)")
    p.add_argument("--physics-rate-hz", type=positive_int, default=None, help="override SimConfig.physics_rate_hz")
    p.add_argument("--force", action="store_true",
                   help="skip the up-front memory estimate check (also OFFROADBENCH_NO_MEMORY_CHECK=1)")
    p.set_defaults(func=cmd_drive)
