"""For the tests that a numba kernel's numbers do not depend on the CPU's SIMD: run code with numba
compiling for the x86-64 baseline."""

from __future__ import annotations

import os
import subprocess
import sys


def run_compiled_for_x86_64_baseline(code: str, cache_dir) -> str:
    """The standard output of ``python -c code`` with numba compiling for the x86-64 baseline (no AVX, no
    FMA: ``NUMBA_CPU_NAME=x86-64``, a fresh cache in ``cache_dir``)."""
    env = dict(os.environ, NUMBA_CPU_NAME="x86-64", NUMBA_CPU_FEATURES="", NUMBA_CACHE_DIR=str(cache_dir))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
