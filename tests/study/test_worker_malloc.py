"""A study worker's threads share glibc's main malloc arena (offroadbench.memory.one_malloc_arena,
called by every worker's bootstrap): the terrain's thread pool otherwise allocates in arenas of its
own that keep what it frees (issue 41: a MuJoCo worker's peak 345 -> 310 MB)."""

from __future__ import annotations

import ctypes
import subprocess
import sys

import pytest

# a thread allocates 64 KiB blocks; malloc_info's XML then lists one <heap> per arena
CODE = """
import ctypes, os, sys, tempfile, threading
if sys.argv[1] == "worker":
    from offroadbench.study.execution.common import worker_bootstrap
    worker_bootstrap()
held = []
t = threading.Thread(target=lambda: held.extend(bytearray(65536) for _ in range(16)))
t.start(); t.join()
libc = ctypes.CDLL(None)
libc.fopen.restype = ctypes.c_void_p
libc.fopen.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
libc.malloc_info.argtypes = [ctypes.c_int, ctypes.c_void_p]
libc.fclose.argtypes = [ctypes.c_void_p]
path = os.path.join(tempfile.mkdtemp(), "info.xml")
fp = libc.fopen(path.encode(), b"w")
libc.malloc_info(0, fp)
libc.fclose(fp)
print(open(path).read().count("<heap nr="))
"""


def _glibc() -> bool:
    try:
        libc = ctypes.CDLL(None)
        return hasattr(libc, "malloc_info") and hasattr(libc, "mallopt")
    except OSError:
        return False


@pytest.mark.skipif(not _glibc(), reason="glibc only (mallopt, malloc_info)")
def test_a_workers_threads_share_one_malloc_arena():
    arenas = {}
    for mode in ("plain", "worker"):
        r = subprocess.run([sys.executable, "-c", CODE, mode], capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        arenas[mode] = int(r.stdout.split()[-1])
    assert arenas["plain"] >= 2, arenas  # glibc's own behaviour: the thread got an arena of its own
    assert arenas["worker"] == 1, arenas
