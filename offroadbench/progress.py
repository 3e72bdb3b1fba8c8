"""Progress reporting convention.

Long library functions take ``progress: ProgressFn | None``, a callable ``progress(done, total)``
called after each finished unit of work (terrains, trials). The library never prints; the CLI
turns the callback into a tqdm bar with :func:`offroadbench.cli._common.bar`.
"""

from __future__ import annotations

from typing import Callable, Optional

ProgressFn = Callable[[int, int], None]

__all__ = ["ProgressFn", "report"]


def report(progress: Optional[ProgressFn], done: int, total: int) -> None:
    """Call ``progress(done, total)`` if a callback was given."""
    if progress is not None:
        progress(done, total)
