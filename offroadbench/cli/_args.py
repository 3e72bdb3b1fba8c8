"""Argument types shared by the commands: integers with a lower bound, named in the message."""

from __future__ import annotations

import argparse
from typing import Callable


def int_at_least(lo: int, what: str = "value") -> Callable[[str], int]:
    """An argparse type: an integer >= ``lo``; otherwise one line naming ``what`` and the range."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be an integer >= {lo}, got {text!r}") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"{what} must be an integer >= {lo}, got {v}")
        return v

    return parse


seed_arg = int_at_least(0, "seed")
positive_int = int_at_least(1, "value")
