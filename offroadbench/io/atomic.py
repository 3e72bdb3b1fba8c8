"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or a bad input never leaves a partial file under the final name.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator

from offroadbench.errors import InputError

__all__ = ["atomic_path", "check_writable", "current_umask"]


def check_writable(path: str | Path) -> Path:
    """Return ``path`` as a Path if its directory exists and is writable, else raise InputError."""
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"output path {p}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"output path {p}: directory {parent} is not writable")
    if p.is_dir():
        raise InputError(f"output path {p} is a directory; give a file name")
    return p


def current_umask() -> int:
    """The process umask (read without changing it for longer than one call)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; on success rename it to ``path``.

    On any exception the temporary file is removed and ``path`` is left untouched.
    """
    target = check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, 0o666 & ~current_umask())  # mkstemp makes 0600; give the usual file mode
        os.replace(tmp_path, target)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise
