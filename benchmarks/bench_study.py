"""Study throughput: where the time and memory of the paper study go, and variants side by side.

    .venv/bin/python benchmarks/bench_study.py profile [--terrains 1] [--missions 4]
    .venv/bin/python benchmarks/bench_study.py plans [--missions 5] [--planner astar ...]
    .venv/bin/python benchmarks/bench_study.py smoke
    .venv/bin/python benchmarks/bench_study.py compare [--terrains 1] [--missions 20] \
        [--variant NAME[:executor=local,workers=2,tree=PATH,KEY=VALUE...]] ...

``profile`` runs paper-study terrains in this process and prints, per terrain, the seconds of
the terrain (W-M layers), its classes and missions, the PyBullet heightfield and world, and per
trial the vehicle spawn (settling), the physics steps and everything else in Python per tick
(control, telemetry, end rules, metrics), plus the RSS and the peak RSS of each phase (the peak
is reset between phases through /proc/self/clear_refs) and the cost of committing one row.

``plans`` times the planners on one paper terrain per D: the first mission of a terrain (which
computes the footprint hazard) and the median of the others (which reuse it).

``smoke`` runs ``profile`` and ``plans`` once on 161^2 maps (seconds; CI runs it so the script
cannot rot); its figures mean nothing.

``compare`` runs the paper study cut to ``--terrains`` terrains per D (the same seeds and first
terrains as the full study) once per variant, each in a fresh process, one after the other in
this one run, and prints wall time, trials/s, the peak RSS of the largest worker (the
children's ``ru_maxrss``), the CPU time of the workers and of the coordinator, and a digest of the trial table, so variants that must give identical
results can be checked. A variant is ``NAME`` or ``NAME:k=v,k=v``: ``executor`` (local, dask,
inline), ``workers``, ``tree`` (another checkout of offroadbench, e.g. a git worktree of an
older commit, to compare with the old code), and dotted study keys such as
``recipe.layers.base.wm.method=nufft``, ``sim.solver_iterations=30`` or ``sim.mujoco.hfield_collision=exact``. Machines here are
shared: compare the ratios of one run, not absolute figures across runs.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "experiments" / "majhor2023.toml"


# ---------------------------------------------------------------------------- memory
def _status_mb(key: str) -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


def _reset_peak() -> None:
    """Reset VmHWM (peak RSS) of this process (Linux >= 4.0)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass


class Phase:
    """Wall seconds and peak RSS (MB) of a block: ``with Phase() as p: ...; p.s, p.peak_mb``."""

    def __enter__(self) -> "Phase":
        _reset_peak()
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        self.s = time.perf_counter() - self.t0
        self.peak_mb = _status_mb("VmHWM")
        self.rss_mb = _status_mb("VmRSS")


# ---------------------------------------------------------------------------- profile
def bench_store(n: int = 5000) -> float:
    """Seconds per committed trial row (one transaction each)."""
    from offroadbench.study.store.store import Store

    row = {"mission_index": 0, "success": True, "failure_reason": "", **{f"m{i}": 1.2345 for i in range(16)}}
    with tempfile.TemporaryDirectory() as d, Store(d, create=True) as store:
        t0 = time.perf_counter()
        for k in range(n):
            store.add_trial(0, k // 20, k % 20, 1, 2, row)
        return (time.perf_counter() - t0) / n


def profile(terrains: int, missions: int, rows: int | None = None) -> None:
    """Per terrain: the phases of the paper study's work, timed in this process (``rows``: a smaller
    square grid than the study's, for the smoke mode)."""
    from offroadbench.sim import open_world
    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.sim.trial.runner import drive_mission

    tasks, study = _tasks(terrains, missions, rows)
    print(f"python baseline: RSS {_status_mb('VmRSS'):.0f} MB")
    print("terrain | terrain + classes + missions s | world build s | build peak MB | RSS after build MB | "
          "trials | spawn s/trial | steps s/trial | python s/trial | steps/trial | us/step | us python/tick")
    tot = {"terrain": 0.0, "build": 0.0, "spawn": 0.0, "step": 0.0, "python": 0.0}
    n_trials = 0
    for task in tasks:
        cell = task.cell
        settings = cell.trial_settings
        with Phase() as p_terrain:
            prepared = prepare_terrain(cell.recipe(), task.terrain_seed, settings, task.missions)
        with Phase() as p_build:
            world = open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim))
        spawn_s = step_s = trial_s = 0.0
        steps = ticks = 0
        spawning = False
        with world:
            plain_step, plain_spawn = world.step, world.spawn
            # the two wrappers live only inside this `with world:` block, so they see this
            # iteration's world, flag and methods (B023 cannot tell)

            def timed_step() -> None:
                nonlocal step_s, steps
                if spawning:  # noqa: B023 (the settling steps are the spawn's)
                    plain_step()  # noqa: B023
                    return
                t = time.perf_counter()
                plain_step()  # noqa: B023
                step_s += time.perf_counter() - t
                steps += 1

            def timed_spawn(*a, **kw) -> None:
                nonlocal spawn_s, spawning
                t = time.perf_counter()
                spawning = True
                try:
                    plain_spawn(*a, **kw)  # noqa: B023
                finally:
                    spawning = False
                spawn_s += time.perf_counter() - t

            world.step, world.spawn = timed_step, timed_spawn
            world.advance = None  # the trial loop's steps one by one, each timed
            for m in prepared.missions:
                t = time.perf_counter()
                rec = drive_mission(world, m, settings=settings, classes=prepared.maps.closed)
                trial_s += time.perf_counter() - t
                ticks += len(rec.telemetry["t_s"])
        ms = prepared.missions
        python_s = trial_s - spawn_s - step_s
        k = len(ms)
        print(
            f"D={cell.values.get('recipe.layers.base.D_high')} j={task.terrain} | {p_terrain.s:.2f} | "
            f"{p_build.s:.2f} | {p_build.peak_mb:.0f} | {p_build.rss_mb:.0f} | {k} | {spawn_s / k:.3f} | {step_s / k:.3f} | "
            f"{python_s / k:.3f} | {steps / k:.0f} | {step_s / max(steps, 1) * 1e6:.0f} | {python_s / max(ticks, 1) * 1e6:.0f}"
        )
        for key, v in (("terrain", p_terrain.s), ("build", p_build.s),
                       ("spawn", spawn_s), ("step", step_s), ("python", python_s)):
            tot[key] += v
        n_trials += k
    store_s = bench_store(200 if rows else 5000) * n_trials
    tot["store"] = store_s
    total = sum(tot.values())
    print(f"share of the time of {len(tasks)} terrains x {missions} trials: " +
          ", ".join(f"{k} {v / total * 100:.0f} %" for k, v in tot.items()))
    print(f"store: {store_s / n_trials * 1e6:.0f} us per committed trial; peak RSS of this process "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


# ---------------------------------------------------------------------------- plans
def plans(missions: int, planners: list[str], rows: int | None = None) -> None:
    """Seconds per planned mission on one paper terrain per D: the first mission of a terrain (the
    footprint hazard is computed) and the median of the others (it is reused)."""
    import statistics

    from offroadbench.navigation.costmap import _HAZARD_CACHE
    from offroadbench.navigation.planners import PlanningProblem, plan
    from offroadbench.sim import open_world
    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.sim.trial.runner import vehicle_envelope

    tasks, _ = _tasks(1, missions, rows)
    print("terrain | planner | first mission s | median of the others s | waypoints (median)")
    for task in tasks:
        cell = task.cell
        settings = cell.trial_settings
        prepared = prepare_terrain(cell.recipe(), task.terrain_seed, settings, task.missions)
        with open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim)) as world:
            envelope = vehicle_envelope(world)
        for name in planners:
            _HAZARD_CACHE.clear()  # each planner's first mission computes the hazard
            times, sizes = [], []
            for m in prepared.missions:
                problem = PlanningProblem(hm=prepared.hm, classes=prepared.maps.closed, start_xy=m.start_xy_m,
                                          goal_xy=m.goal_xy_m, border_m=settings.missions.border_m, vehicle=envelope)
                t = time.perf_counter()
                sizes.append(len(plan(name, problem)))
                times.append(time.perf_counter() - t)
            print(f"D={cell.values.get('recipe.layers.base.D_high')} | {name} | {times[0]:.2f} | "
                  f"{statistics.median(times[1:]) if len(times) > 1 else float('nan'):.2f} | {statistics.median(sizes):.0f}")


def _tasks(terrains: int, missions: int, rows: int | None):
    """The paper study's terrain tasks, cut to ``terrains`` per D and ``missions`` each; with
    ``rows``, on a rows x rows grid with 5 m missions and a 1 m border (the smoke mode)."""
    import dataclasses

    from offroadbench.study import load_study
    from offroadbench.study.runner import plan_tasks
    from offroadbench.study.spec.config import plan_cells

    study, _ = load_study(STUDY)
    study = dataclasses.replace(study, terrains_per_cell=terrains, missions_per_terrain=missions)
    if rows:
        settings = {k: dict(v) for k, v in study.settings.items()}
        settings["missions"] = {**settings.get("missions", {}), "length_m": 5.0, "border_m": 1.0}
        settings["roughness"] = {**settings.get("roughness", {}), "border_m": 1.0}
        study = dataclasses.replace(study, settings=settings, recipe_overrides={
            **study.recipe_overrides, "grid.rows": rows, "grid.cols": rows})
    return plan_tasks(study, plan_cells(study), set()), study


# ---------------------------------------------------------------------------- compare
def parse_variant(text: str) -> dict:
    name, _, rest = text.partition(":")
    spec = {"name": name, "executor": "local", "workers": 2, "tree": str(ROOT), "sets": {}}
    for item in filter(None, rest.split(",")):
        k, _, v = item.partition("=")
        if k in ("executor", "tree"):
            spec[k] = v
        elif k == "workers":
            spec[k] = int(v)
        else:
            from offroadbench.config import parse_set_value

            spec["sets"][k] = parse_set_value(v)
    return spec


def child(spec: dict) -> dict:
    """Run one variant of the cut paper study in this (fresh) process."""
    import dataclasses

    from offroadbench.study import load, load_study, run_study
    from offroadbench.study.spec.config import plan_cells

    study, _ = load_study(STUDY)
    overrides = dict(study.recipe_overrides)
    settings = {k: dict(v) for k, v in study.settings.items()}
    for key, value in spec["sets"].items():
        target, _, rest = key.partition(".")
        if target == "recipe":
            overrides[rest] = value
        else:  # a settings table's key, nested tables by dots (sim.mujoco.hfield_collision)
            node = settings.setdefault(target, {})
            *path, leaf = rest.split(".")
            for part in path:
                node = node.setdefault(part, {})
            node[leaf] = value
    study = dataclasses.replace(study, terrains_per_cell=spec["terrains"], missions_per_terrain=spec["missions"],
                                recipe_overrides=overrides, settings=settings)
    plans = plan_cells(study)
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        run_study(study, plans, d, executor=spec["executor"], workers=spec["workers"])
        wall = time.perf_counter() - t0
        table = load(d).sort_values(["cell", "terrain", "mission"])
    keep = [c for c in table.columns if c not in ("wall_s", "build_s", "finished_at")]
    digest = hashlib.sha256(table[keep].to_csv(index=False).encode()).hexdigest()[:12]
    return {
        "wall_s": wall,
        "trials": len(table),
        "successes": int(table["success"].sum()),
        "digest": digest,
        "worker_peak_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
        "self_peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        # CPU seconds (user + system) of the workers and of this coordinator: on a shared machine
        # these move much less with the load than the wall time does
        "workers_cpu_s": _cpu_s(resource.RUSAGE_CHILDREN),
        "self_cpu_s": _cpu_s(resource.RUSAGE_SELF),
    }


def _cpu_s(who: int) -> float:
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def compare(variants: list[str], terrains: int, missions: int) -> None:
    rows = []
    for text in variants:
        spec = parse_variant(text) | {"terrains": terrains, "missions": missions}
        code = (f"import sys, json; sys.path[:0] = [{spec['tree']!r}, {str(ROOT / 'benchmarks')!r}]; "
                f"import bench_study; print('RESULT ' + json.dumps(bench_study.child(json.loads({json.dumps(spec)!r}))))")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=spec["tree"])
        line = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT ")]
        if out.returncode or not line:
            print(f"{spec['name']}: failed\n{out.stderr[-2000:]}")
            continue
        res = json.loads(line[0][7:])
        rows.append((spec, res))
        print(
            f"{spec['name']} ({spec['executor']}, {spec['workers']} worker(s)): {res['trials']} trials in {res['wall_s']:.1f} s = "
            f"{res['trials'] / res['wall_s']:.2f} trials/s, {res['successes']} successes, worker peak RSS "
            f"{res['worker_peak_mb']:.0f} MB, coordinator {res['self_peak_mb']:.0f} MB, CPU workers "
            f"{res['workers_cpu_s']:.1f} s + coordinator {res['self_cpu_s']:.1f} s, table {res['digest']}",
            flush=True,
        )
    if rows:
        base_spec, base = rows[0]
        print(f"\nratios to {base_spec['name']} (wall time; efficiency = speed-up / workers x base workers):")
        for spec, res in rows:
            speed = base["wall_s"] / res["wall_s"]
            eff = speed * base_spec["workers"] / spec["workers"]
            cpu = (base["workers_cpu_s"] + base["self_cpu_s"]) / (res["workers_cpu_s"] + res["self_cpu_s"])
            print(f"  {spec['name']}: speed-up {speed:.2f}x, efficiency {eff * 100:.0f} %, CPU time ratio {cpu:.2f}x, "
                  f"same table: {res['digest'] == base['digest']}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("profile")
    p.add_argument("--terrains", type=int, default=1, help="terrains per D")
    p.add_argument("--missions", type=int, default=4)
    q = sub.add_parser("plans")
    q.add_argument("--missions", type=int, default=5, help="missions per terrain (one terrain per D)")
    q.add_argument("--planner", action="append", default=[], help="planner name (repeat; default astar, lattice)")
    c = sub.add_parser("compare")
    c.add_argument("--terrains", type=int, default=1, help="terrains per D (full study: 20)")
    c.add_argument("--missions", type=int, default=20, help="missions per terrain (full study: 20)")
    c.add_argument("--variant", action="append", default=[], help="NAME[:k=v,...] (repeat); the first is the base")
    sub.add_parser("smoke", help="profile and plans on 161^2 maps, one trial per D (CI: seconds)")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    from offroadbench.study.store.store import machine_description

    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f}")
    if args.cmd == "smoke":  # every mode's code runs, on small maps (its figures mean nothing)
        profile(1, 1, rows=161)
        plans(2, ["astar", "lattice"], rows=161)
    elif args.cmd == "profile":
        profile(args.terrains, args.missions)
    elif args.cmd == "plans":
        plans(args.missions, args.planner or ["astar", "lattice"])
    else:
        compare(args.variant or ["local-2:workers=2", "local-1:workers=1"], args.terrains, args.missions)


if __name__ == "__main__":
    main()
