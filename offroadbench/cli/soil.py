"""``offroadbench soil list`` and ``offroadbench soil check SOIL``: the soils of the terramechanics
tyre model, and one wheel on a soil at controlled slip in the engine beside the Wong-Reece integrals.

The work is :mod:`offroadbench.sim.rigs.soil_check`; this module parses, prints and writes the figure.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from offroadbench.cli._common import (
    add_plot_option,
    bar,
    created_dirs,
    format_table,
    plot_path,
    positive_float,
    save_figure,
)


def outside_rows(rig, model) -> np.ndarray:
    """Per slip, True where the rig or the integrals have the wheel bottomed out (outside the model:
    offroadbench.sim.rigs.soil_check, "Where the model ends")."""
    out = np.zeros(len(rig.slip), dtype=bool)
    for check in (rig, model):
        if check.outside_model is not None:
            out |= check.outside_model
    return out


def _worst(rig, model) -> float | None:
    """Largest engine - integrals difference over the rows inside the model, as a fraction of the load
    (pull) or load x radius (torque); None when every row is outside the model."""
    inside = ~outside_rows(rig, model)
    if not inside.any():
        return None
    return max(float(abs(rig.drawbar_pull_n - model.drawbar_pull_n)[inside].max()) / rig.load_n,
               float(abs(rig.torque_nm - model.torque_nm)[inside].max()) / (rig.load_n * rig.radius_m))


def compare_published(model, bands) -> list[dict]:
    """Each published slip-sinkage band beside the model's sinkage(slip) / sinkage(0) there, and
    where the model leaves it (``below``, ``within`` or ``above``)."""
    out = []
    for b in bands:
        ratio = float(np.interp(b.slip, model.slip, model.sinkage_m) / model.sinkage_m[0])
        where = "below" if ratio < b.ratio_low else "above" if ratio > b.ratio_high else "within"
        if model.outside_model is not None and model.outside_model.any():
            where = "outside the model"  # a bottomed-out wheel's sinkage is the cap, not the soil's
        out.append({"source": b.source, "figure": b.figure, "wheel": b.wheel, "soil": b.soil, "slip": b.slip,
                    "ratio_low": b.ratio_low, "ratio_high": b.ratio_high, "model_ratio": ratio, "model_is": where})
    return out


def _outside_line(rig, model) -> str | None:
    """One line naming the rows outside the model and why, or None when there are none."""
    from offroadbench.sim.tyre_laws.terramechanics import MAX_SINKAGE_FRACTION

    outside = outside_rows(rig, model)
    if not outside.any():
        return None
    slips = ", ".join(f"{s:g}" for s in rig.slip[outside])
    cap = "" if model.capacity_n is None else (
        f": the soil carries at most {float(model.capacity_n[outside].max()):.1f} N of the {rig.load_n:.1f} N load "
        f"at the tables' sinkage cap ({MAX_SINKAGE_FRACTION:g} r)")
    return (f"OUTSIDE THE MODEL at slip {slips} (the wheel bottoms out{cap}); those rows are not agreement and "
            "are left out of the largest difference")


def format_soil_check(rig, model, gravity_m_s2: float, published=()) -> str:
    """The per-slip table: engine rig beside the integrals (rows outside the model marked), then the
    published comparison."""
    import pandas as pd

    outside = outside_rows(rig, model)
    df = pd.DataFrame({
        "slip": rig.slip,
        "sinkage_mm": 1000 * rig.sinkage_m, "model_sinkage_mm": 1000 * model.sinkage_m,
        "pull_per_load": rig.drawbar_pull_n / rig.load_n, "model_pull_per_load": model.drawbar_pull_n / rig.load_n,
        "torque_nm": rig.torque_nm, "model_torque_nm": model.torque_nm,
        "model": np.where(outside, "OUTSIDE", "inside"),
    })
    worst = _worst(rig, model)
    lines = [
        (f"soil check: {rig.soil}, wheel r = {rig.radius_m:g} m, b = {rig.width_m:g} m, load {rig.load_n:.2f} N "
        f"(gravity {gravity_m_s2:g} m/s^2; Bekker parameters are from 1 g tests)"),
        format_table(df, "{:.3f}"),
        "",
    ]
    note = _outside_line(rig, model)
    if note is not None:
        lines.append(note)
    lines.append("largest difference engine - integrals: none inside the model" if worst is None else
                 f"largest difference engine - integrals: {100 * worst:.2f} % of the load (pull) or load x radius "
                 "(torque), over the rows inside the model")
    if not published:
        lines.append("published slip-sinkage: none for this soil (soils/data/slip-sinkage-*.csv)")
    for p in published:
        lines.append(f"published: {p['source']}, {p['figure']} ({p['wheel']}, {p['soil']}): sinkage at slip "
                     f"{p['slip']:g} is {p['ratio_low']:g}-{p['ratio_high']:g}x the static sinkage; the model gives "
                     f"{p['model_ratio']:.2f}x, {p['model_is']} the band")
    return "\n".join(lines)


def soil_check_json(rig, model, gravity_m_s2: float, published=()) -> str:
    """The check as JSON: the soil, wheel, load and gravity, the per-slip rows and the comparisons."""
    outside = outside_rows(rig, model)
    cap = model.capacity_n if model.capacity_n is not None else np.full(len(rig.slip), np.nan)
    rows = [{"slip": float(s), "sinkage_m": float(h), "model_sinkage_m": float(mh), "drawbar_pull_n": float(f),
             "model_drawbar_pull_n": float(mf), "torque_nm": float(t), "model_torque_nm": float(mt),
             "outside_model": bool(o), "soil_capacity_n": float(c)}
            for s, h, mh, f, mf, t, mt, o, c in zip(rig.slip, rig.sinkage_m, model.sinkage_m, rig.drawbar_pull_n,
                                                    model.drawbar_pull_n, rig.torque_nm, model.torque_nm, outside,
                                                    cap, strict=True)]
    return json.dumps({"soil": rig.soil, "wheel_radius_m": rig.radius_m, "wheel_width_m": rig.width_m,
                       "load_n": rig.load_n, "gravity_m_s2": gravity_m_s2, "rows": rows,
                       "rows_outside_model": int(outside.sum()), "outside_model_note": _outside_line(rig, model),
                       "largest_difference_fraction": _worst(rig, model), "published": list(published)}, indent=1)


def cmd_list(args: argparse.Namespace) -> int:
    from offroadbench.sim.tyre_laws.terramechanics import load_soil, soil_files

    import sys

    from offroadbench.errors import InputError

    bad = []
    for name, path in soil_files().items():
        try:
            soil = load_soil(path)
        except InputError as exc:  # one invalid user soil does not hide the others
            bad.append(f"offroadbench: invalid soil {name} ({path}): {' '.join(str(exc).split())}")
            continue
        print(f"{name:30s} {soil.description}")
    for line in bad:
        sys.stderr.write(line + "\n")
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from offroadbench.errors import InputError
    from offroadbench.sim.rigs.soil_check import model_curve, rig_curve, wheel_load_n
    from offroadbench.sim.trial.vehicle import load_vehicle
    from offroadbench.sim.tyre_laws.terramechanics import load_soil, published_slip_sinkage

    from pathlib import Path

    plot = plot_path(args.plot, f"soil_check_{Path(args.soil).stem}_{Path(args.wheel).stem}.png")
    soil = load_soil(args.soil)
    spec = load_vehicle(args.wheel)
    if spec.wheel_width_m is None:
        raise InputError(f"--wheel {args.wheel}: the vehicle has no wheel_width_m")
    load = args.load_n if args.load_n is not None else wheel_load_n(spec, args.gravity)
    with bar("slips", unit="slip") as progress:
        rig = rig_curve(soil, spec.wheel_radius_m, spec.wheel_width_m, load, gravity_m_s2=args.gravity,
                        engine=args.engine, progress=progress)
    model = model_curve(soil, spec.wheel_radius_m, spec.wheel_width_m, load)
    bands = published_slip_sinkage(soil.name)
    published = compare_published(model, bands)
    if args.json:
        print(soil_check_json(rig, model, args.gravity, published))
    else:
        print(format_soil_check(rig, model, args.gravity, published))
    if plot is not None:
        from offroadbench.plots.soil import plot_soil_check

        with created_dirs(plot.parent):
            save_figure(plot_soil_check(rig, model, bands=bands, gravity_m_s2=args.gravity), plot)
        if not args.json:
            print(f"\nwrote {plot}")
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
    c.add_argument("--engine", default="pybullet",
                   help="physics engine of the rig (pybullet, the default, or mujoco; the soil's force law is "
                   "the same code on both)")
    add_plot_option(c, "the figure (rig and Wong-Reece curves against slip)", "soil_check_SOIL_WHEEL.png")
    c.add_argument("--json", action="store_true", help="print the check as JSON (rows, published comparison)")
    c.set_defaults(func=cmd_check)
