"""Fuzz table of bad inputs for every command: exit 2, one stderr line, no traceback, nothing left.

Every case is a real CLI process. To keep the suite fast, most cases run through
``fuzz_driver.py``: one interpreter imports the CLI once and forks a fresh process per case (same
top level as the console script). A few cases also run as ordinary ``offroadbench`` subprocesses,
which shows that a cold start (pybullet's import included) prints nothing else either.
"""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

DRIVER = Path(__file__).with_name("fuzz_driver.py")

STUDY = """
[study]
name = "fuzz"
recipe = "paper-d2.45"
root_seed = 3
terrains_per_cell = 1
missions_per_terrain = 1

[grid]
"recipe.layers.base.D_high" = [2.3]

[recipe_overrides]
"grid.rows" = 129
"grid.cols" = 129

[roughness]
border_m = 1.0

[missions]
length_m = {length}
border_m = 1.0
"""


def _png16(path: Path, rows: int = 41, cols: int = 41, sidecar: object = "auto") -> None:
    from offroadbench.heightmap import Heightmap
    from offroadbench.io.png16 import write_png16

    y, x = np.mgrid[0:rows, 0:cols] * 0.05
    write_png16(Heightmap(0.05 * np.sin(x) * np.cos(y), 0.05), path)
    if sidecar != "auto":
        side = path.with_suffix(".json")
        if sidecar is None:
            side.unlink()
        else:
            side.write_text(sidecar if isinstance(sidecar, str) else json.dumps(sidecar))


def _store(run_dir: Path, study_id: str = "another-study", user_version: int | None = None) -> None:
    from offroadbench.study.store.store import Store

    with Store(run_dir, create=True) as store:
        store.init_meta({"study_id": study_id})
    if user_version is not None:
        con = sqlite3.connect(run_dir / "study.sqlite")
        con.execute(f"PRAGMA user_version={user_version}")
        con.close()


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    b = tmp_path_factory.mktemp("fuzz")
    (b / "adir").mkdir()
    (b / "dir.png").mkdir()
    (b / "afile").write_text("x")
    _png16(b / "good.png")
    good = (b / "good.png").read_bytes()
    (b / "empty.png").write_bytes(b"")
    (b / "hdr.png").write_bytes(good[:20])
    (b / "cut.png").write_bytes(good[: len(good) // 2])
    (b / "cut.json").write_text((b / "good.json").read_text())
    (b / "text.png").write_text("not a png at all\n")
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(b / "g8.png")
    Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(b / "rgb.png")
    meta = json.loads((b / "good.json").read_text())
    _png16(b / "strcell.png", sidecar={**meta, "cell_size_m": "five cm"})
    _png16(b / "negcell.png", sidecar={**meta, "cell_size_m": -0.05})
    _png16(b / "boolcell.png", sidecar={**meta, "cell_size_m": True})
    _png16(b / "flipz.png", sidecar={**meta, "z_min_m": 1.0, "z_max_m": 0.0})
    _png16(b / "rows.png", sidecar={**meta, "rows": 999})
    _png16(b / "badjson.png", sidecar="{not json")
    _png16(b / "listjson.png", sidecar=[1, 2, 3])
    _png16(b / "nometa.png", sidecar={"cell_size_m": 0.05})
    Image.fromarray(np.zeros((8, 8), np.uint16)).save(b / "bare16.png")
    (b / "bad.toml").write_text("[study\nname = 1\n")
    (b / "empty.toml").write_text("")
    (b / "binary.toml").write_bytes(b"\xff\xfe\x00\x01garbage")
    (b / "study.toml").write_text(STUDY.format(length=2.0))
    (b / "far.toml").write_text(STUDY.format(length=500.0))
    (b / "unknown.toml").write_text(STUDY.format(length=2.0).replace("[roughness]", "[roughness]\nbordr_m = 1"))
    (b / "noseed.toml").write_text(STUDY.format(length=2.0).replace("root_seed = 3\n", ""))
    _store(b / "corrupt", study_id="damaged")  # a real store whose pages after the header are garbage
    db = bytearray((b / "corrupt" / "study.sqlite").read_bytes())
    db[100:] = b"\x13" * (len(db) - 100)
    (b / "corrupt" / "study.sqlite").write_bytes(bytes(db))
    (b / "notdb").mkdir()
    (b / "notdb" / "study.sqlite").write_text("hello, I am a text file\n")
    (b / "foreign").mkdir()
    con = sqlite3.connect(b / "foreign" / "study.sqlite")
    con.execute("CREATE TABLE photos (id INTEGER, name TEXT)")
    con.commit()
    con.close()
    _store(b / "other")
    _store(b / "newer", user_version=99)
    # issue 23: hostile files
    _png16(b / "deepjson.png", sidecar="[" * 100_000 + "]" * 100_000)
    _png16(b / "digits.png", sidecar='{"cell_size_m": ' + "9" * 5000 + ', "z_min_m": 0, "z_max_m": 1}')
    _png16(b / "mixed.png")
    _png16(b / "other.png", rows=45)
    (b / "mixed.json").write_text((b / "other.json").read_text())  # a sidecar of another write
    (b / "deep.toml").write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    for stem, name in (("dotdot", ".."), ("newline", "a\\nb"), ("nul", "a\\u0000b"), ("slash", "a/b")):
        (b / f"{stem}.toml").write_text(STUDY.format(length=2.0).replace('name = "fuzz"', f'name = "{name}"'))
    big = ", ".join(repr(2.0 + 1e-6 * i) for i in range(20_001))
    (b / "huge.toml").write_text(STUDY.format(length=2.0).replace('"recipe.layers.base.D_high" = [2.3]',
                                                                   f'"missions.length_m" = [{big}]'))
    # issue 30: values outside physical bounds, a 1e12 m spike, absurd cell sizes
    _png16(b / "cell1e-6.png", sidecar={**meta, "cell_size_m": 1e-6})
    _png16(b / "cell5e-324.png", sidecar={**meta, "cell_size_m": 5e-324})
    _png16(b / "spike.png", sidecar={**meta, "z_max_m": 1e12})
    _png16(b / "range1e308.png", sidecar={**meta, "z_min_m": -1e308, "z_max_m": 1e308})  # issue 44: no RuntimeWarning
    from offroadbench import resources

    soil = resources.soil_files()["lunar-regolith"].read_text()
    (b / "absurd-soil.toml").write_text(soil.replace("k_phi = 820000.0", "k_phi = 1e300"))
    (b / "thick-soil.toml").write_text(soil.replace("cohesion_pa = 170.0", "cohesion_pa = 1e300"))
    husky = resources.vehicle_files()["husky"]
    (b / "absurd-vehicle").mkdir()
    for q in husky.parent.iterdir():
        if q.is_file():
            (b / "absurd-vehicle" / q.name).write_bytes(q.read_bytes())
    v = b / "absurd-vehicle" / "vehicle.toml"
    v.write_text(v.read_text().replace("wheel_torque_limit_nm = 28.0", "wheel_torque_limit_nm = 1e300"))
    # issue 44: a model file outside physical bounds, or not a URDF at all
    chassis = '<mass value="46.034"/>'
    urdfs = {f"mass-{tag}": husky.with_name("husky.urdf").read_text().replace(chassis, f'<mass value="{value}"/>')
             for tag, value in (("0", "0"), ("1e9", "1e9"), ("nan", "NaN"))}
    urdfs["not-xml"] = "this is not a URDF\n"
    urdfs["svg"] = '<svg xmlns="http://www.w3.org/2000/svg"><rect width="1" height="1"/></svg>\n'
    for stem, text in urdfs.items():
        (b / stem).mkdir()
        (b / stem / "vehicle.toml").write_text(husky.read_text())
        (b / stem / "husky.urdf").write_text(text)
        (b / f"study-{stem}.toml").write_text(STUDY.format(length=2.0) + f'\n[vehicle]\nname = "{stem}/vehicle.toml"\n')
        search = (Path(__file__).parents[1] / "search" / "small-search.toml").read_text()
        (b / f"search-{stem}.toml").write_text(search + f'\n[vehicle]\nname = "{stem}/vehicle.toml"\n')
    (b / "search.toml").write_text(search)
    # issue 44: stores that carry code or do not decode
    row = "INSERT INTO trials (cell, terrain, mission, terrain_seed, mission_seed, success, row) VALUES (0, 0, 0, 1, 2, 1, '{}')"
    for stem, sql in (("trigger", "CREATE TRIGGER t AFTER INSERT ON trials BEGIN UPDATE trials SET success = 1; END"),
                      ("view", "CREATE VIEW v AS SELECT * FROM trials"),
                      ("meta-not-json", "UPDATE meta SET value = '{not json' WHERE key = 'study_id'"),
                      ("deep-row", row.format("[" * 100_000 + "]" * 100_000))):
        _store(b / stem)
        con = sqlite3.connect(b / stem / "study.sqlite")
        with con:
            con.execute(sql)
        con.close()
    return b


#: (id, argv) -- every case must exit 2 with one stderr line and leave the tree as it was
CASES = [
    # generate
    ("gen-out-is-dir", ["generate", "paper-d2.45", "-o", "adir"]),
    ("gen-out-proc", ["generate", "paper-d2.45", "-o", "/proc/offroadbench/o.png"]),
    ("gen-out-under-file", ["generate", "paper-d2.45", "-o", "afile/o.png"]),
    ("gen-out-suffix", ["generate", "paper-d2.45", "-o", "o.txt"]),
    ("gen-huge-grid", ["generate", "paper-d2.45", "--set", "grid.rows=200000", "--set", "grid.cols=200000", "-o", "o.png"]),
    ("gen-recipe-syntax", ["generate", "bad.toml", "-o", "o.png"]),
    ("gen-recipe-dir", ["generate", "adir", "-o", "o.png"]),
    ("gen-recipe-empty", ["generate", "empty.toml", "-o", "o.png"]),
    ("gen-recipe-binary", ["generate", "binary.toml", "-o", "o.png"]),
    ("gen-seed-text", ["generate", "paper-d2.45", "--seed", "abc", "-o", "o.png"]),
    ("gen-D-string", ["generate", "paper-d2.45", "--set", "layers.base.D_high=\"x\"", "-o", "o.png"]),
    ("gen-cell-negative", ["generate", "paper-d2.45", "--set", "grid.cell_size_m=-1", "-o", "o.png"]),
    ("gen-missing-output", ["generate", "paper-d2.45"]),
    # analyze
    ("ana-missing", ["analyze", "missing.png"]),
    ("ana-dir", ["analyze", "dir.png"]),
    ("ana-empty", ["analyze", "empty.png"]),
    ("ana-truncated-header", ["analyze", "hdr.png"]),
    ("ana-truncated-data", ["analyze", "cut.png"]),
    ("ana-not-png", ["analyze", "text.png"]),
    ("ana-8-bit", ["analyze", "g8.png"]),
    ("ana-rgb", ["analyze", "rgb.png"]),
    ("ana-sidecar-string", ["analyze", "strcell.png"]),
    ("ana-sidecar-negative", ["analyze", "negcell.png"]),
    ("ana-sidecar-bool", ["analyze", "boolcell.png"]),
    ("ana-sidecar-z-order", ["analyze", "flipz.png"]),
    ("ana-sidecar-rows", ["analyze", "rows.png"]),
    ("ana-sidecar-not-json", ["analyze", "badjson.png"]),
    ("ana-sidecar-list", ["analyze", "listjson.png"]),
    ("ana-sidecar-missing-keys", ["analyze", "nometa.png"]),
    ("ana-no-metadata", ["analyze", "bare16.png"]),
    ("ana-plot-proc", ["analyze", "good.png", "--plot", "/proc/offroadbench.png"]),
    ("ana-border-negative", ["analyze", "good.png", "--border-m", "-1"]),
    ("ana-border-too-wide", ["analyze", "good.png", "--border-m", "100"]),
    ("ana-set-on-png", ["analyze", "good.png", "--set", "grid.rows=3"]),
    # roughness-study
    ("rs-out-file", ["roughness-study", "--terrains", "1", "--out", "afile"]),
    ("rs-out-proc", ["roughness-study", "--terrains", "1", "--out", "/proc/offroadbench"]),
    ("rs-bad-D", ["roughness-study", "--dims", "3.5", "--terrains", "1", "--out", "rs"]),
    ("rs-zero-terrains", ["roughness-study", "--terrains", "0", "--out", "rs"]),
    # drive
    ("drive-plot-no-out", ["drive", "good.png", "--plot"]),
    ("drive-map-too-small", ["drive", "good.png", "--out", "d"]),
    ("drive-vehicle", ["drive", "good.png", "--vehicle", "tank", "--out", "d"]),
    ("drive-length", ["drive", "good.png", "--length-m", "-5", "--out", "d"]),
    ("drive-empty-png", ["drive", "empty.png", "--out", "d"]),
    ("drive-out-under-file", ["drive", "good.png", "--out", "afile/d"]),
    ("drive-animate-suffix", ["drive", "good.png", "--animate", "d/a.avi"]),
    ("drive-plot-suffix", ["drive", "good.png", "--plot", "d/a.txt"]),
    ("drive-set-sim-unknown", ["drive", "good.png", "--set", "sim.nope=1", "--out", "d"]),
    ("drive-set-sim-range", ["drive", "good.png", "--set", "sim.physics_rate_hz=1", "--out", "d"]),
    ("drive-gravity-negative", ["drive", "good.png", "--gravity", "-1", "--out", "d"]),
    ("drive-border-negative", ["drive", "good.png", "--border-m", "-1", "--out", "d"]),
    # config
    ("config-unknown-section", ["config", "nosuch"]),
    ("config-reference-proc", ["config", "--write-reference", "/proc/offroadbench.md"]),
    # export
    ("exp-format", ["export", "good.png", "--format", "nosuch", "-o", "e"]),
    ("exp-out-proc", ["export", "good.png", "--format", "npy", "-o", "/proc/offroadbench"]),
    ("exp-truncated", ["export", "cut.png", "--format", "npy", "-o", "e"]),
    ("exp-missing-args", ["export", "good.png"]),
    # study run
    ("run-dir", ["study", "run", "adir", "--out", "r"]),
    ("run-empty", ["study", "run", "empty.toml", "--out", "r"]),
    ("run-syntax", ["study", "run", "bad.toml", "--out", "r"]),
    ("run-unknown-key", ["study", "run", "unknown.toml", "--out", "r"]),
    ("run-no-root-seed", ["study", "run", "noseed.toml", "--out", "r"]),
    ("run-workers-0", ["study", "run", "study.toml", "--workers", "0", "--out", "r"]),
    ("run-scheduler-local", ["study", "run", "study.toml", "--scheduler", "tcp://127.0.0.1:1", "--out", "r"]),
    ("run-corrupt-store", ["study", "run", "study.toml", "--out", "corrupt"]),
    ("run-text-store", ["study", "run", "study.toml", "--out", "notdb"]),
    # (a 0-byte study.sqlite is no longer refused: stores are created atomically, and a run that
    # holds the directory's lock replaces such a leftover of an older version; tests/study/test_lock.py)
    ("run-foreign-store", ["study", "run", "study.toml", "--out", "foreign"]),
    ("run-newer-store", ["study", "run", "study.toml", "--out", "newer"]),
    ("run-other-study", ["study", "run", "study.toml", "--out", "other"]),
    ("run-out-proc", ["study", "run", "study.toml", "--out", "/proc/offroadbench"]),
    ("run-no-mission-possible", ["study", "run", "far.toml", "--workers", "1", "--out", "new/far"]),
    ("run-toml-deep", ["study", "run", "deep.toml", "--out", "r"]),
    ("run-name-dotdot", ["study", "run", "dotdot.toml"]),
    ("run-name-newline", ["study", "run", "newline.toml"]),
    ("run-name-nul", ["study", "run", "nul.toml"]),
    ("run-name-slash", ["study", "run", "slash.toml"]),
    ("run-huge-grid", ["study", "run", "huge.toml", "--out", "r"]),
    ("run-timeout-inline", ["study", "run", "study.toml", "--executor", "inline", "--trial-timeout-s", "5", "--out", "r"]),
    # issue 30
    ("run-timeout-1e10", ["study", "run", "study.toml", "--trial-timeout-s", "1e10", "--out", "r"]),
    ("run-timeout-dask-1e10", ["study", "run", "study.toml", "--executor", "dask", "--trial-timeout-s", "1e10",
                               "--out", "r"]),
    ("gen-cell-1e-6", ["generate", "paper-d2.45", "--set", "grid.cell_size_m=1e-6", "-o", "o.png"]),
    ("gen-cell-5e-324", ["generate", "paper-d2.45", "--set", "grid.cell_size_m=5e-324", "-o", "o.png"]),
    ("ana-cell-1e-6", ["analyze", "cell1e-6.png"]),
    ("ana-cell-5e-324", ["analyze", "cell5e-324.png"]),
    ("drive-spike-1e12", ["drive", "spike.png", "--border-m", "0.2", "--length-m", "1", "--missions", "1",
                          "--out", "d"]),
    ("drive-days-of-work", ["drive", "good.png", "--length-m", "1e7", "--out", "d"]),
    ("drive-vehicle-absurd", ["drive", "good.png", "--vehicle", "absurd-vehicle/vehicle.toml", "--out", "d"]),
    ("soil-check-absurd-k-phi", ["soil", "check", "absurd-soil.toml"]),
    ("soil-check-absurd-cohesion", ["soil", "check", "thick-soil.toml"]),
    ("gen-recipe-deep", ["generate", "deep.toml", "-o", "o.png"]),
    ("ana-sidecar-deep", ["analyze", "deepjson.png"]),
    ("ana-sidecar-digits", ["analyze", "digits.png"]),
    ("ana-sidecar-of-another-png", ["analyze", "mixed.png"]),
    ("ana-sidecar-range-1e308", ["analyze", "range1e308.png"]),
    ("drive-sidecar-range-1e308", ["drive", "range1e308.png", "--out", "d"]),
    # issue 44: a per-trial limit below the study's shortest possible trial
    ("run-timeout-0.001", ["study", "run", "study.toml", "--trial-timeout-s", "0.001", "--out", "r"]),
    ("run-timeout-1e-9", ["study", "run", "study.toml", "--trial-timeout-s", "1e-9", "--out", "r"]),
    ("run-timeout-dask-0.001", ["study", "run", "study.toml", "--executor", "dask", "--trial-timeout-s", "0.001",
                                "--out", "r"]),
    ("search-timeout-0.001", ["search", "run", "search.toml", "--trial-timeout-s", "0.001", "--out", "s"]),
    # issue 44: the vehicle's URDF outside physical bounds, or not a URDF
    *[case for stem in ("mass-0", "mass-1e9", "mass-nan", "not-xml", "svg") for case in (
        (f"drive-urdf-{stem}", ["drive", "good.png", "--vehicle", f"{stem}/vehicle.toml", "--out", "d"]),
        (f"run-urdf-{stem}", ["study", "run", f"study-{stem}.toml", "--out", "r"]),
        (f"vehicle-check-urdf-{stem}", ["vehicle", "check", f"{stem}/vehicle.toml"]),
        (f"search-urdf-{stem}", ["search", "run", f"search-{stem}.toml", "--out", "s"]))],
    # issue 44: a store that carries code, or whose values do not decode
    *[case for stem in ("trigger", "view", "meta-not-json", "deep-row") for case in (
        (f"run-store-{stem}", ["study", "run", "study.toml", "--out", stem]),
        (f"rep-store-{stem}", ["study", "report", stem]),
        (f"sexp-store-{stem}", ["study", "export", stem]),
        (f"search-store-{stem}", ["search", "run", "search.toml", "--out", stem]),
        (f"search-report-store-{stem}", ["search", "report", stem]))],
    # study export / report
    ("sexp-not-a-run", ["study", "export", "adir"]),
    ("sexp-corrupt", ["study", "export", "corrupt"]),
    ("sexp-out-proc", ["study", "export", "other", "--out", "/proc/offroadbench"]),
    ("rep-newer", ["study", "report", "newer"]),
    ("rep-foreign", ["study", "report", "foreign"]),
    ("rep-fig4", ["study", "report", "other", "--fig4", "x"]),
    ("replay-animate-suffix", ["study", "replay", "other", "--cell", "0", "--terrain", "0", "--mission", "0",
                               "--animate", "a.avi"]),
]

#: cases also run as ordinary cold subprocesses of the console script
COLD = ("ana-truncated-data", "run-corrupt-store", "drive-map-too-small")


def _check(case_id: str, res: dict) -> None:
    err = res["stderr"]
    assert not res["timed_out"], f"{case_id}: still running after 30 s"
    assert res["code"] == 2, f"{case_id}: exit {res['code']}, stderr:\n{err}"
    assert "Traceback" not in err, f"{case_id}:\n{err}"
    assert err.count("\n") == 1 and err.endswith("\n"), f"{case_id}: not one stderr line:\n{err}"
    assert "pybullet" not in err + res["stdout"], f"{case_id}: banner"
    for key in ("added", "removed", "changed"):
        assert not res.get(key), f"{case_id}: files {key}: {res[key]}"
    if "-timeout-" in case_id and "1e10" not in case_id and "inline" not in case_id:
        assert "shortest possible trial" in err, f"{case_id}:\n{err}"
    if "-store-" in case_id:  # the line names the store and what is wrong with it
        stem = case_id.split("-store-")[1]
        assert f"{stem}/study.sqlite: " in err, f"{case_id}: the store is not named:\n{err}"
        assert ("corrupt study store" if stem in ("meta-not-json", "deep-row") else "which no offroadbench store has") \
            in err, f"{case_id}:\n{err}"
    if "-urdf-" in case_id:  # the line names the model file, and the link where one is wrong
        stem = case_id.split("-urdf-")[1]
        assert f"/{stem}/husky.urdf" in err, f"{case_id}: the file is not named:\n{err}"
        assert not stem.startswith("mass-") or "'base_link'" in err, f"{case_id}: the link is not named:\n{err}"


def test_every_bad_input_is_one_line_exit_2_and_leaves_nothing(base, tmp_path):
    assert len(CASES) >= 40
    assert len({c for c, _ in CASES}) == len(CASES)
    commands = {argv[0] if argv[0] != "study" else f"study {argv[1]}" for _, argv in CASES}
    assert commands >= {"generate", "analyze", "roughness-study", "drive", "export", "study run", "study export", "study report"}
    cases = tmp_path / "cases.json"
    cases.write_text(json.dumps([{"id": c, "argv": argv} for c, argv in CASES]))
    logs = tmp_path / "logs"
    logs.mkdir()
    proc = subprocess.run([sys.executable, str(DRIVER), str(cases), str(base), str(logs)],
                          capture_output=True, text=True, timeout=60 * len(CASES))
    assert proc.returncode == 0, proc.stderr
    results = json.loads(proc.stdout)
    failures = []
    for res in results:
        try:
            _check(res["id"], res)
        except AssertionError as exc:
            failures.append(str(exc))
    assert not failures, "\n\n".join(failures)


@pytest.mark.parametrize("case_id", COLD)
def test_cold_console_script_prints_one_line(base, case_id):
    argv = dict(CASES)[case_id]
    exe = Path(sys.executable).with_name("offroadbench")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "offroadbench.cli"]
    res = subprocess.run([*cmd, *argv], cwd=base, capture_output=True, text=True, timeout=30)
    _check(case_id, {"code": res.returncode, "timed_out": False, "stderr": res.stderr, "stdout": res.stdout})


# ---------------------------------------------------------------------------- issue 30, item 6
def _cli(args: list[str], cwd: Path, env: dict | None = None, preexec=None) -> subprocess.CompletedProcess:
    import os

    code = "import sys; from offroadbench.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], cwd=cwd, capture_output=True, text=True, errors="replace", timeout=120,
                          env={**os.environ, **(env or {})}, preexec_fn=preexec)


def test_non_utf8_file_names_export_and_plot_without_a_traceback(base, tmp_path):
    import os

    name = os.fsdecode(b"m\xff.png")  # a file name that is not UTF-8
    (tmp_path / name).write_bytes((base / "good.png").read_bytes())
    (tmp_path / os.fsdecode(b"m\xff.json")).write_bytes((base / "good.json").read_bytes())
    res = _cli(["export", name, "--format", "unreal", "--name", "ok", "-o", "ue"], tmp_path)
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
    assert (tmp_path / "ue" / "ok.png").is_file()
    res = _cli(["analyze", name, "--border-m", "0.2", "--plot", os.fsdecode(b"p\xff.png")], tmp_path)
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
    assert (tmp_path / os.fsdecode(b"p\xff.png")).is_file()


def test_a_huge_png_under_an_address_space_limit_is_one_line(tmp_path):
    import resource

    from PIL import Image

    Image.fromarray(np.zeros((8000, 8000), np.uint16)).save(tmp_path / "big.png")
    (tmp_path / "big.json").write_text(json.dumps({"cell_size_m": 0.05, "z_min_m": 0.0, "z_max_m": 1.0}))

    def limit() -> None:  # 3 GiB of address space: the interpreter fits, the 8000^2 analysis (5 GB) does not
        resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))

    res = _cli(["analyze", "big.png"], tmp_path, preexec=limit)
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert "address-space limit" in res.stderr and "Traceback" not in res.stderr


def test_a_policy_raising_in_drive_is_one_line(base, tmp_path, monkeypatch, capsys):
    from offroadbench.cli import main
    from offroadbench.navigation.drivers import POLICIES, PolicySpec

    class Raises:
        def __init__(self, cfg, context) -> None:
            pass

        def reset(self, problem) -> None:
            pass

        def act(self, obs):
            raise ZeroDivisionError("division by zero in the policy")

    POLICIES.add("raises-test", PolicySpec(Raises, summary="test policy"))
    try:
        monkeypatch.chdir(tmp_path)
        code = main(["drive", "paper-d2.45", "--set", "grid.rows=161", "--set", "grid.cols=161", "--border-m", "1",
                     "--length-m", "3", "--missions", "1", "--planner", "raises-test"])
    finally:
        POLICIES._entries.pop("raises-test", None)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert "policy 'raises-test' failed in act() at t = 0.00 s: ZeroDivisionError: division by zero" in err[0]


def test_a_trial_fault_in_drive_is_one_line(tmp_path, monkeypatch, capsys):
    """A vehicle thrown while it settles (legal values that combine badly) ends ``drive`` with one
    line and exit 1, not a TrialFault traceback (issue 44), and writes no output folder."""
    from offroadbench.cli import main
    from offroadbench.errors import TrialFault
    from offroadbench.sim.trial import runner

    def thrown(*args, **kwargs):
        raise TrialFault("the vehicle was thrown while it settled (test)")

    monkeypatch.setattr(runner, "check_settled", thrown)
    monkeypatch.chdir(tmp_path)
    code = main(["drive", "paper-d2.45", "--set", "grid.rows=161", "--set", "grid.cols=161", "--border-m", "1",
                 "--length-m", "3", "--missions", "1", "--out", "d"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err == ["offroadbench: trial fault: the vehicle was thrown while it settled (test)"]
    assert not (tmp_path / "d").exists()


def test_soil_list_names_an_invalid_user_soil_and_lists_the_others(base, tmp_path):
    user = tmp_path / "user" / "soils"
    user.mkdir(parents=True)
    (user / "absurd.toml").write_text((base / "absurd-soil.toml").read_text().replace(
        'name = "lunar-regolith"', 'name = "absurd"'))
    res = _cli(["soil", "list"], tmp_path, env={"OFFROADBENCH_PATH": str(tmp_path / "user")})
    assert res.returncode == 0, res.stderr
    assert "lunar-regolith" in res.stdout and "absurd" not in res.stdout
    assert res.stderr.count("\n") == 1 and "invalid soil absurd" in res.stderr and "k_phi = 1e+300" in res.stderr


def test_drive_out_on_a_full_disk_leaves_nothing(tmp_path, monkeypatch):
    import errno
    from types import SimpleNamespace

    from offroadbench.cli.drive import write_drive_run
    from offroadbench.io import telemetry

    calls = {"n": 0}
    real = telemetry.save_telemetry

    def fills_up(columns, path, **kw):
        calls["n"] += 1
        if calls["n"] == 2:  # the second mission's telemetry
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(columns, path, **kw)

    monkeypatch.setattr(telemetry, "save_telemetry", fills_up)
    run = SimpleNamespace(rows=lambda: [{"mission": 0}, {"mission": 1}],
                          telemetry={k: {"t_s": np.arange(3.0), "x_m": np.zeros(3)} for k in (0, 1)})
    with pytest.raises(OSError) as info:
        write_drive_run(run, tmp_path / "out")
    assert info.value.errno == errno.ENOSPC and str(tmp_path / "out") in str(info.value.filename)
    assert list(tmp_path.iterdir()) == []  # no trials.csv without its telemetry, no staging folder
