"""`twin gap diagnose CAMPAIGN --out DIR` and `twin gap bench --out DIR`."""

from __future__ import annotations

from pathlib import Path

from twin.args import JOBS, MODEL_TOLERANCE_DEG, check_number, number
from twin.outputs import OutputLock, check_output, publish_folder


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
        "--out", required=True, metavar="DIR", help="output folder (made if missing; not the campaign's own folder)"
    )
    d.add_argument(
        "--model-tolerance-deg",
        type=number(**MODEL_TOLERANCE_DEG),
        default=None,
        metavar="DEG",
        help="twin model tolerance added to the noise floor (default: gap.diagnose.MODEL_TOLERANCE_DEG, twice the worst replay-vs-plant rms of the protocol library, gap.protocols)",
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
    b.add_argument("--out", required=True, metavar="DIR", help="output folder: the generated campaigns and bench.json")
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
        help="only these cases, comma-separated (a trailing * matches the start of a name: none*)",
    )
    b.set_defaults(func=cmd_bench)


def run_diagnose(
    campaign: str | Path,
    out: str | Path,
    model_tolerance_deg: float | None = None,
    jobs: int = 2,
    progress: bool = True,
    scheduler: str | None = None,
) -> dict:
    """Check the numbers, the campaign and `out`, then diagnose and write the report into `out`.
    The report's files arrive whole; if `out` fails after the work they are kept beside it (where:
    diag.out)."""
    from gap.campaign import load_campaign
    from gap.diagnose import MODEL_TOLERANCE_DEG as DEFAULT_TOLERANCE_DEG
    from gap.diagnose import diagnose
    from gap.report import write

    tolerance = DEFAULT_TOLERANCE_DEG if model_tolerance_deg is None else model_tolerance_deg
    check_number("model_tolerance_deg", tolerance, **MODEL_TOLERANCE_DEG)
    check_number("jobs", jobs, **JOBS)
    loaded = load_campaign(campaign)
    out = Path(out)
    check_output(out, "--out", folder=True, inputs=[loaded.folder, *(r.path for r in loaded.runs)])

    def diagnose_into(staging: Path) -> dict:
        diag = diagnose(loaded, model_tolerance_deg=tolerance, n_jobs=jobs, progress=progress, scheduler=scheduler)
        write(diag, staging)
        return diag

    with OutputLock([out]):
        diag, folder = publish_folder(out, diagnose_into, "the diagnosis")
    diag.out = folder
    return diag


def verdict_line(diag: dict) -> str:
    """The one-line answer. For a gap outside the catalogue it names the nearest family, never a
    candidate (a candidate's name there would read like a diagnosis)."""
    w = diag.which
    top = w.top
    if w.verdict == "outside the catalogue":
        return f"verdict: outside the catalogue (nearest family: {w.nearest.family}; nominal twin {diag.before_rms_deg:.2f} deg rms)"
    if top is None:
        return f"verdict: {w.verdict} (nominal twin {diag.before_rms_deg:.2f} deg rms, threshold {diag.noise_floor.significance_threshold_deg:.2f})"
    bound = " [fitted on a catalogue bound]" if any(top.at_bound) else ""
    return f"verdict: {w.verdict} ({top.name}{bound}, held-out rms {diag.before_rms_deg:.2f} -> {top.heldout_rms_deg:.2f} deg)"


def cmd_diagnose(args) -> int:
    diag = run_diagnose(args.campaign, args.out, args.model_tolerance_deg, args.jobs, scheduler=args.scheduler)
    print(verdict_line(diag))
    inst = diag.instrument
    print(
        f"instrument: latency {inst.latency_s * 1e3:.0f} ms ({'estimated' if inst.latency_estimated else 'declared'}), zero offset {inst.offset_deg:.3f} deg, "
        f"{inst.observed_rate_hz:.1f} Hz, {inst.dropped_samples} samples missing"
    )
    print(f"report: {diag.out / 'report.md'}")
    return 0


def cmd_bench(args) -> int:
    from gap.bench import run_bench

    check_output(Path(args.out), "--out", folder=True)

    def bench_into(staging: Path) -> dict:
        return run_bench(
            staging,
            quick=args.quick,
            jobs=args.jobs,
            chamber_pressures=False if args.angle_only else None,
            only=args.only,
        )

    with OutputLock([Path(args.out)]):
        summary, _ = publish_folder(Path(args.out), bench_into, "the bench's results")
    print({k: v for k, v in summary.items() if k != "cases"})
    return 0
