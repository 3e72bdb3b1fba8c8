"""The compiled Gaussian filter of seen_map (offroadbench.navigation.compiled.smooth) gives scipy's
numbers to the last bit, so the mast sensor's plans do not depend on whether numba is installed."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

import offroadbench.navigation.perception as perception
from offroadbench.heightmap import Heightmap

pytest.importorskip("numba")


def _hex(a) -> list[str]:
    return [float(x).hex() for x in np.ravel(a)]


@pytest.mark.parametrize(("shape", "sigma"), [((121, 137), 20.0), ((40, 9), 6.5), ((5, 300), 3.0), ((64, 64), 0.7)])
def test_gaussian_nearest_is_scipys_to_the_bit(shape, sigma):
    from offroadbench.navigation.compiled.smooth import gaussian_nearest

    rng = np.random.default_rng(len(shape) + int(10 * sigma))
    seen = rng.random(shape) < 0.5
    for a in (seen.astype(float), np.where(seen, rng.normal(0.0, 0.4, shape), 0.0), rng.normal(0.0, 1.0, shape)):
        want = gaussian_filter(a, sigma, mode="nearest")
        got = gaussian_nearest(a, sigma)
        assert _hex(got) == _hex(want)
        assert not np.array_equal(want, a)  # a real filter


def test_seen_map_is_the_same_with_and_without_the_compiled_filter(monkeypatch):
    rng = np.random.default_rng(4)
    y, x = np.mgrid[0:121, 0:101] * 0.05
    hm = Heightmap(0.3 * np.sin(x / 1.3) + 0.2 * np.sin((x + y) / 0.9), 0.05)
    seen = ((x - 2.0) ** 2 + (y - 3.0) ** 2 < 4.0) & (rng.random(hm.shape) < 0.9)
    out = []
    for use in (True, False):
        monkeypatch.setattr(perception, "USE_COMPILED_SMOOTHING", use)
        out.append(perception.seen_map(hm, seen).z)
    assert _hex(out[0]) == _hex(out[1])
    assert not np.array_equal(out[0], hm.z)


def test_the_compiled_sweep_and_filter_give_the_numpy_bits_when_compiled_for_the_x86_64_baseline(tmp_path):
    """numba compiles for the host CPU; compiled for the x86-64 baseline instead (no AVX, no FMA:
    ``NUMBA_CPU_NAME=x86-64``, a fresh cache) the mast sensor's sweep (navigation.compiled.sweep) and seen_map's
    filter (navigation.compiled.smooth) give the numpy/scipy path's bits: a mast drive's maps do not depend on the
    CPU's SIMD nor on whether numba is installed."""
    import hashlib
    import subprocess
    import sys

    from tests.compiled_baseline import run_compiled_for_x86_64_baseline

    code = (
        "import hashlib, math\n"
        "import numpy as np\n"
        "import offroadbench.navigation.perception as perception\n"
        "import offroadbench.navigation.sensor as sensor\n"
        "from offroadbench.heightmap import Heightmap\n"
        "from offroadbench.navigation.perception import PerceptionConfig\n"
        "sensor.USE_COMPILED_SWEEP = perception.USE_COMPILED_SMOOTHING = USE\n"
        "assert not USE or sensor._compiled_sweep() is not None  # numba is there: the compiled path runs\n"
        "y, x = np.mgrid[0:101, 0:121] * 0.05\n"
        "hm = Heightmap(0.3 * np.sin(x / 1.3) + 0.2 * np.sin((x + y) / 0.9) + 0.05 * np.cos(3.1 * x * y), 0.05)\n"
        "cfg = PerceptionConfig(sensor='mast', sensor_range_m=2.5, odometry_drift=0.05, scan_every_m=0.2)\n"
        "m = sensor.MastSensor(hm, cfg, np.random.default_rng(3), (1.0, 1.2), 0.3)\n"
        "h = hashlib.sha256()\n"
        "pos, heading = np.array((1.0, 1.2)), 0.3\n"
        "for k in range(60):\n"
        "    heading += 0.05 * math.sin(k)\n"
        "    pos = pos + 0.07 * np.array([math.cos(heading), math.sin(heading)])\n"
        "    m.update(pos, heading)\n"
        "    h.update(m.z.tobytes())\n"
        "h.update(perception.seen_map(hm, ~np.isnan(m.z)).z.tobytes())\n"
        "print(m.scans, h.hexdigest())\n"
    )
    compiled = run_compiled_for_x86_64_baseline(code.replace("USE", "True"), tmp_path)
    plain = subprocess.run([sys.executable, "-c", code.replace("USE", "False")], capture_output=True,
                           text=True, check=True).stdout
    assert compiled == plain and int(plain.split()[0]) > 10
    assert hashlib.sha256().hexdigest() not in plain
