"""The platform a study's trials ran on, and whether a trial stored on one platform is promised
to come out bit for bit the same on another.

:func:`platform_fingerprint` describes this process: the architecture and CPU model, numpy's
enabled SIMD dispatch targets (``numpy._core._multiarray_umath.__cpu_features__`` restricted to
``__cpu_dispatch__``: what ``np.show_runtime()`` lists as found), OpenBLAS's version and the
core type its kernels were chosen for (threadpoolctl), whether the CPU has AVX2 and FMA (its
``/proc/cpuinfo`` flags: glibc's ``sin``/``exp``/``atan2`` take other code paths without them),
the versions of the code a trial's numbers go through (numpy, pybullet, ruckig, finufft, glibc,
Python), and the environment switches that change numpy's or OpenBLAS's dispatch
(``NPY_DISABLE_CPU_FEATURES``, ``OPENBLAS_CORETYPE``). ``study run`` stores it per session
(``runs.platform``).

The promise (:func:`identity_promise`), as the README's reproducibility contract states it:

* terrain quantised to 16-bit levels (``[grid] quantise = "png16"``, the default) and the
  dispatch-free trial loop give identical trials on every x86-64 CPU with AVX2 and FMA, given the
  same versions of numpy, pybullet, ruckig, finufft and glibc (and the same offroadbench);
* float64 terrain (``quantise = "none"``) is identical only on the same *CPU kind*: the same
  architecture, numpy dispatch targets and OpenBLAS core type (SIMD transcendental functions,
  BLAS kernels and FFTW's codelets differ in their last bits between kinds), with those versions;
* other architectures, x86-64 without AVX2/FMA and other versions are not covered.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping
from typing import Any

__all__ = ["TRIAL_PACKAGES", "cpu_kind", "describe", "identity_promise", "platform_fingerprint"]

#: code whose versions decide a trial's bits (the README's contract)
TRIAL_PACKAGES = ("numpy", "pybullet", "ruckig", "finufft", "glibc")
_ALL_PACKAGES = ("numpy", "pybullet", "ruckig", "finufft")
_X86_64 = ("x86_64", "amd64")


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _avx2_fma() -> bool | None:
    """Whether the CPU has AVX2 and FMA (``/proc/cpuinfo`` flags; None where unknown)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
                    return {"avx2", "fma"} <= flags
    except OSError:
        pass
    return None


def _numpy_dispatch() -> tuple[list[str], list[str]]:
    """(baseline, enabled dispatch targets) of numpy's SIMD loops in this process."""
    try:
        from numpy._core import _multiarray_umath as umath  # numpy >= 2
    except ImportError:  # pragma: no cover - numpy 1.x
        from numpy.core import _multiarray_umath as umath
    features = getattr(umath, "__cpu_features__", {})
    dispatch = list(getattr(umath, "__cpu_dispatch__", []))
    baseline = list(getattr(umath, "__cpu_baseline__", []))
    return baseline, [t for t in dispatch if features.get(t)]


def _openblas() -> dict[str, Any]:
    """numpy's OpenBLAS (its wheel's ``numpy.libs`` copy; scipy may load another one, which is
    left out so the fingerprint does not depend on what else the process imported)."""
    try:
        from threadpoolctl import threadpool_info
    except ImportError:  # pragma: no cover - a declared dependency
        return {}
    import numpy

    libs = [lib for lib in threadpool_info() if lib.get("internal_api") == "openblas"]
    root = os.path.dirname(os.path.dirname(numpy.__spec__.origin))  # site-packages holding numpy
    ours = [lib for lib in libs if os.path.basename(os.path.dirname(lib.get("filepath", ""))) == "numpy.libs"
            or str(lib.get("filepath", "")).startswith(os.path.join(root, "numpy"))]
    for lib in ours or libs[:1]:
        return {"version": lib.get("version"), "core": lib.get("architecture")}
    return {}


def _version(name: str) -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return None


def platform_fingerprint() -> dict[str, Any]:
    """This process's platform (see the module docstring); plain JSON data."""
    baseline, targets = _numpy_dispatch()
    env = {k: os.environ[k] for k in ("NPY_DISABLE_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")
           if os.environ.get(k)}
    return {
        "arch": platform.machine(),
        "cpu": _cpu_model(),
        "numpy_baseline": baseline,
        "numpy_dispatch": targets,
        "avx2_fma": _avx2_fma(),
        "openblas": _openblas(),
        "versions": {**{p: _version(p) for p in _ALL_PACKAGES}, "glibc": platform.libc_ver()[1] or None,
                     "python": platform.python_version()},
        "env": env,
    }


def cpu_kind(fp: Mapping[str, Any]) -> tuple:
    """What decides float64 results' last bits: architecture, numpy dispatch targets, OpenBLAS core."""
    return (fp.get("arch"), tuple(fp.get("numpy_dispatch") or ()), (fp.get("openblas") or {}).get("core"))


def describe(fp: Mapping[str, Any] | None) -> str:
    """One line, e.g. ``AMD EPYC (x86_64; numpy X86_V3 X86_V4; OpenBLAS 0.3.31 Haswell); numpy 2.4.0, ...``."""
    if not fp:
        return "not recorded (a session of an older offroadbench)"
    ob = fp.get("openblas") or {}
    targets = " ".join(fp.get("numpy_dispatch") or []) or "baseline only"
    versions = ", ".join(f"{k} {v}" for k, v in (fp.get("versions") or {}).items() if v and k != "python")
    env = "; ".join(f"{k}={v}" for k, v in (fp.get("env") or {}).items())
    text = (f"{fp.get('cpu')} ({fp.get('arch')}; numpy {targets}; OpenBLAS {ob.get('version', '?')} "
            f"{ob.get('core', '?')}); {versions}")
    return f"{text}; {env}" if env else text


def identity_promise(stored: Mapping[str, Any] | None, here: Mapping[str, Any], quantise: str,
                     stored_version: str | None = None, version: str | None = None) -> tuple[bool | None, str]:
    """Whether a trial stored on platform ``stored`` is promised to replay bit for bit ``here``.

    ``quantise`` is the terrain's ``[grid] quantise`` setting (``"png16"`` or ``"none"``);
    ``stored_version``/``version`` the offroadbench versions of the two runs (optional). Returns
    (True, why) when promised, (False, why) when not covered, (None, why) when the stored
    platform is unknown (a store of an older offroadbench)."""
    if version is not None and stored_version is not None and version != stored_version:
        return False, f"it was run by offroadbench {stored_version}, this is {version}"
    if not stored:
        return None, "the platform of the stored trial was not recorded"
    if stored.get("arch") != here.get("arch"):
        return False, f"architecture {stored.get('arch')} vs {here.get('arch')}: not covered"
    sv, hv = stored.get("versions") or {}, here.get("versions") or {}
    differ = [f"{p} {sv.get(p)} vs {hv.get(p)}" for p in TRIAL_PACKAGES if sv.get(p) != hv.get(p)]
    if differ:
        return False, "other versions (" + ", ".join(differ) + ") are not covered"
    if cpu_kind(stored) == cpu_kind(here):
        return True, "same CPU kind and versions"
    if quantise == "none":
        return False, ('float64 terrain (quantise = "none") is promised only on the same CPU kind '
                       "(numpy dispatch targets and OpenBLAS core)")
    if str(here.get("arch")).lower() not in _X86_64:
        return False, f"only x86-64 is covered across CPU kinds, this is {here.get('arch')}"
    if not (stored.get("avx2_fma") and here.get("avx2_fma")):
        return False, "only x86-64 CPUs with AVX2 and FMA are covered across CPU kinds"
    return True, "quantised terrain and the same versions on x86-64 CPUs with AVX2 and FMA"
