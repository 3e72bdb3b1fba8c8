"""``offroadbench soil list`` and ``offroadbench soil check SOIL``: the soils of the terramechanics
tyre model, and one wheel on a soil at controlled slip in the engine beside the Wong-Reece integrals.

The work is :mod:`offroadbench.sim.rigs.soil_check`; this module parses, prints and writes the figure.
"""

from __future__ import annotations

import argparse

import pandas as pd

from offroadbench.cli._common import (
    bar,
    check_output_file,
    format_table,
    positive_float,
    save_figure,
)


def format_soil_check(rig, model, gravity_m_s2: float) -> str:
    """The per-slip table: engine rig beside the integrals."""
    df = pd.DataFrame({
        "slip": rig.slip,
        "sinkage_mm": 1000 * rig.sinkage_m, "model_sinkage_mm": 1000 * model.sinkage_m,
        "drawbar_pull_n": rig.drawbar_pull_n, "model_pull_n": model.drawbar_pull_n,
        "torque_nm": rig.torque_nm, "model_torque_nm": model.torque_nm,
    })
    worst = max(float(abs(rig.drawbar_pull_n - model.drawbar_pull_n).max()) / rig.load_n,
                float(abs(rig.torque_nm - model.torque_nm).max()) / (rig.load_n * rig.radius_m))
    return "\n".join([
        (f"soil check: {rig.soil}, wheel r = {rig.radius_m:g} m, b = {rig.width_m:g} m, load {rig.load_n:.2f} N "
        f"(gravity {gravity_m_s2:g} m/s^2; Bekker parameters are from 1 g tests)"),
        format_table(df, "{:.3f}"),
        "",
        f"largest difference engine - integrals: {100 * worst:.2f} % of the load (pull) or load x radius (torque)",
    ])


def cmd_list(args: argparse.Namespace) -> int:
    from offroadbench.sim.tyre_laws.terramechanics import load_soil, soil_files

    for name in soil_files():
        print(f"{name:30s} {load_soil(name).description}")
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from offroadbench.errors import InputError
    from offroadbench.sim.rigs.soil_check import model_curve, rig_curve, wheel_load_n
    from offroadbench.sim.tyre_laws.terramechanics import load_soil
    from offroadbench.sim.trial.vehicle import load_vehicle

    if args.plot:
        check_output_file(args.plot, "--plot", (".png", ".pdf", ".svg"))
    soil = load_soil(args.soil)
    spec = load_vehicle(args.wheel)
    if spec.wheel_width_m is None:
        raise InputError(f"--wheel {args.wheel}: the vehicle has no wheel_width_m")
    load = args.load_n if args.load_n is not None else wheel_load_n(spec, args.gravity)
    with bar("slips", unit="slip") as progress:
        rig = rig_curve(soil, spec.wheel_radius_m, spec.wheel_width_m, load, gravity_m_s2=args.gravity, progress=progress)
    model = model_curve(soil, spec.wheel_radius_m, spec.wheel_width_m, load)
    print(format_soil_check(rig, model, args.gravity))
    if args.plot:
        from offroadbench.plots.soil import plot_soil_check

        save_figure(plot_soil_check(rig, model), args.plot)
        print(f"\nwrote {args.plot}")
    return 0


def register(sub) -> None:
    p = sub.add_parser("soil", help="soils of the terramechanics tyre model: list, single-wheel check",
                       description="Soil tools.")
    ssub = p.add_subparsers(dest="soil_command", required=True, parser_class=sub._parser_class)
    lst = ssub.add_parser("list", help="list the known soils")
    lst.set_defaults(func=cmd_list)
    c = ssub.add_parser("check", help="one wheel at slip 0-0.9 in the engine beside the Wong-Reece integrals",
                        description="Drive one wheel at controlled slip (0-0.9) and load on the soil in the "
                        "physics engine; print sinkage, drawbar pull and torque against slip beside the "
                        "same quantities from the Wong-Reece integrals.")
    c.add_argument("soil", help="soil name (offroadbench soil list) or soil .toml path")
    c.add_argument("--wheel", default="husky", help="vehicle whose wheel is tested (default husky)")
    c.add_argument("--load-n", type=positive_float, default=None,
                   help="wheel load, N (default: a quarter of the vehicle's weight at --gravity)")
    c.add_argument("--gravity", type=positive_float, default=9.81, help="gravity, m/s^2 (default 9.81)")
    c.add_argument("--plot", metavar="PATH", help="write the figure (.png, .pdf or .svg)")
    c.set_defaults(func=cmd_check)
