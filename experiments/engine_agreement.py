"""Each planned test of a study on two engines, from two committed single-engine runs of it (issue 42).

The majhor2023 study ran once on PyBullet (experiments/results/majhor2023) and once on MuJoCo
(experiments/results/majhor2023-mujoco), with the same root seed (2023), so the same terrains and
missions; since their issue 42 re-runs each has a blind seed of its own, so the committed folders no
longer pair and the script refuses them (the runs at root seed 2023 are in git history, before
d4d7026). Two runs pair when every trial has the same terrain and mission seeds in both. This
script treats the two trial tables as one study with a ``sim.engine`` axis and computes the first run's
plan on each engine exactly as a study on both engines would (offroadbench.study.stats.plan:
confirmatory_table over both engines' tests, one Holm family, then engine_table: the verdict per test and
the engine difference with its terrain-bootstrap interval). It is exploratory: the pairing of the two runs
and the 16-test family were chosen after both had run (experiments/majhor2023-engines.toml is the
planned, blind, powered version of it).

    python experiments/engine_agreement.py experiments/results/majhor2023 experiments/results/majhor2023-mujoco \
        [--out experiments/results/majhor2023/engine_verdicts.csv]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from experiments.rerender import folder_meta  # noqa: E402
from offroadbench.study.stats.engines import ENGINE_KEY, engine_table  # noqa: E402
from offroadbench.study.stats.plan import confirmatory_table, stored_plan  # noqa: E402


def agreement(first: Path, second: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(confirmatory table over both engines, engine table) of ``first``'s plan on the two runs' trials."""
    metas = [folder_meta(f) for f in (first, second)]
    trials = [pd.read_parquet(f / "trials.parquet") for f in (first, second)]
    engines = [str(t["sim.engine"].iloc[0]) for t in trials]
    if len(set(engines)) != 2 or any(t["sim.engine"].nunique() != 1 for t in trials):
        raise SystemExit("the two runs must each be on one engine, and on different ones")
    seeds = [t.set_index(["cell", "terrain", "mission"])[["terrain_seed", "mission_seed"]].sort_index() for t in trials]
    if not seeds[0].equals(seeds[1]):
        raise SystemExit(f"{first} and {second} did not drive the same terrains and missions (their seeds differ): "
                         "they cannot be paired")
    m0 = metas[0]
    grid = [*m0["study"]["grid"], {"key": ENGINE_KEY, "values": engines}]
    cells, parts = [], []
    for e, (meta, t) in enumerate(zip(metas, trials, strict=True)):
        for c in sorted(meta["cells"], key=lambda c: c["index"]):
            index = len(cells)
            cells.append({"index": index, "values": {**c["values"], ENGINE_KEY: engines[e]}})
            parts.append(t[t["cell"] == c["index"]].assign(cell=index))
    meta = {"study": {**m0["study"], "grid": grid}, "columns": {**m0["columns"], ENGINE_KEY: "engine"}, "cells": cells}
    both = pd.concat(parts, ignore_index=True)
    plan = stored_plan(m0)
    confirm = confirmatory_table(plan, meta, both, None)
    return confirm, engine_table(plan, meta, both, None, confirm)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("first", type=Path)
    ap.add_argument("second", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    _, eng = agreement(args.first, args.second)
    if args.out:
        eng.to_csv(args.out, index=False)
    pd.set_option("display.width", 250)
    print(eng[["comparison", "engine", "terrains", "effect", "ci_low", "ci_high", "p_adjusted", "reject", "verdict",
               "engine_difference", "engine_difference_low", "engine_difference_high"]].to_string(index=False))


if __name__ == "__main__":
    main()
