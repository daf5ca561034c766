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

The one joint's diagnosis by job: diagnose (the orchestration), campaign_replay (the campaign's
runs replayed through the nominal twin, the fit's objective), single_fits, pair_search, floors,
members and family (the family call), verdict (its rules) with kinds (verdicts and families, one
row each), assembly (the typed result, gap.result), jobs (threads or a Dask cluster).
"""

from gap.bench import run_bench
from gap.campaign import Campaign, GapError, MeasuredRun, load_campaign
from gap.diagnose import diagnose
from gap.effects import CATALOGUE, NOT_IN_CATALOGUE, Effect
from gap.report import write as write_report
from gap.synth import make_campaign

# Imported here, not on use: a function named like its module (`diagnose` in gap/diagnose.py) is
# shadowed by the module once anything imports `gap.diagnose` unless the package binds it after
# the module has loaded (tests/test_api.py). `import gap` then takes the diagnosis's libraries.

__all__ = [
    "CATALOGUE",
    "Campaign",
    "Effect",
    "GapError",
    "NOT_IN_CATALOGUE",
    "MeasuredRun",
    "diagnose",
    "load_campaign",
    "make_campaign",
    "run_bench",
    "write_report",
]
