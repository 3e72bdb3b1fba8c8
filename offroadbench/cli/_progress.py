"""tqdm progress bars for the library's ``progress(done, total)`` callbacks."""

from __future__ import annotations

import contextlib
import sys
from typing import Iterator

from tqdm import tqdm

from offroadbench.progress import ProgressFn


@contextlib.contextmanager
def bar(desc: str, unit: str = "it", postfix=None) -> Iterator[ProgressFn]:
    """Yield a ``progress(done, total)`` callback that drives a tqdm bar on stderr.

    ``postfix``, if given, is a zero-argument callable returning a dict shown after the bar
    (e.g. success rate so far).
    """
    pbar = tqdm(desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True, disable=None)

    def update(done: int, total: int) -> None:
        if pbar.total != total:
            pbar.total = total
        pbar.n = done
        if postfix is not None:
            pbar.set_postfix(postfix(), refresh=False)
        pbar.refresh()

    try:
        yield update
    finally:
        pbar.close()
