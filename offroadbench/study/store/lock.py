"""The lock of a run directory: only the process holding it writes the store (``fcntl.flock`` on
``study.lock``, released by the kernel when the process dies; see offroadbench.study.store.store)."""

from __future__ import annotations

import errno
import os
import time
from pathlib import Path

from offroadbench.errors import InputError


#: the lock file of a run directory (see :class:`RunLock`)
LOCK_NAME = "study.lock"


def lock_holder_alive(run_dir: Path) -> bool:
    """Whether the run directory's lock file names a live process (a run removes the file as it
    ends; a killed one leaves it behind with its dead pid)."""
    try:
        pid = int((Path(run_dir) / LOCK_NAME).read_text().strip())
    except (OSError, ValueError):
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def error_reason(exc: OSError) -> str:
    if exc.errno == errno.ENOSPC:
        return "no space left on the device"
    return exc.strerror or str(exc)


class RunDirLocked(InputError):
    """Another live process holds the run directory's lock."""


class RunLock:
    """An exclusive, OS-level lock on a run directory while a study runs in it.

    ``fcntl.flock`` on ``DIR/study.lock``, which holds the owner's pid. The kernel releases the
    lock when the process ends, however it ends (SIGKILL included), so a stale lock never blocks a
    later run. A second process is refused at once with :class:`RunDirLocked`: "a study is running
    in DIR (pid N)". The directory is created if missing. On release the lock file is removed
    while still locked; a process that opened it just before re-checks, after locking, that it
    locked the file that is at the path, and otherwise tries again.
    """

    def __init__(self, run_dir: str | Path) -> None:
        self.run_dir = Path(run_dir)
        self.path = self.run_dir / LOCK_NAME
        self.fd: int | None = None

    def acquire(self) -> RunLock:
        import fcntl

        for _ in range(100):
            try:
                self.run_dir.mkdir(parents=True, exist_ok=True)
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            except FileNotFoundError:  # the directory was removed by a run that failed meanwhile
                continue
            except OSError as exc:
                raise InputError(f"{self.path}: cannot create the run directory's lock file ({error_reason(exc)})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                pid = self._read_pid(fd)
                os.close(fd)
                raise RunDirLocked(f"a study is running in {self.run_dir} (pid {pid}); wait for it to end "
                                   "or use another --out directory") from None
            try:
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if not same:  # locked a file its owner removed as it released it: try again
                os.close(fd)
                continue
            try:
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            except OSError as exc:  # a full disk: leave no lock file behind
                self.path.unlink(missing_ok=True)
                os.close(fd)
                raise InputError(f"{self.path}: cannot write the run directory's lock file ({error_reason(exc)})") from None
            self.fd = fd
            return self
        raise RunDirLocked(f"{self.run_dir}: could not lock the run directory (other runs keep starting and stopping)")

    @staticmethod
    def _read_pid(fd: int) -> str:
        for _ in range(50):  # the owner writes its pid just after it locks
            text = os.pread(fd, 32, 0).decode(errors="replace").strip()
            if text:
                return text
            time.sleep(0.01)
        return "unknown"

    def release(self) -> None:
        if self.fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)
        finally:
            os.close(self.fd)  # closing the last descriptor releases the flock
            self.fd = None

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
