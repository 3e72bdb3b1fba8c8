"""All-or-nothing output of a set of files into a directory (the export transaction).

:func:`staged_dir` yields an empty staging directory; the exporter writes every file there, and only
when the block ends without an error do the files appear in the output directory:

* a new output directory is the staging directory renamed into place (one ``rename``);
* an existing output directory receives the staged files one by one (renames on one file system).
  Files they replace are set aside first and put back if a later move fails, so a crash or a full
  disk half way leaves the directory as it was.

On any error the staging directory is deleted. Where the output may go is the one output-path
policy of offroadbench.io.outputs: a missing output directory and its missing parents are created
(and removed again if the export fails); the nearest existing ancestor must accept a new file.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

from offroadbench.errors import InputError
from offroadbench.io.atomic import current_umask
from offroadbench.io.outputs import check_output_dir, created_dirs

__all__ = ["staged_dir"]


@contextlib.contextmanager
def staged_dir(out_dir: str | Path) -> Iterator[Path]:
    """Yield an empty staging directory; on success its contents appear in ``out_dir`` (see module doc)."""
    out_dir = check_output_dir(out_dir, "output directory")
    fresh = not out_dir.exists()
    parent = out_dir.parent if fresh else out_dir
    with created_dirs(parent):  # missing parents, removed again if the export fails
        try:
            stage = Path(tempfile.mkdtemp(prefix=f".{out_dir.name or 'export'}.", suffix=".tmp", dir=parent))
        except OSError as exc:
            raise InputError(f"output directory {out_dir}: cannot write there ({exc.strerror})") from None
        try:
            yield stage
            if fresh:
                os.chmod(stage, 0o777 & ~current_umask())  # mkdtemp makes 0700; give the usual directory mode
                os.rename(stage, out_dir)
            else:
                _merge_into(stage, out_dir)
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
    _check_merge(stage, out_dir)
    backup = Path(tempfile.mkdtemp(prefix=".export-replaced.", suffix=".tmp", dir=out_dir))
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
