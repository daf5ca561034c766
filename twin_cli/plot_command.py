"""`twin plot RUN.mcap`: the README's angles figure (true, predicted and target angle of every
joint that moved, against simulated time) for any run logged with `twin run --mcap`."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.errors import UserError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plot", help="plot true, predicted and target angles of a run logged as MCAP (PNG)")
    p.add_argument("file", type=Path, help="an MCAP log written by `twin run --mcap` (may be cut short)")
    p.add_argument("--out", type=Path, help="the PNG to write (default: beside the log, RUN.angles.png)")
    p.add_argument("--until", type=float, metavar="S", help="plot only the first S simulated seconds")
    p.add_argument("--all-joints", action="store_true", help="a panel for every joint, also those that did not move")
    p.set_defaults(func=cmd_plot)


def cmd_plot(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from twin.pictures import plot_run_angles

    if args.until is not None and not args.until > 0:
        raise UserError(f"--until {args.until}: must be > 0 simulated seconds")
    out = args.out or args.file.with_suffix(".angles.png")
    if out.resolve() == args.file.resolve():
        raise UserError(f"--out {out}: is the log itself; choose another file")
    try:
        path, report = plot_run_angles(args.file, out, until_s=args.until, only_moving=not args.all_joints)
    except OSError as e:
        raise UserError(f"--out {out}: cannot write the figure: {e.strerror or e}") from e
    state = "whole file" if report["complete"] else f"file {report['stopped_by']}"
    print(f"{path}: angles of {report['samples']} samples, {report['duration_s']:.2f} s simulated, from the {state}")
    return 0
