"""SIGTERM like Ctrl-C, and closing logs that neither can cut short.

`timeout`, systemd and docker stop a program with SIGTERM; Python's default is to die at once,
leaving the MCAP without its footer and the .rrd up to a batch behind. `stop_on_sigterm()`
turns it into `Terminated`, a KeyboardInterrupt, so every `finally` that finishes a log on Ctrl-C
does so on SIGTERM too. `shielded()` holds both signals off while logs are being closed and
raises the first one afterwards. `stop_behind(e)` finds the stop behind an exception: a signal
handled while compiled code has called back into Python comes out as a SystemError.
"""

from __future__ import annotations

import contextlib
import signal
import threading

from twin_plumbing.errors import Terminated


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


def stop_behind(e: BaseException | None) -> KeyboardInterrupt | None:
    """The Ctrl-C (KeyboardInterrupt) or SIGTERM (Terminated) that `e` is or that a SystemError `e`
    came from, else None. A signal's handler runs at the next Python line, which may be one that
    compiled code called back (numba's `_numba_unpickle`, boxing an @njit function's result): the
    compiled code does not pass the exception on but returns, and Python raises "SystemError: ...
    returned a result with an exception set", chained to the KeyboardInterrupt."""
    seen: set[int] = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return e
        if not isinstance(e, SystemError):
            return None
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None
