"""Traversal-trial speed and physics quality against physics rate and wheel shape.

For each physics rate (240 / 120 / 60 Hz; plus cylinder wheels at 60 Hz) this drives the same
35 m missions on a paper 1009^2 terrain in one process and prints the real-time factor
(simulated s per wall s of the driving loop), max wheel penetration, success, and the RMS
pitch rate on flat ground (contact jitter). It also runs the physics sanity scenarios of
tests/test_sim_physics.py (15 deg ramp, wall, off the edge) at each rate.

    .venv/bin/python benchmarks/bench_sim.py [--preset paper-d2.45] [--seed 1] [--missions 5]
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


def cylinder_wheel_vehicle(tmp: Path):
    """The husky with true cylinder collision wheels (axis along y), written to ``tmp``."""
    spec = load_vehicle("husky")
    text = Path(spec.urdf).read_text().replace(
        '<collision>\n      <geometry><sphere radius="0.165"/></geometry>',
        '<collision>\n      <origin xyz="0 0 0" rpy="1.5707963 0 0"/>\n'
        '      <geometry><cylinder radius="0.165" length="0.125"/></geometry>',
    )
    assert text.count("<cylinder") == 8  # 4 visual + 4 collision
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="paper-d2.45")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--missions", type=int, default=5)
    args = ap.parse_args()

    t0 = time.perf_counter()
    hm = generate_terrain(load_recipe(args.preset), args.seed)
    rc = RoughnessConfig()
    closed = close_rough(classify(hm, rc), rc.closing_radius_m, hm.cell_size_m)
    missions = sample_missions(hm, closed, MissionConfig(count=args.missions), np.random.default_rng(args.seed))
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


if __name__ == "__main__":
    main()
