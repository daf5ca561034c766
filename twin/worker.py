"""A child Python process spoken to in pickles over its stdin and stdout: how the MCAP writer
(`python -m twin.mcap_log`) and the camera renderer (`python -m twin.camera`) run beside a run.

A plain subprocess rather than multiprocessing, which would re-import the user's main script. The
child runs in a session of its own, so Ctrl-C in a terminal reaches the run alone, which then
finishes its files and ends the child by closing its stdin.

    proc = start("twin.camera", [model, ...])       # the parent
    send(proc.stdin, request); reply = receive(proc.stdout)
    for request in requests(sys.stdin.buffer): ...  # the child, until the parent closes the pipe
"""

from __future__ import annotations

import contextlib
import os
import pickle
import subprocess
import sys
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows has none: its pipes keep their size
    fcntl = None

ROOT = str(Path(__file__).resolve().parent.parent)  # where `twin` is importable from
# how a pipe to a child that died shows: on writing, on reading its reply
LOST = (OSError, EOFError, pickle.UnpicklingError)


def start(module: str, args=(), env: dict | None = None, stderr=None) -> subprocess.Popen:
    """`python -m module args` with this tree importable, its stdin and stdout pipes to us."""
    env = dict(os.environ if env is None else env)
    env["PYTHONPATH"] = os.pathsep.join([ROOT, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    proc = subprocess.Popen(
        [sys.executable, "-m", module, *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=stderr,
        env=env,
        start_new_session=True,
    )
    _widen(proc.stdin)
    return proc


PIPE_BYTES = 1 << 20  # what the pipe to a child holds before a send waits for it to read


def _widen(stream) -> None:
    # Linux's pipes hold 64 KiB: a child busy with a batch, or short of a core beside the run and
    # rerun's threads, made the run wait on its next send (the MCAP writer's pipe: 0.21 s of a 1.8 s
    # run, 60 s of the cleaning task). F_SETPIPE_SZ where the system has it, up to its limit
    # (/proc/sys/fs/pipe-max-size, 1 MiB by default); elsewhere the pipe stays as it is.
    set_size = getattr(fcntl, "F_SETPIPE_SZ", None)
    if set_size is not None:
        with contextlib.suppress(OSError):
            fcntl.fcntl(stream.fileno(), set_size, PIPE_BYTES)


def send(stream, obj) -> None:
    """Pickle `obj` down `stream` and flush: the other side has it now (a kill of this process loses none)."""
    pickle.dump(obj, stream, protocol=pickle.HIGHEST_PROTOCOL)
    stream.flush()


def receive(stream):
    """The next object sent down `stream`."""
    return pickle.load(stream)


def requests(stream):
    """The objects sent down `stream`, in order, until the other side closes it."""
    while True:
        try:
            yield pickle.load(stream)
        except EOFError:
            return
