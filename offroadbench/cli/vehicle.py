"""``offroadbench vehicle check NAME [--json]``: judge a vehicle model against its own physics.

The work is :func:`offroadbench.sim.rigs.vehicle_check.check_vehicle`; this module prints its rows as a table
(or a JSON list) and exits 1 if any figure is outside its tolerance of what the model's grip,
geometry and motor torque predict. Spec-sheet figures are printed beside, as information.
"""

from __future__ import annotations

import argparse
import json

from offroadbench.cli._common import bar

EXIT_CHECK_FAILED = 1


def format_checks(name: str, rows) -> str:
    """A fixed-width table: figure, measured, expected (the model's physics), spec sheet, unit,
    pass/fail, tolerance, note."""
    width = max(len(r.name) for r in rows)
    lines = [f"vehicle check: {name}", "",
             (f"{'figure':<{width}}  {'measured':>9}  {'expected':>9}  {'sheet':>7}  {'unit':<5}  {'':4}  "
             "tolerance; note")]
    for r in rows:
        tail = "; ".join(t for t in (r.tolerance, r.note) if t)
        sheet = "" if r.sheet is None else f"{r.sheet:.3g}"
        lines.append(f"{r.name:<{width}}  {r.measured:9.3f}  {r.expected:9.3f}  {sheet:>7}  {r.unit:<5}  "
                     f"{'ok' if r.ok else 'FAIL':4}  {tail}")
    failed = sum(not r.ok for r in rows)
    lines += ["", (f"{len(rows) - failed} of {len(rows)} figures within tolerance of the model's physics (expected); "
              "sheet: the spec sheet's figure, information only")]
    return "\n".join(lines)


def cmd_check(args: argparse.Namespace) -> int:
    from offroadbench.sim import SimConfig, load_vehicle
    from offroadbench.sim.rigs.vehicle_check import check_vehicle

    spec = load_vehicle(args.name)
    changes = {k: v for k, v in (("tyre_model", args.tyre_model), ("engine", args.engine),
                                 ("physics_rate_hz", args.physics_rate_hz)) if v is not None}
    sim = SimConfig(**changes)
    with bar("checking", unit="step") as progress:
        rows = check_vehicle(spec, sim, progress=progress)
    if args.json:
        keys = ("name", "measured", "expected", "sheet", "unit", "ok", "tolerance", "note")
        print(json.dumps([{k: r.as_dict()[k] for k in keys} for r in rows], indent=1))
    else:
        print(format_checks(spec.name, rows))
    return 0 if all(r.ok for r in rows) else EXIT_CHECK_FAILED


def register(sub) -> None:
    from offroadbench.sim.config import TYRE_MODELS

    p = sub.add_parser("vehicle", help="vehicle tools: check a vehicle model against its own physics",
                       description="Vehicle tools.")
    vsub = p.add_subparsers(dest="vehicle_command", required=True, parser_class=sub._parser_class)
    c = vsub.add_parser("check", help="measure a vehicle on small test worlds against its own physics",
                        description="Measure yaw-rate tracking, straight-line drift, stopping distance, tilt-table "
                        "tip angle, static stability, side slope, climb and step on small test worlds, each "
                        "against what the model's grip, geometry and motor torque predict; the spec sheet's "
                        "figures stand beside as information, with the reason for a difference. Exit status 1 "
                        "if any figure is out of tolerance of the model's physics.")
    c.add_argument("name", help="vehicle name (e.g. husky, jackal) or vehicle.toml path")
    c.add_argument("--json", action="store_true",
                   help='print a JSON list of {"name", "measured", "expected", "unit", "ok", ...}')
    c.add_argument("--tyre-model", choices=TYRE_MODELS, default=None,
                   help="override SimConfig.tyre_model (default: the package default)")
    c.add_argument("--engine", default=None,
                   help="physics engine (SimConfig.engine: pybullet, the default, or mujoco)")
    c.add_argument("--physics-rate-hz", type=int, default=None, help="override SimConfig.physics_rate_hz")
    c.set_defaults(func=cmd_check)
