"""SIGTERM like Ctrl-C, and closing logs that neither can cut short.

`timeout`, systemd and docker stop a program with SIGTERM; Python's default is to die at once,
leaving the MCAP without its footer and the .rrd up to a batch behind. `stop_on_sigterm()`
turns it into `Terminated`, a KeyboardInterrupt, so every `finally` that finishes a log on Ctrl-C
does so on SIGTERM too. `shielded()` holds both signals off while logs are being closed and
raises the first one afterwards.
"""

from __future__ import annotations

import contextlib
import signal
import threading

from twin.errors import Terminated


def _terminate(signum, frame) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a second SIGTERM does not cut the clean-up
    raise Terminated(signum)


@contextlib.contextmanager
def stop_on_sigterm():
    """Inside, SIGTERM raises Terminated (in the main thread); the old handler is put back after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def shielded():
    """Run the body to its end although SIGINT or SIGTERM arrives; then raise what arrived."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived: list[int] = []
    previous = {
        s: signal.signal(s, lambda signum, frame: arrived.append(signum)) for s in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if arrived:
            raise Terminated(arrived[0]) if arrived[0] == signal.SIGTERM else KeyboardInterrupt()
