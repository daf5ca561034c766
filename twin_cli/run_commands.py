"""`twin run`, `twin sweep`, `twin paper`, `twin bench`: the scenario-facing subcommands."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path

from twin_cli.args import add_workers, number, place
from twin_cli.figures import figure_lines
from twin_cli.progress import ProgressLine
from twin_plumbing.checks import CAMERA_FPS as CAMERA_FPS_RANGE
from twin_plumbing.checks import DURATION_S, MONTE_CARLO, RECORDING_CAMERA_FPS, SEED
from twin_plumbing.outputs import OutputLock, check_output, keep_result, publish_folder, write_atomic
from twin_plumbing.signals import shielded, stop_behind


def _add_run(sub: argparse._SubParsersAction) -> None:
    """`twin run SCENARIO`: one run, its summary, and optionally its recordings."""
    p = sub.add_parser("run", help="run a scenario file; exit 1 if a pass criterion broke")
    p.add_argument("scenario", help="scenario TOML file, or the name of a shipped one (e.g. insulator_cleaning)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--rrd", type=place, help="write a rerun recording here")
    p.add_argument("--mcap", type=place, help="write an MCAP log here")
    live = p.add_mutually_exclusive_group()
    live.add_argument("--spawn", action="store_true", help="stream the rerun recording live to a viewer started here")
    live.add_argument(
        "--connect",
        metavar="ADDR",
        help="stream the rerun recording live to a running viewer (e.g. rerun+http://127.0.0.1:9876/proxy)",
    )
    p.add_argument(
        "--camera-fps",
        type=number(**CAMERA_FPS_RANGE),
        default=RECORDING_CAMERA_FPS,
        metavar="N",
        help=(
            f"global-camera frames per simulated second in the recording "
            f"(default {RECORDING_CAMERA_FPS:g}; 0: none; at most the log rate, 50)"
        ),
    )
    p.add_argument("--duration", type=number(**DURATION_S), metavar="S", help="stop after this many simulated seconds")
    p.add_argument("--seed", type=number(**SEED), metavar="N", help="override the scenario's seed")
    p.add_argument(
        "--start-time",
        metavar="ISO|now",
        help="the MCAP log's start, with --mcap (default 2000-01-01T00:00:00Z, deterministic; 'now': the wall clock)",
    )
    p.set_defaults(func=cmd_run, kept_on_stop="the logs written so far are kept")


def _add_sweep(sub: argparse._SubParsersAction) -> None:
    """`twin sweep SCENARIO`: a grid of field values and/or Monte Carlo seeds."""
    p = sub.add_parser("sweep", help="run a scenario over a grid of field values and/or Monte Carlo seeds")
    p.add_argument("scenario", help="scenario TOML file, or the name of a shipped one")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="FIELD=V1,V2",
        help="grid over a scenario field, e.g. supply.pressure_mpa=0.5,0.6,0.7 (repeatable)",
    )
    p.add_argument(
        "--monte-carlo",
        type=number(**MONTE_CARLO),
        default=0,
        metavar="N",
        help="N runs per grid point with child seeds (default 0: the scenario's own seed only)",
    )
    add_workers(p)
    p.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="Dask scheduler address (e.g. tcp://host:8786): run the sweep on that cluster",
    )
    p.add_argument(
        "--duration", type=number(**DURATION_S), metavar="S", help="shorten every run to this many simulated seconds"
    )
    p.add_argument(
        "--out",
        type=place,
        help=(
            "write all summaries to this JSON file, and a table (a row per run) beside it as .csv "
            "(default: print them on stdout)"
        ),
    )
    p.set_defaults(func=cmd_sweep)


def _add_paper(sub: argparse._SubParsersAction) -> None:
    """`twin paper --out DIR`: the paper's experiments reproduced."""
    p = sub.add_parser("paper", help="reproduce the paper's experiments into DIR (paper.json, PNG plots, report.md)")
    p.add_argument("--out", type=place, required=True, metavar="DIR", help="output folder (made if missing)")
    p.add_argument("--quick", action="store_true", help="fewer angles and a shorter random-supply run")
    p.set_defaults(func=cmd_paper)


def _add_bench(sub: argparse._SubParsersAction) -> None:
    """`twin bench`: speed ratios against bare MuJoCo."""
    p = sub.add_parser("bench", help="speed benchmarks as ratios against bare MuJoCo measured in the same run")
    p.add_argument("--json", action="store_true", help="print the figures as JSON on stdout")
    p.add_argument("--quick", action="store_true", help="shorter runs (noisier figures)")
    p.set_defaults(func=cmd_bench)


def register(sub: argparse._SubParsersAction) -> None:
    """The scenario-facing subcommands, in the order of `twin --help`."""
    _add_run(sub)
    _add_sweep(sub)
    _add_paper(sub)
    _add_bench(sub)


def cmd_run(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from scenarios.recording import close_all, open_recorders
    from scenarios.runner import run_scenario
    from scenarios.schema import load, with_overrides

    scenario = load(args.scenario)
    if args.seed is not None:
        scenario = with_overrides(scenario, {"seed": args.seed})
    outputs = {"--rrd": args.rrd, "--mcap": args.mcap}
    for flag, path in outputs.items():
        if path is not None:
            check_output(
                path,
                flag,
                streamed=True,
                inputs=[Path(scenario.path)],
                others={f: p for f, p in outputs.items() if f != flag},
            )
    viewer = "spawn" if args.spawn else args.connect
    # the progress line only where someone watches it: not into a pipe or a file, not beside --json
    progress = ProgressLine() if not args.json and sys.stderr.isatty() else None
    with OutputLock(outputs.values()):
        recorders = open_recorders(scenario, args.rrd, args.mcap, args.camera_fps, args.start_time, viewer)
        try:
            result = run_scenario(scenario, recorders=recorders, duration_s=args.duration, progress=progress)
        finally:
            if progress is not None:
                progress.close()
            log_errors = close_all(recorders)
    summary = result.summary()
    if args.json:
        json.dump(summary, sys.stdout, indent=2)
        print()
    else:
        print_summary(summary)
    for label, path in (("rerun recording", args.rrd), ("MCAP log", args.mcap), ("rerun viewer", args.connect)):
        if path:
            state = " NOT written whole (the error below)" if Path(path) in log_errors else ""
            print(f"{label}: {path}{state}", file=sys.stderr if args.json else sys.stdout)
    for e in log_errors.values():  # the summary above is the run's result; a log that failed is said after it
        print(f"twin: error: {e}", file=sys.stderr)
    return 2 if log_errors else 0 if result.passed else 1


def run_state(summary: dict) -> str:
    """PASSED, FAILED, or NOT JUDGED (cut short before any criterion could be judged); a pass with
    criteria not judged says how many."""
    left = summary.get("not_judged", [])
    if not summary["passed"] and left and len(left) == len(summary["criteria"]) and not summary.get("error"):
        return "NOT JUDGED (cut short before any criterion could be judged)"
    if summary["passed"] and left:
        return f"PASSED the criteria judged ({len(left)} of {len(summary['criteria'])} not judged: cut short)"
    return "PASSED" if summary["passed"] else "FAILED"


def print_summary(summary: dict) -> None:
    from scenarios.criteria import CRITERIA, When

    print(f"{summary['scenario']}: {run_state(summary)} after {summary['duration_s']:.2f} s simulated")
    if summary.get("error"):
        print(f"  stopped: {summary['error']}")
    if summary.get("refused"):
        print(f"  refused, arm left braked: {summary['refused']}")
    for event in summary.get("controller_events", []):
        print(f"  controller: {event}")
    print(f"  {'joint':<16}{'target':>9}{'true':>9}{'predicted':>11}{'error':>9}")
    for joint, j in summary["joints"].items():
        cells = [j["target_deg"], j["true_final_deg"], j["predicted_final_deg"], j["error_deg"]]
        print(f"  {joint:<16}" + _cells(cells, (9, 9, 11, 9)))
    if summary.get("discs"):
        # peak N at the physics rate; rim %, top %: the shares gone over in the force band (scenarios/cleaning.py)
        head = f"{'contact s':>10}{'peak N':>9}{'mean N':>9}{'brushed cm':>12}{'rim %':>7}{'top %':>7}"
        print(f"  {'disc':<8}{head}  cleaned")
        for d in summary["discs"]:
            cells = [d["contact_s"], d["peak_force_n"], d["mean_force_n"], 100 * d["brushed_m"]]
            cells += [100 * d["rim_share"], 100 * d["top_share"]]
            state = {True: "yes", False: "NO", None: "not judged"}[d["cleaned"]]
            print(f"  disc_{d['disc']:<3}" + _cells(cells, (10, 9, 9, 12, 7, 7)) + f"  {state}")
        judged = [d for d in summary["discs"] if d["cleaned"] is not None]
        cleaned = sum(bool(d["cleaned"]) for d in judged)
        print(f"  discs cleaned: {cleaned} of {len(judged)} judged (contact, force band, brushed rim)")
    for c in summary["criteria"]:
        if summary.get("discs") and CRITERIA[c["kind"]].when is When.PER_DISC:
            continue  # in the disc table above
        mark = "ok  " if c["passed"] else "FAIL" if c.get("judged", True) else "----"
        print(f"  [{mark}] {c['kind']} {c['subject']}: {c['value']:.4g} (allowed {c['limit']})")
    if summary.get("faults_not_applied"):
        late = ", ".join(summary["faults_not_applied"])
        print(f"  not applied (after the cut, what depends on it not judged): {late}")
    if summary.get("not_judged"):
        print(f"  not judged (cut short before they were reached): {', '.join(summary['not_judged'])}")
    if summary.get("not_reached"):
        left = summary["not_reached"]
        discs = sorted({t.split("(")[1].rstrip(")") for t in left if "(" in t}, key=lambda d: int(d.split("_")[1]))
        on = f", on {', '.join(discs)}" if discs else ""
        print(f"  not reached (cut short, not judged): {len(left)} targets from {left[0]}{on}")


def _cells(values, widths) -> str:
    """Numbers right-aligned in columns of the given widths, '-' for None."""
    return "".join(f"{'-' if v is None else f'{v:.2f}':>{w}}" for v, w in zip(values, widths, strict=True))


def cmd_sweep(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from scenarios.schema import load
    from scenarios.sweep import parse_grid, partial_path, sweep, sweep_points, table_path, write_csv

    scenario = load(args.scenario)
    grid = parse_grid(args.set)
    table = None if args.out is None else table_path(args.out)
    partial = None if args.out is None else partial_path(args.out)
    if args.out is not None:
        check_output(args.out, "--out", inputs=[Path(scenario.path)])
        check_output(table, "--out's table", inputs=[Path(scenario.path)], others={"--out": args.out})
    finished: dict[int, dict] = {}
    with OutputLock([args.out, table, partial, partial and table_path(partial)]):
        try:
            results = sweep(
                scenario, grid, args.monte_carlo, args.workers, args.scheduler, args.duration, finished=finished
            )
        except BaseException as e:
            if stop_behind(e) is not None:
                with shielded():  # a second signal does not cut the keeping short
                    _keep_finished(finished, len(sweep_points(scenario, grid, args.monte_carlo)), partial)
            raise
        passed = sum(r["passed"] for r in results)
        cut = sum(bool(r.get("not_judged")) for r in results)
        cut_note = f", {cut} cut short with criteria not judged (column not_judged)" if cut else ""
        if args.out:
            saved = keep_result(
                args.out, lambda place: write_atomic(place, json.dumps(results, indent=2)), "the sweep's summaries"
            )
            rows = keep_result(table_path(saved), lambda place: write_csv(results, place), "the sweep's table")
            print(f"{len(results)} runs, {passed} passed{cut_note}; summaries in {saved}, one row per run in {rows}")
        else:
            json.dump(results, sys.stdout, indent=2)
            print()
            print(f"{len(results)} runs, {passed} passed{cut_note}", file=sys.stderr)
    if args.out and (saved != args.out or rows != table):
        return 2  # kept elsewhere, as said: the place asked for failed
    return 0 if passed == len(results) else 1


def _keep_finished(finished: dict[int, dict], planned: int, partial: Path | None) -> None:
    """A stopped sweep's finished runs, in the points' order: at `partial` (and its table, marked
    partial) or, without --out, on stdout; said on stderr either way."""
    from scenarios.sweep import write_summaries

    done = [finished[i] for i in sorted(finished)]
    if not done:
        print(f"twin: stopped before any of the {planned} runs finished; nothing to keep", file=sys.stderr)
        return
    if partial is None:
        json.dump(done, sys.stdout, indent=2)
        print()
        print(f"twin: stopped; the {len(done)} of {planned} runs that finished are above (partial)", file=sys.stderr)
        return
    saved = keep_result(partial, lambda place: write_summaries(done, place, partial=True), "the finished runs")
    print(
        f"twin: stopped; the {len(done)} of {planned} runs that finished are in {saved} and, one row per run "
        f"(column partial), {saved.with_suffix('.csv')} (partial: the sweep did not end)",
        file=sys.stderr,
    )


def cmd_paper(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from scenarios.paper import PARTIAL, reproduce

    check_output(args.out, "--out", folder=True)
    with OutputLock([args.out]):
        report, folder = publish_folder(
            args.out,
            lambda staging: reproduce(staging, quick=args.quick, progress=sys.stderr.isatty()),
            f"the paper's experiments ({PARTIAL}, partial)",
            keep_on_stop=True,
        )
    print(f"paper's experiments reproduced: {folder / report.name}")
    return 0


def cmd_bench(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from benchmarks.all import run_all

    finished: dict = {}
    try:
        with contextlib.redirect_stdout(sys.stderr):  # the benchmarks' own chatter stays off the JSON
            results = run_all(quick=args.quick, finished=finished)
    except BaseException as e:  # stopped: the benchmarks that finished, said to be partial
        if stop_behind(e) is not None and finished:
            with shielded():
                _print_figures({**finished, "partial": f"stopped after {', '.join(finished)}"}, args.json)
        raise
    _print_figures(results, args.json)
    return 0


def _print_figures(results: dict, as_json: bool) -> None:
    if as_json:
        json.dump(results, sys.stdout, indent=2)
        print()
    else:
        print("\n".join(figure_lines(results)))
