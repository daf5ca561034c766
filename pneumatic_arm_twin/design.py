"""The next runs to make, from Python (`twin gap design`): `design_runs("my_campaign/", out="next/")`
diagnoses the campaign and proposes the runs that best tell its leading hypotheses apart;
`design_runs(joint="wrist_pitch", instrument="camera")` proposes the smallest campaign that tells
every catalogue family apart. Returns gap.design.Design (`.chosen`, `.separation`, `.unseparated`,
`.runs()`, `.arm_time_s()`); with `out`, the plan (campaign files), design.md, design.json and
predicted.png are written there."""

from __future__ import annotations

from pathlib import Path

from gap.design import Design
from gap.design_cli import run_design


def design_runs(
    campaign: str | Path | None = None,
    *,
    out: str | Path,
    joint: str | None = None,
    instrument: str | None = None,
    pressures: bool = False,
    jobs: int = 2,
) -> Design:
    """The design (gap.design) of `campaign`'s next runs, or before any campaign of `joint` read by
    `instrument` ("encoder" or "camera"; `pressures`: with chamber-pressure transducers), written to `out`."""
    return run_design(campaign, out, joint, instrument, pressures, jobs)[0]
