"""`twin gap design`: checked inputs, the diagnosis (from a campaign) or the catalogue (before any
campaign), the design (gap.design) written whole into the output folder (gap.design_report)."""

from __future__ import annotations

from pathlib import Path

import assets
from gap import synth
from gap.campaign import load_campaign
from gap.design import Design, design, design_before_campaign
from gap.design_report import write_design
from gap.diagnose import diagnose
from gap.plan import Header
from gap.report import write
from twin.checks import JOBS, check_number
from twin.errors import UserError
from twin.outputs import OutputLock, check_output, publish_folder

INSTRUMENTS = {"encoder": synth.ENCODER, "camera": synth.CAMERA}


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
    if campaign is None:
        if joint not in assets.JOINTS or instrument not in INSTRUMENTS:
            raise UserError(
                f"twin gap design: without a campaign, --joint (one of {', '.join(assets.JOINTS)}; got {joint!r}) and "
                f"--instrument (one of {', '.join(INSTRUMENTS)}; got {instrument!r}) are needed"
            )
        check_output(out, "--out", folder=True)
        header = Header(joint=joint, pressures=pressures)

        def work(staging: Path) -> Design:
            d = design_before_campaign(joint, INSTRUMENTS[instrument], pressures, n_jobs=jobs)
            write_design(d, staging, header)
            return d

    else:
        if joint is not None or instrument is not None or pressures:
            raise UserError(
                "twin gap design: --joint, --instrument and --pressures are for before any campaign; "
                "a campaign says its own"
            )
        loaded = load_campaign(campaign)
        check_output(out, "--out", folder=True, inputs=[loaded.folder, *(r.path for r in loaded.runs)])

        def work(staging: Path) -> Design:
            diag = diagnose(loaded, n_jobs=jobs, progress=True)
            write(diag, staging / "diagnosis")
            d = design(loaded, diag, n_jobs=jobs)
            write_design(d, staging, Header.of_campaign(loaded, diag.pressure.measured))
            return d

    with OutputLock([out]):
        d, folder = publish_folder(out, work, "the design")
    return d, folder
