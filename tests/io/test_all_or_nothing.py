"""All or nothing on disk (issue 23, Deliver 3): a killed writer leaves the old complete output or
the new one, never a mix that reads back without error; its temporary files are removed by the
next write to the same path."""

from __future__ import annotations

import json
import multiprocessing
import os

import numpy as np
import pytest

from offroadbench import Heightmap, InputError
from offroadbench.io import atomic
from offroadbench.io.export import _staging as staging
from offroadbench.io.export import export_heightmap
from offroadbench.io.png16 import read_png16, sidecar_path, write_png16


def maps():
    rng = np.random.default_rng(7)
    a = Heightmap(rng.random((40, 50)) * 2.0, 0.1)
    b = Heightmap(rng.random((40, 50)) * 3.0 - 1.0, 0.1)
    return a, b


def in_child(fn, *args) -> int:
    ctx = multiprocessing.get_context("fork")
    p = ctx.Process(target=fn, args=args)
    p.start()
    p.join(60)
    return p.exitcode


def dotfiles(d):
    return sorted(q.name for q in d.iterdir() if q.name.startswith("."))


# ---------------------------------------------------------------------------- PNG + sidecar
def _write_killed_at_sidecar(path) -> None:
    real = os.replace
    calls = []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 2:  # the PNG is in place, the sidecar is not
            os._exit(9)
        return real(src, dst)

    atomic.os.replace = replace
    write_png16(maps()[1], path)


def test_a_png_killed_between_its_renames_is_refused_not_misread(tmp_path):
    a, b = maps()
    png = tmp_path / "t.png"
    meta = write_png16(a, png)
    assert meta["png_bytes"] == png.stat().st_size and len(meta["png_sha256"]) == 64
    assert json.loads(sidecar_path(png).read_text())["png_sha256"] == meta["png_sha256"]
    assert np.array_equal(read_png16(png).z, read_png16(png).z)
    assert in_child(_write_killed_at_sidecar, png) == 9
    assert dotfiles(tmp_path)  # the killed writer's temporary sidecar
    with pytest.raises(InputError, match=r"t.json: belongs to another PNG than .*t.png"):
        read_png16(png)
    write_png16(b, png)  # the next write to the path sweeps the dead writer's temporary file
    assert dotfiles(tmp_path) == []
    assert np.allclose(read_png16(png).z, b.z, atol=b.relief_m / 65535)


def test_the_cli_refuses_a_mixed_pair_in_one_line(tmp_path, capsys):
    from offroadbench.cli import main

    a, _ = maps()
    png = tmp_path / "t.png"
    write_png16(a, png)
    assert in_child(_write_killed_at_sidecar, png) == 9
    assert main(["analyze", str(png)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "belongs to another PNG" in err


def test_an_older_sidecar_without_a_checksum_still_reads(tmp_path):
    a, _ = maps()
    png = tmp_path / "t.png"
    write_png16(a, png)
    side = sidecar_path(png)
    meta = json.loads(side.read_text())
    del meta["png_bytes"], meta["png_sha256"]
    side.write_text(json.dumps(meta))
    assert read_png16(png).shape == a.shape


@pytest.mark.parametrize("text", ["[" * 100_000 + "]" * 100_000, '{"cell_size_m": ' + "9" * 5000 + "}"])
def test_hostile_sidecar_json_is_one_input_error(tmp_path, text):
    a, _ = maps()
    png = tmp_path / "t.png"
    write_png16(a, png)
    sidecar_path(png).write_text(text)
    with pytest.raises(InputError, match="t.json: "):
        read_png16(png)


def test_a_live_writers_temporary_file_is_left_alone(tmp_path):
    live = tmp_path / f".t.png.{os.getpid()}.abcd.tmp"
    dead = tmp_path / ".t.png.999999999.abcd.tmp"
    live.write_text("x")
    dead.write_text("x")
    write_png16(maps()[0], tmp_path / "t.png")
    assert live.exists() and not dead.exists()


# ---------------------------------------------------------------------------- export directories
def _export_killed(out, point: str) -> None:
    real_link, real_exchange = staging._link_rest, staging._exchange

    if point == "linking":
        def link_rest(o, s):
            os.link(o / "keep.txt", s / "keep.txt")
            os._exit(9)
        staging._link_rest = link_rest
    elif point == "before_exchange":
        def exchange(a, b):
            os._exit(9)
        staging._exchange = exchange
    elif point == "after_exchange":
        def exchange(a, b):
            real_exchange(a, b)
            os._exit(9)
        staging._exchange = exchange
    elif point == "writing":
        real_write = atomic.os.replace
        calls = []

        def replace(src, dst):
            calls.append(dst)
            if len(calls) == 2:
                os._exit(9)
            return real_write(src, dst)

        atomic.os.replace = replace
    assert real_link
    export_heightmap(maps()[1], "unreal", out, name="t")
    os._exit(0)


def snapshot(d):
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("point", ["writing", "linking", "before_exchange", "after_exchange"])
def test_a_killed_export_over_an_existing_one_leaves_old_or_new_never_a_mix(tmp_path, point):
    a, b = maps()
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("the user's own file")
    (out / "sub").mkdir()
    (out / "sub" / "notes.md").write_text("notes")
    export_heightmap(a, "unreal", out, name="t")
    old = snapshot(out)
    ref = tmp_path / "ref"
    ref.mkdir()
    (ref / "keep.txt").write_text("the user's own file")
    (ref / "sub").mkdir()
    (ref / "sub" / "notes.md").write_text("notes")
    export_heightmap(b, "unreal", ref, name="t")
    new = snapshot(ref)
    assert old != new
    assert in_child(_export_killed, out, point) == 9
    now = snapshot(out)
    assert now == (new if point == "after_exchange" else old)
    assert read_png16(out / "t.png").shape == a.shape
    export_heightmap(b, "unreal", out, name="t")  # the next export removes what the killed one left
    assert snapshot(out) == new
    assert dotfiles(out) == [] and dotfiles(tmp_path) == []


def test_an_export_over_an_existing_directory_keeps_other_files_and_is_one_swap(tmp_path, monkeypatch):
    a, b = maps()
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    export_heightmap(a, "unreal", out, name="t")
    moved = []
    monkeypatch.setattr(staging, "_merge_into", lambda s, o: moved.append(s))
    export_heightmap(b, "unreal", out, name="t")
    assert moved == []  # swapped, not merged
    assert (out / "keep.txt").read_text() == "mine"
    assert np.allclose(read_png16(out / "t.png").z, b.z, atol=b.relief_m / 65535)
    assert dotfiles(out) == [] and dotfiles(tmp_path) == []


# ---------------------------------------------------------------------------- a full disk
class _FullDisk:
    """Stands in for the tempfile module of offroadbench.io.atomic: every temporary file fails."""

    def __getattr__(self, name):
        import tempfile

        return getattr(tempfile, name)

    @staticmethod
    def mkstemp(*a, **k):
        import errno

        raise OSError(errno.ENOSPC, "No space left on device")


def test_a_full_disk_is_one_line_naming_the_path_and_leaves_nothing(tmp_path, monkeypatch, capsys):
    from offroadbench.cli import main

    monkeypatch.setattr(atomic, "tempfile", _FullDisk())
    out = tmp_path / "t.png"
    assert main(["generate", "paper-d2.45", "--set", "grid.rows=65", "--set", "grid.cols=65", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no space left on the device" in err and str(tmp_path) in err
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    write_png16(maps()[0], out)
    monkeypatch.setattr(atomic, "tempfile", _FullDisk())
    assert main(["export", str(out), "--format", "unreal", "--out", str(tmp_path / "exp")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no space left on the device" in err
    assert sorted(q.name for q in tmp_path.iterdir()) == ["t.json", "t.png"]
