"""Sim-to-real gap diagnosis of one joint: where the twin departs from a measured calibration
campaign, which catalogue effect (or pair) explains it, and how far the gap shrinks on runs
withheld from the fit.

Public surface (everything else in gap/ is internal):
    load_campaign(folder) -> Campaign       campaign.toml + run files (CSV or the twin's MCAP logs)
    GapError                                a campaign that cannot be diagnosed (a twin UserError)
    diagnose(campaign, catalogue=CATALOGUE, ...) -> Diagnosis   the typed diagnosis (gap.result)
    write_report(diagnosis, out_dir)         diagnosis.json, report.md and PNG plots
    CATALOGUE, Effect, NOT_IN_CATALOGUE      the candidate effects
    make_campaign(folder, reality, ...)      a synthetic campaign from the plant (gap.synth)
    run_bench(out_dir, quick=False, chamber_pressures=None) -> dict  the blind check (gap.bench)
Command line: `twin gap diagnose CAMPAIGN --out DIR`, `twin gap bench --out DIR`.
"""

from gap.campaign import Campaign, GapError, Run, load_campaign
from gap.effects import CATALOGUE, NOT_IN_CATALOGUE, Effect

# The functions below import their module on use: `import gap` takes 0.6 s, with gap.diagnose (scipy,
# joblib, the compiled replay) 2.0 s, with gap.report (matplotlib) 2.2 s (python -X importtime on
# this 2-core machine, under load); a command that does not diagnose should not pay for them.


def diagnose(campaign, *args, **kwargs):
    from gap.diagnose import diagnose as _diagnose  # scipy/joblib imported on use

    return _diagnose(campaign, *args, **kwargs)


def write_report(diagnosis, out):
    from gap.report import write  # matplotlib imported on use

    return write(diagnosis, out)


def make_campaign(folder, reality, **kwargs):
    from gap.synth import make_campaign as _make

    return _make(folder, reality, **kwargs)


def run_bench(
    out, quick: bool = False, jobs: int = 2, chamber_pressures: bool | None = None, only: str | None = None
) -> dict:
    from gap.bench import run_bench as _run

    return _run(out, quick=quick, jobs=jobs, chamber_pressures=chamber_pressures, only=only)


__all__ = [
    "CATALOGUE",
    "Campaign",
    "Effect",
    "GapError",
    "NOT_IN_CATALOGUE",
    "Run",
    "diagnose",
    "load_campaign",
    "make_campaign",
    "run_bench",
    "write_report",
]
