"""One design round of the blind check (`twin gap bench --design-round`): a case's diagnosis proposes
its next runs (gap.design), the plan is written as files (gap.plan), played on the same hidden
reality by the same instruments (the same camera latency; other noise), its runs added to the
campaign, and the campaign diagnosed again."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from gap import synth
from gap.campaign import Campaign, load_campaign
from gap.design import design
from gap.design_report import write_design
from gap.diagnose import diagnose
from gap.plan import Header, add_runs, play_plan
from gap.result import Diagnosis

ROUND_SEED = 50_000  # the round's measurement noise: the case's seed this far on (its own draws)


def design_round(
    campaign: Campaign,
    diag: Diagnosis,
    folder: Path,
    reality,
    instrument: synth.SimInstrument,
    chamber_pressures: bool,
    catalogue,
    seed: int,
    jobs: int,
    rig_spring_nm_per_rad: float = 0.0,
    rig_load_nm: float = 0.0,
) -> tuple[Diagnosis | None, dict]:
    """The round for a campaign and its diagnosis: the design in `folder` (gap.design_report), its plan in
    `folder`/plan, played into
    `folder`/played, the campaign with its runs in `folder`/campaign, and its diagnosis (None when
    the design proposes nothing), with what the round cost."""
    t0 = time.perf_counter()
    d = design(campaign, diag, catalogue, n_jobs=jobs)
    t_design = time.perf_counter() - t0
    cost = {
        "proposed": [p.protocol for p in d.chosen],
        "runs_added": len(d.runs()),
        "arm_time_s": d.arm_time_s(),
        "design_s": t_design,
        "separation": d.separation,
        "unseparated": d.unseparated,
    }
    write_design(d, folder, Header.of_campaign(campaign, chamber_pressures))  # plan/, design.md, design.json
    if not d.chosen:
        return None, cost
    play_plan(
        folder / "plan",
        folder / "played",
        reality,
        instrument,
        np.random.default_rng(ROUND_SEED + seed),
        chamber_pressures,
        rig_spring_nm_per_rad,
        rig_load_nm,
    )
    extended = add_runs(Path(campaign.folder), folder / "played", folder / "campaign")
    t1 = time.perf_counter()
    again = diagnose(load_campaign(extended), catalogue=catalogue, n_jobs=jobs, progress=False)
    cost["diagnose_s"] = time.perf_counter() - t1
    return again, cost
