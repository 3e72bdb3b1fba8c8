"""Where results may be written: one output-path policy for every command and library writer.

An output directory, or the directory of an output file, may be missing; its missing parents are
created when the results are written (:func:`created_dirs`), after the work. Before any work the
caller checks that the path can be created (:func:`check_output_dir`, :func:`check_output_file`):
the nearest existing ancestor must be a directory in which a file can actually be created (a
read-only filesystem, ``/proc`` or a path under a regular file is refused with one line naming
the path). If the writer then fails, the directories it created are removed again, so a failed
command or export leaves nothing behind. The CLI (offroadbench.cli._common) and the export
transaction (offroadbench.io.export._staging) both use these functions.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator

from offroadbench.errors import InputError

__all__ = ["check_output_dir", "check_output_file", "created_dirs", "missing_dirs"]


def _probe_dir(d: Path, flag: str, target: Path) -> None:
    """Raise InputError unless a file can be created in the existing directory ``d``."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".offroadbench-probe.", dir=d)
    except OSError as exc:
        raise InputError(f"{flag} {target}: cannot write into {d} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(tmp)


def _nearest_existing(p: Path, flag: str, target: Path) -> Path:
    """The nearest existing ancestor of ``p`` (itself included); it must be a directory."""
    q = p
    while not q.exists() and not q.is_symlink():
        if q.parent == q:
            break
        q = q.parent
    if not q.is_dir():
        raise InputError(f"{flag} {target}: {q} is a file, not a directory")
    return q


def check_output_dir(path: str | Path, flag: str = "--out") -> Path:
    """Check, before any work, that ``path`` is (or can be created as) a writable directory."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{flag} {p}: exists and is not a directory")
    _probe_dir(_nearest_existing(p, flag, p), flag, p)
    return p


def check_output_file(path: str | Path, flag: str = "--output", suffixes: tuple[str, ...] = ()) -> Path:
    """Check, before any work, that the file ``path`` can be written (its directory created)."""
    p = Path(path)
    if p.is_dir() or str(path).endswith(("/", os.sep)):
        raise InputError(f"{flag} {p}: is a directory; give a file name")
    if suffixes and p.suffix.lower() not in suffixes:
        raise InputError(f"{flag} {p}: must end in {' or '.join(suffixes)}")
    parent = p.parent if str(p.parent) else Path(".")
    _probe_dir(_nearest_existing(parent, flag, p), flag, p)
    return p


def missing_dirs(path: str | Path) -> list[Path]:
    """The directories of ``path`` (itself included) that do not exist yet, deepest first: what a
    writer creates, and removes again (in this order) if it fails."""
    out = []
    q = Path(path)
    while not q.exists() and q.parent != q:
        out.append(q)
        q = q.parent
    return out


@contextlib.contextmanager
def created_dirs(*dirs: str | Path) -> Iterator[None]:
    """Create ``dirs`` (with missing parents); if the block fails, remove the ones created here."""
    made: list[Path] = []
    try:
        for d in dirs:
            for m in reversed(missing_dirs(d)):
                try:
                    m.mkdir()
                except OSError as exc:
                    raise InputError(f"cannot create directory {m} ({exc.strerror})") from None
                made.append(m)
        yield
    except BaseException:
        for m in reversed(made):
            with contextlib.suppress(OSError):
                m.rmdir()  # only empty ones: a file someone else put there stays
        raise
