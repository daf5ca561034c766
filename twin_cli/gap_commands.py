"""`twin gap diagnose CAMPAIGN --out DIR` and `twin gap bench --out DIR`."""

from __future__ import annotations

from pathlib import Path

from twin_cli import gap_arm_commands
from twin_cli.args import number, number_from, place
from twin_cli.figures import figure_lines
from twin_plumbing.checks import JOBS
from twin_plumbing.outputs import OutputLock, check_output, publish_folder

BENCH_OUTPUTS = ("campaigns", "rounds", "bench.json")  # what `gap bench` writes into DIR, replacing an earlier bench's


# the ranges gap/ owns, imported when a flag is given: importing gap takes seconds (twin_cli/cli.py)
def _tolerance_range() -> dict:
    from gap.run import MODEL_TOLERANCE_DEG

    return MODEL_TOLERANCE_DEG


def _shift_range() -> dict:
    from gap.bench import BENCH_SHIFT

    return BENCH_SHIFT


def register(subparsers) -> None:
    p = subparsers.add_parser("gap", help="sim-to-real gap diagnosis")
    sub = p.add_subparsers(
        dest="gap_command", required=True, metavar="COMMAND", help="diagnose a campaign, or check the diagnosis blind"
    )
    d = sub.add_parser(
        "diagnose", help="diagnose a calibration campaign into DIR (diagnosis.json, report.md, PNG plots)"
    )
    d.add_argument("campaign", help="folder with campaign.toml and the run files")
    d.add_argument(
        "--out",
        type=place,
        required=True,
        metavar="DIR",
        help="output folder (made if missing; not the campaign's own folder)",
    )
    d.add_argument(
        "--model-tolerance-deg",
        type=number_from(_tolerance_range),
        default=None,
        metavar="DEG",
        help=(
            "twin model tolerance added to the noise floor (default: gap.floors.MODEL_TOLERANCE_DEG, "
            "twice the worst replay-vs-plant rms of the protocol library, gap.protocols)"
        ),
    )
    d.add_argument("--jobs", type=number(**JOBS), default=2, metavar="N", help="parallel fits (default 2)")
    d.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="Dask scheduler address: fit the candidates on that cluster (as `twin sweep --scheduler`)",
    )
    d.set_defaults(func=cmd_diagnose)
    b = sub.add_parser(
        "bench", help="blind check on campaigns generated from the plant with hidden effects (DIR/bench.json)"
    )
    b.add_argument(
        "--out", type=place, required=True, metavar="DIR", help="output folder: the generated campaigns and bench.json"
    )
    b.add_argument("--quick", action="store_true", help="a few cases only (for tests)")
    b.add_argument("--jobs", type=number(**JOBS), default=2, metavar="N", help="parallel fits (default 2)")
    b.add_argument(
        "--angle-only",
        action="store_true",
        help="every campaign without chamber-pressure transducers (default: half of them, in turn)",
    )
    b.add_argument(
        "--only",
        metavar="CASES",
        help="only these cases, comma-separated: names, a trailing * matching the start of a name (none*), "
        "or kinds (single, form, pair, outside, none)",
    )
    b.add_argument(
        "--protocol",
        metavar="NAME",
        help="every case on this protocol of the motion library (gap/protocols.py; a name it lacks is refused with "
        "the list) instead of its own: how far the figures carry to other motions",
    )
    for flag, spec, meta, text in (
        (
            "--shift",
            _shift_range,
            "K",
            "each case with the protocol, instrument and pressure transducers of the case K places along",
        ),
        (
            "--seeds",
            gap_arm_commands.seeds_range,
            "S",
            "each campaign's seed S further on: other noise, dropped frames and camera latencies",
        ),
    ):
        b.add_argument(flag, type=number_from(spec), default=0, metavar=meta, help=text)
    gap_arm_commands.add_bench_options(b)
    b.add_argument(
        "--design-round",
        action="store_true",
        help="after each diagnosis, play the runs `twin gap design` proposes on the same hidden reality, add them "
        "and diagnose again (DIR/rounds/CASE: the plan, its played files, the extended campaign)",
    )
    b.set_defaults(func=cmd_bench)
    gap_arm_commands.register(sub)
    register_design(sub)


INSTRUMENTS = ("encoder", "camera")  # gap.synth.ENCODER, gap.synth.CAMERA


def register_design(sub) -> None:
    g = sub.add_parser(
        "design",
        help="the next runs to make: from a campaign's diagnosis, or before any campaign the smallest one that "
        "tells every catalogue family apart (DIR/plan, design.md, design.json, predicted.png)",
    )
    g.add_argument(
        "campaign", nargs="?", help="folder with campaign.toml and the run files (omit: before any campaign)"
    )
    g.add_argument("--out", type=place, required=True, metavar="DIR", help="output folder (made if missing)")
    g.add_argument("--joint", help="before any campaign: the joint under test (assets.JOINTS)")
    g.add_argument("--instrument", choices=INSTRUMENTS, help="before any campaign: the reference instrument")
    g.add_argument("--pressures", action="store_true", help="before any campaign: chamber-pressure transducers too")
    g.add_argument(
        "--arm",
        action="store_true",
        help="the whole arm's: from an arm campaign's diagnosis (twin gap arm-diagnose), or before any with "
        "--joint, which joint to exercise, in which posture and at which speed (docs/gap_design.md)",
    )
    g.add_argument("--jobs", type=number(**JOBS), default=2, metavar="N", help="parallel replays (default 2)")
    g.set_defaults(func=cmd_design)


def cmd_diagnose(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from gap.report import window_line
    from gap.run import run_diagnose, verdict_line

    diag = run_diagnose(args.campaign, args.out, args.model_tolerance_deg, args.jobs, scheduler=args.scheduler)
    print(verdict_line(diag))
    if diag.windowed:
        print(f"runs: {window_line(diag.windowed)}")
    inst = diag.instrument
    how = "estimated" if inst.latency_estimated else "declared"
    print(
        f"instrument: latency {inst.latency_s * 1e3:.0f} ms ({how}), zero offset {inst.offset_deg:.3f} deg, "
        f"{inst.observed_rate_hz:.1f} Hz, {inst.dropped_samples} samples missing"
    )
    if inst.rate_mismatch:
        print(
            f"instrument: campaign.toml declares rate_hz = {inst.declared.rate_hz:g}, the run files sample at "
            f"{inst.observed_rate_hz:.1f} Hz: they do not match (more than 5 % apart); check the declared rate"
        )
    print(f"report: {diag.out / 'report.md'}")
    return 0


def cmd_bench(args) -> int:
    if args.arm:
        return gap_arm_commands.cmd_arm_bench(args)
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from gap.bench import Variant, check_only, check_variant, run_bench

    variant = Variant(args.protocol, args.shift, args.seeds)
    check_only(args.only, args.quick)
    check_variant(variant)
    check_output(args.out, "--out", folder=True)

    def bench_into(staging: Path) -> dict:
        return run_bench(
            staging,
            quick=args.quick,
            jobs=args.jobs,
            chamber_pressures=False if args.angle_only else None,
            only=args.only,
            variant=variant,
            design_round=args.design_round,
        )

    with OutputLock([args.out]):
        summary, _ = publish_folder(
            args.out, bench_into, "the bench's results", replaces=BENCH_OUTPUTS, keep_on_stop=True
        )
    print("\n".join(figure_lines({k: v for k, v in summary.items() if k != "cases"})))
    return 0


def cmd_design(args) -> int:
    # on use: at the top, the libraries take `twin --help` from 0.45 to 2.2 s
    from gap.design_cli import run_arm_design, run_design

    if args.arm:
        a, folder = run_arm_design(args.campaign, args.out, args.joint, args.instrument, args.pressures, args.jobs)
        d = a.design
        for k, p in enumerate(d.chosen, 1):
            e = a.exercises[p.protocol]
            told = sum(s >= 1.0 for s in p.separation.values())  # gap.discrimination.SEPARATED_FLOORS
            print(
                f"{k}. {e.label()}: {p.arm_time_s:.1f} s of arm time; alone it tells {told}/{len(p.separation)} "
                f"pairs apart, the least by {min(p.separation.values(), default=0.0):.2f} floors"
            )
    else:
        d, folder = run_design(args.campaign, args.out, args.joint, args.instrument, args.pressures, args.jobs)
        for k, p in enumerate(d.chosen, 1):
            print(f"{k}. {p.protocol}: {len(p.runs)} runs, {p.arm_time_s:.1f} s of arm time")
    if not d.chosen:
        print("no run proposed (nothing to tell apart)")
    told = len(d.separation) - len(d.unseparated)
    print(
        f"pairs told apart: {told}/{len(d.separation)}"
        + (f"; not: {', '.join(d.unseparated)}" if d.unseparated else "")
    )
    print(f"plan: {folder / 'design.md'}")
    return 0
