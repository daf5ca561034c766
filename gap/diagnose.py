"""The diagnosis: where the twin departs from measured runs, which catalogue effect explains it, and
how far the gap shrinks on runs withheld from the fit. This module is the orchestration; each step
lives in its own module.

Steps (each a plain function of the campaign):
1. the reference instrument's nuisance first (gap.instrument): its zero offset from the rest
   samples, its latency (declared, or fitted with every candidate, the nominal twin included);
   replay every run through the nominal twin (gap.campaign_replay; repeats share one replay) ->
   residual = measured - twin, in angle and, where the campaign measured them, chamber pressures;
2. where (gap.where): break the angle residual down by motion phase, supply, direction, load,
   angle, speed and time since start, beside a floor of the instrument's noise and the drift
   between repeats and the twin's own model tolerance (gap.floors). The fit's objective counts
   angle and pressure samples each in units of its own floor: the replay is given that weight;
3. which: for each catalogue effect, fit its one bounded parameter on training runs and score it
   on withheld runs (leave one supply pressure out; alternating split when there is one pressure;
   gap.single_fits). When no single effect brings the gap to the floor, pairs of the best singles
   are screened and the best fitted together (gap.pair_search). A verdict and a family call by
   the rules of gap.verdict (a pair counts only with both effects off nominal and a clear margin;
   the family by each family's own corrections on withheld runs, read at the instrument latency
   each fold's training runs choose with the family (gap.members), ties told apart by the
   where-profile, gap.family);
4. how far: per pressure, mean and max |error| on withheld runs before and after each effect, with
   bootstrap confidence intervals over runs, and the typed result (gap.assembly).
The fits run on local threads or a Dask cluster (gap.jobs).
"""

from __future__ import annotations

import time

import numpy as np
from joblib import delayed

from gap import instrument, verdict
from gap.assembly import result_of
from gap.campaign import Campaign, GapError
from gap.campaign_replay import CampaignReplay, folds_of, nominal_residuals, prepared_runs, where_labels
from gap.candidate import Candidate, Fits
from gap.effects import CATALOGUE, Effect
from gap.floors import MODEL_TOLERANCE_DEG, Floors, floors_of
from gap.jobs import parallel_jobs, stage_bar
from gap.members import at_fold_latencies, family_members
from gap.pair_search import pair_stage
from gap.result import Diagnosis, Timing
from gap.single_fits import fit_single
from gap.stats import rms_deg, rms_kpa


def diagnose(
    campaign: Campaign,
    catalogue: tuple[Effect, ...] = CATALOGUE,
    model_tolerance_deg: float | None = None,
    n_jobs: int = 2,
    progress: bool = True,
    seed: int = 0,
    scheduler: str | None = None,
) -> Diagnosis:
    """The diagnosis of `campaign` (see the module docstring for its steps)."""
    tolerance = MODEL_TOLERANCE_DEG if model_tolerance_deg is None else model_tolerance_deg
    # the cluster first: a scheduler that does not answer is refused before any work
    with parallel_jobs(n_jobs, scheduler) as run_jobs:
        nuisance = instrument.estimate(campaign)
        fl = floors_of(campaign, prepared_runs(campaign, nuisance), tolerance)
        replay = CampaignReplay(campaign, pressure_weight=fl.pressure_weight, nuisance=nuisance)
        rng = np.random.default_rng(seed)
        nominal_latency = replay.ref_latency_s
        gap = replay.gap_vector
        before, before_p = nominal_residuals(replay, nominal_latency)
        check_finite(campaign, before, before_p)
        before_rms, before_kpa = rms_deg(before), rms_kpa(before_p)
        significant = fl.above(before_rms, before_kpa)
        fits = fit_candidates(replay, catalogue, fl, significant, run_jobs, progress)
        folds = folds_of(campaign)
        corrections = at_fold_latencies(replay, family_members(replay, fits.singles, catalogue), folds, run_jobs)

    judge = verdict.Judge(replay, fl, before_rms, fl.score, rng, before_kpa)
    call = judge.call(significant, fits.singles, fits.pairs)
    labels = where_labels(replay)
    family = judge.family_call(
        fits.singles,
        labels,
        gap,
        folds,
        corrections,
        among=verdict.families_of([call.top.name, *call.rivals]) if call.verdict.tied else None,
    )
    # the instrument as best understood: the latency fitted with the answer (with the nominal twin
    # alone a latency soaks up part of any gap that makes the twin run ahead); the nominal twin's
    # residual, its breakdown and how far are reported at it
    latency = call.top.latency_s if call.top is not None else nominal_latency
    return result_of(judge, fits, call, family, labels, latency, rng)


def fit_candidates(replay: CampaignReplay, catalogue, fl: Floors, significant: bool, run_jobs, progress: bool) -> Fits:
    """Step 3's fits: every single effect, then, when no single brings a significant gap under the
    threshold, the pair stage (`pair_stage`)."""
    # effects already in the nominal twin at their catalogue value are not candidates
    effects = [
        e for e in catalogue if not (e.discrete_value is not None and e.value_of(replay.params) == e.discrete_value)
    ]
    folds = folds_of(replay.campaign)
    start = time.perf_counter()
    with stage_bar(len(effects), "gap: effects", progress):
        singles: list[Candidate] = run_jobs(delayed(fit_single)(replay, e, folds) for e in effects)
    singles.sort(key=fl.score)
    t_singles = time.perf_counter()
    pairs: list[Candidate] = []
    if significant and singles and fl.above(rms_deg(singles[0].heldout), rms_kpa(singles[0].heldout_p)):
        pairs = pair_stage(replay, singles, folds, run_jobs, progress)
        pairs.sort(key=fl.score)
    t_pairs = time.perf_counter()
    timing = Timing(t_singles - start, t_pairs - t_singles, t_pairs - start)
    return Fits(singles, pairs, [e.name for e in catalogue if e not in effects], timing)


def check_finite(campaign: Campaign, angle: list[np.ndarray], pressure: list[np.ndarray]) -> None:
    """Refuse (GapError) a campaign whose nominal twin's replay is not finite (its model values put
    the replay where its 1 ms step diverges): never a verdict computed from NaN."""
    for run, a, p in zip(campaign.runs, angle, pressure, strict=True):
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(p))):
            raise GapError(
                f"{campaign.folder / 'campaign.toml'}: the nominal twin's replay of {run.path.name} is not finite "
                f"(hose_length_m = {campaign.hose_length_m}, the run's rig_inertia_kg_m2 = {run.rig_inertia_kg_m2} "
                f"and payload_kg = {run.payload_kg}); allowed: values whose replay stays finite"
            )
