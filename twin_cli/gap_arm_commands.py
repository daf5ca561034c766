"""`twin gap arm-campaign`, `twin gap arm-diagnose` and `twin gap bench --arm`: the whole arm's gap
(docs/gap_arm.md)."""

from __future__ import annotations

import json
from pathlib import Path

from twin_cli.args import number, number_from, place
from twin_plumbing.checks import DURATION_S, JOBS
from twin_plumbing.errors import UserError
from twin_plumbing.outputs import OutputLock, check_output

INSTRUMENTS = ("camera", "encoder")


def seeds_range() -> dict:
    """gap.bench's range of seeds, imported when a flag is given: importing gap takes seconds (twin_cli/cli.py)."""
    from gap.bench import BENCH_SEEDS

    return BENCH_SEEDS


def register(sub) -> None:
    """The arm's subcommands under `twin gap`."""
    c = sub.add_parser(
        "arm-campaign", help="rehearse an arm campaign: the twin's own scenario runs through an instrument model"
    )
    c.add_argument("scenarios", nargs="+", help='scenario files (model = "arm"), one run each per supply')
    c.add_argument("--out", type=place, required=True, metavar="DIR", help="the campaign folder (made)")
    c.add_argument(
        "--reality",
        metavar="EFFECT=VALUE",
        help="hide one effect in the plant: '<joint>:<effect>=<value>' or 'arm:<effect>=<value>' "
        "(gap/arm_effects.py); recorded under [reality] in campaign.toml",
    )
    c.add_argument("--supplies", default="0.5,0.6,0.7,0.8", metavar="MPA,...", help="supplies, gauge MPa")
    c.add_argument("--instrument", choices=INSTRUMENTS, default="camera", help="the angle instrument's model")
    c.add_argument("--duration", type=number(**DURATION_S), default=60.0, metavar="S", help="seconds a run")
    c.add_argument("--seed", type=number_from(seeds_range), default=0, metavar="N", help="the instruments' noise")
    c.set_defaults(func=cmd_arm_campaign)
    d = sub.add_parser("arm-diagnose", help="diagnose an arm campaign into DIR (diagnosis.json)")
    d.add_argument("campaign", help="folder with campaign.toml and the run files")
    d.add_argument("--out", type=place, required=True, metavar="DIR", help="output folder (made if missing)")
    d.add_argument("--jobs", type=number(**JOBS), default=1, metavar="N", help="parallel replays (default 1)")
    d.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler address: the replays on that cluster")
    d.add_argument(
        "--rrd",
        type=place,
        metavar="FILE",
        help="also write a rerun recording: the measured and replayed arm on the withheld runs, the departing "
        "joint marked (gap/arm_view.py)",
    )
    d.set_defaults(func=cmd_arm_diagnose)


def add_bench_options(b) -> None:
    """`twin gap bench`'s options for the arm's bench."""
    b.add_argument("--arm", action="store_true", help="the arm-level bench (gap/arm_bench.py) instead")
    b.add_argument(
        "--arm-duration", type=number(**DURATION_S), default=20.0, metavar="S", help="with --arm: seconds a run"
    )


def _reality(text: str | None):
    from gap.arm_campaign import HiddenArmEffect
    from gap.arm_effects import candidate_named

    if text is None:
        return None
    name, eq, value = text.partition("=")
    try:
        candidate_named(name.strip())
        return HiddenArmEffect(effect=name.strip(), value=float(value))
    except ValueError:
        raise UserError(
            f"--reality {text!r}; allowed: '<joint>:<effect>=<number>' or 'arm:<effect>=<number>' "
            "(gap/arm_effects.py: JOINT_CATALOGUE, ARM_CATALOGUE)"
        ) from None


def cmd_arm_campaign(args) -> int:
    from gap.arm_campaign import CAMERA, ENCODER
    from gap.arm_rehearsal import make_arm_campaign
    from scenarios.schema import load

    reality = _reality(args.reality)
    try:
        supplies = tuple(float(s) for s in args.supplies.split(","))
    except ValueError:
        raise UserError(f"--supplies {args.supplies!r}; allowed: gauge MPa, comma-separated (0.5,0.6)") from None
    scenarios = [load(s) for s in args.scenarios]
    for s in scenarios:
        if s.model != "arm":
            raise UserError(f'{s.path}: model = {s.model!r}; allowed: "arm" (an arm campaign\'s runs)')
    instrument = CAMERA if args.instrument == "camera" else ENCODER
    folder = make_arm_campaign(args.out, scenarios, supplies, reality, instrument, args.seed, args.duration)
    print(f"campaign: {folder / 'campaign.toml'} ({len(scenarios) * len(supplies)} runs)")
    return 0


def cmd_arm_diagnose(args) -> int:
    from gap.arm_campaign import load_arm_campaign
    from gap.arm_diagnose import diagnose_arm

    campaign = load_arm_campaign(args.campaign)
    if Path(args.out).resolve() == campaign.folder.resolve():
        raise UserError(f"--out {args.out}: the campaign's own folder; allowed: another folder")
    if args.rrd is not None:  # refused before the diagnosis, not after it
        check_output(args.rrd, "--rrd", inputs=[campaign.folder], others={"--out": Path(args.out)})
    d = diagnose_arm(campaign, args.jobs, args.scheduler)
    Path(args.out).mkdir(parents=True, exist_ok=True)
    (Path(args.out) / "diagnosis.json").write_text(json.dumps(d.as_dict(), indent=2, default=str))
    print(d.line())
    for g in d.joints:
        print(
            f"  {g.joint}: angle {g.angle_rms_deg:.3f} deg rms ({g.angle_floors:.1f} floors), ports "
            f"{g.pressure_rms_kpa:.2f} kPa rms ({g.pressure_floors:.1f} floors)"
        )
    print(f"diagnosis: {Path(args.out) / 'diagnosis.json'}")
    if args.rrd is not None:  # after diagnosis.json: a recording that fails loses nothing of it
        from gap.arm_view import describe, write_arm_view

        with OutputLock([args.rrd]):
            write_arm_view(args.rrd, campaign, d, args.jobs, args.scheduler)
        print(describe(args.rrd, d))
    return 0


def cmd_arm_bench(args) -> int:
    from gap.arm_bench import run_arm_bench

    Path(args.out).mkdir(parents=True, exist_ok=True)
    s = run_arm_bench(
        Path(args.out), args.only, args.arm_duration, args.jobs, args.seeds, report=lambda line: print(line, flush=True)
    )
    for k in ("false_alarms", "right_joint", "right_effect", "median_withheld_shrink"):
        print(f"{k}: {s[k]}")
    if s["below_floor"]:
        below = ", ".join(s["below_floor"])
        print(f"not scored, the hidden effect below the noise on its protocol: {below}")
        print(f"right_joint, right_effect with them: {s['right_joint_all']}, {s['right_effect_all']}")
    return 0
