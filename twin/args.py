"""Checked command-line numbers: argparse types that refuse NaN, infinities and values out of
range before any work, with the flag, the value and what is allowed (argparse adds the flag)."""

from __future__ import annotations

import argparse
import math


def number(low: float, high: float, unit: str = "", *, above: bool = False, integer: bool = False):
    """An argparse `type` for a finite number in low..high (`above`: strictly above `low`)."""
    kind = "a whole number" if integer else "a number"
    u = f" {unit}" if unit else ""
    allowed = f"{kind} > {low:g}{u} and <= {high:g}{u}" if above else f"{kind} in {low:g}..{high:g}{u}"

    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {kind}; allowed: {allowed}") from None
        if not math.isfinite(value) or value > high or value < low or (above and value == low):
            raise argparse.ArgumentTypeError(f"{text!r} is not allowed; allowed: {allowed}")
        return value

    parse.__name__ = "number"  # argparse names the type in some messages
    return parse
