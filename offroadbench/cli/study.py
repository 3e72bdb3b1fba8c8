"""``offroadbench study run|export|report``: Monte Carlo studies (issue 4)."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``study`` command group."""
    p = subparsers.add_parser("study", help="run, export and report Monte Carlo studies")
    p.add_subparsers(dest="study_command", required=True)
