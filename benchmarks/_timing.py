"""Timing helper shared by the benchmark scripts (run them as ``python benchmarks/NAME.py``)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path


def best_of(fn, repeats: int) -> float:
    """The shortest wall time in seconds of ``repeats`` calls of ``fn()``: the least disturbed run."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def run_in_tree(tree: str, script: str, argv: list[str], label: str) -> dict | None:
    """Run benchmark ``script`` (a module of benchmarks/, e.g. ``bench_tick``) with ``argv`` in a
    fresh interpreter that imports offroadbench from checkout ``tree`` (a before/after comparison of
    two trees); its ``RESULT {json}`` line as a dict, or None (its failure printed with ``label``)."""
    bench = str(Path(__file__).resolve().parent)
    code = (f"import sys; sys.path.insert(0, {tree!r}); sys.argv[1:] = {argv!r}; "
            f"sys.path.insert(1, {bench!r}); import {script}; {script}.main()")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tree)
    line = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT ")]
    if out.returncode or not line:
        print(f"{tree} ({label}): failed\n{out.stderr[-2000:]}")
        return None
    return json.loads(line[0][7:])
