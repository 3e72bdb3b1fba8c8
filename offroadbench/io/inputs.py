"""Checks of input files before they are parsed: each way a path can be wrong has its own message.

A missing path, a directory, an unreadable file and an empty file are told apart here, so the
parsers (PNG, TOML, JSON, SQLite, npy) only have to report a wrong or truncated format.
"""

from __future__ import annotations

import os
from pathlib import Path

from offroadbench.errors import InputError

__all__ = ["check_input_file"]


def check_input_file(path: str | Path, what: str = "input file") -> Path:
    """``path`` as a Path if it is a readable, non-empty regular file; else one-line InputError.

    ``what`` names the input in the message (e.g. ``"study TOML"``, ``"heightmap PNG"``).
    """
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise InputError(f"{what} {p}: no such file") from None
    except NotADirectoryError:
        raise InputError(f"{what} {p}: a parent of it is a file, not a directory") from None
    except OSError as exc:
        raise InputError(f"{what} {p}: cannot be read ({exc.strerror})") from None
    if p.is_dir():
        raise InputError(f"{what} {p}: is a directory; give a file")
    if not p.is_file():
        raise InputError(f"{what} {p}: is not a regular file")
    if not os.access(p, os.R_OK):
        raise InputError(f"{what} {p}: is not readable (permission denied)")
    if st.st_size == 0:
        raise InputError(f"{what} {p}: is empty")
    return p
