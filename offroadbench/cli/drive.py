"""``offroadbench drive TERRAIN.png|PRESET``: run random straight-line missions on one terrain."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import pandas as pd

from offroadbench.cli._args import positive_int, seed_arg
from offroadbench.cli.terrain import (
    format_table,
    load_heightmap_arg,
    save_figure,
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
_MEDIANS = ("traversal_time_s", "rms_vertical_accel_m_s2", "rms_pitch_rate_deg_s", "rms_roll_rate_deg_s")


def mission_rng(seed: int) -> np.random.Generator:
    """The missions' generator: a child of ``seed`` apart from the terrain's stream."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])


def _load_terrain(args):
    hm, label, _ = load_heightmap_arg(args.terrain, args.seed, sets=args.set)
    return hm, label


def summarise(df: pd.DataFrame) -> dict[str, float]:
    """Success rate (Eq. 5) and medians of the successful trials' metrics."""
    from offroadbench.navigation.metrics import success_rate

    ok = df[df["success"]]
    out = {"trials": float(len(df)), "success_rate_pct": success_rate(df["success"])}
    for col in _MEDIANS:
        out[f"median_{col}"] = float(ok[col].median()) if len(ok) else math.nan
    return out


def cmd_drive(args: argparse.Namespace) -> int:
    from offroadbench.analysis.roughness import RoughnessConfig, classify_terrain
    from offroadbench.cli._progress import bar
    from offroadbench.io.atomic import atomic_path
    from offroadbench.navigation.missions import MissionConfig, sample_missions
    from offroadbench.sim import SimConfig, load_vehicle, run_missions

    out = Path(args.out) if args.out else None
    if args.plot and out is None:
        raise InputError("--plot needs --out DIR to write the figures into")
    if out is not None and out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory")
    vehicle = load_vehicle(args.vehicle)
    sim = SimConfig() if args.physics_rate_hz is None else SimConfig(physics_rate_hz=args.physics_rate_hz)
    hm, label = _load_terrain(args)
    rcfg = RoughnessConfig()
    closed = classify_terrain(hm, rcfg).closed
    mcfg = MissionConfig(count=args.missions, length_m=args.length_m, border_m=rcfg.border_m)
    missions = sample_missions(hm, closed, mcfg, mission_rng(args.seed))

    tel_dir = None
    if out is not None:
        try:
            out.mkdir(parents=True, exist_ok=True)
            tel_dir = out / "telemetry"
            tel_dir.mkdir(exist_ok=True)
        except OSError as exc:
            raise InputError(f"--out {out}: cannot create directory ({exc.strerror})") from None
    with bar("missions", unit="mission") as progress:
        results = run_missions(hm, missions, vehicle=vehicle, sim=sim, progress=progress, telemetry_dir=tel_dir)

    df = pd.DataFrame([r.as_row() for r in results])
    df["outcome"] = df["failure_reason"].replace("", "success")
    df["max_penetration_mm"] = 1000 * df["max_penetration_m"]
    print(f"{label}: {len(missions)} missions of {mcfg.length_m:g} m, vehicle {vehicle.name}, physics {sim.physics_rate_hz} Hz")
    table = df[[c for c, _ in _TABLE]].rename(columns=dict(_TABLE))
    print(format_table(table))
    summary = summarise(df)
    print(f"\nsuccess rate {summary['success_rate_pct']:.1f} % ({int(df['success'].sum())}/{len(df)}); "
          "medians of successful trials:")
    print("  " + ", ".join(f"{k[len('median_'):]} {v:.3f}" for k, v in summary.items() if k.startswith("median_")))
    if out is None:
        return 0
    with atomic_path(out / "trials.csv") as tmp:
        df.drop(columns=["outcome", "max_penetration_mm"]).to_csv(tmp, index=False)
    written = ["trials.csv", "telemetry/mission_*.npz"]
    if args.plot:
        from offroadbench.io.telemetry import load_telemetry
        from offroadbench.plots.traversal import plot_missions, plot_timeseries, plot_trajectories

        tel = {m.index: load_telemetry(tel_dir / f"mission_{m.index:03d}.npz") for m in missions}
        save_figure(plot_missions(hm, closed, missions, border_m=mcfg.border_m, title=f"{label}: missions"),
                    out / "missions.png")
        save_figure(plot_trajectories(hm, closed, missions, tel, results, border_m=mcfg.border_m,
                                      title=f"{label}: trajectories"), out / "trajectories.png")
        shown = next((r for r in results if r.success), results[0])
        save_figure(plot_timeseries(tel[shown.mission_index], title=f"{label}: mission {shown.mission_index} "
                                    f"({shown.failure_reason or 'success'})"), out / "timeseries.png")
        written += ["missions.png", "trajectories.png", "timeseries.png"]
    print(f"\nwrote {', '.join(f'{out}/{w}' for w in written)}")
    return 0


def register(sub) -> None:
    p = sub.add_parser("drive", help="drive random straight-line missions on one terrain (PyBullet)",
                       description="Sample missions on one terrain (paper Sec. 2.3), drive them with the "
                       "vehicle and print a per-mission table and a summary.")
    p.add_argument("terrain", help="a 16-bit PNG heightmap (with its .json sidecar) or a preset / recipe TOML")
    p.add_argument("--seed", type=seed_arg, default=0, help="terrain seed (presets) and mission seed (default 0)")
    p.add_argument("--missions", type=positive_int, default=20, help="number of missions (default 20)")
    p.add_argument("--length-m", type=float, default=35.0, help="start-goal distance, m (default 35, paper)")
    p.add_argument("--out", help="directory for trials.csv, telemetry/ and figures")
    p.add_argument("--plot", action="store_true", help="write missions.png, trajectories.png, timeseries.png")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="recipe override, e.g. layers.base.D_high=2.6")
    p.add_argument("--vehicle", default="husky", help="vehicle name or vehicle.toml path (default husky)")
    p.add_argument("--physics-rate-hz", type=positive_int, default=None, help="override SimConfig.physics_rate_hz")
    p.set_defaults(func=cmd_drive)
