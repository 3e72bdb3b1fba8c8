"""A study worker makes the cyclic collector's full collections rarer and freezes what it inherited
(offroadbench.study.execution.common.worker_bootstrap): a full collection walks every tracked object,
numba's and MuJoCo's modules included, and cost ~1.5 % of a MuJoCo worker's driving CPU (branch perf3)."""

from __future__ import annotations

import subprocess
import sys

CODE = """
import gc
import sys
mode = sys.argv[1]
junk = [[i] for i in range(1000)]  # tracked objects alive before the bootstrap
if mode == "worker":
    from offroadbench.study.execution.common import WORKER_GC_THRESHOLDS, worker_bootstrap
    worker_bootstrap()
    assert gc.get_threshold() == WORKER_GC_THRESHOLDS, gc.get_threshold()
print(gc.get_threshold()[2], gc.get_freeze_count())
"""


def test_a_worker_collects_fully_ten_times_rarer_and_freezes_its_inheritance():
    out = {}
    for mode in ("plain", "worker"):
        r = subprocess.run([sys.executable, "-c", CODE, mode], capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        out[mode] = [int(v) for v in r.stdout.split()]
    assert out["worker"][0] == 10 * out["plain"][0], out
    assert out["plain"][1] == 0 and out["worker"][1] >= 1000, out
