"""A campaign diagnosed into a folder, checked first: what `twin gap diagnose` runs (and the
bench times): the numbers, the campaign and the output folder are checked before any work; the
report's files arrive whole. `verdict_line` is the one-line answer the command prints."""

from __future__ import annotations

from pathlib import Path

from gap.campaign import load_campaign
from gap.diagnose import diagnose
from gap.floors import MODEL_TOLERANCE_DEG as DEFAULT_TOLERANCE_DEG
from gap.kinds import Verdict
from gap.report import write
from gap.result import Diagnosis
from twin_plumbing.checks import JOBS, check_number
from twin_plumbing.outputs import OutputLock, check_output, publish_folder

# the range of `model_tolerance_deg` (check_number), the command line's flag too
MODEL_TOLERANCE_DEG = {"low": 0.0, "high": 45.0, "unit": "deg"}  # a tolerance this wide hides any gap worth diagnosing


def run_diagnose(
    campaign: str | Path,
    out: str | Path,
    model_tolerance_deg: float | None = None,
    jobs: int = 2,
    progress: bool = True,
    scheduler: str | None = None,
) -> Diagnosis:
    """Check the numbers, the campaign and `out`, then diagnose and write the report into `out`.
    The report's files arrive whole; if `out` fails after the work they are kept beside it (where:
    diag.out)."""
    tolerance = DEFAULT_TOLERANCE_DEG if model_tolerance_deg is None else model_tolerance_deg
    check_number("model_tolerance_deg", tolerance, **MODEL_TOLERANCE_DEG)
    check_number("jobs", jobs, **JOBS)
    loaded = load_campaign(campaign)
    out = Path(out)
    check_output(out, "--out", folder=True, inputs=[loaded.folder, *(r.path for r in loaded.runs)])

    def diagnose_into(staging: Path) -> Diagnosis:
        diag = diagnose(loaded, model_tolerance_deg=tolerance, n_jobs=jobs, progress=progress, scheduler=scheduler)
        write(diag, staging)
        return diag

    with OutputLock([out]):
        diag, folder = publish_folder(out, diagnose_into, "the diagnosis")
    diag.out = folder
    return diag


def verdict_line(diag: Diagnosis) -> str:
    """The one-line answer. For a gap outside the catalogue it names the nearest family, never a
    candidate (a candidate's name there would read like a diagnosis); for an ambiguous one, the
    candidates and their nearest family."""
    w = diag.which
    top = w.top
    before = f"{diag.before_rms_deg:.2f}"
    if w.verdict == Verdict.OUTSIDE:
        return f"verdict: outside the catalogue (nearest family: {w.nearest.family}; nominal twin {before} deg rms)"
    if top is None:
        threshold = diag.noise_floor.significance_threshold_deg
        return f"verdict: {w.verdict} (nominal twin {before} deg rms, threshold {threshold:.2f})"
    bound = " [fitted on a catalogue bound]" if any(top.at_bound) else ""
    rivals = f" or {', '.join(w.rivals)}; nearest family: {w.nearest.family}" if w.rivals and w.nearest else ""
    return f"verdict: {w.verdict} ({top.name}{bound}{rivals}, held-out rms {before} -> {top.heldout_rms_deg:.2f} deg)"
