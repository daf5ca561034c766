"""The family call's members, replayed (gap.family fits them, no replay there): each catalogue
family's members with every value their single fits replayed, the parts the nominal twin already
has varied (gap.effects.IN_TWIN_VARIATIONS) and the parts varied for the call only
(gap.effects.FAMILY_VARIATIONS); then their corrections of the gap as read at the nominal twin's
latency and, per fold, at the latency the family's best row fits the fold's training runs with
(gap.family.fold_latencies), the rows replayed again where that is not the nominal twin's.
"""

from __future__ import annotations

import numpy as np
from joblib import delayed

from gap.campaign_replay import CampaignReplay
from gap.effects import BY_NAME, FAMILY_VARIATIONS, IN_TWIN_VARIATIONS, Effect
from gap.family import Corrections, Member, fold_latencies


def family_members(replay: CampaignReplay, singles: list, catalogue) -> dict[str, list[Member]]:
    """Per family, its members: each single candidate (gap.candidate.Candidate) at every value its fit
    replayed, then the family's members from the twin (`in_twin_members`)."""
    out: dict[str, list[Member]] = {}
    for c in singles:
        e = BY_NAME[c.name]
        rows = [[(e, float(v))] for v in c.grid_values]
        out.setdefault(e.family, []).append(Member(rows, c.grid_residuals, c.grid_sses))
    for f, ms in in_twin_members(replay, catalogue).items():
        out.setdefault(f, []).extend(ms)
    return out


def in_twin_members(replay: CampaignReplay, catalogue) -> dict[str, list[Member]]:
    """Per family, for each catalogue switch the nominal twin already has on (the hose loss): the
    correction of switching it off, and its opposite (more of it, to first order), so that a family
    is in the family call even when none of its members is a candidate (a narrower hose); and the
    corrections of the part it switches at other values (gap.effects.IN_TWIN_VARIATIONS: the hose's
    bore and length), more and less of it than the twin's, replayed: one member, not added to each
    other. And for each family with a member in `catalogue`, its parts varied for the family call
    only (gap.effects.FAMILY_VARIATIONS: the load's static torque the same at every angle), one
    member per part."""
    out: dict[str, list[Member]] = {}
    every = list(range(len(replay.runs)))

    def member(varied: list[tuple[Effect, float]], mirrored: bool = False) -> Member:
        evals = [replay.run_sses_and_residual([ev], every) for ev in varied]
        residuals = np.array([r for _, r in evals])
        return Member([[ev] for ev in varied], residuals, np.array([s for s, _ in evals]), mirrored)

    for e in catalogue:
        if e.discrete_value is not None and e.value_of(replay.params) == e.discrete_value:
            varied = [(e, e.low)]
            for part, factors in IN_TWIN_VARIATIONS.get(e.name, ()):
                varied += [(part, k * part.value_of(replay.params)) for k in factors]
            out.setdefault(e.family, []).append(member(varied, mirrored=True))
    in_catalogue = {e.family for e in catalogue}
    for family, parts in FAMILY_VARIATIONS.items():
        for part, values in parts if family in in_catalogue else ():
            out.setdefault(family, []).append(member([(part, v) for v in values]))
    return out


def at_fold_latencies(replay: CampaignReplay, members: dict[str, list[Member]], folds, run_jobs) -> Corrections:
    """Per family, its members' corrections of the gap at the nominal twin's latency (the reference)
    and, per fold of `folds` ((training, withheld) run lists), at the latency its best row fits the
    training runs with (gap.family.fold_latencies): the rows as replayed where that is the
    reference, replayed again on `run_jobs` where not (one replay gives every latency)."""
    every = list(range(len(replay.runs)))
    i_ref = replay.latency_index(replay.ref_latency_s)
    index = {f: fold_latencies(ms, [list(tr) for tr, _ in folds]) for f, ms in members.items()}
    others = {f: sorted(set(ix) - {i_ref}) for f, ix in index.items()}
    again = [(effects, others[f]) for f, ms in members.items() for m in ms for effects in m.effects if others[f]]
    replayed = iter(run_jobs(delayed(replay.residual_vectors)(effects, every, ix) for effects, ix in again))
    needed = sorted(set().union(*others.values()))
    gaps = {i_ref: replay.gap_vector, **(replay.residual_vectors([], every, needed) if needed else {})}
    reference: dict[str, list[np.ndarray]] = {}
    per_fold: dict[str, list[tuple[list[np.ndarray], np.ndarray]]] = {}
    for f, ms in members.items():
        at = [{i_ref: m.residuals} for m in ms]  # per member, its rows' residuals by latency index
        for m, rows_at in zip(ms, at, strict=True) if others[f] else ():
            rows = [next(replayed) for _ in m.effects]
            rows_at.update({i: np.array([r[i] for r in rows]) for i in others[f]})
        # one set of corrections per latency, shared by the folds that chose it
        by_latency = {
            i: [m.corrections(gaps[i], a[i]) for m, a in zip(ms, at, strict=True)] for i in {i_ref, *index[f]}
        }
        reference[f] = by_latency[i_ref]
        per_fold[f] = [(by_latency[i], gaps[i]) for i in index[f]]
    latency_s = {f: [float(replay.latencies[i]) for i in ix] for f, ix in index.items()}
    return Corrections(reference, per_fold, latency_s)
