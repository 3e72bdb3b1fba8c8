"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or a bad input never leaves a partial file under the final name. Temporary names carry
the writer's pid, ``.NAME.<pid>.XXXXXXXX.tmp``; the next write to ``NAME`` removes those whose
process is gone (a killed writer's leftovers), and leaves a live writer's alone. A full disk is an
OSError that names the final path (:func:`os_error`), which the CLI prints as one line.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

from offroadbench.errors import InputError

__all__ = ["DISK_FULL", "atomic_path", "atomic_paths", "finish_commits", "check_writable", "current_umask", "os_error", "remove_stale", "temp_prefix"]


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


def temp_prefix(name: str) -> str:
    """The prefix of this process's temporary files for a target called ``name``."""
    return f".{name}.{os.getpid()}."


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def remove_stale(directory: str | Path, name: str) -> list[Path]:
    """Remove ``.NAME.<pid>.*.tmp`` files and directories in ``directory`` whose process is gone."""
    removed = []
    head = f".{name}."
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for e in entries:
        if not (e.name.startswith(head) and e.name.endswith(".tmp")):
            continue
        pid = e.name[len(head):].split(".", 1)[0]
        if not pid.isdigit() or _alive(int(pid)):
            continue
        try:
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(e.path, ignore_errors=True)
            else:
                os.unlink(e.path)
            removed.append(Path(e.path))
        except OSError:
            pass
    return removed


#: errno values that mean "the disk (or the quota) is full"
DISK_FULL = (errno.ENOSPC, errno.EDQUOT)


def os_error(exc: OSError, path: str | Path) -> OSError:
    """A full disk (or quota) as an OSError whose ``filename`` is the output ``path`` (not a
    temporary name), so the message names what could not be written; other OSErrors unchanged.
    numpy's short write (``ndarray.tofile``: "N requested and M written", no errno) is a full disk
    too: the kernel writes less than asked only when the device or a file-size limit is reached."""
    if exc.errno in DISK_FULL:
        return OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(path))
    if exc.errno is None and _SHORT_WRITE.fullmatch(str(exc).strip()):
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    return exc


_SHORT_WRITE = re.compile(r"\d+ requested and \d+ written")


@contextlib.contextmanager
def atomic_path(path: str | Path, *, sweep: bool = True) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; on success rename it to ``path``.

    On any exception the temporary file is removed and ``path`` is left untouched; a full disk is
    an OSError naming ``path`` (:func:`os_error`). ``sweep`` first removes the temporary files of killed earlier
    writers of the same ``path`` (:func:`remove_stale`; it lists the directory, so a caller that
    writes thousands of files into one directory sweeps once itself and passes False).
    """
    target = check_writable(path)
    if sweep:
        remove_stale(target.parent, target.name)
    try:
        fd, tmp = tempfile.mkstemp(prefix=temp_prefix(target.name), suffix=".tmp", dir=target.parent)
    except OSError as exc:
        raise os_error(exc, target) from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, 0o666 & ~current_umask())  # mkstemp makes 0600; give the usual file mode
        os.replace(tmp_path, target)
    except OSError as exc:
        tmp_path.unlink(missing_ok=True)
        err = os_error(exc, target)
        if err is exc:
            raise
        raise err from None
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


# ---------------------------------------------------------------------------- several files (issue 30)
_JOURNAL = ".offroadbench-commit"


def finish_commits(directory: str | Path) -> list[Path]:
    """Complete the commits of :func:`atomic_paths` that a killed writer left in ``directory``:
    every rename its journal lists whose temporary file is still there is done, then the journal
    is removed (a live writer's journal is left alone). Returns the files completed."""
    import json

    done: list[Path] = []
    try:
        entries = [e for e in os.scandir(directory) if e.name.startswith(_JOURNAL + ".") and e.name.endswith(".json")]
    except OSError:
        return done
    for e in entries:
        pid = e.name[len(_JOURNAL) + 1:].split(".", 1)[0]
        if not pid.isdigit() or _alive(int(pid)):
            continue
        try:
            pairs = json.loads(Path(e.path).read_text())
            for tmp, final in pairs:
                tmp_p, final_p = Path(directory) / tmp, Path(directory) / final
                if tmp_p.exists():
                    os.replace(tmp_p, final_p)
                    done.append(final_p)
            os.unlink(e.path)
        except (OSError, ValueError, TypeError):
            continue
    return done


@contextlib.contextmanager
def atomic_paths(paths: list[str | Path]) -> Iterator[list[Path]]:
    """All or nothing for several files in one directory: yield a temporary path for each; when
    the block ends without an error they replace their targets together.

    The commit point is a journal (``.offroadbench-commit.<pid>.json``, written atomically)
    naming every rename; the renames follow and the journal goes. A writer killed between two
    renames leaves the journal behind, and the next :func:`atomic_paths` (or
    :func:`finish_commits`) in that directory completes the commit, so the set is always either
    the old one or the new one once anything looks at it again. Before the journal is written,
    any failure (a full disk: an OSError naming the target, as :func:`atomic_path`) leaves every
    target as it was and no temporary file behind."""
    import json

    targets = [check_writable(p) for p in paths]
    parents = {t.parent.resolve() for t in targets}
    if len(parents) != 1:
        raise ValueError("atomic_paths: every target must be in one directory")
    directory = targets[0].parent
    finish_commits(directory)
    for t in targets:
        remove_stale(directory, t.name)
    temps: list[Path] = []
    journal = directory / f"{_JOURNAL}.{os.getpid()}.json"
    current = targets[0]
    try:
        for t in targets:
            current = t
            fd, tmp = tempfile.mkstemp(prefix=temp_prefix(t.name), suffix=".tmp", dir=directory)
            os.close(fd)
            temps.append(Path(tmp))
        yield list(temps)
        mode = 0o666 & ~current_umask()
        for tmp in temps:
            os.chmod(tmp, mode)
        current = journal
        with atomic_path(journal) as jtmp:
            with open(jtmp, "w") as fh:
                json.dump([[tmp.name, t.name] for tmp, t in zip(temps, targets, strict=True)], fh)
                fh.flush()
                os.fsync(fh.fileno())
        for tmp, t in zip(temps, targets, strict=True):  # committed: from here on a kill is completed later
            current = t
            os.replace(tmp, t)
        journal.unlink(missing_ok=True)
    except OSError as exc:
        if not journal.exists():
            for tmp in temps:
                tmp.unlink(missing_ok=True)
        err = os_error(exc, current)
        if err is exc:
            raise
        raise err from None
    except BaseException:
        if not journal.exists():
            for tmp in temps:
                tmp.unlink(missing_ok=True)
        raise
