"""A stop asked by a signal (Ctrl-C is SIGINT, ``kill`` is SIGTERM), noted so that it is never lost.

Python raises a signal's exception wherever the main thread happens to be; when that is inside a
callback run from C (a fork's ``at_fork`` handler while a worker process starts, a finaliser) the
exception is printed as "ignored" and the run goes on as if nothing had been asked. So the
command line's handler (:func:`handled`) notes the signal before it raises
:class:`~offroadbench.errors.Stopped` (and keeps a swallowed one from printing), and the loops that
wait on workers call :func:`check`, which raises it again if it was swallowed: a run stops within
one poll of the signal, every time, with its one line.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from typing import Iterator

from offroadbench.errors import Stopped

__all__ = ["check", "deferred", "handled"]

_asked: list[int] = []  # the signals received while handled(), in order


def _handler(signum, frame) -> None:
    _asked.append(signum)
    raise Stopped(signum=signum)


def check() -> None:
    """Raise :class:`~offroadbench.errors.Stopped` if a stop was asked (and perhaps swallowed)."""
    if _asked:
        raise Stopped(signum=_asked[-1])


@contextlib.contextmanager
def handled(signals: tuple[int, ...] = (signal.SIGINT, signal.SIGTERM)) -> Iterator[None]:
    """While inside: each of ``signals`` is noted and raises Stopped (a KeyboardInterrupt) in the main
    thread. Outside the main thread (where no handler can be set) nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _asked.clear()
    old = {s: signal.signal(s, _handler) for s in signals}
    old_hook = sys.unraisablehook

    def quiet(info) -> None:  # a swallowed stop is noted (check raises it again): no "Exception ignored" lines
        if not isinstance(info.exc_value, Stopped):
            old_hook(info)

    sys.unraisablehook = quiet
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        sys.unraisablehook = old_hook
        _asked.clear()


@contextlib.contextmanager
def deferred(signals: tuple[int, ...] = (signal.SIGINT, signal.SIGTERM)) -> Iterator[None]:
    """Hold ``signals`` back while inside (a few statements that must not be cut in two, such as
    writing a session's row and keeping its id): one that comes meanwhile is noted, and raised again
    just after, so its exception comes once the statements are done. Outside the main thread nothing
    changes.

    Not a signal mask: ``pthread_sigmask`` holds a signal back from the main thread only, and the
    kernel hands a signal sent to the process to any thread that does not block it (a Dask, tqdm or
    thread-pool thread), whose C handler then has the main thread raise at its next bytecode, inside
    the statements. Python runs every handler in the main thread, so a noting handler defers it
    whichever thread the kernel chose."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    old = {s: signal.getsignal(s) for s in signals}
    held = [s for s, h in old.items() if h is not None]  # a handler set outside Python cannot be restored
    for s in held:
        signal.signal(s, lambda signum, frame: got.append(signum))
    try:
        yield
    finally:
        for s in held:
            signal.signal(s, old[s])
        for s in got[:1]:  # one stop is one stop: raised once, by the handler that was there before
            signal.raise_signal(s)
