"""Power of a study's planned tests before its run, and its size (issue 42; issues 29 and 31 before it).

For a study TOML whose ``[analysis]`` plan names a ``pilot`` (an earlier run's trial table) and states
each comparison's ``effect``, prints every expanded test's power at that effect with the exact test and
the Holm step it will face (offroadbench.study.stats.power.plan_power: the pilot's per-terrain
differences centred on the effect, resampled as the truth), at the study's terrains per cell and at
the others given; then the design's size: trials and the runner's CPU estimate
(offroadbench.study.runner.estimate_study), and the wall time on ``--cores`` cores at a measured
seconds-per-trial when one is given (a committed run's sessions.csv wall time / its trials).

    python experiments/power.py experiments/vehicle-planner.toml [--terrains 16 20 24] [--s-per-trial 2.4]

``study run`` computes the same power at the study's own terrains per cell and refuses a test under
the plan's ``min_power`` unless the plan marks it exploratory.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from offroadbench.config import load_toml
from offroadbench.study.runner import estimate_study
from offroadbench.study.spec.config import study_from_dict
from offroadbench.study.stats.power import load_pilot, plan_power, resolve_pilot


def power_table(toml: Path, terrains: list[int]) -> pd.DataFrame:
    """One row per planned test, one ``power at K`` column per terrain count (the study's own first)."""
    study = study_from_dict(load_toml(toml), where=str(toml))
    plan = study.analysis
    if plan is None or not plan.pilot:
        raise SystemExit(f"{toml}: its [analysis] plan names no pilot")
    path = resolve_pilot(plan.pilot, [toml.parent])
    if path is None:
        raise SystemExit(f"{toml}: pilot {plan.pilot} not found")
    pilot = load_pilot(path)
    out = None
    for k in dict.fromkeys([study.terrains_per_cell, *terrains]):
        t = plan_power(plan, study.cell_values(), study.column_names(), k, pilot)
        if out is None:
            out = t.drop(columns=["terrains", "power"])
        out[f"power at {k}"] = t["power"].to_numpy()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", type=Path)
    ap.add_argument("--terrains", type=int, nargs="*", default=[])
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--s-per-trial", type=float, default=None,
                    help="measured worker seconds per trial of a comparable committed run")
    args = ap.parse_args()
    study = study_from_dict(load_toml(args.study), where=str(args.study))
    pd.set_option("display.width", 250)
    pd.set_option("display.max_columns", 20)
    pd.set_option("display.max_colwidth", 60)
    print(power_table(args.study, args.terrains).to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    est = estimate_study(study)
    line = f"\n{study.name}: {est.describe()}; on {args.cores} cores about {est.cpu_s / args.cores / 3600:.2g} h"
    if args.s_per_trial:
        line += (f"; at the measured {args.s_per_trial:g} s per trial about "
                 f"{est.trials * args.s_per_trial / args.cores / 3600:.2g} h")
    print(line)


if __name__ == "__main__":
    main()
