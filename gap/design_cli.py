"""`twin gap design`: checked inputs, the diagnosis (from a campaign) or the catalogue (before any
campaign), the design (gap.design) written whole into the output folder (gap.design_report)."""

from __future__ import annotations

import json
from pathlib import Path

import assets
from gap import synth
from gap.arm_campaign import CAMERA, ENCODER, load_arm_campaign
from gap.arm_design import ArmDesign, design_arm, design_arm_before_campaign
from gap.arm_design_report import write_arm_design
from gap.arm_diagnose import diagnose_arm
from gap.campaign import load_campaign
from gap.design import Design, design, design_before_campaign
from gap.design_report import write_design
from gap.diagnose import diagnose
from gap.plan import Header
from gap.report import write
from twin_plumbing.checks import JOBS, check_number
from twin_plumbing.errors import UserError
from twin_plumbing.outputs import OutputLock, check_output, publish_folder

INSTRUMENTS = {"encoder": synth.ENCODER, "camera": synth.CAMERA}
ARM_INSTRUMENTS = {"encoder": ENCODER, "camera": CAMERA}  # the arm's (gap.arm_campaign)
PRESSURE_NOISE_PA = synth.NOISE_PA  # the platform's port transducers before any arm campaign (gap.synth)


def _checked(campaign, out: Path, joint, instrument, pressures: bool, instruments: dict, command: str, load):
    """The inputs checked (UserError in one line): without a campaign, a joint and an instrument;
    with one, neither (the campaign says its own). Returns the campaign loaded by `load`, or None;
    `out` checked as the output folder (not one of the campaign's files)."""
    if campaign is None:
        if joint not in assets.JOINTS or instrument not in instruments:
            raise UserError(
                f"{command}: without a campaign, --joint (one of {', '.join(assets.JOINTS)}; got {joint!r}) and "
                f"--instrument (one of {', '.join(instruments)}; got {instrument!r}) are needed"
            )
        check_output(out, "--out", folder=True)
        return None
    if joint is not None or instrument is not None or pressures:
        raise UserError(
            f"{command}: --joint, --instrument and --pressures are for before any campaign; a campaign says its own"
        )
    loaded = load(campaign)
    check_output(out, "--out", folder=True, inputs=[loaded.folder, *(r.path for r in loaded.runs)])
    return loaded


def _published(out: Path, work):
    with OutputLock([out]):
        return publish_folder(out, work, "the design")


def run_design(
    campaign: str | Path | None,
    out: str | Path,
    joint: str | None = None,
    instrument: str | None = None,
    pressures: bool = False,
    jobs: int = 2,
) -> tuple[Design, Path]:
    """From a campaign: diagnose it (DIR/diagnosis) and design its next runs; without one: the smallest
    campaign for `joint` read by `instrument`. Returns the design and the folder it was written to."""
    check_number("jobs", jobs, **JOBS)
    out = Path(out)
    loaded = _checked(campaign, out, joint, instrument, pressures, INSTRUMENTS, "twin gap design", load_campaign)
    if loaded is None:
        header = Header(joint=joint, pressures=pressures)

        def work(staging: Path) -> Design:
            d = design_before_campaign(joint, INSTRUMENTS[instrument], pressures, n_jobs=jobs)
            write_design(d, staging, header)
            return d

    else:

        def work(staging: Path) -> Design:
            diag = diagnose(loaded, n_jobs=jobs, progress=True)
            write(diag, staging / "diagnosis")
            d = design(loaded, diag, n_jobs=jobs)
            write_design(d, staging, Header.of_campaign(loaded, diag.pressure.measured))
            return d

    return _published(out, work)


def run_arm_design(
    campaign: str | Path | None,
    out: str | Path,
    joint: str | None = None,
    instrument: str | None = None,
    pressures: bool = False,
    jobs: int = 2,
) -> tuple[ArmDesign, Path]:
    """`twin gap design --arm`: from an arm campaign, diagnose it (DIR/diagnosis/diagnosis.json) and
    design its next runs; without one, the smallest set of exercises of `joint` read by `instrument`
    (and the platform's port transducers with `pressures`) (gap.arm_design)."""
    check_number("jobs", jobs, **JOBS)
    out = Path(out)
    command = "twin gap design --arm"
    loaded = _checked(campaign, out, joint, instrument, pressures, ARM_INSTRUMENTS, command, load_arm_campaign)
    if loaded is None:
        noise_pa = PRESSURE_NOISE_PA if pressures else None

        def work(staging: Path) -> ArmDesign:
            a = design_arm_before_campaign(joint, ARM_INSTRUMENTS[instrument], noise_pa, n_jobs=jobs)
            write_arm_design(a, staging)
            return a

    else:

        def work(staging: Path) -> ArmDesign:
            diag = diagnose_arm(loaded, jobs)
            (staging / "diagnosis").mkdir(parents=True, exist_ok=True)
            (staging / "diagnosis" / "diagnosis.json").write_text(json.dumps(diag.as_dict(), indent=2, default=str))
            a = design_arm(loaded, diag, n_jobs=jobs)
            write_arm_design(a, staging)
            return a

    return _published(out, work)
