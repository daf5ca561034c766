"""Checked numbers and places on the command line: an argparse `type` that refuses NaN, infinities
and values out of range with what is allowed (argparse adds the flag's name), by the ranges of
twin_plumbing.checks, which the Python API checks with, in the words of twin_plumbing.fields.range_text; and
one that refuses an empty place."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from twin_plumbing.checks import WORKERS, problem
from twin_plumbing.fields import range_text


def number(low: float, high: float, unit: str = "", *, above: bool = False, integer: bool = False):
    """An argparse `type` for a finite number in low..high (`above`: strictly above `low`)."""

    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            value = text
        why = problem(value, low, high, above, integer)
        if why:
            raise argparse.ArgumentTypeError(f"{text!r} {why}; allowed: {range_text(low, high, unit, above, integer)}")
        return value

    parse.__name__ = "number"  # argparse names the type in some messages
    return parse


def number_from(ranges: Callable[[], dict]):
    """`number` with the range `ranges()` gives, looked up when a value is given rather than when
    the parser is built: for the ranges gap/ owns, which takes seconds to import (twin_cli/cli.py)."""

    def parse(text: str):
        return number(**ranges())(text)

    parse.__name__ = "number"
    return parse


def place(text: str) -> Path:
    """An argparse `type` for an output place: an empty one ('') would be the working folder."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is empty; allowed: a file or folder name")
    return Path(text)


def add_workers(parser: argparse.ArgumentParser) -> None:
    """`--workers K`, as every command that runs scenarios in parallel takes it."""
    parser.add_argument(
        "--workers",
        type=number(**WORKERS),
        default=0,
        metavar="K",
        help="local worker processes (default 0: all cores)",
    )
