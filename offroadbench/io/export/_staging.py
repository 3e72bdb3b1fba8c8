"""All-or-nothing output of a set of files into a directory (the export transaction).

:func:`staged_dir` yields an empty staging directory; the exporter writes every file there, and only
when the block ends without an error do the files appear in the output directory:

* a new output directory is the staging directory renamed into place (one ``rename``);
* an existing output directory is swapped whole: the staging directory (a sibling of it) is
  completed with hard links to every entry of the output directory that the export does not
  replace, then the two are exchanged in one atomic ``renameat2(RENAME_EXCHANGE)`` (Linux 3.15+),
  and the old version is deleted. A reader, or a crash at any instant, sees the old directory or
  the new one, never a mix.
* where that is impossible (no ``renameat2``, a file system without hard links, an output
  directory with more than :data:`MAX_LINKED` entries, the parent not writable, the output
  directory being a mount point or ``.``), the staged files are moved in one by one. Files they
  replace are set aside first and put back if a later move fails; only a kill between two of
  these moves can then leave a mix, and the log says so.

Staging and set-aside directories carry the writer's pid (``.NAME.<pid>.XXXX.tmp``); the next
export to the same directory removes those of processes that are gone. On any error the staging
directory is deleted. Where the output may go is the one output-path policy of
offroadbench.io.outputs: a missing output directory and its missing parents are created (and
removed again if the export fails); the nearest existing ancestor must accept a new file.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import logging
import os
import shutil
import stat
import tempfile
from pathlib import Path
from typing import Iterator

from offroadbench.errors import InputError
from offroadbench.io.atomic import current_umask, os_error, remove_stale, temp_prefix
from offroadbench.io.outputs import check_output_dir, created_dirs

__all__ = ["MAX_LINKED", "staged_dir"]

log = logging.getLogger(__name__)

#: an existing output directory with more entries than this is merged file by file, not swapped
MAX_LINKED = 2000
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (renameat2 RENAME_EXCHANGE); False where the system cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.EXDEV, errno.EBUSY, errno.ENOTSUP, errno.EPERM):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _link_rest(out_dir: Path, stage: Path) -> bool:
    """Hard-link into ``stage`` every entry of ``out_dir`` the stage does not have (directories
    recreated, symlinks copied). False (stage unchanged in meaning) if the tree is too large or a
    link cannot be made."""
    count = 0
    for root, dirs, files in os.walk(out_dir):
        rel = Path(root).relative_to(out_dir)
        count += len(dirs) + len(files)
        if count > MAX_LINKED:
            return False
        for d in dirs:
            target = stage / rel / d
            src = Path(root) / d
            if src.is_symlink():
                if not os.path.lexists(target):
                    os.symlink(os.readlink(src), target)
                continue
            if not target.exists():
                target.mkdir()
                shutil.copymode(src, target)
        for f in files:
            target = stage / rel / f
            if os.path.lexists(target):
                continue
            src = Path(root) / f
            if src.is_symlink():
                os.symlink(os.readlink(src), target)
                continue
            try:
                os.link(src, target, follow_symlinks=False)
            except OSError as exc:
                if exc.errno in (errno.EXDEV, errno.EPERM, errno.EMLINK, errno.ENOTSUP):
                    return False
                raise
    return True


@contextlib.contextmanager
def staged_dir(out_dir: str | Path) -> Iterator[Path]:
    """Yield an empty staging directory; on success its contents appear in ``out_dir`` (see module doc)."""
    out_dir = check_output_dir(out_dir, "output directory")
    fresh = not out_dir.exists()
    parent = out_dir.parent if str(out_dir.parent) else Path(".")
    with created_dirs(parent):  # missing parents, removed again if the export fails
        yield from _staged(out_dir, fresh, parent)


def _staged(out_dir: Path, fresh: bool, parent: Path) -> Iterator[Path]:
    name = out_dir.resolve().name or "export"
    remove_stale(parent, name)
    if not fresh:
        remove_stale(out_dir, "export-replaced")
        remove_stale(out_dir, name)  # staging directories of the file-by-file fallback
    swap = fresh or (os.access(parent, os.W_OK | os.X_OK) and out_dir.resolve() != Path.cwd().resolve()
                     and not os.path.ismount(out_dir))
    where = parent if swap else out_dir
    try:
        stage = Path(tempfile.mkdtemp(prefix=temp_prefix(name), suffix=".tmp", dir=where))
    except OSError as exc:
        if os_error(exc, out_dir) is not exc:
            raise os_error(exc, out_dir) from None
        raise InputError(f"output directory {out_dir}: cannot write there ({exc.strerror})") from None
    try:
        yield stage
        if fresh:
            os.chmod(stage, 0o777 & ~current_umask())  # mkdtemp makes 0700; give the usual directory mode
            os.rename(stage, out_dir)
            return
        _check_merge(stage, out_dir)
        if swap:
            os.chmod(stage, stat.S_IMODE(out_dir.stat().st_mode))
            if _link_rest(out_dir, stage) and _exchange(stage, out_dir):
                return  # ``stage`` now holds the old version; removed below
            log.info("%s: cannot swap the directory in one step; moving the files in one by one", out_dir)
        _merge_into(stage, out_dir)
    except OSError as exc:
        err = os_error(exc, out_dir)
        if err is exc:
            raise
        raise err from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _check_merge(stage: Path, out_dir: Path) -> None:
    """InputError if an existing path in ``out_dir`` has the wrong kind (file vs directory)."""
    for src in stage.rglob("*"):
        dst = out_dir / src.relative_to(stage)
        if dst.exists() and src.is_dir() != dst.is_dir():
            kind = "a directory" if dst.is_dir() else "a file"
            raise InputError(f"output {dst}: is {kind} already; remove it or choose another --name or directory")


def _merge_into(stage: Path, out_dir: Path) -> None:
    """The file-by-file fallback; only the staged files (not links to existing ones) move."""
    backup = Path(tempfile.mkdtemp(prefix=temp_prefix("export-replaced"), suffix=".tmp", dir=out_dir))
    created: list[Path] = []
    replaced: list[tuple[Path, Path]] = []  # (target, its previous version in backup)
    try:
        for src in sorted(stage.rglob("*")):
            rel = src.relative_to(stage)
            dst = out_dir / rel
            if src.is_dir():
                if not dst.is_dir():
                    dst.mkdir()
                    created.append(dst)
                continue
            if dst.exists() and os.path.samefile(src, dst):
                continue  # a hard link made for the swap: the file is already there
            if dst.exists():
                old = backup / rel
                old.parent.mkdir(parents=True, exist_ok=True)
                os.replace(dst, old)
                replaced.append((dst, old))
            os.replace(src, dst)
            created.append(dst)
    except BaseException:
        for p in reversed(created):
            with contextlib.suppress(OSError):
                p.rmdir() if p.is_dir() else p.unlink()
        for dst, old in replaced:
            with contextlib.suppress(OSError):
                os.replace(old, dst)
        raise
    finally:
        shutil.rmtree(backup, ignore_errors=True)
