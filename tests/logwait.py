"""Waiting on a run in a child process until its MCAP log holds some simulated time."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

from twin.mcap_log import LogError, read_mcap


def wait_until_logged(proc: subprocess.Popen, mcap: Path, seconds: float, timeout_s: float = 120.0) -> float:
    """Poll `mcap` until it holds `seconds` of simulated time; fail if the child ends or time runs out."""
    deadline = time.monotonic() + timeout_s
    seen = 0.0
    while seen < seconds:
        assert proc.poll() is None, "the child run ended before it was stopped"
        assert time.monotonic() < deadline, f"the child never logged {seconds} s"
        time.sleep(0.2)
        try:
            seen = read_mcap(mcap)[1]["recovery"]["duration_s"] if mcap.exists() else 0.0
        except LogError:
            seen = 0.0  # header not yet flushed
    return seen
