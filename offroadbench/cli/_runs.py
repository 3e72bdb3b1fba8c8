"""What ``study run`` and ``search run`` share: the default run directory's name, the worker count,
SIGTERM ending a run as Ctrl-C does, and the lines said at the end of a run."""

from __future__ import annotations

import argparse
import contextlib
import signal
from pathlib import Path
from typing import Iterator

from offroadbench.errors import InputError, RunInterrupted, Stopped, StudyError

__all__ = ["check_dir_name", "fault_lines", "stop_on_sigterm", "run_workers"]


def check_dir_name(name: str, path: Path) -> None:
    """The study name names the default run directory runs/NAME: it must be one plain path
    component (not empty, ``.`` or ``..``, no slash, NUL or control character)."""
    bad = name in ("", ".", "..") or any(c in name for c in "/\\") or any(ord(c) < 32 or ord(c) == 127 for c in name)
    if bad:
        raise InputError(f"{path}: [study] name = {name!r} cannot name the run directory runs/NAME (it must be one "
                         "plain file name: no slash, control character, '.' or '..'); rename the study or give --out")


def run_workers(args: argparse.Namespace, plans) -> int | None:
    """--workers, or as many as both the cores and the memory allow; refuse what cannot fit."""
    from offroadbench.memory import check_memory, format_bytes, workers_that_fit
    from offroadbench.study.runner import worker_memory_bytes

    if args.executor == "inline" or (args.executor == "dask" and args.scheduler):
        return args.workers  # one process here, or a cluster whose memory is not ours to judge
    per_worker = worker_memory_bytes(plans)
    workers = args.workers if args.workers is not None else workers_that_fit(per_worker)
    check_memory(workers * per_worker, f"{workers} worker(s) of about {format_bytes(per_worker)} each", args.force,
                 per_process_bytes=per_worker)
    return workers


def _raise_stopped(signum, frame) -> None:
    raise Stopped(signum=signum)


@contextlib.contextmanager
def stop_on_sigterm() -> Iterator[None]:
    """While inside: SIGTERM ends the run as Ctrl-C does (a :class:`~offroadbench.errors.Stopped`
    in the main thread: workers stopped, the session ``interrupted``, every committed trial kept,
    the same one line said; exit 143). A stop outside the run's session (resolving the cells, the
    report) says so in the same one line."""
    old = signal.signal(signal.SIGTERM, _raise_stopped)
    try:
        yield
    except RunInterrupted:
        raise
    except KeyboardInterrupt as exc:
        raise RunInterrupted("every trial stored so far is kept; run the same command again to resume",
                             signum=getattr(exc, "signum", signal.SIGINT)) from None
    finally:
        signal.signal(signal.SIGTERM, old)


def fault_lines(summary, out: Path) -> list[str]:
    """The lines on the faults a run stored: one per kind with its count. A run whose every trial
    faulted (none gave an outcome) is a StudyError saying so in one line (exit 1)."""
    if not summary.faulted:
        return []
    kinds = "; ".join(f.describe() for f in summary.new_faults)
    if not summary.ran:
        raise StudyError(f"every trial of this run faulted, none gave an outcome ({kinds}); the faults are stored "
                         f"in {out} (--retry-faults runs them again)")
    return [f"faults of this run: {f.describe()}" for f in summary.new_faults]
