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
    for name, v in zip(c.effects, c.full_values):
        e = BY_NAME[name]
        out.append(e.discrete_value is not None or abs(_unit(e, v) - _unit(e, e.value_of(params))) > OFF_NOMINAL)
    return out


def at_bounds(c) -> list[str | None]:
    """Per effect of candidate c: "low"/"high" if its fitted value sits on that catalogue bound."""
    out = []
    for name, v in zip(c.effects, c.full_values):
        e = BY_NAME[name]
        if e.discrete_value is not None:
            out.append(None)
            continue
        span = e.high - e.low
        out.append(
            "high" if v >= e.high - AT_BOUND * span else "low" if (v <= e.low + AT_BOUND * span and e.low > 0) else None
        )
    return out


@dataclass
class Call:
    verdict: str
    top: object | None
    rivals: list[str]
    pairs_refused: list[dict]


class Judge:
    def __init__(self, twin, floors, before_rms: float, score, rng: np.random.Generator):
        self.twin, self.floors, self.before_rms, self.score, self.rng = twin, floors, before_rms, score, rng

    def explains(self, c) -> bool:
        from gap.diagnose import rms_deg

        return rms_deg(c.heldout) <= max(self.floors.threshold_deg, EXPLAIN_SHRINK * self.before_rms)

    def pair_counts(self, pair, best) -> str:
        """'' if the pair counts, else why not."""
        off = off_nominal(pair, self.twin.params)
        if not all(off):
            return f"{', '.join(e for e, o in zip(pair.effects, off) if not o)} stayed at its nominal value"
        if best is not None and self.score(pair) > PAIR_MARGIN * self.score(best):
            return f"misfit {self.score(pair):.2f} floors is not clearly below the best single's {self.score(best):.2f} (needs <= {PAIR_MARGIN} x)"
        if not self.explains(pair):
            return "does not explain the gap"
        return ""

    def rivals_of(self, c, pool) -> list[str]:
        from gap.diagnose import run_ms

        fl = self.floors
        out = []
        ms_c = run_ms(c.heldout, c.heldout_p, fl.floor_deg, fl.floor_kpa)
        n = len(ms_c)
        for o in pool:
            if o is c or not self.explains(o):
                continue
            diff = run_ms(o.heldout, o.heldout_p, fl.floor_deg, fl.floor_kpa) - ms_c
            boots = diff[self.rng.integers(0, n, (400, n))].mean(axis=1)
            if np.quantile(boots, 0.05) <= 0.0 or self.score(o) <= 1.1 * self.score(c):
                out.append(o.name)
        return out

    def call(self, significant: bool, singles: list, pairs: list) -> Call:
        best = singles[0] if singles else None
        refused = []
        counting = []
        for p in pairs:
            why = self.pair_counts(p, best)
            (refused.append({"pair": p.name, "why": why}) if why else counting.append(p))
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
    ) -> dict:
        """The families ranked by where-evidence and held-out fit (module docstring)."""
        from gap.diagnose import rms_deg

        n = len(self.twin.runs)
        gap = np.concatenate(before)
        best_of: dict[str, dict] = {}
        for c in singles:
            e = BY_NAME[c.name]
            res = self.twin.residuals_with([(e, c.full_values[0])], range(n), latency_s)
            correction = gap - np.concatenate([res[k][0] for k in range(n)])
            entry = {
                "family": e.family,
                "best": c.name,
                "score_in_floors": self.score(c),
                "shrink": rms_deg(c.heldout) / self.before_rms if self.before_rms > 0 else math.nan,
                "where_match": where.profile_match(labels, gap, correction),
            }
            if e.family not in best_of or entry["score_in_floors"] < best_of[e.family]["score_in_floors"]:
                best_of[e.family] = entry
        evidence = sorted(best_of.values(), key=lambda x: x["score_in_floors"])
        eligible = [x for x in evidence if x["where_match"] >= PROFILE_MIN]
        chosen = eligible[0] if eligible else (max(evidence, key=lambda x: x["where_match"]) if evidence else None)
        return {
            "family": chosen["family"] if chosen else None,
            "where_match": chosen["where_match"] if chosen else None,
            "by_where": bool(eligible),
            "evidence": evidence,
        }
