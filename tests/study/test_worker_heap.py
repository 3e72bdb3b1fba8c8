"""A study worker lets glibc keep freed blocks while a terrain is prepared (offroadbench.memory.
reusing_freed_blocks, inside offroadbench.sim.trial.pipeline.prepare_terrain) and holds its
thresholds again afterwards; the prepared terrain is the same bytes either way, in either order."""

from __future__ import annotations

import ctypes
import subprocess
import sys

import pytest

from tests.study.test_worker_malloc import MALLINFO
from tests.terrain.test_bit_identical import NUFFT

# an 8 MB array freed, then a 4 MB one: inside the block it comes from the heap (mallinfo2's hblkhd,
# the bytes mmapped, does not grow by it), after the block it gets its own mapping again
THRESHOLDS = MALLINFO + """
import numpy as np
from offroadbench.memory import reusing_freed_blocks
from offroadbench.study.execution.common import worker_bootstrap
def mapped_growth():
    a = np.ones(2**20)
    del a
    before = libc.mallinfo2().hblkhd
    b = np.ones(2**19)
    grew = libc.mallinfo2().hblkhd - before
    del b
    return grew
worker_bootstrap()
print(mapped_growth())
with reusing_freed_blocks():
    print(mapped_growth())
print(mapped_growth())
"""

# the full-size paper terrain prepared with and without the block, in the order given
PREPARE = """
import contextlib, hashlib, sys
import offroadbench.sim.trial.pipeline as pipeline
from offroadbench.study.execution.common import worker_bootstrap
from offroadbench.sim.trial.settings import TrialSettings
from offroadbench.terrain.recipe import load_recipe
worker_bootstrap()
reuse = pipeline.reusing_freed_blocks
for mode in sys.argv[1:]:
    pipeline.reusing_freed_blocks = reuse if mode == "reuse" else contextlib.nullcontext
    p = pipeline.prepare_terrain(load_recipe("paper-d2.45"), 0, TrialSettings(), [(0, 11), (1, 12)])
    h = hashlib.sha256()
    for a in (p.maps.classes, p.maps.closed):
        h.update(a.tobytes())
    h.update(repr(p.missions).encode())
    print(mode, hashlib.sha256(p.hm.z.tobytes()).hexdigest(), h.hexdigest())
"""


def _glibc_with_mallinfo2() -> bool:
    try:
        return hasattr(ctypes.CDLL(None), "mallinfo2")
    except OSError:
        return False


def _run(code: str, *args: str) -> list[str]:
    r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return r.stdout.split("\n")[:-1]


@pytest.mark.skipif(not _glibc_with_mallinfo2(), reason="glibc >= 2.33 (mallinfo2) only")
def test_the_heap_is_reused_inside_the_block_and_released_after_it():
    held, inside, after = (int(x) for x in _run(THRESHOLDS))
    assert held >= 2**22 and after >= 2**22, (held, inside, after)  # its own mapping, returned when freed
    assert inside < 2**22, (held, inside, after)  # from the heap, which kept the 8 MB block's memory


def test_a_prepared_terrain_does_not_depend_on_the_heap():
    lines = _run(PREPARE, "reuse", "held", "reuse") + _run(PREPARE, "held", "reuse")
    rows = {tuple(line.split()[1:]) for line in lines}
    assert len(rows) == 1, lines
    (z_sha, _), = rows
    assert z_sha == NUFFT["full"]  # the pinned bits (tests/terrain/test_bit_identical.py)
