"""The verdict of a diagnosis and its family-level call, from the fitted candidates.

Rules:
- a gap is significant above SIGNIFICANCE x floor in either channel, the angle or (where measured)
  the chamber pressures, each against its own floor (gap.floors.Floors.above);
- a candidate explains it if, in every channel measured, its held-out rms is under the threshold,
  or under EXPLAIN_SHRINK of the nominal twin's; in the angle, what it leaves beyond the twin's own
  spread on each run (gap.campaign_replay.CampaignReplay.spread) may count instead;
- a pair counts only if both its effects moved off their nominal values (an effect left at its
  nominal value is no effect: the pair is its other member alone), it beats the best single by a
  clear margin (score <= PAIR_MARGIN x the best single's) and each of its effects is earned:
  dropped, the pair is its other member alone (the better on withheld runs of that member's single
  fit and the pair's own fits with the dropped effect at its nominal value, `without`), and the
  pair must beat that on withheld runs by the test a candidate's rivals are told by (`earned_over`:
  per run, the mean square misfit in floors beyond what a true model's would leave, the floor and
  the twin's own spread on the run; the one-sided 95 % bootstrap lower bound over runs of the other
  member's excess above 0). This is the drop-one (partial) test of a nested model, each term
  tested against the model without it (the extra sum of squares principle; Draper & Smith,
  *Applied Regression Analysis*, 3rd ed., 1998, ch. 6), read on withheld runs, which already
  charge a second parameter for what it overfits, and over runs, not samples: a run's samples are
  not independent (its residual is a smooth curve), so a sample-level F or likelihood-ratio test
  with the noise floor finds any misfit a form outside the catalogue leaves significant (F(1, 934)
  = 8537 for the set-point dead time the bench's lossy gear is given with Coulomb friction after a
  design round). The margin alone counts a pair whose gain lies on a run on a knife edge or under
  the floor; the nominal rule stays first: without it, an effect 1.5 % of its range off nominal
  (a brake's holding torque at 104 N·m for the twin's 100, fitted with Coulomb friction on a run
  on a knife edge) passes this test, the other member's fold fits being what it makes up for;
- rivals: candidates that explain too and that the best does not beat clearly (a one-sided 95 %
  bootstrap over runs, and a 10 % margin on the score);
- a fitted value on (or within AT_BOUND of) a catalogue bound is flagged: the true value may lie
  beyond it, or the effect is standing in for another;
- the family call does not need the gap's form to be in the catalogue: each family is fitted with its
  own corrections (gap.family: per fold, one member's correction or two members' added, at the
  values the single fits replayed, chosen on the training runs) and scored on the withheld runs;
  the call is the family that leaves least there, unless others are not clearly worse (a one-sided
  95 % bootstrap over runs, the test of a candidate's rivals): then, of those tied, the one whose
  shapes explain most of the gap's where-profile (its mean per bin of supply, load, angle, speed,
  time since start, phase and direction, gap.where.profile_matrix), and the report names the others.
  An "outside the catalogue" verdict names that family, never a candidate;
- an "ambiguous" verdict (candidates that explain and that the withheld runs do not tell apart)
  names a family too: the family call among the families of those candidates. Their fits alone
  do not say which part of the joint it is; the family's own corrections on withheld runs may
  (measured: a valve opening less per bar on the paper's moves was ambiguous between a hose leak
  and a valve dead zone, and the valve's corrections fit it as well as the leakage's and match its
  where-profile better).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from gap import family, where
from gap.campaign_replay import folds_of
from gap.effects import BY_NAME
from gap.kinds import Family, Verdict
from gap.stats import mean_lower_bound, residual_vector, rms_beyond_deg, rms_deg, rms_kpa, run_ms, run_ms_beyond
from pneumatics import JointParams

OMIT_NONE = {"omit_none": True}  # a field left out of diagnosis.json when None (gap.result.to_json)
EXPLAIN_SHRINK = 0.1
PAIR_MARGIN = 0.8  # a pair must bring the misfit (in floors) under 0.8 x the best single's
OFF_NOMINAL = 0.03  # an effect is off its nominal value beyond 3 % of its range (log range for log effects)
AT_BOUND = 0.01  # within 1 % of its range from a bound counts as on the bound
EARNED_SEED = 0  # the earned test's bootstrap draws (Judge.earned_over): deterministic, apart from the verdict's rng


def _unit(e, v: float) -> float:
    """Where `v` lies in effect e's range, 0..1 (logarithmic for log effects, 0 mapped to 0)."""
    if e.log:
        lo = e.low if e.low > 0 else e.high / 100.0
        return (
            0.0
            if v <= lo * 0.5 and e.low == 0
            else float(np.clip(math.log(max(v, lo) / lo) / math.log(e.high / lo), 0.0, 1.0))
        )
    return (v - e.low) / (e.high - e.low)


def off_nominal(c, params: JointParams) -> list[bool]:
    """Per effect of candidate c: did its fitted value move off the nominal twin's value?"""
    out = []
    for name, v in zip(c.effects, c.full_values, strict=True):
        e = BY_NAME[name]
        out.append(e.discrete_value is not None or abs(_unit(e, v) - _unit(e, e.value_of(params))) > OFF_NOMINAL)
    return out


def at_bounds(c) -> list[str | None]:
    """Per effect of candidate c: "low"/"high" if its fitted value sits on that catalogue bound."""
    out = []
    for name, v in zip(c.effects, c.full_values, strict=True):
        e = BY_NAME[name]
        if e.discrete_value is not None:
            out.append(None)
            continue
        span = e.high - e.low
        out.append(
            "high" if v >= e.high - AT_BOUND * span else "low" if (v <= e.low + AT_BOUND * span and e.low > 0) else None
        )
    return out


def families_of(names: list[str]) -> set[Family]:
    """The families of candidates by name (a pair "a+b": both its effects')."""
    return {BY_NAME[e].family for n in names for e in n.split("+")}


@dataclass(frozen=True)
class Refusal:
    """A pair that does not count, and why."""

    pair: str
    why: str


@dataclass(frozen=True)
class FamilyEvidence:
    """A family's best member and its held-out misfit; the family's free-form fit (gap.family) on
    withheld runs and how its correction matches the gap's where-pattern."""

    family: Family
    best: str  # the member (a single effect)
    score_in_floors: float
    shrink: float  # held-out rms / the nominal twin's
    where_match: float  # the part of the gap's where-profile its shapes explain (1 - gap.family.profile_misfit)
    heldout_shrink: float  # held-out rms of the gap after the family's own corrections / before (gap.family)
    latency_s: list[float]  # per fold, the instrument latency fitted with its corrections (gap.family.fold_latencies)
    # the same per channel where chamber pressures are measured (None where not): which channel the
    # family's corrections fit, the angle's or the pressures'
    heldout_shrink_angle: float | None = field(default=None, metadata=OMIT_NONE)
    heldout_shrink_pressure: float | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class FamilyCall:
    """The family-level answer (None when there is no candidate) and the evidence behind it (every
    family's, also those the call could not choose)."""

    family: Family | None
    where_match: float | None
    tied: list[Family]  # other families the withheld runs do not tell apart from it (the where-profile chose)
    evidence: list[FamilyEvidence]  # families by held-out misfit, best first


@dataclass
class Call:
    verdict: Verdict
    top: object | None
    rivals: list[str]
    pairs_refused: list[Refusal]


class Judge:
    def __init__(self, replay, floors, before_rms: float, score, rng: np.random.Generator, before_kpa=None):
        """`replay`: the campaign's (gap.campaign_replay.CampaignReplay); `before_rms` (deg) and
        `before_kpa` (None: no chamber pressure measured): the nominal twin's rms residuals."""
        self.replay, self.floors, self.before_rms, self.score, self.rng = replay, floors, before_rms, score, rng
        self.before_kpa = before_kpa

    def explains(self, c) -> bool:
        """Held-out, every channel measured is under its threshold or shrunk to EXPLAIN_SHRINK; in
        the angle, what is left beyond the twin's own spread on each run (`beyond_spread_deg`)."""
        fl = self.floors
        bar = max(fl.threshold_deg, EXPLAIN_SHRINK * self.before_rms)
        if rms_deg(c.heldout) > bar and self.beyond_spread_deg(c) > bar:
            return False
        p = rms_kpa(c.heldout_p)
        return p is None or self.before_kpa is None or p <= max(fl.threshold_kpa, EXPLAIN_SHRINK * self.before_kpa)

    def beyond_spread_deg(self, c) -> float:
        """The held-out angle rms of candidate c beyond the twin's own spread with c on each run
        (gap.campaign_replay.CampaignReplay.spread, replayed once per candidate when first asked): a run on a knife
        edge, a drive that only just beats the friction, is not held to more than the twin itself
        can say of it."""
        if c.spread is None:
            c.spread = self.replay.spread([(BY_NAME[n], v) for n, v in zip(c.effects, c.full_values, strict=True)])
        return rms_beyond_deg(c.heldout, c.spread)

    def pair_counts(self, pair, best, singles: list = ()) -> str:
        """'' if the pair counts, else why not (module docstring). `singles`: the single fits, each
        effect of the pair tested against its other member's (`earned_over`)."""
        off = off_nominal(pair, self.replay.params)
        if not all(off):
            stayed = ", ".join(e for e, o in zip(pair.effects, off, strict=True) if not o)
            return f"{stayed} stayed at its nominal value"
        if best is not None and self.score(pair) > PAIR_MARGIN * self.score(best):
            return (
                f"misfit {self.score(pair):.2f} floors is not clearly below the best single's "
                f"{self.score(best):.2f} (needs <= {PAIR_MARGIN} x)"
            )
        by_name = {c.name: c for c in singles}
        for dropped, kept in (pair.effects, pair.effects[::-1]):
            subs = [c for c in (by_name.get(kept), self.without(pair, dropped)) if c is not None]
            alone = min(subs, key=self.score, default=None)
            if alone is not None and not self.earned_over(pair, alone):
                return (
                    f"{dropped} is not earned: on withheld runs the pair is not clearly better than {kept} alone "
                    f"({self.score(pair):.2f} floors against {self.score(alone):.2f}; "
                    "one-sided 95 % bootstrap over runs)"
                )
        if not self.explains(pair):
            return "does not explain the gap"
        return ""

    def without(self, pair, dropped: str):
        """The pair with effect `dropped` back at its nominal value: its other member at the values
        the pair's folds fitted, scored on each fold's withheld runs (a candidate of that member).
        Beside that member's own single fit it is the model without `dropped`: a pair's search in two
        parameters can land its kept member nearer its best value than the single's fit did (a
        slow brake release fitted at the twin's own 0.05 s with Coulomb friction 30.06 N·m, the
        single's 29.24 on the same runs), and then the dropped effect has earned nothing."""
        i = 1 - pair.effects.index(dropped)
        kept = BY_NAME[pair.effects[i]]
        heldout: list = [None] * len(self.replay.runs)
        heldout_p: list = [None] * len(self.replay.runs)
        for (train, test), values in zip(folds_of(self.replay.campaign), pair.fold_values, strict=True):
            _, res = self.replay.fold_residuals([(kept, values[i])], train, test)
            for k, (a, p) in res.items():
                heldout[k], heldout_p[k] = a, p
        return replace(
            pair,
            name=kept.name,
            effects=[kept.name],
            fold_values=[[v[i]] for v in pair.fold_values],
            full_values=[pair.full_values[i]],
            heldout=heldout,
            heldout_p=heldout_p,
            spread=None,
        )

    def earned_over(self, pair, alone) -> bool:
        """Does `pair` beat its member `alone` on withheld runs: the one-sided 95 % lower bound of the
        mean over runs of alone's excess above the pair's is above 0, each run's misfit counted beyond
        what a true model's would leave there (`gap.stats.run_ms_beyond`: the floor, and in the angle
        the twin's own spread on the run, the larger of the two candidates', as the rule that says
        what explains)? Below the floor a run tells nothing; on a run on a knife edge, where the
        joint lets go hangs on a fraction of a N·m, a second effect that lands nearer the measured
        run has earned nothing (the bench's Coulomb friction at 30 N·m on back-and-forth moves: a
        slow brake release at 0.0495 s for the twin's 0.05, fitted with it, moved the 0.6 MPa runs'
        release and came nearer; the 0.5 MPa runs' misfit fell from 0.36 to 0.12 floors², under the
        floor). Its own seeded generator (EARNED_SEED): the verdict's other intervals draw as they
        did without it."""
        fl = self.floors
        for c in (pair, alone):
            self.beyond_spread_deg(c)  # its spread, replayed once when first asked
        spread = np.maximum(pair.spread, alone.spread)
        excess = run_ms_beyond(alone.heldout, alone.heldout_p, spread, fl.floor_deg, fl.floor_kpa) - run_ms_beyond(
            pair.heldout, pair.heldout_p, spread, fl.floor_deg, fl.floor_kpa
        )
        return mean_lower_bound(excess, np.random.default_rng(EARNED_SEED)) > 0.0

    def rivals_of(self, c, pool) -> list[str]:
        fl = self.floors
        out = []
        ms_c = run_ms(c.heldout, c.heldout_p, fl.floor_deg, fl.floor_kpa)
        for o in pool:
            if o is c or not self.explains(o):
                continue
            diff = run_ms(o.heldout, o.heldout_p, fl.floor_deg, fl.floor_kpa) - ms_c
            if mean_lower_bound(diff, self.rng) <= 0.0 or self.score(o) <= 1.1 * self.score(c):
                out.append(o.name)
        return out

    def call(self, significant: bool, singles: list, pairs: list) -> Call:
        best = singles[0] if singles else None
        refused = []
        counting = []
        for p in pairs:
            why = self.pair_counts(p, best, singles)
            (refused.append(Refusal(p.name, why)) if why else counting.append(p))
        if not significant:
            return Call(Verdict.NO_GAP, None, [], refused)
        if counting:
            rivals = self.rivals_of(counting[0], counting)
            return Call(Verdict.AMBIGUOUS if rivals else Verdict.EXPLAINED, counting[0], rivals, refused)
        if best is not None and self.explains(best):
            rivals = self.rivals_of(best, singles)
            return Call(Verdict.AMBIGUOUS if rivals else Verdict.EXPLAINED, best, rivals, refused)
        return Call(Verdict.OUTSIDE, best, [], refused)

    def family_call(
        self,
        singles: list,
        labels: dict[str, np.ndarray],
        gap: np.ndarray,
        folds,
        corrections: family.Corrections,
        among: set[Family] | None = None,
    ) -> FamilyCall:
        """The families ranked by the fit of their own corrections on withheld runs (gap.family),
        ties told apart by the gap's where-profile (module docstring). `gap`: the nominal twin's
        residual vector (CampaignReplay.run_sses_and_residual), the held-out shrinks' denominator; `folds`:
        (training, withheld) run lists; `corrections`: per family, its members' corrections of the gap
        at the nominal twin's latency and at each fold's own (gap.members.at_fold_latencies);
        `among`: the families the call may choose from (None: every one; the evidence lists all)."""
        replay = self.replay
        angle = replay.angle_mask()
        masks = [(replay.sample_mask(tr), replay.sample_mask(te)) for tr, te in folds]
        profile = where.profile_matrix(labels)
        fits = family.family_fits(corrections, gap, masks, angle, profile)
        if not fits:
            return FamilyCall(None, None, [], [])
        best_of: dict[str, object] = {}
        for c in singles:  # singles come sorted by score: the first of a family is its best
            best_of.setdefault(BY_NAME[c.name].family, c)
        for f, c in best_of.items():  # a family does on withheld runs at least what its best member does
            held_out = residual_vector(c.heldout, c.heldout_p, replay.pressure_weight)
            fits[f] = family.at_least(fits[f], held_out, masks, angle)
        run_masks = [replay.sample_mask([k]) for k in range(len(replay.runs))]
        per_run = {f: np.array([np.sum(ft.heldout[m] ** 2) for m in run_masks]) for f, ft in fits.items()}
        nominal = sum(float(np.sum(gap[te] ** 2)) for _, te in masks)
        nominal_angle = sum(float(np.sum(gap[te & angle] ** 2)) for _, te in masks)
        evidence = sorted(
            (
                self._evidence(f, best_of.get(f), fit, nominal, nominal_angle, corrections.latency_s[f])
                for f, fit in fits.items()
            ),
            key=lambda x: x.heldout_shrink,
        )
        pool = [x for x in evidence if among is None or x.family in among] or evidence
        lead = pool[0].family
        tied = [
            x for x in pool if x.family == lead or mean_lower_bound(per_run[x.family] - per_run[lead], self.rng) <= 0.0
        ]
        chosen = max(tied, key=lambda x: x.where_match)  # the first of the most where-like: stable order
        return FamilyCall(chosen.family, chosen.where_match, [x.family for x in tied if x is not chosen], evidence)

    def _evidence(
        self, f: str, best, fit, nominal: float, nominal_angle: float, latency_s: list[float]
    ) -> FamilyEvidence:
        """Family f's line of evidence: its best single member (None: only a member already in the
        twin), the fit of its own corrections (gap.family.FamilyFit) at its folds' latencies, in all and, where
        chamber pressures are measured, per channel (`nominal`, `nominal_angle`: the gap's withheld SSE)."""
        per_channel = {}
        if self.replay.has_pressure:
            per_channel = {
                "heldout_shrink_angle": _shrink(fit.heldout_sse_angle, nominal_angle),
                "heldout_shrink_pressure": _shrink(fit.heldout_sse - fit.heldout_sse_angle, nominal - nominal_angle),
            }
        return FamilyEvidence(
            f,
            best.name if best is not None else "(in the twin)",
            self.score(best) if best is not None else math.nan,
            rms_deg(best.heldout) / self.before_rms if best is not None and self.before_rms > 0 else math.nan,
            1.0 - fit.where_misfit,
            _shrink(fit.heldout_sse, nominal),
            latency_s,
            **per_channel,
        )


def _shrink(sse: float, nominal_sse: float) -> float:
    """Held-out rms after / before, from their SSEs (NaN without a gap)."""
    return math.sqrt(sse / nominal_sse) if nominal_sse > 0 else math.nan
