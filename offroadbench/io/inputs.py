"""Checks of input files before they are parsed: each way a path can be wrong has its own message.

A missing path, a directory, an unreadable file and an empty file are told apart here, so the
parsers (PNG, TOML, JSON, SQLite, npy) only have to report a wrong or truncated format.
"""

from __future__ import annotations

import os
from pathlib import Path

from offroadbench.errors import InputError

__all__ = ["check_input_file", "file_kind"]


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


#: leading bytes -> what a file is (the formats a user may hand a terrain command by mistake)
_MAGIC = (
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"\x89PNG\r\n\x1a\n", "a PNG image"),
    (b"GIF87a", "a GIF image"),
    (b"GIF89a", "a GIF image"),
    (b"II*\x00", "a TIFF image"),
    (b"MM\x00*", "a TIFF image"),
    (b"BM", "a BMP image"),
    (b"\x93NUMPY", "a NumPy array (.npy)"),
    (b"PK\x03\x04", "a zip archive (or .npz)"),
    (b"%PDF", "a PDF document"),
    (b"SQLite format 3\x00", "an SQLite database"),
    (b"\x1f\x8b", "a gzip archive"),
)


def file_kind(path: str | Path) -> str | None:
    """What a file is, from its first bytes: ``"a JPEG image"``, ``"a JSON file"``, ... (None:
    not recognised, e.g. text that may be TOML). Reads at most 64 bytes."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(64)
    except OSError:
        return None
    for magic, kind in _MAGIC:
        if head.startswith(magic):
            return kind
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if text[:1] in (b"{", b"["):
        return "a JSON file" if text[:1] == b"{" or text[1:2] in (b"{", b"[", b'"', b"\n", b" ", b"]") else None
    return None
