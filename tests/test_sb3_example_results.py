"""The SB3 example's README quotes its committed run (examples/sb3_policy/results/), without torch.

examples/sb3_policy/summarize.py computes the README's "Measured" section from the committed files;
this test fails while README.md's section differs from it, and checks that the committed files agree
with each other (the training summary with the learning curve, the study table with the report's).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pandas as pd

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "sb3_policy"


def _load():
    spec = importlib.util.spec_from_file_location("sb3_summarize", EXAMPLE / "summarize.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


summarize = _load()


def test_readme_measured_section_is_computed_from_the_committed_run():
    text = (EXAMPLE / "README.md").read_text(encoding="utf-8")
    assert summarize.readme_block(text) == summarize.render(summarize.load()), (
        "examples/sb3_policy/README.md's Measured section is stale: run `python examples/sb3_policy/summarize.py "
        "--write-readme`")


def test_a_changed_trial_changes_the_section():
    r = summarize.load()
    before = summarize.render(r)
    flipped = r["trials"].copy()
    i = flipped.index[flipped["planner"] == "straight"][0]
    flipped.loc[i, "success"] = not flipped.loc[i, "success"]
    assert summarize.render({**r, "trials": flipped}) != before


def test_committed_files_agree_with_each_other():
    r = summarize.load()
    tr, curve, trials = r["training"], r["curve"], r["trials"]
    last = curve.tail(tr["episodes_in_buffer"])
    assert len(curve) == tr["episodes"] and curve["timesteps"].is_monotonic_increasing
    assert round(last["return"].mean(), 2) == tr["mean_return"]
    assert round(last["length_steps"].mean(), 1) == tr["mean_length_steps"]
    assert curve["timesteps"].iloc[-1] <= tr["timesteps"]
    assert len(trials) == 40 and set(trials["planner"]) == {"straight", "sb3"}
    report = pd.read_csv(summarize.RESULTS / "planner_success.csv")
    for row in report.to_dict("records"):
        sel = trials[(trials["planner"] == row["planner"]) & (trials["D_high"] == row["D_high"])]
        assert (len(sel), int(sel["success"].sum())) == (row["trials"], row["successes"])
    p = summarize.paired(trials)
    assert sum(p.values()) == 20
    assert (summarize.RESULTS / "ppo_traverse.zip").stat().st_size < 1_000_000
