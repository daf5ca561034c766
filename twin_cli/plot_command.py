"""`twin plot RUN.mcap`: the README's angles figure (true, predicted and target angle of every
joint that moved, against simulated time) for any run logged with `twin run --mcap`."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin_cli.args import place
from twin_plumbing.errors import UserError
from twin_plumbing.outputs import OutputLock, check_output, keep_result, write_atomic


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plot", help="plot true, predicted and target angles of a run logged as MCAP (PNG)")
    p.add_argument("file", type=Path, help="an MCAP log written by `twin run --mcap` (may be cut short)")
    p.add_argument(
        "--out",
        type=place,
        help="the picture to write, its format from its suffix (default: beside the log, RUN.angles.png; none: .png)",
    )
    p.add_argument("--until", type=float, metavar="S", help="plot only the first S simulated seconds")
    p.add_argument("--all-joints", action="store_true", help="a panel for every joint, also those that did not move")
    p.set_defaults(func=cmd_plot)


def picture_place(out: Path, formats: tuple[str, ...]) -> tuple[Path, str]:
    """Where `--out` writes and in which format: its suffix's, or PNG with `.png` added to a name
    without one (as matplotlib does); UserError for a suffix that is no picture format."""
    if not out.suffix and not out.is_dir():  # a folder is refused by check_output, not renamed
        out = out.with_name(f"{out.name}.png")
    fmt = out.suffix.lower().lstrip(".")
    if out.suffix and fmt not in formats:
        allowed = ", ".join(f".{f}" for f in formats)
        raise UserError(f"--out {out}: {out.suffix} is not a picture format; allowed: {allowed}")
    return out, fmt


def cmd_plot(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from twin.pictures import PICTURE_FORMATS, picture_bytes, run_angles_figure

    if args.until is not None and not args.until > 0:
        raise UserError(f"--until {args.until}: must be > 0 simulated seconds")
    out, fmt = picture_place(args.out or args.file.with_suffix(".angles.png"), PICTURE_FORMATS)
    check_output(out, "--out", inputs=[args.file])
    with OutputLock([out]):
        figure, report = run_angles_figure(args.file, until_s=args.until, only_moving=not args.all_joints)
        picture = picture_bytes(figure, fmt)
        path = keep_result(out, lambda place: write_atomic(place, picture), "the figure")
    state = "whole file" if report["complete"] else f"file {report['stopped_by']}"
    print(f"{path}: angles of {report['samples']} samples, {report['duration_s']:.2f} s simulated, from the {state}")
    return 0 if path == out else 2  # kept elsewhere, as said: the place asked for failed
