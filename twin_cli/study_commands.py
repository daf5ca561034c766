"""`twin study cleaning`: the cleaning task under each strategy, supply and seed (scenarios/study.py)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin_cli.args import add_workers, number, place
from twin_plumbing.checks import DURATION_S
from twin_plumbing.errors import UserError
from twin_plumbing.outputs import OutputLock, check_output, publish_folder
from twin_plumbing.signals import shielded, stop_behind

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
        help="child seeds per strategy and supply, or per robustness case (default 2)",
    )
    c.add_argument(
        "--robustness",
        action="store_true",
        help="instead: the operator's task with the string moved, the arm and camera off the belief, one "
        "factor at a time (scenarios/robustness.py): DIR/robustness.json, .csv, .md, .png",
    )
    c.add_argument(
        "--cases",
        default=None,
        help="with --robustness: comma-separated subset of the cases (default: all; names as in robustness.md)",
    )
    c.add_argument(
        "--duration", type=number(**DURATION_S), metavar="S", help="shorten every run to this many simulated seconds"
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
    from scenarios import robustness
    from scenarios.study import run_study, table, write

    if args.robustness:
        try:
            cases = None if args.cases is None else robustness.cases_named([c.strip() for c in args.cases.split(",")])
        except ValueError as e:
            raise UserError(f"--cases: {e}") from None
        check_output(args.out, "--out", folder=True)

        def runs(finished: dict[int, dict]) -> list:
            return robustness.run_robustness(
                cases, seeds=args.seeds, workers=args.workers, duration_s=args.duration, finished=finished
            )

        (results, _), folder = _published(args.out, runs, robustness.write)
        print(robustness.table(robustness.rows(results), robustness.goals(results)))
        names = ("robustness.json", "robustness.csv", "robustness.md", "robustness.png")
    else:
        if args.cases is not None:
            raise UserError("--cases is for --robustness; allowed: --strategies and --supplies")
        strategies, supplies = _parse(args)
        check_output(args.out, "--out", folder=True)

        def runs(finished: dict[int, dict]) -> list:
            how = {"seeds": args.seeds, "workers": args.workers, "duration_s": args.duration, "finished": finished}
            return run_study(strategies, supplies, **how)

        (_, study_rows), folder = _published(args.out, runs, write)
        print(table(study_rows))
        names = ("study.json", "study.csv", "study.md", "study.png")
    print(", ".join(str(folder / n) for n in names))
    return 0


def _published(out: Path, runs, write) -> tuple:
    """((the results, what `write` returns), the folder) for the results of `runs(finished)` written into `out` as
    a whole; a stopped study leaves the runs that finished as a partial table."""
    from scenarios.sweep import write_summaries

    def study_into(staging: Path):
        finished: dict[int, dict] = {}
        try:
            results = runs(finished)
        except BaseException as e:  # stopped: the runs that finished, as a partial table
            if stop_behind(e) is not None and finished:
                with shielded():
                    write_summaries([finished[i] for i in sorted(finished)], staging / PARTIAL, partial=True)
            raise
        return results, write(results, staging)

    with OutputLock([out]):
        return publish_folder(out, study_into, f"the study's runs ({PARTIAL}, partial)", keep_on_stop=True)
