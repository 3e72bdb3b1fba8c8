"""Traversal-trial speed and physics quality against physics rate and wheel shape.

For each physics rate (240 / 120 / 60 Hz; plus cylinder wheels at 60 Hz) this drives the same
35 m missions on a paper 1009^2 terrain in one process and prints the real-time factor
(simulated s per wall s of the driving loop), max wheel penetration, success, and the RMS
pitch rate on flat ground (contact jitter). It also runs the physics sanity scenarios of
tests/test_sim_physics.py (15 deg ramp, wall, off the edge) at each rate.

    .venv/bin/python benchmarks/bench_sim.py [--preset paper-d2.45] [--seed 1] [--missions 5]

``--contact`` instead compares the tyre-terrain contact models (offroadbench.sim.engines.pybullet.tyres) in one
run, at the default 60 Hz with sphere wheels: the old default (Bullet's friction, the URDF's
light wheels, 50 solver iterations), ``bullet`` (Bullet's friction with the drive train's spin inertia) and ``coulomb``
(the new default). Per model it prints the RTF on the same missions (run in rounds: each
terrain and planner runs every model in turn, so changes of machine load hit all alike) and its ratio to the old default, the successes of the straight
and astar planners, the yaw-rate tracking on flat ground (achieved / commanded, 0.25-2 rad/s in
place and at 1 m/s, headings 0 / 22.5 / 45 deg) and the median turn-in-place rate on rough ground.

    .venv/bin/python benchmarks/bench_sim.py --contact [--preset paper-d2.6] [--seeds 1,2] [--missions 10]

``--soil`` instead compares ``terramechanics`` (lunar regolith) with ``coulomb`` on small lunar-mare
maps (513^2 at 5 cm, 15 m missions, lunar gravity): the same missions run with each model in turn
(interleaved, so machine load hits both alike); it prints each model's RTF and their ratio.

    .venv/bin/python benchmarks/bench_sim.py --soil [--seeds 1,2] [--missions 4]

``--iterations 50,30,20`` instead compares Bullet solver iteration counts (``SimConfig.
solver_iterations``) at the default contact model and rate: per count, the RTF on the same missions
(in rounds, as above) and its ratio to the first count, successes, wheel penetration, flat-ground
pitch jitter, the sanity scenarios and the rows of the vehicle check (``sim.check``) that fail.

    .venv/bin/python benchmarks/bench_sim.py --iterations 50,30,20,12 [--preset paper-d2.6] [--seeds 1,2] [--missions 10]

``--paired`` measures PyBullet's wasted work (issue 25) with paired runs on the paper's missions:
terrain 0 of each D of the paper study (root seed 2023, 1009^2, 35 m missions), every mission
driven by every variant in turn (variants interleaved mission by mission, their order rotated
from one mission to the next, so machine load and order hit all alike), ratios from the one run. Variants: ``main`` (cone friction on, the tyre loop of
``--old-rev``, i.e. the code before this change), ``cone-off``, ``lean`` (the lean tyre loop, cone on), ``new`` (both:
today's default) and ``main+0.1mm`` (main with a 0.1 mm higher spawn: the chaos yardstick). Per
variant: the trial-time and per-simulated-second ratios to ``main``, successes, outcome flips
against ``main`` and the median ratio of RMS vertical acceleration over the trials both succeeded.

    .venv/bin/python benchmarks/bench_sim.py --paired [--missions 8] [--old-rev main]

``--engines`` compares physics engines and rates the same way (the first variant is the reference;
``contact.FIELD=VALUE`` sets a field of the MuJoCo world's ContactTuning):

    .venv/bin/python benchmarks/bench_sim.py --engines 'pybullet:;mujoco60:engine=mujoco;mujoco120:engine=mujoco,physics_rate_hz=120'

MuJoCo's height-field collision modes against the chaos yardstick (issue 41: a 0.1 mm higher spawn
is the reference's own run-to-run spread; ``closed_form`` should flip no more outcomes than it):

    .venv/bin/python benchmarks/bench_sim.py --missions 12 --engines 'own:engine=mujoco,contact.hfield_collision=mujoco;own+0.1mm:engine=mujoco,spawn_clearance_m=0.0201,contact.hfield_collision=mujoco;exact:engine=mujoco,contact.hfield_collision=exact;closed_form:engine=mujoco,contact.hfield_collision=closed_form;pybullet:'

``--smoke`` runs every mode above once, with one mission on 201^2 maps and 6 m missions (seconds
of work each; CI runs it so the script cannot rot); its figures mean nothing.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from offroadbench.analysis.roughness import RoughnessConfig, classify, close_rough
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission, MissionConfig, sample_missions
from offroadbench.terrain.recipe import generate_terrain, load_recipe
from offroadbench.sim import SimConfig, World, load_vehicle, run_mission

CELL = 0.05
SMOKE = False
"""--smoke: every terrain 201^2 and every mission 6 m with a 1 m border (set by main)."""


def smoke_grid(recipe):
    """``recipe`` on the smoke mode's small grid (unchanged outside it)."""
    from offroadbench.terrain.recipe import apply_overrides

    return apply_overrides(recipe, {"grid.rows": 201, "grid.cols": 201}) if SMOKE else recipe


def terrain(preset: str, seed: int):
    """The preset's terrain of ``seed`` (on the smoke grid under --smoke)."""
    return generate_terrain(smoke_grid(load_recipe(preset)), seed)


def mission_config(**fields) -> MissionConfig:
    """A MissionConfig (6 m missions with a 1 m border under --smoke)."""
    return MissionConfig(**(fields | ({"length_m": 6.0, "border_m": 1.0} if SMOKE else {})))


def cylinder_wheel_vehicle(tmp: Path):
    """The husky with true cylinder collision wheels (axis along y, the tyre's radius and width),
    written to ``tmp``."""
    import re

    spec = load_vehicle("husky")
    r, w = spec.wheel_radius_m, spec.wheel_width_m
    text, n = re.subn(r'<collision>(\s*)<geometry><sphere radius="[0-9.]+"/></geometry>',
                      rf'<collision>\1<origin xyz="0 0 0" rpy="1.5707963 0 0"/>\1'
                      rf'<geometry><cylinder radius="{r}" length="{w}"/></geometry>', Path(spec.urdf).read_text())
    assert n == 4, f"expected 4 sphere wheel collisions in {spec.urdf}, found {n}"
    urdf = tmp / "husky_cylinder.urdf"
    urdf.write_text(text)
    return dataclasses.replace(spec, urdf=str(urdf))


def sanity(vehicle, sim) -> str:
    """Outcomes of the ramp / wall / edge scenarios: 'ok' when each ends as it must."""
    x = np.arange(501) * CELL
    strip = lambda z: Heightmap(np.tile(z, (81, 1)), CELL)  # noqa: E731
    cases = [
        ("ramp15", strip(np.tan(np.radians(15)) * np.clip(x - 4, 0, None)), Mission.between(0, (2, 2), (13, 2)), ""),
        ("wall", strip(np.where(x >= 8, 1.0, 0.0)), Mission.between(0, (3, 2), (23, 2)), "stuck"),
        ("edge", Heightmap.flat(81, 321, CELL), Mission.between(0, (3, 2), (25, 2)), "off_map"),
    ]
    bad = []
    for name, hm, mission, want in cases:
        with World(hm, vehicle, sim) as w:
            r, _ = run_mission(w, mission)
        if r.failure_reason != want:
            bad.append(f"{name}:{r.failure_reason or 'success'}")
    return "ok" if not bad else ",".join(bad)


def flat_jitter(vehicle, sim) -> float:
    with World(Heightmap.flat(81, 321, CELL), vehicle, sim) as w:
        r, _ = run_mission(w, Mission.between(0, (3, 2), (13, 2)))
    return r.rms_pitch_rate_deg_s


CONTACT_MODELS = ("old default", "bullet", "coulomb")


def contact_variant(name: str):
    """(vehicle, SimConfig) of a contact model of CONTACT_MODELS."""
    husky = load_vehicle("husky")
    if name == "old default":  # before issue 10: Bullet's friction, the URDF's light wheels, 50 iterations
        return dataclasses.replace(husky, wheel_spin_inertia_kg_m2=None), SimConfig(tyre_model="bullet", solver_iterations=50)
    return husky, SimConfig(tyre_model=name)


def yaw_tracking(vehicle, sim) -> tuple[float, float]:
    """(min, max) of achieved / commanded yaw rate on flat ground over the vehicle check's cases."""
    from offroadbench.sim.rigs.vehicle_check import _yaw_tracking

    with World(Heightmap.flat(161, 161, 0.1), vehicle, sim) as w:
        ratios = [r.measured / r.expected for r in _yaw_tracking(w, (0.0, 22.5, 45.0), (0.25, 0.5, 1.0, 2.0))]
    return min(ratios), max(ratios)


def rough_turn_rate(vehicle, sim) -> float:
    """Median |yaw rate| of a 1 rad/s turn in place at 27 poses on a small rough D = 2.6 terrain, rad/s."""
    from offroadbench.sim.rigs.vehicle_check import mean_yaw_rate
    from offroadbench.terrain.recipe import apply_overrides

    recipe = apply_overrides(load_recipe("paper-d2.6"), {"grid.rows": 241, "grid.cols": 241, "layers.base.relief_m": 1.5})
    hm = generate_terrain(recipe, 11)
    with World(hm, vehicle, sim) as w:
        rates = [abs(mean_yaw_rate(w, 0.0, 1.0, np.radians(h), seconds=4.0, at=(x, y)))
                 for x in (3.0, 6.0, 9.0) for y in (3.0, 6.0, 9.0) for h in (0.0, 30.0, 60.0)]
    return float(np.median(rates))


def compare_contact(args) -> None:
    from offroadbench.navigation.planners import planner_from_table

    print(f"contact models, {args.preset} seeds {args.seeds}, {args.missions} missions of 35 m each, 60 Hz")
    clock = {m: [0.0, 0.0] for m in CONTACT_MODELS}
    wins = {(m, p): 0 for m in CONTACT_MODELS for p in ("straight", "astar")}
    trials = 0
    for seed in (int(s) for s in args.seeds.split(",")):
        hm = terrain(args.preset, seed)
        rc = RoughnessConfig()
        closed = close_rough(classify(hm, rc), rc.closing_radius_m, hm.cell_size_m)
        missions = sample_missions(hm, closed, mission_config(count=args.missions), np.random.default_rng(seed))
        trials += len(missions)
        for planner in ("straight", "astar"):
            choice = planner_from_table({"name": planner})
            for model in CONTACT_MODELS:
                vehicle, sim = contact_variant(model)
                with World(hm, vehicle, sim) as world:
                    for m in missions:
                        tw = time.perf_counter()
                        r, _ = run_mission(world, m, planner=choice, classes=closed, border_m=mission_config().border_m)
                        clock[model][1] += time.perf_counter() - tw
                        clock[model][0] += r.sim_time_s + sim.settle_time_s
                        wins[model, planner] += r.success
    old_rtf = clock["old default"][0] / clock["old default"][1]
    print(f"{'model':12s} {'RTF':>6s} {'ratio':>6s} {'straight':>9s} {'astar':>7s} {'yaw min-max':>12s} {'rough turn':>10s}")
    for model in CONTACT_MODELS:
        vehicle, sim = contact_variant(model)
        rtf = clock[model][0] / clock[model][1]
        lo, hi = yaw_tracking(vehicle, sim)
        print(f"{model:12s} {rtf:6.1f} {rtf / old_rtf:6.2f} {wins[model, 'straight']:>4d}/{trials:<4d} "
              f"{wins[model, 'astar']:>3d}/{trials:<3d} {lo:5.2f}-{hi:<5.2f} {rough_turn_rate(vehicle, sim):10.2f}",
              flush=True)


def compare_soil(args) -> None:
    from offroadbench.terrain.recipe import apply_overrides

    recipe = smoke_grid(apply_overrides(load_recipe("lunar-mare"), {"grid.rows": 513, "grid.cols": 513,
                                                                    "layers.craters.population.d_max_m": 6.0}))
    models = ("coulomb", "terramechanics")
    clock = {m: [0.0, 0.0] for m in models}
    outcomes = {m: [] for m in models}
    husky = load_vehicle("husky")
    for seed in (int(s) for s in args.seeds.split(",")):
        hm = generate_terrain(recipe, seed)
        rc = RoughnessConfig()
        closed = close_rough(classify(hm, rc), rc.closing_radius_m, hm.cell_size_m)
        mcfg = mission_config(count=args.missions, length_m=15.0, border_m=2.0)
        missions = sample_missions(hm, closed, mcfg, np.random.default_rng(seed))
        worlds = {m: World(hm, husky, SimConfig(tyre_model=m, soil="lunar-regolith", gravity_m_s2=1.62))
                  for m in models}
        try:
            for mission in missions:
                for m in models:  # interleaved, mission by mission
                    tw = time.perf_counter()
                    r, _ = run_mission(worlds[m], mission)
                    clock[m][1] += time.perf_counter() - tw
                    clock[m][0] += r.sim_time_s + worlds[m].sim.settle_time_s
                    outcomes[m].append(r.failure_reason or "ok")
        finally:
            for w in worlds.values():
                w.close()
    rtf = {m: clock[m][0] / clock[m][1] for m in models}
    for m in models:
        print(f"{m:15s} RTF {rtf[m]:6.1f}  simulated {clock[m][0]:7.1f} s  outcomes {' '.join(outcomes[m])}")
    print(f"RTF ratio terramechanics / coulomb: {rtf['terramechanics'] / rtf['coulomb']:.2f}", flush=True)


def compare_iterations(args) -> None:
    from offroadbench.sim.rigs.vehicle_check import check_vehicle

    counts = [int(s) for s in args.iterations.split(",")]
    husky = load_vehicle("husky")
    print(f"solver iterations {counts}, {args.preset} seeds {args.seeds}, {args.missions} missions of 35 m each, 60 Hz")
    clock = {n: [0.0, 0.0] for n in counts}
    results = {n: [] for n in counts}
    for seed in (int(s) for s in args.seeds.split(",")):
        hm = terrain(args.preset, seed)
        rc = RoughnessConfig()
        closed = close_rough(classify(hm, rc), rc.closing_radius_m, hm.cell_size_m)
        missions = sample_missions(hm, closed, mission_config(count=args.missions), np.random.default_rng(seed))
        for n in counts:
            sim = SimConfig(solver_iterations=n)
            with World(hm, husky, sim) as world:
                for m in missions:
                    tw = time.perf_counter()
                    r, _ = run_mission(world, m)
                    clock[n][1] += time.perf_counter() - tw
                    clock[n][0] += r.sim_time_s + sim.settle_time_s
                    results[n].append(r)
    base = clock[counts[0]][0] / clock[counts[0]][1]
    print(f"{'iters':>5s} {'RTF':>6s} {'ratio':>6s} {'success':>8s} {'pen_max_mm':>10s} {'flat_pitch':>10s} "
          f"{'sanity':>8s}  vehicle-check rows failed")
    for n in counts:
        sim = SimConfig(solver_iterations=n)
        rtf = clock[n][0] / clock[n][1]
        rs = results[n]
        failed = [f"{row.name} ({row.measured:.3g} vs {row.expected:.3g} {row.unit})"
                  for row in check_vehicle(husky, sim) if not row.ok]
        print(f"{n:5d} {rtf:6.1f} {rtf / base:6.2f} {sum(r.success for r in rs):>3d}/{len(rs):<4d} "
              f"{1000 * max(r.max_penetration_m for r in rs):10.1f} {flat_jitter(husky, sim):10.2f} "
              f"{sanity(husky, sim):>8s}  {'; '.join(failed) or 'none'}", flush=True)
        print("      outcomes: " + " ".join(r.failure_reason or f"{r.sim_time_s:.0f}s" for r in rs))


def _old_tyres(rev: str):
    """CoulombTyres as ``sim/contact.py`` (later ``sim/engines/pybullet/tyres.py``) of git revision ``rev`` defines it (loaded from ``git show``)."""
    import subprocess
    import types

    root = Path(__file__).resolve().parents[1]
    for path in ("offroadbench/sim/contact.py", "offroadbench/sim/engines/pybullet/tyres.py"):  # before / after the move
        got = subprocess.run(["git", "show", f"{rev}:{path}"], cwd=root, capture_output=True, text=True)
        if got.returncode == 0:
            break
    got.check_returncode()
    src = got.stdout
    mod = types.ModuleType(f"contact_{rev}")
    exec(compile(src, f"{rev}:contact.py", "exec"), mod.__dict__)
    return mod.CoulombTyres


PAIRED = {  # variant -> (SimConfig changes, old tyre loop?)
    "main": ({"cone_friction": True}, True),
    "cone-off": ({"cone_friction": False}, True),
    "lean": ({"cone_friction": True}, False),
    "new": ({}, False),
    "main+0.1mm": ({"cone_friction": True, "spawn_clearance_m": SimConfig().spawn_clearance_m + 1e-4}, True),
}


def _paper_terrain(d_high: float, rc, mcfg, n: int):
    """Terrain 0 of root seed 2023 at ``d_high`` and its first ``n`` missions, as the paper study has them
    (through offroadbench.sim.trial.pipeline.prepare_terrain)."""
    from offroadbench.seeding import mission_seed, terrain_seed
    from offroadbench.sim.trial.pipeline import TrialSettings, prepare_terrain
    from offroadbench.terrain.recipe import apply_overrides, load_recipe

    recipe = smoke_grid(apply_overrides(load_recipe("paper-d2.45"), {"layers.base.D_high": d_high}))
    prepared = prepare_terrain(recipe, terrain_seed(2023, 0), TrialSettings(missions=mcfg, roughness=rc),
                               [(k, mission_seed(2023, 0, k)) for k in range(n)])
    return prepared.hm, list(prepared.missions)



def _drive_rotated(worlds: dict, missions, wall: dict, simt: dict, res: dict) -> None:
    """Drive every mission in every variant's world, the variants' order rotated per mission (no
    variant always last), adding wall time, simulated time and results per variant; closes the worlds."""
    try:
        order = list(worlds.items())
        for i, m in enumerate(missions):
            for n, w in order[i % len(order):] + order[:i % len(order)]:
                t0 = time.perf_counter()
                r, _ = run_mission(w, m)
                wall[n] += time.perf_counter() - t0
                simt[n] += r.sim_time_s + w.sim.settle_time_s
                res[n].append(r)
    finally:
        for w in worlds.values():
            w.close()

def paired(args) -> None:
    import offroadbench.sim.engines.pybullet.world as world_mod

    old, lean = _old_tyres(args.old_rev), world_mod.CoulombTyres
    husky = load_vehicle("husky")
    wall = {v: 0.0 for v in PAIRED}
    simt = {v: 0.0 for v in PAIRED}
    res = {v: [] for v in PAIRED}
    rc = RoughnessConfig(border_m=1.0 if SMOKE else 5.0)
    mcfg = mission_config(count=args.missions, length_m=35.0, border_m=5.0)
    print(f"paired variants {list(PAIRED)}; terrain 0 of each D (root seed 2023), {args.missions} missions each; "
          f"old tyre loop from {args.old_rev}", flush=True)
    for d in (2.3, 2.45, 2.6):
        hm, missions = _paper_terrain(d, rc, mcfg, args.missions)
        worlds = {}
        for v, (changes, use_old) in PAIRED.items():
            world_mod.CoulombTyres = old if use_old else lean
            try:
                worlds[v] = World(hm, husky, dataclasses.replace(SimConfig(), **changes))
            finally:
                world_mod.CoulombTyres = lean
        _drive_rotated(worlds, missions, wall, simt, res)
        print(f"  D = {d}: done", flush=True)
    base = res["main"]
    print(f"{'variant':12s} {'trial-time':>10s} {'per-sim-s':>9s} {'success':>8s} {'flips':>5s} {'rms_az ratio':>12s} "
          f"{'pen_med_mm':>10s}")
    for v in PAIRED:
        flips = sum(a.failure_reason != b.failure_reason for a, b in zip(base, res[v], strict=True))
        both = [(a, b) for a, b in zip(base, res[v], strict=True) if a.success and b.success]
        az = np.median([b.rms_vertical_accel_m_s2 / a.rms_vertical_accel_m_s2 for a, b in both]) if both else np.nan
        pen = np.median([1000 * r.max_penetration_m for r in res[v]])
        print(f"{v:12s} {wall['main'] / wall[v]:10.3f} {(wall['main'] / simt['main']) / (wall[v] / simt[v]):9.3f} "
              f"{sum(r.success for r in res[v]):>3d}/{len(res[v]):<4d} {flips:5d} {az:12.3f} {pen:10.1f}", flush=True)


def _number(text: str):
    """``text`` as an int or a float where it is one, else the text."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _parse_variant(text: str) -> tuple[str, dict]:
    """``NAME:key=value,key=value`` (SimConfig fields) -> (NAME, changes)."""
    name, _, rest = text.partition(":")
    changes = {}
    for item in filter(None, rest.split(",")):
        key, _, value = item.partition("=")
        changes[key] = _number(value)
    return name, changes


def engines(args) -> None:
    """Paired runs of physics engines / rates on the paper missions (as ``--paired``)."""
    from offroadbench.sim import open_world

    variants = [_parse_variant(v) for v in args.engines.split(";")]
    names = [n for n, _ in variants]
    wall = dict.fromkeys(names, 0.0)
    simt = dict.fromkeys(names, 0.0)
    build = dict.fromkeys(names, 0.0)
    res = {n: [] for n in names}
    rc = RoughnessConfig(border_m=1.0 if SMOKE else 5.0)
    mcfg = mission_config(count=args.missions, length_m=35.0, border_m=5.0)
    print(f"engines {variants}; terrain 0 of each D (root seed 2023), {args.missions} missions each", flush=True)
    for d in (2.3, 2.45, 2.6):
        hm, missions = _paper_terrain(d, rc, mcfg, args.missions)
        worlds = {}
        for n, changes in variants:
            t0 = time.perf_counter()
            tuning = {k.split(".", 1)[1]: v for k, v in changes.items() if k.startswith("contact.")}
            sim = dataclasses.replace(SimConfig(), **{k: v for k, v in changes.items() if not k.startswith("contact.")})
            if tuning:  # MuJoCo contact settings (offroadbench.sim.engines.mujoco.world.ContactTuning)
                from offroadbench.sim.engines.mujoco.settings import ContactTuning
                from offroadbench.sim.engines.mujoco.world import MuJoCoWorld

                worlds[n] = MuJoCoWorld(hm, "husky", sim, ContactTuning(**tuning))
            else:
                worlds[n] = open_world(hm, "husky", sim)
            build[n] += time.perf_counter() - t0
        _drive_rotated(worlds, missions, wall, simt, res)
        print(f"  D = {d}: done", flush=True)
    ref = names[0]
    print(f"{'variant':14s} {'build_s':>7s} {'trial-time':>10s} {'per-sim-s':>9s} {'success':>8s} {'flips':>5s} "
          f"{'rms_az':>7s} {'az ratio':>8s} {'pitch ratio':>11s} {'pen_med_mm':>10s}")
    for n in names:
        flips = sum(a.failure_reason != b.failure_reason for a, b in zip(res[ref], res[n], strict=True))
        both = [(a, b) for a, b in zip(res[ref], res[n], strict=True) if a.success and b.success]
        az = np.median([b.rms_vertical_accel_m_s2 / a.rms_vertical_accel_m_s2 for a, b in both]) if both else np.nan
        pr = np.median([b.rms_pitch_rate_deg_s / a.rms_pitch_rate_deg_s for a, b in both]) if both else np.nan
        ok = [r.rms_vertical_accel_m_s2 for r in res[n] if r.success]
        pen = np.median([1000 * r.max_penetration_m for r in res[n]])
        print(f"{n:14s} {build[n]:7.2f} {wall[ref] / wall[n]:10.3f} {(wall[ref] / simt[ref]) / (wall[n] / simt[n]):9.3f} "
              f"{sum(r.success for r in res[n]):>3d}/{len(res[n]):<4d} {flips:5d} {np.median(ok) if ok else np.nan:7.3f} "
              f"{az:8.3f} {pr:11.3f} {pen:10.1f}", flush=True)
        print("      outcomes: " + " ".join(r.failure_reason or "ok" for r in res[n]), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default=None, help="terrain preset (default paper-d2.45; --contact: paper-d2.6)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--seeds", default="1,2", help="--contact: terrain seeds")
    ap.add_argument("--missions", type=int, default=None, help="missions per terrain (default 5; --contact: 10)")
    ap.add_argument("--contact", action="store_true", help="compare the tyre-terrain contact models")
    ap.add_argument("--iterations", default=None, help="compare solver iteration counts, e.g. 50,30,20")
    ap.add_argument("--paired", action="store_true", help="PyBullet's wasted work: paired variants (issue 25)")
    ap.add_argument("--old-rev", default="main", help="--paired: git revision of the old tyre loop")
    ap.add_argument("--engines", default=None,
                    help="paired engines, e.g. 'pybullet:;mujoco60:engine=mujoco;mujoco120:engine=mujoco,physics_rate_hz=120'")
    ap.add_argument("--soil", action="store_true", help="compare terramechanics with coulomb on lunar-mare")
    ap.add_argument("--smoke", action="store_true", help="every mode once: 1 mission, 201^2 maps, 6 m missions (CI)")
    args = ap.parse_args()
    if args.smoke:
        smoke(args)
        return
    run_mode(args)


def run_mode(args) -> None:
    """Run the mode ``args`` selects (main's flags)."""
    if args.soil:
        args.missions = args.missions or 4
        compare_soil(args)
        return
    if args.engines:
        args.missions = args.missions or 8
        engines(args)
        return
    if args.paired:
        args.missions = args.missions or 8
        paired(args)
        return
    if args.iterations:
        args.preset = args.preset or "paper-d2.6"
        args.missions = args.missions or 10
        compare_iterations(args)
        return
    if args.contact:
        args.preset = args.preset or "paper-d2.6"
        args.missions = args.missions or 10
        compare_contact(args)
        return
    args.preset = args.preset or "paper-d2.45"
    args.missions = args.missions or 5

    t0 = time.perf_counter()
    hm = terrain(args.preset, args.seed)
    rc = RoughnessConfig()
    closed = close_rough(classify(hm, rc), rc.closing_radius_m, hm.cell_size_m)
    missions = sample_missions(hm, closed, mission_config(count=args.missions), np.random.default_rng(args.seed))
    print(f"{args.preset} seed {args.seed}: {hm.rows}x{hm.cols}, terrain + missions {time.perf_counter() - t0:.1f} s; "
          f"{len(missions)} missions of 35 m")
    husky = load_vehicle("husky")
    with tempfile.TemporaryDirectory() as tmp:
        variants = [("sphere", husky, r) for r in (240, 120, 60)] + [("cylinder", cylinder_wheel_vehicle(Path(tmp)), 60)]
        print(f"{'wheels':9s} {'rate':>5s} {'build_s':>7s} {'RTF':>6s} {'sim_s':>6s} {'wall_s':>6s} {'success':>7s} "
              f"{'pen_max_mm':>10s} {'pen_med_mm':>10s} {'flat_pitch_rate':>15s} {'sanity':>8s}")
        for shape, vehicle, rate in variants:
            sim = SimConfig(physics_rate_hz=rate)
            tb = time.perf_counter()
            with World(hm, vehicle, sim) as world:
                build = time.perf_counter() - tb
                sim_s = wall_s = 0.0
                results = []
                for m in missions:
                    tw = time.perf_counter()
                    r, _ = run_mission(world, m)
                    wall_s += time.perf_counter() - tw
                    sim_s += r.sim_time_s + sim.settle_time_s
                    results.append(r)
            pens = [1000 * r.max_penetration_m for r in results]
            ok = sum(r.success for r in results)
            print(f"{shape:9s} {rate:5d} {build:7.2f} {sim_s / wall_s:6.1f} {sim_s:6.1f} {wall_s:6.1f} "
                  f"{ok:>3d}/{len(results):<3d} {max(pens):10.1f} {np.median(pens):10.1f} "
                  f"{flat_jitter(vehicle, sim):15.2f} {sanity(vehicle, sim):>8s}", flush=True)
            print("          outcomes: " + " ".join(r.failure_reason or "ok" for r in results)
                  + "; times " + " ".join(f"{r.sim_time_s:.0f}" for r in results))


def smoke(args) -> None:
    """Every mode once, small (``--smoke``)."""
    global SMOKE
    SMOKE = True
    base = dict(vars(args), smoke=False, missions=1, seeds="1", old_rev="HEAD")
    for name, changes in [("default", {}), ("contact", {"contact": True}), ("soil", {"soil": True}),
                          ("iterations", {"iterations": "50,30"}), ("paired", {"paired": True}),
                          ("engines", {"engines": "pybullet:;mujoco:engine=mujoco;mujoco-tuned:engine=mujoco,contact.wheel_margin_m=0.0"})]:
        print(f"--- smoke: {name}", flush=True)
        run_mode(argparse.Namespace(**(base | changes)))


if __name__ == "__main__":
    main()
