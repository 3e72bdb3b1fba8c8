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
    from offroadbench.study.store import Store

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
    ("gen-recipe-deep", ["generate", "deep.toml", "-o", "o.png"]),
    ("ana-sidecar-deep", ["analyze", "deepjson.png"]),
    ("ana-sidecar-digits", ["analyze", "digits.png"]),
    ("ana-sidecar-of-another-png", ["analyze", "mixed.png"]),
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
