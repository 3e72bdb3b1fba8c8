"""Keep pybullet's "pybullet build time: ..." banner out of the program's output.

The pybullet extension writes its banner through C stdio when the process exits, after every
line the program printed, so it ends up at the bottom of tables and piped output. Python's
atexit handlers run before the C library's exit handlers: this one flushes Python's stdout and
then points file descriptor 1 at /dev/null for the few C-level writes that follow.
"""

from __future__ import annotations

import atexit
import os
import sys

_installed = False


def _silence_stdout_at_exit() -> None:
    try:
        sys.stdout.flush()
    except (OSError, ValueError):
        pass
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)
    except OSError:
        pass


def hide_pybullet_banner() -> None:
    """Install the exit handler once per process."""
    global _installed
    if not _installed:
        atexit.register(_silence_stdout_at_exit)
        _installed = True
