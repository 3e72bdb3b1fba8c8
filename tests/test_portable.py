"""Portable reproducibility (README, "Reproducibility"): the same seeds give the same terrain levels
and the same trial rows on every x86-64 CPU the project runs on, and a mission's row does not depend
on the missions run before it in the same World.

How another CPU is emulated on this one. numpy chooses its SIMD loops when it is imported and
OpenBLAS its kernels when it loads; ``NPY_DISABLE_CPU_FEATURES`` and ``OPENBLAS_CORETYPE`` switch
both down to the x86-64 baseline, and a process started so computes as an older CPU would. On an
AVX-512 machine that is the code the AVX2 machines run and more (numpy's ``X86_V3``/``X86_V4``/
AVX-512 loops and OpenBLAS's Haswell/SkylakeX kernels all go); on an AVX2-only machine it still
swaps numpy's AVX2 loops and OpenBLAS's Haswell kernels for SSE ones, so the test means something
on either. glibc's AVX-512 code paths are switched off too (``GLIBC_TUNABLES``); its FMA variants of
``sin``, ``exp``, ``atan2``, ... stay: every machine of the project has FMA (x86-64-v3), and a libm
without FMA computes other last bits (not covered; README). The quantities compared are exact:
float64 bits of the terrain and of every number in a trial row (``float.hex``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.conftest import SMALL_MAPS_TOML as SMALL_MAPS

#: the environment of an older x86-64 CPU (see the module docstring)
BASELINE_ENV = {
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR",
    "OPENBLAS_CORETYPE": "Nehalem",
    "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX512F,-AVX512DQ,-AVX512BW,-AVX512VL,-AVX512CD",
}

#: a short study slice: two roughness levels, two planners (one plans on the class map), 2 terrains
#: per cell, 3 missions per terrain = 24 trials on 12.8 m maps
SLICE = """
[study]
name = "portable-slice"
recipe = "paper-d2.45"
root_seed = 5
terrains_per_cell = 2
missions_per_terrain = 3

[grid]
"recipe.layers.base.D_high" = [2.45, 2.9]
"planner.name" = ["straight", "astar"]
""" + SMALL_MAPS

#: a soft-soil slice: the terramechanics tyre model's tables (sin, cos, exp, acos, pow and the
#: quadrature nodes) on lunar regolith in lunar gravity, and its per-step soil contact; 2 terrains x 2
#: missions = 4 trials on 12.8 m maps
SOIL_SLICE = """
[study]
name = "portable-soil"
recipe = "lunar-mare"
root_seed = 7
terrains_per_cell = 2
missions_per_terrain = 2

[grid]
"sim.tyre_model" = ["terramechanics"]

[recipe_overrides]
"grid.rows" = 257
"grid.cols" = 257
"layers.base.relief_m" = 0.6
"layers.craters.population.d_max_m" = 3.0

[roughness]
border_m = 1.0

[missions]
length_m = 5.0
border_m = 1.0

[sim]
soil = "lunar-regolith"
gravity_m_s2 = 1.62
"""

#: the closed-loop policies with their own numerics, through the mast sensor (their sensor arm in
#: experiments/vehicle-planner.toml): mppi (rollouts, cos/sin, weights), ppo (the MLP) and reactive
#: (its arcs' sin/cos and height look-ups); 1 terrain x 2 missions each = 6 trials on 12.8 m maps
POLICY_SLICE = """
[study]
name = "portable-policies"
recipe = "paper-d2.45"
root_seed = 5
terrains_per_cell = 1
missions_per_terrain = 2

[grid]
"planner.name" = ["mppi", "ppo", "reactive"]

[planner]
sensor = "mast"
""" + SMALL_MAPS

#: run in a subprocess (or in-process): drive the slice's tasks with the missions in a given order
#: (a fourth argument ``python``: mppi's headings through its Python pass, not numba's)
DRIVER = textwrap.dedent('''
    import hashlib, json, sys
    from offroadbench.levels16 import encode_levels
    from offroadbench.study.runner import plan_tasks
    from offroadbench.study.spec.config import load_study
    from offroadbench.study.execution.tasks import TerrainTask, run_terrain
    from offroadbench.terrain.recipe import generate_terrain

    def drive(study_path, order):
        study, plans = load_study(study_path)
        out = {"terrains": {}, "rows": {}}
        for task in plan_tasks(study, plans, set()):
            hm = generate_terrain(task.cell.recipe(), task.terrain_seed)
            levels = encode_levels(hm.z, hm.z_min_m, hm.z_max_m)
            key = f"{task.cell.index}/{task.terrain}"
            out["terrains"][key] = [hashlib.sha256(hm.z.tobytes()).hexdigest(),
                                    hashlib.sha256(levels.tobytes()).hexdigest()]
            missions = list(task.missions)
            if order == "reversed":
                missions = missions[::-1]
            elif order == "subset":  # every other mission, the last first
                missions = missions[1::2][::-1]
            task = TerrainTask(cell=task.cell, terrain=task.terrain, terrain_seed=task.terrain_seed,
                               missions=tuple(missions), telemetry="none")
            for msg in run_terrain(task):
                if hasattr(msg, "row"):  # a TrialDone
                    row = {k: (float(v).hex() if isinstance(v, float) else v) for k, v in msg.row.items()}
                    out["rows"][f"{key}/{msg.mission}"] = row
        return out

    if __name__ == "__main__":
        if sys.argv[4:] == ["python"]:
            import offroadbench.navigation.policies.mppi as mppi
            mppi.USE_COMPILED_TRIG = False
        json.dump(drive(sys.argv[1], sys.argv[2]), open(sys.argv[3], "w"))
''')


def _run_driver(tmp_path: Path, order: str, env_extra: dict[str, str], *extra: str) -> dict:
    script = tmp_path / "driver.py"
    script.write_text(DRIVER)
    out = tmp_path / f"out-{order}-{len(env_extra)}.json"
    env = {**os.environ, **env_extra}
    proc = subprocess.run([sys.executable, str(script), str(tmp_path / "slice.toml"), order, str(out), *extra],
                          env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def native(tmp_path_factory) -> tuple[Path, dict]:
    """The slice driven in mission order by this process's own numpy and OpenBLAS."""
    tmp = tmp_path_factory.mktemp("portable")
    (tmp / "slice.toml").write_text(SLICE)
    namespace: dict = {}
    exec(compile(DRIVER, "driver", "exec"), namespace)
    return tmp, namespace["drive"](str(tmp / "slice.toml"), "forward")


def test_the_slice_is_not_trivial(native):
    _, out = native
    assert len(out["terrains"]) == 8 and len(out["rows"]) == 24
    rows = out["rows"].values()
    assert {r["failure_reason"] for r in rows} >= {""}
    # real trials: 12 distinct missions per planner (astar may drive a straight one exactly as straight does)
    assert len({r["rms_vertical_accel_m_s2"] for r in rows}) >= 12


def test_terrain_and_trials_are_identical_on_a_baseline_cpu_in_reversed_order(native):
    """Every terrain level and every number of every trial row, with numpy/OpenBLAS/glibc switched
    down to the x86-64 baseline and each terrain's missions driven in reversed order in its World."""
    tmp, out = native
    other = _run_driver(tmp, "reversed", BASELINE_ENV)
    assert other["terrains"] == out["terrains"]
    assert set(other["rows"]) == set(out["rows"])
    differ = [k for k in out["rows"] if other["rows"][k] != out["rows"][k]]
    assert not differ, f"{len(differ)} of {len(out['rows'])} trial rows differ, e.g. {differ[:3]}"


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_soft_soil_trials_are_identical_on_a_baseline_cpu(tmp_path, engine):
    """The terramechanics tyre model's tables and soil contact (MuJoCo's compiled soil loop too): every
    number of every row of a soft-soil slice, natively and with numpy/OpenBLAS/glibc switched down
    (``terramechanics`` module docstring, "Portability")."""
    if engine == "mujoco":
        pytest.importorskip("mujoco")
    (tmp_path / "slice.toml").write_text(SOIL_SLICE + f'engine = "{engine}"\n')
    out = _run_driver(tmp_path, "forward", {})
    other = _run_driver(tmp_path, "reversed", BASELINE_ENV)
    assert len(out["rows"]) == 4 and set(other["rows"]) == set(out["rows"])
    assert len({r["traversal_time_s"] for r in out["rows"].values()}) >= 2  # real trials, not one repeated row
    differ = [k for k in out["rows"] if other["rows"][k] != out["rows"][k]]
    assert not differ, f"{len(differ)} of {len(out['rows'])} soft-soil rows differ, e.g. {differ[:3]}"


def test_mppi_ppo_and_reactive_trials_are_identical_on_a_baseline_cpu(tmp_path):
    """``mppi``, ``ppo`` and ``reactive`` through the mast sensor: every number of every row natively
    (mppi's numba pass where numba is installed) and with numpy/OpenBLAS/glibc switched down, in
    reversed order and through mppi's Python pass (the mppi and ppo modules, "Portability")."""
    (tmp_path / "slice.toml").write_text(POLICY_SLICE)
    namespace: dict = {}
    exec(compile(DRIVER, "driver", "exec"), namespace)
    out = namespace["drive"](str(tmp_path / "slice.toml"), "forward")
    other = _run_driver(tmp_path, "reversed", BASELINE_ENV, "python")
    assert len(out["rows"]) == 6 and set(other["rows"]) == set(out["rows"])
    assert {k.split("/")[0] for k in out["rows"]} == {"0", "1", "2"}  # a cell per policy
    assert len({r["rms_vertical_accel_m_s2"] for r in out["rows"].values()}) == 6  # real, distinct trials
    differ = [k for k in out["rows"] if other["rows"][k] != out["rows"][k]]
    assert not differ, f"{len(differ)} of {len(out['rows'])} policy rows differ: {differ}"


def test_a_subset_of_missions_in_another_order_gives_the_same_rows(native):
    """A mission's row does not depend on which missions the World ran before it (resume, replay)."""
    tmp, out = native
    other = _run_driver(tmp, "subset", {})
    assert other["rows"] and set(other["rows"]) < set(out["rows"])
    assert {k: out["rows"][k] for k in other["rows"]} == other["rows"]


def test_pinned_terrain_hashes_hold_on_a_baseline_cpu():
    """tests/terrain/test_bit_identical.py's pinned hashes, recomputed with the dispatch switched down."""
    here = Path(__file__).parent
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", str(here / "terrain" / "test_bit_identical.py")],
        env={**os.environ, **BASELINE_ENV}, capture_output=True, text=True, timeout=900, cwd=here.parent,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]


def test_drive_of_the_exported_png_equals_drive_of_the_preset(tmp_path):
    """``generate PRESET -o x.png`` then ``drive x.png`` meets the same terrain, with the same rows,
    as ``drive PRESET`` (the default terrain is the PNG's 16-bit terrain, bit for bit)."""
    import pandas as pd

    from offroadbench.cli import main
    from offroadbench.seeding import terrain_seed

    grid = ["--set", "grid.rows=281", "--set", "grid.cols=281"]  # 14 m: 4 m inside the 5 m border
    drive = ["--seed", "4", "--missions", "2", "--length-m", "3"]
    assert main(["generate", "lunar-mare", "--seed", str(terrain_seed(4, 0)), *grid, "-o", str(tmp_path / "x.png")]) == 0
    assert main(["drive", "lunar-mare", *grid, *drive, "--out", str(tmp_path / "preset")]) == 0
    assert main(["drive", str(tmp_path / "x.png"), *drive, "--out", str(tmp_path / "png")]) == 0
    a = pd.read_csv(tmp_path / "preset" / "trials.csv").drop(columns=["terrain_seed"])
    b = pd.read_csv(tmp_path / "png" / "trials.csv").drop(columns=["terrain_seed"])
    assert len(a) == 2
    pd.testing.assert_frame_equal(a, b, check_exact=True)
