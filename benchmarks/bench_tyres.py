"""Cost of the MuJoCo world's tyre loop (coulomb tyres or terramechanics soil) per 60 Hz trial step: Python against compiled.

The loop is the work the world does around MuJoCo at each of a trial step's MuJoCo steps (2 at the
default 60 Hz trial rate and ``ContactTuning.min_rate_hz = 120``): read the wheels' terrain contacts
after ``mj_step2`` and apply the tyre forces after ``mj_step1``. Both loops are timed on the same
MuJoCo states, sampled along a paper mission (terrain 0 of D = 2.45, root seed 2023, the chassis
touching the ground in some of them), alternating python and compiled in rounds (best of
``--repeats`` rounds per state, so load hits both alike); the compiled loop is timed with the
attribute look-ups its call needs (``d.contact`` and its fields), as the world makes them.
It also times the whole trial step (``world.step``) both ways, over the mission's first
``calls / 10`` steps.

With ``--model terramechanics`` the loop is the soil's (offroadbench.sim.tyre_laws.soil_wheels on
lunar regolith in lunar gravity, ``_soil_c`` compiled): the soil forces after each ``mj_step1``
(the Python loop also reads the step's contacts, none of them a wheel's); ``--model both`` runs
the two one after the other.

    .venv/bin/python benchmarks/bench_tyres.py [--model coulomb|terramechanics|both] [--states 12] [--repeats 7] [--smoke]

``--breakdown N`` instead drives the first ``N`` missions of the paper study on MuJoCo
(experiments/majhor2023-mujoco.toml, terrain 0 of each D, through prepare_terrain and
drive_mission as the study does) and prints where a trial's CPU time goes: per trial step
``mj_step1``, the compiled tyre loop's two kernels, ``mj_step2`` and the Python around them, the
trial loop's Python (control, telemetry, rules: everything in drive_mission outside the world's
step and spawn), the spawn, and per terrain its preparation and the world build; then, in a second
pass over the same trials, MuJoCo's own timers (``mjcb_time``) per MuJoCo step. CPU time
(``time.process_time_ns``) so that other jobs on the machine inflate it less than wall time.

``--smoke`` runs both models and a one-mission breakdown in seconds on small maps (for CI: the
script must not rot).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import mujoco
import numpy as np

from offroadbench.heightmap import Heightmap
from offroadbench.sim import SimConfig
from offroadbench.sim.engines.mujoco.world import ContactTuning, MuJoCoWorld


def _states(world: MuJoCoWorld, start, goal, count: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(qpos, qvel) of ``count`` moments of a straight drive from ``start`` towards ``goal``, 20 trial steps apart."""
    world.spawn(*start, float(np.arctan2(goal[1] - start[1], goal[0] - start[0])))
    out = []
    for k in range(20 * count):
        world.command_wheels(7.0 + 3.0 * np.sin(0.05 * k), 7.0 - 3.0 * np.sin(0.05 * k))
        world.step()
        if k % 20 == 19:
            out.append((world.data.qpos.copy(), world.data.qvel.copy()))
    return out


def _python_loop(world: MuJoCoWorld):
    def run(n: int) -> None:
        for _ in range(n):
            world._apply_tyres()
            world._read_contacts()
    return run


def _compiled_soil_loop(world: MuJoCoWorld):
    sc, f, ist, tab = world._fast_soil
    d = world.data
    apply = sc.APPLY
    qvel, xmat, xipos, xfrc = d.qvel, d.xmat, d.xipos, d.xfrc_applied

    def run(n: int) -> None:
        for _ in range(n):
            apply(qvel, xmat, xipos, xfrc, f, ist, tab)
    return run


def _compiled_loop(world: MuJoCoWorld):
    if world._fast_soil is not None:
        return _compiled_soil_loop(world)
    tc, f, ist = world._fast
    d = world.data
    apply, read = tc.APPLY, tc.READ
    qvel, xmat, xipos, xfrc = d.qvel, d.xmat, d.xipos, d.xfrc_applied

    def run(n: int) -> None:
        for _ in range(n):
            apply(qvel, xmat, xipos, xfrc, f, ist)
            con = d.contact
            read(con.geom, con.dist, con.pos, con.frame, con.efc_address, d.efc_force, f, ist)
    return run


def _at(world: MuJoCoWorld, state) -> None:
    """Put ``world`` at ``state`` with its contacts of one MuJoCo step (mj_step1, mj_step2)."""
    d = world.data
    d.qpos[:], d.qvel[:] = state
    mujoco.mj_step1(world.model, d)
    mujoco.mj_step2(world.model, d)
    d.qpos[:], d.qvel[:] = state
    mujoco.mj_step1(world.model, d)


def _study_terrains(missions: int, rows: int | None = None):
    """(cell values, trial settings, prepared terrain) of terrain 0 of each D of the MuJoCo paper
    study, with its first ``missions`` missions (``rows``: a smaller grid, 5 m missions, for --smoke)."""
    import dataclasses
    from pathlib import Path

    from offroadbench.sim.trial.pipeline import prepare_terrain
    from offroadbench.study import load_study
    from offroadbench.study.runner import plan_tasks
    from offroadbench.study.spec.config import plan_cells

    study, _ = load_study(Path(__file__).resolve().parents[1] / "experiments" / "majhor2023-mujoco.toml")
    study = dataclasses.replace(study, terrains_per_cell=1, missions_per_terrain=missions)
    if rows:
        settings = {k: dict(v) for k, v in study.settings.items()}
        settings["missions"] = {**settings.get("missions", {}), "length_m": 5.0, "border_m": 1.0}
        settings["roughness"] = {**settings.get("roughness", {}), "border_m": 1.0}
        study = dataclasses.replace(study, settings=settings, recipe_overrides={
            **study.recipe_overrides, "grid.rows": rows, "grid.cols": rows})
    for task in plan_tasks(study, plan_cells(study), set()):
        t0 = time.process_time_ns()
        prepared = prepare_terrain(task.cell.recipe(), task.terrain_seed, task.cell.trial_settings, task.missions)
        yield task.cell.trial_settings, prepared, time.process_time_ns() - t0


def breakdown(missions: int, rows: int | None = None) -> None:
    """Print where the CPU time of ``missions`` paper missions per D goes on MuJoCo (module docstring)."""
    from offroadbench.sim import open_world
    from offroadbench.sim.trial.runner import drive_mission

    clk = time.process_time_ns
    acc = dict.fromkeys(("step1", "apply", "step2", "read", "step", "spawn", "trial", "terrain", "build"), 0)
    n_steps = n_trials = n_terrains = n_con = 0
    timers: dict[str, list] = {}
    names = [n for n in mujoco.mjtTimer.__members__ if n != "mjNTIMER"]
    for settings, prepared, terrain_ns in _study_terrains(missions, rows):
        acc["terrain"] += terrain_ns
        n_terrains += 1
        t0 = clk()
        world = open_world(prepared.hm, settings.vehicle, prepared.sim_for(settings.sim))
        acc["build"] += clk() - t0
        with world:
            m, d = world.model, world.data
            tc, f, ist = world._fast
            plain_spawn = world.spawn
            spawning = [False]

            def step(world=world, m=m, d=d, tc=tc, f=f, ist=ist, spawning=spawning) -> None:
                """world._step_compiled with a clock around each call (tyres at every MuJoCo step)."""
                nonlocal n_steps, n_con
                t0 = clk()
                qvel, xmat, xipos, xfrc = d.qvel, d.xmat, d.xipos, d.xfrc_applied
                for _ in range(world.substeps):
                    a = clk()
                    mujoco.mj_step1(m, d)
                    b = clk()
                    tc.APPLY(qvel, xmat, xipos, xfrc, f, ist)
                    c = clk()
                    mujoco.mj_step2(m, d)
                    e = clk()
                    con = d.contact
                    tc.READ(con.geom, con.dist, con.pos, con.frame, con.efc_address, d.efc_force, f, ist)
                    g = clk()
                    if not spawning[0]:
                        acc["step1"] += b - a
                        acc["apply"] += c - b
                        acc["step2"] += e - c
                        acc["read"] += g - e
                        n_con += d.ncon
                if not spawning[0]:
                    acc["step"] += clk() - t0
                    n_steps += 1

            def spawn(*a, spawning=spawning, plain_spawn=plain_spawn, **kw) -> None:
                t0 = clk()
                spawning[0] = True
                try:
                    plain_spawn(*a, **kw)
                finally:
                    spawning[0] = False
                acc["spawn"] += clk() - t0

            assert world.contact.tyres_each_substep and world._fast is not None
            for mi in prepared.missions:
                world.step, world.spawn, world.advance = step, spawn, None  # each trial step through step
                t0 = clk()
                drive_mission(world, mi, settings=settings, classes=prepared.maps.closed)
                acc["trial"] += clk() - t0
                n_trials += 1
                # the same trial again, untimed, with MuJoCo's own timers
                del world.step, world.spawn, world.advance  # the class's own methods again
                mujoco.set_mjcb_time(time.process_time)
                try:
                    drive_mission(world, mi, settings=settings, classes=prepared.maps.closed)
                finally:
                    mujoco.set_mjcb_time(None)
                for n in names:
                    t = d.timer[int(getattr(mujoco.mjtTimer, n))]
                    timers.setdefault(n, [0.0, 0])
                    timers[n][0] += t.duration
                    timers[n][1] += t.number
    python = acc["trial"] - acc["step"] - acc["spawn"]
    substeps = 2 if n_steps == 0 else round((timers["mjTIMER_POS_COLLISION"][1]) / max(n_steps, 1))
    print(f"{platform.processor() or platform.machine()}, python {platform.python_version()}, mujoco {mujoco.__version__}; "
          f"{n_trials} paper missions on {n_terrains} terrains, {n_steps} trial steps ({n_steps / n_trials:.0f} per trial), "
          f"{n_con / max(n_steps, 1) / 2:.1f} contacts per MuJoCo step; CPU time")
    us = 1e-3 / max(n_steps, 1)
    parts = {"mj_step1": acc["step1"], "tyre loop: apply kernel": acc["apply"], "mj_step2": acc["step2"],
             "tyre loop: contacts (views + read kernel)": acc["read"],
             "world.step's Python around them": acc["step"] - acc["step1"] - acc["apply"] - acc["step2"] - acc["read"],
             "trial loop Python (control, telemetry, rules)": python, "spawn and settle": acc["spawn"]}
    total = sum(parts.values())
    t0 = clk()
    for _ in range(10000):
        clk()
    tick = (clk() - t0) / 10000 * 1e-3
    print(f"per trial step (us; each clock read costs {tick:.2f} us, 9 per trial step, in the parts "
          "they bracket) | share of a trial's CPU")
    for k, v in parts.items():
        print(f"  {k:48s} {v * us:7.1f} | {100 * v / total:4.1f} %")
    print(f"  {'total':48s} {total * us:7.1f} | trial {total / n_trials / 1e6:.0f} ms")
    print(f"per terrain: preparation {acc['terrain'] / n_terrains / 1e6:.0f} ms, world build {acc['build'] / n_terrains / 1e6:.0f} ms "
          f"(the first build loads numba's cache)")
    n_mj = max(timers["mjTIMER_POS_COLLISION"][1], 1)
    print(f"MuJoCo's timers (mjcb_time = process_time: each timed section also pays ~1 us of callback), "
          f"us per MuJoCo step ({substeps} per trial step):")
    print("  " + ", ".join(f"{n.removeprefix('mjTIMER_').lower()} {dur / n_mj * 1e6:.1f}"
                           for n, (dur, num) in timers.items() if num and n != "mjTIMER_FORWARD"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=12, help="MuJoCo states sampled along the mission")
    ap.add_argument("--repeats", type=int, default=7, help="rounds per state (the best is kept)")
    ap.add_argument("--calls", type=int, default=2000, help="loop calls per timing")
    ap.add_argument("--model", choices=("coulomb", "terramechanics", "both"), default="coulomb",
                    help="the coulomb tyres' loop or the soil's (lunar regolith, lunar gravity)")
    ap.add_argument("--breakdown", type=int, default=0, metavar="N",
                    help="instead: where the CPU time of N paper missions per D goes on MuJoCo")
    ap.add_argument("--smoke", action="store_true", help="a small synthetic map and few calls, both models (seconds)")
    args = ap.parse_args()
    if args.breakdown and not args.smoke:
        breakdown(args.breakdown)
        return
    if args.smoke:
        y, x = np.mgrid[0:81, 0:201] * 0.05
        hm = Heightmap(0.3 + 0.08 * np.sin(2.1 * x) * np.cos(1.7 * y), 0.05)
        start, goal = (2.0, 2.0), (9.0, 2.5)
        args.states, args.repeats, args.calls, args.model = 2, 2, 200, "both"
    else:
        from bench_sim import _paper_terrain  # the paper terrain and missions (run as a script: benchmarks/ is on sys.path)
        from offroadbench.analysis.roughness import RoughnessConfig
        from offroadbench.navigation.missions import MissionConfig

        hm, missions = _paper_terrain(2.45, RoughnessConfig(border_m=5.0), MissionConfig(count=1, length_m=35.0, border_m=5.0), 1)
        start, goal = missions[0].start_xy_m, missions[0].goal_xy_m
    for model in ("coulomb", "terramechanics") if args.model == "both" else (args.model,):
        measure(model, hm, start, goal, args)
    if args.smoke:
        breakdown(1, rows=161)


def measure(model: str, hm: Heightmap, start, goal, args) -> None:
    """Time the ``model``'s loop both ways on ``hm`` along the drive from ``start`` towards ``goal``, and print."""
    sim = SimConfig(engine="mujoco")
    if model == "terramechanics":
        sim = SimConfig(engine="mujoco", tyre_model="terramechanics", soil="lunar-regolith", gravity_m_s2=1.62)
    worlds = {loop: MuJoCoWorld(hm, "husky", sim, ContactTuning(tyre_loop=loop)) for loop in ("python", "compiled")}
    runners = {"python": _python_loop(worlds["python"]), "compiled": _compiled_loop(worlds["compiled"])}
    states = _states(worlds["python"], start, goal, args.states)
    substeps = worlds["python"].substeps
    per = {loop: [] for loop in worlds}
    ncon = []
    for state in states:
        for w in worlds.values():
            _at(w, state)
        ncon.append(worlds["python"].data.ncon)
        for loop in worlds:
            runners[loop](50)  # warm (and the compiled loop's first call compiles or loads from cache)
        best = dict.fromkeys(worlds, float("inf"))
        for _ in range(args.repeats):
            for loop, run in runners.items():
                t0 = time.perf_counter()
                run(args.calls)
                best[loop] = min(best[loop], (time.perf_counter() - t0) / args.calls)
        for loop in worlds:
            per[loop].append(best[loop])
    # whole trial steps, the two worlds alternating
    step_best = dict.fromkeys(worlds, float("inf"))
    heading = float(np.arctan2(goal[1] - start[1], goal[0] - start[0]))
    for _ in range(args.repeats):
        for loop, w in worlds.items():
            w.spawn(*start, heading)  # each timing from the same state: the first steps of the mission
            t0 = time.perf_counter()
            for _ in range(args.calls // 10):
                w.command_wheels(6.0, 5.5)
                w.step()
            step_best[loop] = min(step_best[loop], (time.perf_counter() - t0) / (args.calls // 10))
    for w in worlds.values():
        w.close()
    print(f"{platform.processor() or platform.machine()}, python {platform.python_version()}, mujoco {mujoco.__version__}; "
          f"{len(states)} states, contacts per MuJoCo step {min(ncon)}-{max(ncon)}; {substeps} MuJoCo steps per trial step")
    py, cc = statistics.median(per["python"]), statistics.median(per["compiled"])
    print(f"{model} loop per trial step (median over states, best of {args.repeats}): python {1e6 * substeps * py:.1f} us, "
          f"compiled {1e6 * substeps * cc:.1f} us: {py / cc:.1f}x")
    print(f"whole trial step (best of {args.repeats}): python {1e6 * step_best['python']:.1f} us, "
          f"compiled {1e6 * step_best['compiled']:.1f} us: {step_best['python'] / step_best['compiled']:.2f}x")


if __name__ == "__main__":
    main()
