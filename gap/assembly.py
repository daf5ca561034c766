"""Step 4 and the typed result: the nominal twin's residual, how far each candidate brings the gap
on withheld runs per supply pressure (with bootstrap intervals over runs), the candidates as
reported and the floors' summaries, assembled into a gap.result.Diagnosis."""

from __future__ import annotations

import math

import numpy as np

from gap import instrument, verdict, where
from gap.campaign import Campaign
from gap.campaign_replay import nominal_residuals, supplies
from gap.candidate import Candidate, Fits
from gap.effects import BY_NAME
from gap.floors import MODEL_TOLERANCE_KPA, Floors
from gap.result import (
    CandidateSummary,
    Diagnosis,
    NoiseFloor,
    PressureError,
    PressureFloor,
    Residuals,
    TwinFacts,
    Which,
)
from gap.stats import bootstrap_ci, rms_ci_deg, rms_deg, rms_kpa


def result_of(
    judge: verdict.Judge,
    fits: Fits,
    call: verdict.Call,
    family: verdict.FamilyCall,
    labels: dict[str, np.ndarray],
    latency_s: float,
    rng: np.random.Generator,
) -> Diagnosis:
    """The typed result, with the nominal twin's residual at `latency_s` (the bootstrap intervals
    draw from `rng` in the order: how far, before, top, ranking, pairs)."""
    replay, fl = judge.replay, judge.floors
    campaign = replay.campaign
    before, before_p = nominal_residuals(replay, latency_s)
    before_rms = rms_deg(before)
    how_far = {"before": error_by_pressure(campaign, before, rng)}
    for c in fits.singles + fits.pairs:
        how_far[c.name] = error_by_pressure(campaign, c.heldout, rng)
    before_ci = rms_ci_deg(before, rng)
    top = call.top
    which = Which(
        verdict=call.verdict,
        top=summarise(top, judge, before_rms, rng) if top is not None else None,
        rivals=call.rivals,
        pairs_refused=call.pairs_refused,
        # the family-level answer where no one candidate is (gap.verdict.Judge.family_call): outside the
        # catalogue, among every family; ambiguous, among the families of the candidates that explain
        nearest=family if call.verdict.names_family else None,
        families=family.evidence,
        ranking=[summarise(c, judge, before_rms, rng) for c in fits.singles],
        pairs=[summarise(c, judge, before_rms, rng) for c in fits.pairs],
        skipped_already_in_twin=fits.skipped,
    )
    return Diagnosis(
        campaign=str(campaign.folder),
        joint=campaign.joint,
        runs=[r.name for r in campaign.runs],
        windowed={r.name: r.recorded_s for r in campaign.runs if r.recorded_s is not None},
        twin=TwinFacts(replay.params.hose_loss, replay.inertia),
        folds="leave one supply pressure out" if len(supplies(campaign)) > 1 else "alternating split",
        instrument=instrument.describe(campaign.instrument, replay.nuisance, latency_s, campaign.runs),
        noise_floor=noise_floor_of(fl, campaign),
        pressure=pressure_floor_of(fl, before_p) if replay.has_pressure else PressureFloor(False),
        before_rms_deg=before_rms,
        before_rms_ci95_deg=before_ci,
        where=where.breakdown(labels, np.concatenate(before)),
        which=which,
        how_far=how_far,
        replays=replay.n_replays,
        timing_s=fits.timing,
        residuals=Residuals(before, top.heldout if top is not None else None, [pr.ts for pr in replay.runs]),
    )


def summarise(c: Candidate, judge: verdict.Judge, before_rms: float, rng: np.random.Generator) -> CandidateSummary:
    """Candidate c as reported; its shrink against the nominal twin's rms `before_rms`."""
    lo, hi = rms_ci_deg(c.heldout, rng)
    effects = [BY_NAME[x] for x in c.effects]
    heldout_rms = rms_deg(c.heldout)
    explains = judge.explains(c)  # first: it asks for the twin's spread where the rms alone is over the bar
    return CandidateSummary(
        name=c.name,
        effects=c.effects,
        labels=[e.label for e in effects],
        families=[e.family for e in effects],
        fields=[e.field for e in effects],
        nominal_values=[e.value_of(judge.replay.params) for e in effects],
        fitted_values=c.full_values,
        fold_values=c.fold_values,
        at_bound=verdict.at_bounds(c),
        off_nominal=verdict.off_nominal(c, judge.replay.params),
        latency_s=c.latency_s,
        heldout_rms_deg=heldout_rms,
        heldout_pressure_rms_kpa=rms_kpa(c.heldout_p),
        score_in_floors=judge.score(c),
        heldout_rms_ci95_deg=(lo, hi),
        shrink=heldout_rms / before_rms if before_rms > 0 else math.nan,
        explains=explains,
        heldout_beyond_spread_deg=judge.beyond_spread_deg(c) if c.spread is not None else None,
        spread_deg=np.degrees(c.spread).tolist() if c.spread is not None else None,
    )


def error_by_pressure(campaign: Campaign, res: list[np.ndarray], rng: np.random.Generator) -> dict[str, PressureError]:
    """Per supply: mean and max |residual| (deg) over its runs, the mean's bootstrap interval."""
    out = {}
    for q in supplies(campaign):
        ks = [k for k, r in enumerate(campaign.runs) if round(r.supply_mpa, 4) == q]
        vals = [np.rad2deg(np.abs(res[k])) for k in ks]
        allv = np.concatenate(vals)
        out[f"{q:.2f}"] = PressureError(float(allv.mean()), float(allv.max()), bootstrap_ci(vals, rng, 300), len(ks))
    return out


def noise_floor_of(fl: Floors, campaign: Campaign) -> NoiseFloor:
    return NoiseFloor(
        measurement_deg=fl.noise_deg,
        measurement_from="declared" if campaign.instrument.noise_deg is not None else "repeats",
        repeat_noise_deg=math.degrees(fl.noise.sigma),
        repeat_drift_deg=math.degrees(fl.noise.drift),
        repeat_pairs=fl.noise.pairs,
        repeat_samples=fl.noise.samples,
        model_tolerance_deg=fl.tolerance_deg,
        floor_deg=fl.floor_deg,
        significance_threshold_deg=fl.threshold_deg,
    )


def pressure_floor_of(fl: Floors, before_p: list[np.ndarray]) -> PressureFloor:
    return PressureFloor(
        measured=True,
        noise_kpa=fl.noise_p.sigma / 1e3,
        drift_kpa=fl.noise_p.drift / 1e3,
        model_tolerance_kpa=MODEL_TOLERANCE_KPA,
        floor_kpa=fl.floor_kpa,
        before_rms_kpa=rms_kpa(before_p),
        significance_threshold_kpa=fl.threshold_kpa,
    )
