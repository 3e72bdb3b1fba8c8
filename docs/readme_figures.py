"""The figures README.md quotes from commands, regenerated into docs/readme-figures.md.

    python docs/readme_figures.py                      # every source (about 20 minutes on 2 shared cores)
    python docs/readme_figures.py --only husky-check   # some sources; the others keep their values
    python docs/readme_figures.py --list               # the sources, their commands, and which are cheap

Each *source* is one command (``vehicle check husky``, ``drive paper-d2.3 ...``, a terrain's
statistics, the SB3 example's committed run) and gives named *figures*, formatted as the README
prints them. The script runs the sources, writes every figure with its command to
``docs/readme-figures.md`` and rewrites the README's *quotes* (the sentences and table rows below,
``QUOTES``, each with its figures as placeholders) from the old values to the new ones, so the README
never states a figure that its file does not hold.

``tests/test_readme_figures.py`` fails

* while README.md does not contain every quote formatted with the committed figures (all sources),
* while a *cheap* source (``cheap=True``: deterministic on every CPU and a few seconds: the terrain
  statistics of ``jacksboro`` and ``terrain-tails``, whose bits do not depend on the CPU, README
  "Reproducibility"; ``sb3-example``, read from the example's committed tables) gives other figures
  than the committed file.

The slow sources (vehicle checks, soil check and drives: physics, 15-90 s each; the roughness study,
about a minute) are not re-run by the tests: after a change to the physics or the terrain, run this
script; it prints every figure that moved.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import json
import re
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
FIGURES_PATH = ROOT / "docs" / "readme-figures.md"
README_PATH = ROOT / "README.md"
REGENERATE = "python docs/readme_figures.py"


@dataclass(frozen=True)
class Source:
    name: str
    command: str
    """The command(s) the figures come from, as a user would type them."""
    cheap: bool
    """Deterministic on every CPU and quick: recomputed by the tests."""
    compute: Callable[[], dict[str, str]]
    note: str = ""
    """What is taken from the command's output."""


# --------------------------------------------------------------------------- running commands
def _cli(argv: list[str]) -> str:
    """stdout of ``offroadbench ARGV`` run in this process (exit status 0 or 1 accepted)."""
    from offroadbench.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        status = main(argv)
    if status not in (0, 1):
        raise RuntimeError(f"offroadbench {' '.join(argv)} exited {status}")
    return buf.getvalue()


def _check(vehicle: str, engine: str) -> dict[str, dict]:
    rows = json.loads(_cli(["vehicle", "check", vehicle, "--json", "--engine", engine]))
    return {r["name"]: r for r in rows}


def _drive_successes(terrain: str, seed: int, missions: int, extra: list[str]) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "drive"
        _cli(["drive", terrain, "--seed", str(seed), "--missions", str(missions), *extra, "--out", str(out)])
        trials = pd.read_csv(out / "trials.csv")
    assert len(trials) == missions, f"drive {terrain}: {len(trials)} rows for {missions} missions"
    return int(trials["success"].sum())


# --------------------------------------------------------------------------- sources
def husky_check() -> dict[str, str]:
    r = _check("husky", "pybullet")
    yaw = [v["measured"] / v["expected"] for k, v in r.items() if k.startswith("yaw rate")]
    m = {k: v["measured"] for k, v in r.items()}
    e = {k: v["expected"] for k, v in r.items()}
    soft = "soft soil: "
    return {
        "husky.yaw_ratio": f"{min(yaw):.2f}-{max(yaw):.2f}",
        "husky.yaw_tolerance": r["yaw rate in place, heading 0 deg, command 1 rad/s"]["tolerance"].removesuffix(" x expected"),
        "husky.drift_m": f"{m['straight-line drift over 10 m']:.3f}",
        "husky.drift_tolerance": r["straight-line drift over 10 m"]["tolerance"],
        "husky.tip_deg": f"{m['static tip angle (tilt table)']:.1f}",
        "husky.tip_expected_deg": f"{e['static tip angle (tilt table)']:.1f}",
        "husky.stability_deg": f"{m['static stability: tip angle over slide angle']:.1f}",
        "husky.slide_deg": f"{e['side slope held, parked']:.1f}",
        "husky.side_slope_deg": f"{m['side slope held, parked']:.1f}",
        "husky.grade_deg": f"{m['steepest grade climbed from rest']:.1f}",
        "husky.step_m": f"{m['highest step climbed at cruise speed']:.2f}",
        "husky.step_expected_m": f"{e['highest step climbed at cruise speed']:.2f}",
        "husky.soft_sinkage_mm": f"{1000 * m[soft + 'sinkage at rest']:.1f}",
        "husky.soft_sinkage_expected_mm": f"{1000 * e[soft + 'sinkage at rest']:.1f}",
        "husky.soft_grade_deg": f"{m[soft + 'steepest grade climbed from rest']:.1f}",
        "husky.soft_grade_expected_deg": f"{e[soft + 'steepest grade climbed from rest']:.1f}",
        "husky.soft_pull_n": f"{m[soft + 'drawbar pull at 20 % slip']:.1f}",
        "husky.soft_pull_expected_n": f"{e[soft + 'drawbar pull at 20 % slip']:.1f}",
        "husky.soft_weight_n": f"{float(re.search(r'weight ([0-9.]+) N', r[soft + 'drawbar pull at 20 % slip']['note'])[1]):.0f}",
    }


def talon_check() -> dict[str, str]:
    r = _check("talon", "pybullet")
    step = next(v for k, v in r.items() if k.startswith("highest step climbed"))
    return {"talon.step_expected_m": f"{step['expected']:.3f}",
            "talon.soft_sinkage_expected_mm": f"{1000 * r['soft soil: sinkage at rest']['expected']:.2f}"}


def hunter_soft() -> dict[str, str]:
    out = {}
    for engine in ("pybullet", "mujoco"):
        r = _check("hunter", engine)
        grade, pull = r["soft soil: steepest grade climbed from rest"], r["soft soil: drawbar pull at 20 % slip"]
        out |= {f"hunter.{engine}.soft_grade_deg": f"{grade['measured']:.1f}",
                f"hunter.{engine}.soft_grade_expected_deg": f"{grade['expected']:.1f}",
                f"hunter.{engine}.soft_grade_ok": "pass" if grade["ok"] else "fail",
                f"hunter.{engine}.soft_pull_n": f"{pull['measured']:.1f}",
                f"hunter.{engine}.soft_pull_expected_n": f"{pull['expected']:.1f}",
                f"hunter.{engine}.soft_pull_ok": "pass" if pull["ok"] else "fail"}
    return out


def soil_check() -> dict[str, str]:
    """One Husky wheel on lunar regolith in lunar gravity against the Wong-Reece integrals."""
    d = json.loads(_cli(["soil", "check", "lunar-regolith", "--gravity", "1.62", "--json"]))
    rows = {r["slip"]: r for r in d["rows"]}
    return {"soil.largest_difference_pct": f"{100 * d['largest_difference_fraction']:.2f}",
            "soil.sinkage_ratio_slip0.6": f"{rows[0.6]['sinkage_m'] / rows[0.0]['sinkage_m']:.2f}"}


PAPER_CHANGES_PP = {"low": (-13.8, -7.16), "semi": (11.7, 5.63), "high": (1.54, 3.33)}
"""Majhor & Bos 2023, Sec. 3.1: change of the median class areas, D 2.3 -> 2.45 and 2.45 -> 2.6 (points)."""


def roughness_study() -> dict[str, str]:
    """The paper's Fig. 5 study: median class areas per D and their changes, and their ratio to the paper's."""
    with tempfile.TemporaryDirectory() as tmp:
        _cli(["roughness-study", "--dims", "2.3", "2.45", "2.6", "--terrains", "20", "--seed", "0", "--out", tmp])
        table = pd.read_csv(Path(tmp) / "roughness_summary.csv").sort_values("D")
    out, ratios = {}, []
    for cls, paper in PAPER_CHANGES_PP.items():
        out[f"roughness.{cls}.medians"] = " / ".join(f"{v:.1f}" for v in table[f"median_{cls}_pct"])
        changes = list(table[f"change_{cls}_pp"].iloc[1:])
        out |= {f"roughness.{cls}.change{i}": f"{c:+.2f}" for i, c in enumerate(changes, 1)}
        ratios += [round(c, 2) / p for c, p in zip(changes, paper, strict=True)]
    return out | {"roughness.ratio_range": f"{min(ratios):.2f}-{max(ratios):.2f}"}


VEHICLES = ("husky", "jackal", "talon", "hunter", "sojourner")
"""The shipped vehicles (``offroadbench vehicle list``)."""


def vehicle_checks() -> dict[str, str]:
    """Per engine: how many shipped vehicles pass every row of ``vehicle check`` (exit 0), and which fail."""
    out = {}
    for engine in ("pybullet", "mujoco"):
        failing = [v for v in VEHICLES if not all(r["ok"] for r in _check(v, engine).values())]
        out |= {f"checks.{engine}.passing": f"{len(VEHICLES) - len(failing)} of {len(VEHICLES)}",
                f"checks.{engine}.failing": ", ".join(failing) or "none"}
    return out


DRIVES = (  # (vehicle, engine, root seed) on `drive paper-d2.3 --missions 10 --border-m 2`
    ("husky", "pybullet", 0), ("sojourner", "pybullet", 0), ("talon", "pybullet", 0), ("talon", "mujoco", 0),
    ("hunter", "pybullet", 0), ("hunter", "mujoco", 0), ("talon", "pybullet", 1), ("hunter", "pybullet", 1))


def drive_counts() -> dict[str, str]:
    return {f"drive.{v}.{e}.seed{s}": str(_drive_successes(
        "paper-d2.3", s, 10, ["--border-m", "2", "--vehicle", v, "--engine", e])) for v, e, s in DRIVES}


def jacksboro() -> dict[str, str]:
    from offroadbench.analysis.describe import describe_terrain
    from offroadbench.analysis.roughness import RoughnessConfig
    from offroadbench.terrain.recipe import generate_terrain, load_recipe

    hm = generate_terrain(load_recipe("jacksboro-rover"), 0)  # `analyze jacksboro-rover`: its own seed 0
    rep = describe_terrain(hm, RoughnessConfig())
    return {"jacksboro.relief_m": f"{hm.relief_m:.1f}", "jacksboro.gradient_p50": f"{rep.gradient_p50:.2f}",
            "jacksboro.psd_slope": f"{rep.surface['psd_slope_beta']:.2f}",
            "jacksboro.fractal_dimension": f"{rep.surface['fractal_dimension']:.2f}"}


def jacksboro_drive() -> dict[str, str]:
    return {"jacksboro_drive.successes": str(_drive_successes("jacksboro-rover", 0, 3, ["--length-m", "20"]))}


def terrain_tails() -> dict[str, str]:
    from offroadbench.analysis.relief import tail_report
    from offroadbench.terrain.recipe import generate_terrain, load_recipe

    paper = generate_terrain(load_recipe("paper-d2.45"), 0)
    lo, hi = np.quantile(paper.z, [0.001, 0.999])
    col = int(np.unravel_index(np.argmax(paper.z), paper.z.shape)[1])  # the spire's top
    rows = np.flatnonzero(paper.z[:, col] >= paper.z_max_m - 0.01 * paper.relief_m)
    mare = tail_report(generate_terrain(load_recipe("lunar-mare"), 0))
    return {"paper.p0.1_m": f"{lo:.2f}", "paper.p99.9_m": f"{hi:.2f}", "paper.bulk_span_m": f"{hi - lo:.1f}",
            "paper.spire_rows": f"{rows.min()}-{rows.max()}" if rows.size > 1 else f"{rows.min()}",
            "paper.spire_col": str(col),
            "mare.top_span_m": f"{mare.top_span_m:.2f}", "mare.bottom_span_m": f"{mare.bottom_span_m:.2f}",
            "mare.relief_m": f"{mare.relief_m:.1f}"}


def _sb3_summary():
    path = ROOT / "examples" / "sb3_policy" / "summarize.py"
    spec = importlib.util.spec_from_file_location("sb3_summarize", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def sb3_example() -> dict[str, str]:
    return _sb3_summary().headline(ROOT / "examples" / "sb3_policy" / "results")


SOURCES = (
    Source("husky-check", "offroadbench vehicle check husky --json", False, husky_check, "PyBullet"),
    Source("talon-check", "offroadbench vehicle check talon --json", False, talon_check,
           "PyBullet; the expected column: the belt's quasi-static step bound and its closed-form soft-soil sinkage"),
    Source("hunter-soft", "offroadbench vehicle check hunter --json --engine pybullet|mujoco", False, hunter_soft,
           "the soft-soil rows"),
    Source("vehicle-checks", "offroadbench vehicle check V --json --engine E", False, vehicle_checks,
           "every shipped vehicle on both engines; exit 0 when every row passes"),
    Source("soil-check", "offroadbench soil check lunar-regolith --gravity 1.62 --json", False, soil_check,
           "PyBullet's single-wheel rig; the largest difference from the integrals, sinkage at slip 0.6 over slip 0"),
    Source("roughness-study", "offroadbench roughness-study --dims 2.3 2.45 2.6 --terrains 20 --seed 0", False,
           roughness_study, "no physics, but about a minute; the ratio is ours over the paper's change, per class and step"),
    Source("drive-counts", "offroadbench drive paper-d2.3 --missions 10 --border-m 2 --seed S --vehicle V --engine E",
           False, drive_counts, "successes of 10"),
    Source("jacksboro-drive", "offroadbench drive jacksboro-rover --missions 3 --length-m 20", False, jacksboro_drive,
           "successes of 3"),
    Source("jacksboro", "offroadbench analyze jacksboro-rover", True, jacksboro, "its own seed 0"),
    Source("terrain-tails", "offroadbench generate paper-d2.45 / lunar-mare --seed 0", True, terrain_tails,
           "height quantiles 0.1 / 99.9 %; the spire's top: the rows of the highest sample's column within 1 % of "
           "the relief of the maximum"),
    Source("sb3-example", "python examples/sb3_policy/summarize.py", True, sb3_example,
           "over examples/sb3_policy/results/, the example's committed run"),
)


# --------------------------------------------------------------------------- README quotes
QUOTES = (
    """| yaw rate / expected (the command, or what the wheels' top speed allows), commands 0.25-2 rad/s, in place and at 1 m/s, headings 0 / 22.5 / 45 deg | {husky.yaw_ratio} | {husky.yaw_tolerance} |
| straight-line drift over 10 m, open loop at 1 m/s | {husky.drift_m} m | {husky.drift_tolerance} |
| static tip angle, tilt table | {husky.tip_deg} deg | {husky.tip_expected_deg} deg (atan((track/2) / h), h = 0.188 m) |
| static stability: tip angle over slide angle | {husky.stability_deg} deg | above {husky.slide_deg} deg (atan(0.8)) |
| side slope held, parked | {husky.side_slope_deg} deg | {husky.slide_deg} deg (slides at atan(0.8)); sheet 30 deg |
| steepest grade climbed from rest | {husky.grade_deg} deg | {husky.slide_deg} deg (grip); sheet 45 deg, which needs mu >= 1 |
| highest step | {husky.step_m} m | {husky.step_expected_m} m (the chassis nose, 0.13 m up, reaches past the tyres) |""",
    "sinkage at rest (Husky {husky.soft_sinkage_mm} mm against {husky.soft_sinkage_expected_mm} mm from Wong-Reece)",
    "steepest grade climbed from rest ({husky.soft_grade_deg} deg against the quasi-static soil limit of "
    "{husky.soft_grade_expected_deg} deg; {husky.grade_deg} deg on rigid ground)",
    "the Wong-Reece integrals ({soil.largest_difference_pct} % of the load apart;",
    "`soil check lunar-regolith --gravity 1.62` gives {soil.sinkage_ratio_slip0.6}x the static sinkage at slip 0.6",
    """| low | {roughness.low.change1} | {roughness.low.change2} | -13.8 | -7.16 |
| semi | {roughness.semi.change1} | {roughness.semi.change2} | +11.7 | +5.63 |
| high | {roughness.high.change1} | {roughness.high.change2} | +1.54 | +3.33 |""",
    "Medians: low {roughness.low.medians} %, semi {roughness.semi.medians} %, high {roughness.high.medians} %",
    "({roughness.ratio_range} of its median class-area changes",
    "climbs {husky.grade_deg} deg from rest on mu = 0.8",
    "the belts sink {talon.soft_sinkage_expected_mm} mm",
    "(`track_step_bound_m`, {talon.step_expected_m} m)",
    "Of the five shipped vehicles {checks.pybullet.passing} pass every row on PyBullet (failing: "
    "{checks.pybullet.failing}) and {checks.mujoco.passing} on MuJoCo (failing: {checks.mujoco.failing})",
    "the drawbar pull at 20 % slip ({husky.soft_pull_n} N against {husky.soft_pull_expected_n} N, the Husky weighing "
    "{husky.soft_weight_n} N there)",
    "it climbs {hunter.pybullet.soft_grade_deg} deg and pulls {hunter.pybullet.soft_pull_n} N on PyBullet "
    "(against {hunter.pybullet.soft_grade_expected_deg} deg and {hunter.pybullet.soft_pull_expected_n} N), "
    "{hunter.mujoco.soft_grade_deg} deg and {hunter.mujoco.soft_pull_n} N on MuJoCo",
    "the Husky succeeds on {drive.husky.pybullet.seed0} of 10 and Sojourner on {drive.sojourner.pybullet.seed0}; "
    "the TALON on {drive.talon.pybullet.seed0} (PyBullet; MuJoCo {drive.talon.mujoco.seed0}) and the HUNTER on "
    "{drive.hunter.pybullet.seed0} (PyBullet; MuJoCo {drive.hunter.mujoco.seed0})",
    "TALON 7 -> {drive.talon.pybullet.seed1}, HUNTER 5 -> {drive.hunter.pybullet.seed1}",
    "relief {jacksboro.relief_m} m, median Moore gradient {jacksboro.gradient_p50}, PSD slope {jacksboro.psd_slope} "
    "-> D = {jacksboro.fractal_dimension}",
    "drove {jacksboro_drive.successes} of 3 missions",
    "(rows {paper.spire_rows}, column {paper.spire_col} for seed 0)",
    "lie within {paper.bulk_span_m} m of each other (0.1 and 99.9 percentiles {paper.p0.1_m} and {paper.p99.9_m} m",
    "span {mare.top_span_m} and {mare.bottom_span_m} m of {mare.relief_m} m",
    "{sb3.timesteps} steps in {sb3.wall_min} wall-clock minutes",
    "the policy reached {sb3.sb3_successes} of {sb3.trials_per_planner} goals and the straight line "
    "{sb3.straight_successes}",
)


def quote_pattern(text: str) -> re.Pattern:
    """``text`` as a regex whose whitespace runs match any whitespace (the README wraps its prose)."""
    return re.compile(r"\s+".join(re.escape(t) for t in text.split()))


def missing_quotes(readme: str, figures: dict[str, str]) -> list[str]:
    """The quotes, formatted with ``figures``, that README text ``readme`` does not contain."""
    return [q for q in (fill(q, figures) for q in QUOTES) if not quote_pattern(q).search(readme)]


def fill(template: str, figures: dict[str, str]) -> str:
    return re.sub(r"\{([\w.]+)\}", lambda m: figures.get(m[1], m[0]), template)


def requote(readme: str, old: dict[str, str], new: dict[str, str]) -> str:
    """README text with every quote's old figures replaced by the new ones (its line breaks kept)."""
    for template in QUOTES:
        if not set(re.findall(r"\{([\w.]+)\}", template)) <= set(old):
            continue  # a new quote: missing_quotes names it until the README is edited
        before, after = fill(template, old), fill(template, new)
        if before == after:
            continue
        pat = quote_pattern(before)
        m = pat.search(readme)
        if m is None:
            raise SystemExit(f"README.md does not quote {before!r}: edit it by hand, then re-run")
        gaps = re.findall(r"\s+", m[0])
        words = after.split()
        text = words[0] + "".join(g + w for g, w in zip(gaps, words[1:], strict=True)) if len(gaps) == len(words) - 1 else after
        readme = readme[:m.start()] + text + readme[m.end():]
    return readme


# --------------------------------------------------------------------------- the figures file
def render(figures: dict[str, str]) -> str:
    lines = ["# Figures the README quotes", "",
             f"<!-- Generated by `{REGENERATE}`; do not edit by hand. tests/test_readme_figures.py fails while "
             "README.md quotes other values, and re-runs the cheap sources. -->", "",
             "Each figure comes from the command above its table. *Cheap* sources (deterministic on every CPU, "
             "seconds) are re-run by the tests; the slow ones (physics runs, the roughness study) by the script only.", ""]
    for s in SOURCES:
        keys = [k for k in figures if k.split(".")[0] in _prefixes(s)]
        lines += [f"## {s.name}", "", f"`{s.command}`{f' ({s.note})' if s.note else ''}; "
                  f"{'cheap: re-run by the tests' if s.cheap else 'slow: re-run by the script only'}.",
                  "", "| figure | value |", "|---|---|", *(f"| `{k}` | {figures[k]} |" for k in keys), ""]
    return "\n".join(lines)


PREFIXES = {"husky-check": {"husky"}, "talon-check": {"talon"}, "hunter-soft": {"hunter"}, "vehicle-checks": {"checks"}, "soil-check": {"soil"}, "roughness-study": {"roughness"}, "drive-counts": {"drive"},
            "jacksboro-drive": {"jacksboro_drive"}, "jacksboro": {"jacksboro"}, "terrain-tails": {"paper", "mare"},
            "sb3-example": {"sb3"}}


def _prefixes(s: Source) -> set[str]:
    return PREFIXES[s.name]


def parse(text: str) -> dict[str, str]:
    """The figures of a rendered file (``render``'s inverse)."""
    return dict(re.findall(r"^\| `([\w.]+)` \| (.*) \|$", text, flags=re.M))


def committed() -> dict[str, str]:
    return parse(FIGURES_PATH.read_text(encoding="utf-8")) if FIGURES_PATH.is_file() else {}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", choices=[s.name for s in SOURCES], help="run only these sources")
    ap.add_argument("--cheap", action="store_true", help="run only the cheap sources")
    ap.add_argument("--list", action="store_true", help="list the sources and exit")
    args = ap.parse_args(argv)
    if args.list:
        for s in SOURCES:
            print(f"{s.name:16} {'cheap' if s.cheap else 'slow':5}  {s.command}")
        return 0
    old = committed()
    new = dict(old)
    for s in SOURCES:
        if (args.only and s.name not in args.only) or (args.cheap and not s.cheap):
            continue
        print(f"{s.name}: {s.command}", file=sys.stderr)
        got = s.compute()
        for k, v in got.items():
            if old.get(k) != v:
                print(f"  {k}: {old.get(k)} -> {v}", file=sys.stderr)
        new |= got
    order = [k for s in SOURCES for k in sorted(new) if k.split(".")[0] in _prefixes(s)]
    new = {k: new[k] for k in order}
    readme = README_PATH.read_text(encoding="utf-8")
    if old:
        readme = requote(readme, old, new)
    missing = missing_quotes(readme, new)
    FIGURES_PATH.write_text(render(new), encoding="utf-8")
    README_PATH.write_text(readme, encoding="utf-8")
    print(f"wrote {FIGURES_PATH.relative_to(ROOT)} and {README_PATH.relative_to(ROOT)}", file=sys.stderr)
    for q in missing:
        print(f"README.md does not quote (edit it by hand): {q!r}", file=sys.stderr)
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
