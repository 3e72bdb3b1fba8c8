"""Re-render the sections of a committed results folder's report that are computed from its tables alone.

A results folder keeps the study's TOML (``study.toml``), its trials (``trials.parquet``) and terrains
(``terrains.csv``), not the run's store (``study.sqlite``) nor its telemetry. From those tables the
report's confirmatory section (offroadbench.study.report.paper) and its planner stress-test section
(offroadbench.study.report.planners, except the paths figure, which needs the telemetry and is kept
as committed) are computed exactly as ``offroadbench study report DIR`` computes them, and replace the
same sections of ``report.md`` and ``report.html`` (the HTML body is rendered from the new Markdown by
offroadbench.study.report.html.markdown_to_html, the committed figures inline; the per-trial table and
the replays are kept). Every other section stays as committed. The tables these sections write
(``confirmatory.csv``, ``breaking_points.csv``, ...) and the success figures are written too.

    python experiments/rerender.py experiments/results/planner-stress [more folders ...]
"""

from __future__ import annotations

import argparse
import base64
import json
import re
import sys
from pathlib import Path
from typing import Any

import pandas as pd

from offroadbench.config import load_toml, to_dict


def folder_meta(folder: Path) -> dict[str, Any]:
    """What the report reads of a store's metadata, rebuilt from the folder's ``study.toml``: the study's
    config, the grid's columns and the cells (index and grid values, in the runner's order)."""
    from offroadbench.study.spec.config import study_from_dict

    study = study_from_dict(load_toml(folder / "study.toml"), where=str(folder / "study.toml"))
    meta = {"study": to_dict(study), "columns": study.column_names(),
            "cells": [{"index": i, "values": v} for i, v in enumerate(study.cell_values())]}
    return json.loads(json.dumps(meta, sort_keys=True))  # as the store keeps it (offroadbench.study.store)


def _section(lines: list[str], head: str) -> tuple[int, int]:
    """(first, end) line indices of the ``## `` section whose heading starts with ``head``."""
    start = next((i for i, line in enumerate(lines) if line.startswith(head)), None)
    if start is None:
        raise SystemExit(f"no section {head!r} in the report")
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    return start, end


def _run_dir(folder: Path) -> str:
    """The run directory the committed report names in its replay commands (kept as it was)."""
    old = folder / "replay_examples.csv"
    if old.is_file():
        hit = re.search(r"study replay (\S+) --cell", pd.read_csv(old)["replay"].iloc[0])
        if hit:
            return hit.group(1)
    return str(folder)


def rerender(folder: Path) -> list[str]:
    """Re-render ``folder``'s confirmatory and planner sections; returns the files written."""
    from offroadbench.cli._common import save_figure
    from offroadbench.study.report.html import markdown_to_html
    from offroadbench.study.report.paper import _confirmatory_section, _mark_exploratory
    from offroadbench.study.report.planners import planner_sections

    meta = folder_meta(folder)
    trials = pd.read_parquet(folder / "trials.parquet")
    terrains = pd.read_csv(folder / "terrains.csv")
    md = (folder / "report.md").read_text().rstrip("\n").split("\n")
    written = []
    confirm_lines, confirm = _confirmatory_section(meta, trials, terrains, [Path(__file__).resolve().parent])
    if confirm is not None:
        a, b = _section(md, "## Confirmatory analysis")
        md[a:b] = confirm_lines
        if "engine_verdicts" in confirm.attrs:
            confirm.attrs.pop("engine_verdicts").to_csv(folder / "engine_verdicts.csv", index=False)
            written.append("engine_verdicts.csv")
        confirm.to_csv(folder / "confirmatory.csv", index=False)
        written.append("confirmatory.csv")
    if "planner.name" in meta["columns"]:
        lines, figures, tables = planner_sections(meta, trials, _run_dir(folder), terrains, paths_figure=False)
        a, b = _section(md, "## Planner stress test")
        old = md[a:b]
        keep = next((i for i, line in enumerate(old) if line.startswith("### Planned and driven paths")), None)
        # the paths figure needs the run's telemetry: its subsection stays as committed
        md[a:b] = _mark_exploratory(["## Confirmatory", *lines])[1:] + (old[keep:] if keep is not None else [])
        for name, df in tables.items():
            df.to_csv(folder / name, index=False)
            written.append(name)
        for name, fig in figures.items():
            save_figure(fig, folder / name, dpi=110)
            written.append(name)
    text = "\n".join(md).rstrip() + "\n"
    (folder / "report.md").write_text(text)
    written.append("report.md")
    page = folder / "report.html"
    if page.is_file():
        html = page.read_text(encoding="utf-8")
        head, rest = html.split("</head><body>\n", 1)
        tail = rest[rest.index('\n<h2 id="per-trial-results">'):]
        images = {p.name: "data:image/png;base64," + base64.b64encode(p.read_bytes()).decode("ascii")
                  for p in sorted(folder.glob("*.png"))}
        page.write_text(head + "</head><body>\n" + markdown_to_html(text, images) + tail, encoding="utf-8")
        written.append("report.html")
    return written


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    args = ap.parse_args(argv)
    for folder in args.folders:
        print(f"{folder}: {', '.join(rerender(folder))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
