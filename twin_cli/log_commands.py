"""`twin view FILE` and `twin replay FILE.mcap --rrd OUT`: the logging subcommands."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from twin_cli.args import place
from twin_plumbing.errors import UserError
from twin_plumbing.outputs import OutputLock, check_output
from twin_plumbing.paths import input_problem


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("view", help="open a rerun recording (.rrd) in the rerun viewer")
    p.add_argument("file", type=Path, help="a .rrd written by `twin run --rrd` or `twin replay`")
    p.set_defaults(func=cmd_view)

    p = sub.add_parser("replay", help="make a rerun recording from an MCAP log")
    p.add_argument("file", type=Path, help="an MCAP log written by `twin run --mcap` (may be cut short)")
    p.add_argument("--rrd", type=place, required=True, help="write the recording here")
    p.add_argument(
        "--model",
        type=Path,
        help="MJCF the run used (default: the shipped model its scenario names, or whose bodies match)",
    )
    p.set_defaults(func=cmd_replay, kept_on_stop="the recording written so far is kept")


def check_rrd(path: Path) -> None:
    """Raise UserError unless `path` is a rerun recording rerun itself can read."""
    problem = input_problem(path)
    if problem:
        raise UserError(f"{path}: {problem}; allowed: a readable rerun recording (.rrd)")
    if not path.is_file():
        raise UserError(f"{path}: no such file (expected a rerun recording, .rrd)")
    import rerun as rr  # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s

    try:
        if not rr.chunk.RrdReader(path).recordings():
            raise UserError(f"{path}: a rerun file without a recording in it")
    except UserError:
        raise
    except Exception as e:  # rerun's reader raises its own exception types on bad files
        raise UserError(f"{path}: not a readable rerun recording ({type(e).__name__}: {e})") from e


def check_model(path: Path) -> None:
    """Raise UserError unless `path` is a file named .xml: what --model hands to MuJoCo, whose
    own refusals run over several lines (and a folder makes it warn of a file over 2 GB)."""
    allowed = "allowed: the MJCF (.xml) file the run used"
    problem = input_problem(path)
    if problem:
        raise UserError(f"--model {path}: {problem}; {allowed}")
    if not path.exists():
        raise UserError(f"--model {path}: no such file; {allowed}")
    if not path.is_file():
        raise UserError(f"--model {path}: is not a file; {allowed}")
    if path.suffix.lower() != ".xml":
        raise UserError(f"--model {path}: not an .xml file; {allowed}")


def viewer_command(path: Path) -> list[str]:
    exe = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    if Path(exe).exists():
        return [exe, str(path)]
    return [sys.executable, "-m", "rerun", str(path)]


def cmd_view(args) -> int:
    check_rrd(args.file)
    cmd = viewer_command(args.file)
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        print(
            f"twin: no display here (DISPLAY and WAYLAND_DISPLAY are unset), so the rerun viewer cannot open.\n"
            f"  On a machine with a display: {' '.join(cmd)}\n"
            f"  Or in a browser: {' '.join(cmd[:-1] + ['--web-viewer', cmd[-1]])}",
            file=sys.stderr,
        )
        return 1
    try:
        proc = subprocess.Popen(cmd)
    except OSError as e:
        print(f"twin: cannot start the rerun viewer ({' '.join(cmd)}): {e.strerror}", file=sys.stderr)
        return 1
    time.sleep(2.0)  # a viewer that cannot start (no GPU, no display) exits at once
    if proc.poll() not in (None, 0):
        web = " ".join(cmd[:-1] + ["--web-viewer", cmd[-1]])
        print(f"twin: the rerun viewer exited with status {proc.returncode}; try `{web}`", file=sys.stderr)
        return 1
    print(f"rerun viewer started (pid {proc.pid}) on {args.file}")
    return 0


def cmd_replay(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from twin.replay import replay

    if args.model is not None:
        check_model(args.model)
    check_output(args.rrd, "--rrd", streamed=True, inputs=[args.file, args.model])
    with OutputLock([args.rrd]):
        report = replay(args.file, args.rrd, args.model)
    state = "whole file" if report["complete"] else f"file {report['stopped_by']}"
    print(f"{args.rrd}: {report['samples']} samples, {report['duration_s']:.2f} s simulated, from the {state}")
    return 0
