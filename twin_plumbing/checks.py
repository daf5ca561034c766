"""Checked numbers from the user: NaN, infinities and values out of range are refused before any
work with the name, the value and what is allowed. `check_number` is the check for the Python API;
the command line's flags use the same ranges and words through twin_cli.args.number."""

from __future__ import annotations

import math
import numbers

from twin_plumbing.errors import UserError
from twin_plumbing.fields import range_text


def problem(value, low: float, high: float, above: bool, integer: bool) -> str | None:
    """Why `value` is refused, or None."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral if integer else numbers.Real):
        return "is not a whole number" if integer else "is not a number"
    if not math.isfinite(value) or value > high or value < low or (above and value == low):
        return "is not allowed"
    return None


def check_number(
    name: str, value, low: float, high: float, unit: str = "", *, above: bool = False, integer: bool = False
):
    """`value` if it is a finite number in low..high (`above`: strictly above `low`), else UserError."""
    why = problem(value, low, high, above, integer)
    if why:
        raise UserError(f"{name} = {value!r} {why}; allowed: {range_text(low, high, unit, above, integer)}")
    return value


# The ranges of the numbers a user gives, shared by the command line and the Python API (the gap
# diagnosis's own: gap.bench, gap.run).
DURATION_S = {"low": 0.0, "high": 7200.0, "unit": "s", "above": True}  # the schema's longest scenario (duration_s)
CAMERA_FPS = {"low": 0.0, "high": 50.0, "unit": "frames/s"}  # frames come from telemetry samples, 50 a simulated s
RECORDING_CAMERA_FPS = 2.0  # its default: the operator's global-camera view in recordings, "a few frames per second"
SEED = {"low": 0, "high": 2**63 - 1, "integer": True}  # the schema's seed range
MONTE_CARLO = {"low": 0, "high": 100_000, "integer": True}  # runs per grid point: a bound against typos
WORKERS = {"low": 0, "high": 1024, "integer": True}  # 0: all local cores
JOBS = {"low": 1, "high": 256, "integer": True}
