"""The verdict of a diagnosis and its family-level call, from the fitted candidates.

Rules:
- a gap is significant above SIGNIFICANCE x floor (gap.diagnose.Floors);
- a candidate explains it if its held-out rms is under the threshold, or under EXPLAIN_SHRINK of
  the nominal twin's;
- a pair counts only if both its effects moved off their nominal values (an effect left at its
  nominal value is no effect: the pair is its other member alone) and it beats the best single by
  a clear margin (score <= PAIR_MARGIN x the best single's);
- rivals: candidates that explain too and that the best does not beat clearly (a one-sided 95 %
  bootstrap over runs, and a 10 % margin on the score);
- a fitted value on (or within AT_BOUND of) a catalogue bound is flagged: the true value may lie
  beyond it, or the effect is standing in for another;
- the family call rests on the where-breakdown: each single's correction (the twin with the
  effect fitted to all runs minus the nominal twin) is compared with the gap's pattern over
  supply, load, angle, speed, time since start and phase (gap.where.profile_match); the families
  whose best member matches at least PROFILE_MIN are eligible, and of those the one whose best
  member fits the withheld runs best is the call. An "outside the catalogue" verdict names that
  family, never a candidate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gap import where
from gap.effects import BY_NAME
from gap.stats import mean_lower_bound, rms_deg, run_ms
from pneumatics import JointParams

EXPLAIN_SHRINK = 0.1
PAIR_MARGIN = 0.8  # a pair must bring the misfit (in floors) under 0.8 x the best single's
OFF_NOMINAL = 0.03  # an effect is off its nominal value beyond 3 % of its range (log range for log effects)
AT_BOUND = 0.01  # within 1 % of its range from a bound counts as on the bound
PROFILE_MIN = 0.5  # a family is eligible if its best member's correction matches the gap's pattern this well


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


@dataclass(frozen=True)
class Refusal:
    """A pair that does not count, and why."""

    pair: str
    why: str


@dataclass(frozen=True)
class FamilyEvidence:
    """A family's best member: its where-pattern match and its held-out misfit."""

    family: str
    best: str  # the member (a single effect)
    score_in_floors: float
    shrink: float  # held-out rms / the nominal twin's
    where_match: float  # gap.where.profile_match of its correction with the gap


@dataclass(frozen=True)
class FamilyCall:
    """The family-level answer (None when there is no candidate) and the evidence behind it."""

    family: str | None
    where_match: float | None
    by_where: bool  # some family matched the where-pattern at least PROFILE_MIN
    evidence: list[FamilyEvidence]  # families by held-out misfit, best first


@dataclass
class Call:
    verdict: str
    top: object | None
    rivals: list[str]
    pairs_refused: list[Refusal]


class Judge:
    def __init__(self, twin, floors, before_rms: float, score, rng: np.random.Generator):
        self.twin, self.floors, self.before_rms, self.score, self.rng = twin, floors, before_rms, score, rng

    def explains(self, c) -> bool:
        return rms_deg(c.heldout) <= max(self.floors.threshold_deg, EXPLAIN_SHRINK * self.before_rms)

    def pair_counts(self, pair, best) -> str:
        """'' if the pair counts, else why not."""
        off = off_nominal(pair, self.twin.params)
        if not all(off):
            stayed = ", ".join(e for e, o in zip(pair.effects, off, strict=True) if not o)
            return f"{stayed} stayed at its nominal value"
        if best is not None and self.score(pair) > PAIR_MARGIN * self.score(best):
            return (
                f"misfit {self.score(pair):.2f} floors is not clearly below the best single's "
                f"{self.score(best):.2f} (needs <= {PAIR_MARGIN} x)"
            )
        if not self.explains(pair):
            return "does not explain the gap"
        return ""

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
            why = self.pair_counts(p, best)
            (refused.append(Refusal(p.name, why)) if why else counting.append(p))
        if not significant:
            return Call("no significant gap", None, [], refused)
        if counting:
            rivals = self.rivals_of(counting[0], counting)
            return Call("ambiguous" if rivals else "explained", counting[0], rivals, refused)
        if best is not None and self.explains(best):
            rivals = self.rivals_of(best, singles)
            return Call("ambiguous" if rivals else "explained", best, rivals, refused)
        return Call("outside the catalogue", best, [], refused)

    def family_call(
        self, singles: list, labels: dict[str, np.ndarray], before: list[np.ndarray], latency_s: float
    ) -> FamilyCall:
        """The families ranked by where-evidence and held-out fit (module docstring)."""
        gap = np.concatenate(before)
        best_of: dict[str, FamilyEvidence] = {}
        for c in singles:
            entry = self._evidence(c, labels, gap, latency_s)
            if entry.family not in best_of or entry.score_in_floors < best_of[entry.family].score_in_floors:
                best_of[entry.family] = entry
        evidence = sorted(best_of.values(), key=lambda x: x.score_in_floors)
        eligible = [x for x in evidence if x.where_match >= PROFILE_MIN]
        chosen = eligible[0] if eligible else (max(evidence, key=lambda x: x.where_match) if evidence else None)
        return FamilyCall(
            chosen.family if chosen else None, chosen.where_match if chosen else None, bool(eligible), evidence
        )

    def _evidence(self, c, labels: dict[str, np.ndarray], gap: np.ndarray, latency_s: float) -> FamilyEvidence:
        """Single c's family, held-out fit and how its correction matches the gap's where-pattern."""
        n = len(self.twin.runs)
        e = BY_NAME[c.name]
        res = self.twin.residuals_with([(e, c.full_values[0])], range(n), latency_s)
        correction = gap - np.concatenate([res[k][0] for k in range(n)])
        return FamilyEvidence(
            e.family,
            c.name,
            self.score(c),
            rms_deg(c.heldout) / self.before_rms if self.before_rms > 0 else math.nan,
            where.profile_match(labels, gap, correction),
        )
