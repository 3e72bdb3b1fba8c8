"""A study worker's terrain preparation under glibc's allocator settings: page faults, CPU seconds
and peak memory per paper terrain, variants alternated in one run.

    .venv/bin/python benchmarks/bench_prepare.py [--terrains 3] [--missions 2] [--repeats 2] [--smoke]

Each variant runs in a fresh process, as a MuJoCo paper-study worker does (``[sim] engine =
"mujoco"``): it prepares the paper study's first ``--terrains`` terrains per D (heights, class maps,
missions: offroadbench.sim.trial.pipeline.prepare_terrain), builds each one's world and drives
``--missions`` missions on it. Variants:

- ``held``: the worker's held thresholds (offroadbench.memory.release_large_blocks) without the
  reuse around the preparation (the code before issue 41's ``perf2`` branch);
- ``held+reuse``: the worker as shipped: held thresholds, and the heap kept for reuse while a
  terrain is prepared (offroadbench.memory.reusing_freed_blocks);
- ``glibc``: glibc's own adaptive thresholds (the code before issue 41's memory work).

Per variant: minor page faults and CPU seconds (user + system, this process, all threads) of a
preparation and of a world build, averaged over the terrains after the first (the first pays the
imports and the first allocations), the RSS after each terrain, the peak RSS, and a digest of every
terrain's heights, class maps and missions, which must be the same for every variant.

Prints figures; record them in benchmarks/RESULTS.md. Not a test. ``--smoke`` runs each variant
once on 161^2 maps (seconds; its figures mean nothing).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = ("held", "held+reuse", "glibc")


def _usage() -> tuple[int, float]:
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_minflt, r.ru_utime + r.ru_stime


def _rss_mb() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) // 1024
    return -1


def child(variant: str, terrains: int, missions: int, rows: int | None) -> dict:
    """One variant in this (fresh) process."""
    import contextlib
    import resource

    import offroadbench.sim.trial.pipeline as pipeline
    from offroadbench.memory import release_large_blocks

    if variant != "glibc":
        release_large_blocks()
    if variant != "held+reuse":
        pipeline.reusing_freed_blocks = contextlib.nullcontext
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_study
    from offroadbench.sim import open_world
    from offroadbench.sim.trial.runner import drive_mission

    bench_study.STUDY = ROOT / "experiments" / "majhor2023-mujoco.toml"
    tasks, _ = bench_study._tasks(terrains, missions, rows)
    digest = hashlib.sha256()
    prep, build, rss = [], [], []
    for task in tasks:
        settings = task.cell.trial_settings
        a = _usage()
        prepared = pipeline.prepare_terrain(task.cell.recipe(), task.terrain_seed, settings, task.missions)
        b = _usage()
        world = open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim))
        c = _usage()
        prep.append((b[0] - a[0], b[1] - a[1]))
        build.append((c[0] - b[0], c[1] - b[1]))
        for arr in (prepared.hm.z, prepared.maps.classes, prepared.maps.closed):
            digest.update(arr.tobytes())
        digest.update(repr(prepared.missions).encode())
        with world:
            for m in prepared.missions:
                drive_mission(world, m, settings=settings, classes=prepared.maps.closed)
        del prepared, world
        rss.append(_rss_mb())
    later = len(tasks) - 1 or 1

    def mean(pairs, i):
        return sum(p[i] for p in pairs[1:] or pairs) / later

    return {"prep_faults": mean(prep, 0), "prep_cpu_s": mean(prep, 1), "build_faults": mean(build, 0),
            "build_cpu_s": mean(build, 1), "rss_mb": rss, "digest": digest.hexdigest()[:12],
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--terrains", type=int, default=3, help="terrains per D")
    ap.add_argument("--missions", type=int, default=2, help="missions driven per terrain")
    ap.add_argument("--repeats", type=int, default=2, help="rounds of the variants, alternated")
    ap.add_argument("--smoke", action="store_true", help="each variant once on 161^2 maps (CI)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    rows = 161 if args.smoke else None
    if args.smoke:
        args.terrains, args.missions, args.repeats = 1, 1, 1
    if args.child:
        print("RESULT " + json.dumps(child(args.child, args.terrains, args.missions, rows)))
        return
    from offroadbench.study.store.store import machine_description

    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f}")
    print("variant | prep faults | prep CPU s | world faults | world CPU s | RSS after each terrain MB | peak MB | digest")
    digests = set()
    for _ in range(args.repeats):
        for variant in VARIANTS:
            cmd = [sys.executable, __file__, "--child", variant, "--terrains", str(args.terrains),
                   "--missions", str(args.missions)] + (["--smoke"] if args.smoke else [])
            out = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
            line = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT ")]
            if out.returncode or not line:
                print(f"{variant}: failed\n{out.stderr[-2000:]}")
                continue
            r = json.loads(line[0][7:])
            digests.add(r["digest"])
            print(f"{variant} | {r['prep_faults']:.0f} | {r['prep_cpu_s']:.3f} | {r['build_faults']:.0f} | "
                  f"{r['build_cpu_s']:.3f} | {' '.join(map(str, r['rss_mb']))} | {r['peak_mb']} | {r['digest']}", flush=True)
    print(f"terrains identical across variants: {len(digests) == 1}")


if __name__ == "__main__":
    main()
