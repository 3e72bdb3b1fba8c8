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


def cmd_list(args: argparse.Namespace) -> int:
    """Every known vehicle (search path, shipped, installed packages) with its drive and size."""
    from offroadbench.errors import InputError
    from offroadbench.sim import load_vehicle
    from offroadbench.sim.trial.vehicle import vehicle_files

    rows = []
    for name, path in vehicle_files().items():
        try:
            v = load_vehicle(path)
        except InputError as exc:  # a broken user vehicle is named, the others still listed
            rows.append((name, f"invalid: {' '.join(str(exc).split())}", "", "", "", str(path)))
            continue
        wheels = len(v.left_wheel_joints) + len(v.right_wheel_joints)
        rows.append((name, v.steering + (" (tracks)" if v.belt_drive else ""), f"{wheels}", f"{v.wheel_radius_m:.3f}", f"{v.max_speed_m_s:g}", str(path)))
    header = ("vehicle", "steering", "wheels", "wheel radius, m", "top speed, m/s", "file")
    widths = [max(len(r[i]) for r in (header, *rows)) for i in range(len(header) - 1)]
    for r in (header, *rows):
        print("  ".join(c.ljust(w) for c, w in zip(r[:-1], widths, strict=True)) + "  " + r[-1])
    return 0


def register(sub) -> None:
    from offroadbench.sim.config import TYRE_MODELS

    p = sub.add_parser("vehicle", help="vehicle tools: list the vehicles, check a vehicle model against its own physics",
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
    ls = vsub.add_parser("list", help="the known vehicles (shipped, OFFROADBENCH_PATH, installed packages)")
    ls.set_defaults(func=cmd_list)
