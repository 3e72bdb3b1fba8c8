"""Contract tests over every registered export format (DESIGN.md, STYLE.md smell 8).

Every exporter writes files that its reader (the target tool's documented mapping from file to
world, ``Exporter.read``) turns back into the same heights on the same grid, within the format's
stated precision, with sample (0, 0) at the origin and nothing mirrored or transposed; and an
export that fails at any stage leaves no file behind and an existing directory as it was.
tests/io/test_export_readers.py does the same with the real tools (MuJoCo, rasterio, usd-core, ...).
"""

import os

import numpy as np
import pytest

from offroadbench import Heightmap, InputError
from offroadbench.io.export import EXPORTERS, export_heightmap, read_export
from offroadbench.io.export import _staging

FORMATS = EXPORTERS.names()


def _needs(fmt):
    for module in EXPORTERS.get(fmt).requires:
        pytest.importorskip(module)
    return EXPORTERS.get(fmt)


@pytest.fixture
def hm():
    """17 x 17 (a Gazebo size, so no format resamples), heights far from 0, one distinct peak off
    every symmetry axis: a flip, transpose or offset shows as a moved peak or wrong heights."""
    rng = np.random.default_rng(7)
    z = rng.normal(size=(17, 17)) * 0.3 + 12.0
    z[3, 12] = 15.5
    z[14, 1] = 10.25  # a distinct minimum too
    return Heightmap(z, 0.05)


def _snapshot(d):
    return {p.relative_to(d): (p.read_bytes() if p.is_file() else None) for p in d.rglob("*")}


@pytest.mark.parametrize("fmt", FORMATS)
def test_round_trip_heights_and_placement(fmt, hm, tmp_path):
    exporter = _needs(fmt)
    result = export_heightmap(hm, fmt, tmp_path / "out", name="t", meta={"seed": 3})
    assert result.files and all(p.is_file() for p in result.files)
    assert not [p for p in (tmp_path / "out").rglob(".*")]  # no staging leftovers
    back = read_export(tmp_path / "out", fmt, name="t")
    assert back.shape == hm.shape
    assert back.cell_size_m == pytest.approx(hm.cell_size_m, rel=1e-12)
    err = np.max(np.abs(back.z - hm.z))
    assert err <= exporter.precision_m(hm), f"{fmt}: height error {err} > precision {exporter.precision_m(hm)}"
    assert np.unravel_index(np.argmax(back.z), back.shape) == (3, 12)
    assert np.unravel_index(np.argmin(back.z), back.shape) == (14, 1)


@pytest.mark.parametrize("fmt", FORMATS)
def test_precision_is_at_worst_half_a_16_bit_step(fmt, hm):
    """No format may lose more than the 16-bit PNG formats do (a stated precision cannot hide a bug)."""
    assert EXPORTERS.get(fmt).precision_m(hm) <= hm.relief_m / 65535 / 2 * (1 + 1e-6)


@pytest.mark.parametrize("fmt", FORMATS)
def test_failure_after_writing_leaves_nothing(fmt, hm, tmp_path, monkeypatch):
    exporter = _needs(fmt)

    def write_then_fail(*args, **kwargs):
        exporter.write(*args, **kwargs)
        raise OSError(28, "No space left on device")

    monkeypatch.setitem(EXPORTERS._entries, fmt, type(exporter)(**{**exporter.__dict__, "write": write_then_fail}))
    with pytest.raises(OSError):
        export_heightmap(hm, fmt, tmp_path / "new", name="t")
    assert list(tmp_path.iterdir()) == []

    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "keep.txt").write_text("mine")
    before = _snapshot(tmp_path / "old")
    with pytest.raises(OSError):
        export_heightmap(hm, fmt, tmp_path / "old", name="t")
    assert _snapshot(tmp_path / "old") == before


@pytest.mark.parametrize("fmt", FORMATS)
def test_failed_last_move_restores_the_previous_export(fmt, hm, tmp_path, monkeypatch):
    _needs(fmt)
    export_heightmap(hm, fmt, tmp_path, name="t")
    before = _snapshot(tmp_path)
    n_files = sum(1 for v in before.values() if v is not None)
    real_replace = os.replace
    calls = []

    def flaky(src, dst):  # per file: set the old one aside, move the new one in; the last move fails
        calls.append(dst)
        if len(calls) == 2 * n_files:
            raise OSError(28, "No space left on device")
        return real_replace(src, dst)

    monkeypatch.setattr(_staging.os, "replace", flaky)
    # the file-by-file fallback (the one-step directory swap: tests/io/test_all_or_nothing.py)
    monkeypatch.setattr(_staging, "_exchange", lambda a, b: False)
    with pytest.raises(OSError):
        export_heightmap(hm.with_z(hm.z * 2 + 1), fmt, tmp_path, name="t")
    assert _snapshot(tmp_path) == before


@pytest.mark.parametrize("fmt", FORMATS)
def test_entry_describes_itself(fmt):
    exporter = EXPORTERS.get(fmt)
    assert exporter.name == fmt and exporter.summary and exporter.reader
    assert (exporter.extra is None) == (not exporter.requires)


def test_missing_optional_package_is_an_input_error_naming_the_extra(hm, tmp_path, monkeypatch):
    exporter = EXPORTERS.get(FORMATS[0])
    fake = type(exporter)(**{**exporter.__dict__, "requires": ("no_such_module_for_offroadbench",), "extra": "geo"})
    monkeypatch.setitem(EXPORTERS._entries, FORMATS[0], fake)
    with pytest.raises(InputError, match=r"needs the no_such_module_for_offroadbench package; pip install 'offroadbench\[geo\]'"):
        export_heightmap(hm, FORMATS[0], tmp_path / "o")
    assert list(tmp_path.iterdir()) == []
