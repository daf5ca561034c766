"""`twin study cleaning`: the cleaning task under each strategy, supply and seed (scenarios/study.py)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.errors import UserError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("study", help="studies over the scenarios: `twin study cleaning --out DIR`")
    studies = p.add_subparsers(dest="study", required=True)
    c = studies.add_parser(
        "cleaning", help="the insulator-cleaning task per strategy x supply x seed: DIR/study.json, study.md, study.png"
    )
    c.add_argument("--out", type=Path, required=True)
    c.add_argument(
        "--strategies",
        default="",
        help="comma-separated subset of sensorless,rereference,operator,true_angle (default: all)",
    )
    c.add_argument(
        "--supplies", default="0.5,0.6,0.7,0.8", help="supply pressures, MPa gauge (default 0.5,0.6,0.7,0.8)"
    )
    c.add_argument("--seeds", type=int, default=2, help="child seeds per strategy and supply (default 2)")
    c.add_argument("--workers", type=int, default=0, help="local worker processes (default: all cores)")
    c.set_defaults(func=cmd_study_cleaning)


def _parse(args) -> tuple[list[str], list[float]]:
    from scenarios.schema import STRATEGIES

    strategies = [s.strip() for s in args.strategies.split(",") if s.strip()] or list(STRATEGIES)
    for s in strategies:
        if s not in STRATEGIES:
            raise UserError(f"--strategies {s!r}: allowed: {', '.join(STRATEGIES)}")
    supplies = []
    for v in args.supplies.split(","):
        try:
            mpa = float(v)
        except ValueError:
            raise UserError(f"--supplies {v!r}: allowed: numbers in 0..1.0 MPa gauge, comma-separated") from None
        if not 0.0 <= mpa <= 1.0:
            raise UserError(f"--supplies {v!r}: allowed: numbers in 0..1.0 MPa gauge, comma-separated")
        supplies.append(mpa)
    if args.seeds < 1 or args.workers < 0:
        raise UserError(f"--seeds {args.seeds} / --workers {args.workers}: allowed: seeds >= 1, workers >= 0")
    return strategies, supplies


def cmd_study_cleaning(args) -> int:
    from scenarios.study import run_study, table, write

    strategies, supplies = _parse(args)
    results = run_study(strategies, supplies, seeds=args.seeds, workers=args.workers)
    study_rows = write(results, args.out)
    print(table(study_rows))
    print(f"{len(results)} runs; {args.out / 'study.json'}, {args.out / 'study.md'}, {args.out / 'study.png'}")
    return 0
