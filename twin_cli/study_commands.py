"""`twin study cleaning`: the cleaning task under each strategy, supply and seed (scenarios/study.py)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.errors import UserError
from twin.outputs import OutputLock, check_output, publish_folder
from twin.signals import shielded, stop_behind
from twin_cli.args import add_workers, number, place

PARTIAL = "study.partial.json"  # a stopped study's finished runs (and study.partial.csv, their table)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("study", help="studies over the scenarios: `twin study cleaning --out DIR`")
    studies = p.add_subparsers(dest="study", required=True, metavar="STUDY", help="the study to run")
    c = studies.add_parser(
        "cleaning", help="the cleaning task per strategy x supply x seed: DIR/study.json, .csv, .md, .png"
    )
    c.add_argument(
        "--out",
        type=place,
        required=True,
        metavar="DIR",
        help="output folder (made if missing): study.json, study.csv, study.md, study.png",
    )
    c.add_argument(
        "--strategies",
        default=None,
        help="comma-separated subset of sensorless,rereference,operator,true_angle (default: all)",
    )
    c.add_argument(
        "--supplies", default="0.5,0.6,0.7,0.8", help="supply pressures, MPa gauge (default 0.5,0.6,0.7,0.8)"
    )
    c.add_argument(
        "--seeds",
        type=number(1, 1000, integer=True),
        default=2,
        metavar="N",
        help="child seeds per strategy and supply (default 2)",
    )
    add_workers(c)
    c.set_defaults(func=cmd_study_cleaning)


def _parse(args) -> tuple[list[str], list[float]]:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from scenarios.schema import STRATEGIES

    strategies = list(STRATEGIES) if args.strategies is None else [s.strip() for s in args.strategies.split(",")]
    for s in strategies:
        if s not in STRATEGIES or strategies.count(s) > 1:
            why = "is listed twice" if s in STRATEGIES else "is not a strategy"
            raise UserError(f"--strategies {s!r} {why}; allowed: each of {', '.join(STRATEGIES)} at most once")
    supplies = []
    allowed = "numbers in 0..1.0 MPa gauge, comma-separated, each once"
    for v in args.supplies.split(","):
        try:
            mpa = float(v)
        except ValueError:
            raise UserError(f"--supplies {v!r}: allowed: {allowed}") from None
        if not 0.0 <= mpa <= 1.0 or mpa in supplies:
            raise UserError(f"--supplies {v!r}{' is listed twice' if mpa in supplies else ''}: allowed: {allowed}")
        supplies.append(mpa)
    return strategies, supplies


def cmd_study_cleaning(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from scenarios.study import run_study, table, write
    from scenarios.sweep import write_summaries

    strategies, supplies = _parse(args)
    check_output(args.out, "--out", folder=True)

    def study_into(staging: Path) -> list:
        finished: dict[int, dict] = {}
        try:
            results = run_study(strategies, supplies, seeds=args.seeds, workers=args.workers, finished=finished)
        except BaseException as e:  # stopped: the runs that finished, as a partial table
            if stop_behind(e) is not None and finished:
                with shielded():
                    write_summaries([finished[i] for i in sorted(finished)], staging / PARTIAL, partial=True)
            raise
        return write(results, staging)

    with OutputLock([args.out]):
        study_rows, folder = publish_folder(
            args.out, study_into, f"the study's runs ({PARTIAL}, partial)", keep_on_stop=True
        )
    print(table(study_rows))
    print(f"{folder / 'study.json'}, {folder / 'study.csv'}, {folder / 'study.md'}, {folder / 'study.png'}")
    return 0
