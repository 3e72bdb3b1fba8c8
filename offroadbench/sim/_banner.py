"""Keep pybullet's "pybullet build time: ..." banner out of the program's output.

The pybullet extension prints its banner through C stdio when it is imported (on stderr in
3.2.7; builds that print to stdout leave it in the C buffer, which is flushed when the process
exits, below everything the program printed). :func:`import_pybullet_quietly` imports pybullet
with file descriptors 1 and 2 pointed at /dev/null and flushes C stdio before it restores them,
so the banner goes nowhere whichever stream a build uses.

Application entry points call this (as ``offroadbench.sim.import_pybullet_quietly``): the
CLI's ``main`` and the study workers' bootstrap
(``offroadbench.study.execution.executors``); so does the PyBullet engine's own first import of pybullet
(``offroadbench.sim.engines.pybullet._pb``), so a program using the library sees no banner either.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from typing import Iterator

__all__ = ["import_pybullet_quietly", "silenced_fds"]


def _flush_c_stdio() -> None:
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):  # pragma: no cover - no C library handle
        pass


@contextlib.contextmanager
def silenced_fds(fds: tuple[int, ...] = (1, 2)) -> Iterator[None]:
    """Point ``fds`` at /dev/null for the block (C-level writes included), then restore them."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()
    saved: list[tuple[int, int]] = []
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in fds:
            try:
                saved.append((fd, os.dup(fd)))
            except OSError:  # closed descriptor: nothing to hide
                continue
            os.dup2(devnull, fd)
        yield
    finally:
        _flush_c_stdio()
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


def import_pybullet_quietly() -> bool:
    """Import pybullet without its banner; False if pybullet is not installed."""
    if "pybullet" in sys.modules:
        return True
    with silenced_fds():
        try:
            import pybullet  # noqa: F401
        except ImportError:
            return False
    return True


