"""The next runs to make: from a diagnosis (or, before any campaign, from the catalogue alone), the
runs of the design library (gap.protocols.design_library) that best tell the leading hypotheses
apart, by the T-optimality criterion of Atkinson & Fedorov (gap.discrimination).

Steps:
1. hypotheses: from a diagnosis, the best member of each leading family at its fitted value and
   latency (`hypotheses_of`), free to become any of its family's members at any value when refitted
   (a family's members may stand for a part the catalogue has no law for, so the rival is the whole
   family, not its best member); for an ambiguous verdict also the top candidate and its rivals, each
   free over its own values. Before any campaign, every catalogue effect at a reference size
   (`catalogue_hypotheses`);
2. pairs to tell apart: from a diagnosis, the called family against each other leading family
   (`leading_pairs`: Atkinson & Fedorov's design for several models, the best-fitting one taken as
   true), and for an ambiguous verdict the top candidate against each rival; before any campaign,
   every two families, each member of one against the other family (`family_pairs`);
3. proposals: each protocol of the design library played once at each supply (`proposals`); the
   criterion of each pair on the campaign's own runs with the proposal's added, its increase over the
   campaign's alone per sample of the proposal (`separations`), both ways round;
4. the plan: proposals chosen greedily (`choose`), each adding the most pairs told apart
   (discrimination.SEPARATED_FLOORS) counted softly, until none adds a pair or MAX_PROPOSALS (from a
   diagnosis; before any campaign, until every pair that can be is told apart); the pairs no
   proposal tells apart are listed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed

import assets
from gap import protocols, synth
from gap.campaign import Campaign
from gap.campaign_replay import joint_stops, nominal_inertia, nominal_params, supplies
from gap.discrimination import (
    SEPARATED_FLOORS,
    Change,
    Hypothesis,
    PlannedRun,
    Reading,
    ReplayedJoint,
    latency_index,
    misfits,
    response,
    samples,
    separation_floors,
)
from gap.effects import BY_NAME, CATALOGUE, Effect
from gap.instrument import LATENCY_GRID_S
from gap.kinds import Family
from gap.protocols import worst_tolerance_deg, worst_tolerance_kpa
from gap.result import Diagnosis
from gap.single_fits import effect_grid
from gap.verdict import families_of
from pneumatics import load_joint_params
from pneumatics.gas import AIR
from wrist_rig import commanded_run

N_FAMILIES = 4  # the leading families a diagnosis's design tells apart (by the family call's evidence)
GRID_POINTS = (
    6  # values per member in a hypothesis's alternatives (gap.single_fits.effect_grid: 7 with 0 on a log grid)
)
MAX_PROPOSALS = 2  # from a diagnosis: at most this many protocols in one round (each at every supply)
PRESSURE_NOISE_KPA = synth.NOISE_PA / 1e3  # the bench's transducers (gap.synth), before any campaign
# Before any campaign, each catalogue effect at a reference size: a quarter of the way from its
# nominal value to the far end of its range, in the catalogue's own scale (logarithmic for a log
# grid): a clear effect, well inside what the catalogue allows (assumed; no campaign says otherwise)
REFERENCE_STEP = 0.25


@dataclass(frozen=True)
class Pair:
    """Two hypotheses to tell apart: each way round, the truth's readings against the other's
    alternatives (`directed`: (truth, rival) indices into the hypotheses)."""

    name: str
    directed: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class Proposal:
    """A protocol played once at each supply, what it costs and how far it tells each pair apart
    (rms in floors of the rival's refitted misfit on its runs, the lesser way round)."""

    protocol: str
    runs: tuple[PlannedRun, ...]
    arm_time_s: float
    separation: dict[str, float]

    def score(self) -> float:
        return soft_count(self.separation)


@dataclass
class Design:
    """What `design` found: the hypotheses and pairs, every proposal ranked, the plan chosen, what it
    tells apart (separation on the plan's runs together) and what it does not."""

    hypotheses: list[Hypothesis]
    pairs: list[Pair]
    reading: Reading
    ranking: list[Proposal]
    chosen: list[Proposal]
    separation: dict[str, float]  # per pair, on the chosen proposals' runs together
    unseparated: list[str]
    twin: ReplayedJoint
    source: str  # what the design started from: a campaign's diagnosis or the catalogue

    def runs(self) -> list[PlannedRun]:
        return [r for p in self.chosen for r in p.runs]

    def arm_time_s(self) -> float:
        return sum(p.arm_time_s for p in self.chosen)


def soft_count(separation: dict[str, float]) -> float:
    """Pairs told apart, each counted up to 1 in proportion to its separation over SEPARATED_FLOORS."""
    return float(sum(min(s / SEPARATED_FLOORS, 1.0) for s in separation.values()))


def alternatives(effects: list[Effect], extra: tuple[Change, ...] = ()) -> tuple[Change, ...]:
    """Every effect of `effects` at each value of its grid, one change each, and `extra`."""
    return (*extra, *(((e, float(v)),) for e in effects for v in effect_grid(e, GRID_POINTS)))


def family_members(family: Family, catalogue) -> list[Effect]:
    return [e for e in catalogue if e.family == family and e.discrete_value is None]


def hypotheses_of(diag: Diagnosis, catalogue=CATALOGUE) -> tuple[list[Hypothesis], list[Pair]]:
    """The best member of each leading family as fitted (and, for an ambiguous verdict, the top candidate
    and its rivals) as hypotheses, each free over its family's members and values; the leading family
    (the diagnosis's call) against each other a pair to tell apart (`leading_pairs`; and the top against
    each rival, each free over its own values).

    Atkinson & Fedorov's sequential design for several models (Biometrika 62(2), 1975) takes the model
    that fits best as the truth and maximises the least lack of fit of the others to it. Here a model is
    a family: its best member is what the campaign says it is, and its other members, fitted worse,
    are not candidates for the truth but its freedom when refitted. Every member as a truth of its own
    let a member fitted near its nominal value set the least separation (it does almost nothing, so
    no run tells it from a family that can do nothing either), and every two families a pair let
    pairs the call does not involve count as much as its own: on a static-friction excess on
    staircases called brake, with valve and friction next, back-and-forth moves told a brake engaging
    at 32 ms (the twin's 20) from friction by 1.75 floors, against 17.97 for the brake's best member;
    the design chose dwell-then-move and the call stayed brake. Back-and-forth, whose reversals keep
    the brake's shuttle-fed air high while the joint stops and turns, is what the leading pairs
    choose, and after it the call is friction."""
    w = diag.which
    by_name = {c.name: c for c in [*w.ranking, *w.pairs]}
    best: dict[str, object] = {}
    for c in w.ranking:  # singles sorted by score: the first of a family is its best
        best.setdefault(c.families[0], c)
    wanted = [f for f in (w.nearest.family if w.nearest else None, *(w.nearest.tied if w.nearest else ())) if f]
    if w.top is not None:
        wanted += [w.top.families[0], *sorted(families_of([w.top.name, *w.rivals]))]
    wanted += [x.family for x in w.families]
    families = [f for f in dict.fromkeys(wanted) if f in best][:N_FAMILIES]
    hyps: list[Hypothesis] = []
    for f in families:
        fitted = [_change(c) for c in w.ranking if c.families[0] == f]  # best first
        alts = alternatives(family_members(f, catalogue), tuple(fitted))
        hyps.append(Hypothesis(f"{f} ({_describe(fitted[0])})", f, fitted[0], best[f].latency_s, alts))
    pairs = leading_pairs(hyps)
    if w.verdict.tied and w.top is not None:
        top = len(hyps)
        for k, name in enumerate([w.top.name, *w.rivals]):
            c = by_name[name]
            change = _change(c)
            own = [BY_NAME[e] for e in c.effects if BY_NAME[e].discrete_value is None]
            hyps.append(Hypothesis(name, c.families[0], change, c.latency_s, alternatives(own, (change,))))
            if k:
                pairs.append(Pair(f"{w.top.name} / {name}", ((top, top + k), (top + k, top))))
    return hyps, pairs


def leading_pairs(hyps: list[Hypothesis]) -> list[Pair]:
    """The first hypothesis (the leading family's) against each other, both ways round, each free over
    its family's alternatives."""
    return [Pair(f"{hyps[0].family} / {h.family}", ((0, k), (k, 0))) for k, h in enumerate(hyps) if k]


def family_pairs(hyps: list[Hypothesis], families: list[Family]) -> list[Pair]:
    """Every two families a pair: each hypothesis of one against the first of the other (its
    stand-in, free over that family's alternatives)."""
    stand_in = {f: next(i for i, h in enumerate(hyps) if h.family == f) for f in families}
    return [
        Pair(
            f"{f} / {g}",
            tuple((a, stand_in[g if h.family == f else f]) for a, h in enumerate(hyps) if h.family in (f, g)),
        )
        for i, f in enumerate(families)
        for g in families[i + 1 :]
    ]


def _change(c) -> Change:
    return tuple((BY_NAME[e], float(v)) for e, v in zip(c.effects, c.fitted_values, strict=True))


def _describe(change: Change) -> str:
    return ", ".join(f"{e.name} = {v:.4g}" for e, v in change)


def reference_value(e: Effect, nominal: float) -> float:
    """Effect e a quarter of the way (REFERENCE_STEP) from `nominal` to the far end of its range."""
    if e.discrete_value is not None:
        return e.discrete_value
    if e.log:
        lo = e.low if e.low > 0 else e.high / 100.0
        a, b = math.log(max(nominal, lo)), math.log(e.high)
        far = b if b - a >= a - math.log(lo) else math.log(lo)
        return float(math.exp(a + REFERENCE_STEP * (far - a)))
    far = e.high if e.high - nominal >= nominal - e.low else e.low
    return float(nominal + REFERENCE_STEP * (far - nominal))


def catalogue_hypotheses(
    twin: ReplayedJoint, latency_s: float, catalogue=CATALOGUE
) -> tuple[list[Hypothesis], list[Pair]]:
    """Every catalogue effect at its reference size (`reference_value`), read `latency_s` late, free
    over its family's members; every two families a pair, each member of one against the other
    family."""
    hyps = []
    for e in catalogue:
        if e.discrete_value is not None and e.value_of(twin.params) == e.discrete_value:
            continue  # in the nominal twin already (the hose loss): no change to tell apart
        change = ((e, reference_value(e, e.value_of(twin.params))),)
        hyps.append(Hypothesis(f"{e.name} = {change[0][1]:.4g}", e.family, change, latency_s, ()))
    families = list(dict.fromkeys(h.family for h in hyps))
    members = {f: [e for e in catalogue if e.family == f] for f in families}
    alts = {f: alternatives([e for e in members[f] if e.discrete_value is None]) for f in families}
    hyps = [Hypothesis(h.name, h.family, h.effects, h.latency_s, alts[h.family] or (h.effects,)) for h in hyps]
    pairs = family_pairs(hyps, families)
    return hyps, pairs


def planned_run(
    protocol: protocols.Protocol,
    supply_mpa: float,
    k_u_per_pa: float,
    inertia_kg_m2: float,
    rate_hz: float,
    pressures: bool,
) -> PlannedRun:
    """`protocol` at `supply_mpa` as 1 ms command rows, sampled at `rate_hz` (and the chamber
    pressures every 20 ms where measured), from rest at 0."""
    t = np.round(np.arange(0.0, protocol.total_s() + 1e-9, 1e-3), 6)
    d, u, b = protocol.commands(t, supply_mpa * 1e6, k_u_per_pa)
    ts = np.round(np.arange(0.0, t[-1] + 1e-9, 1.0 / rate_hz), 3)
    tp = np.round(np.arange(0.0, t[-1] + 1e-9, commanded_run.SAMPLE_PERIOD_S), 3) if pressures else np.zeros(0)
    return PlannedRun(
        f"{protocol.name}_{int(round(supply_mpa * 100)):03d}",
        supply_mpa,
        t,
        d,
        u,
        b,
        np.full(t.shape, AIR.p_atm_pa + supply_mpa * 1e6),
        ts,
        tp,
        inertia_kg_m2=inertia_kg_m2,
    )


def proposals(
    twin: ReplayedJoint, supplies_mpa: list[float], inertia_kg_m2: float, rate_hz: float, pressures: bool
) -> list[tuple[str, tuple[PlannedRun, ...]]]:
    """Each protocol of the design library played once at each supply."""
    names = protocols.design_library(supplies_mpa[0])
    return [
        (
            name,
            tuple(
                planned_run(
                    protocols.design_library(q)[name], q, twin.params.k_u_per_pa, inertia_kg_m2, rate_hz, pressures
                )
                for q in supplies_mpa
            ),
        )
        for name in names
    ]


def base_runs(campaign: Campaign, twin: ReplayedJoint) -> list[PlannedRun]:
    """The campaign's own runs as the criterion reads them: their commands and sample times."""
    out = []
    for r in campaign.runs:
        rows = np.isfinite(np.stack([r.extra.get(c, np.full(r.time_s.shape, np.nan)) for c in ("p_a_pa", "p_b_pa")]))
        out.append(
            PlannedRun(
                r.name,
                r.supply_mpa,
                r.time_s,
                r.direction,
                r.valve_gauge_pa,
                r.brake_released,
                r.supply_pa,
                r.time_s[r.sampled],
                r.time_s[rows.any(axis=0)],
                r.valve_is_output,
                r.start_rad,
                nominal_inertia(r.rig_inertia_kg_m2, twin.params),
            )
        )
    return out


def run_misfits(respond, hyps: list[Hypothesis], directed: list[tuple[int, int]], run, reading: Reading):
    """Per directed pair (truth, rival), the rival's alternatives' misfits of the truth on `run`
    (alternatives x latencies; discrimination.misfits), each change replayed once by
    `respond(change, run)` (a discrimination.Response)."""
    cache: dict[tuple, object] = {}

    def resp(change: Change):
        key = tuple((e.name, v) for e, v in change)
        if key not in cache:
            cache[key] = respond(change, run)
        return cache[key]

    out = []
    for a, b in directed:
        truth = resp(hyps[a].effects)
        out.append(misfits(truth, latency_index(reading, hyps[a].latency_s), [resp(c) for c in hyps[b].alternatives]))
    return out


class DesignCriterion:
    """The design's criterion as sums over runs: per directed pair, the misfit of each rival alternative and
    latency summed over the campaign's own runs (`base`) and over each proposal's.

    `respond(change, run)`: a change's predicted readings of a run (discrimination.Response), and
    `count(run)`: the samples it gives; by default the one-joint twin's (discrimination.response,
    discrimination.samples); the arm's design gives the whole arm's (gap.arm_design)."""

    def __init__(self, twin, hyps, pairs, reading, n_jobs: int = 1, respond=None, count=None):
        self.twin, self.hyps, self.pairs, self.reading = twin, hyps, pairs, reading
        self.directed = list(dict.fromkeys(d for p in pairs for d in p.directed))
        self.n_jobs = n_jobs
        self.respond = respond or (lambda change, run: response(twin, change, run, reading))
        self.count = count or (lambda run: samples(run, reading))

    def sums(self, runs: list[PlannedRun]) -> list[np.ndarray]:
        """Per directed pair, the misfits summed over `runs` (alternatives x latencies)."""
        per_run = Parallel(n_jobs=self.n_jobs, backend="threading")(
            delayed(run_misfits)(self.respond, self.hyps, self.directed, r, self.reading) for r in runs
        )
        zero = [np.zeros((len(self.hyps[b].alternatives), len(self.reading.latencies_s))) for _, b in self.directed]
        return [sum((m[i] for m in per_run), zero[i]) for i in range(len(self.directed))]

    def separation(self, base: list[np.ndarray] | None, added: list[np.ndarray], n_samples: int) -> dict[str, float]:
        """Per pair, the lesser way round of the rival's refitted misfit that `added` brings beyond
        `base` (None: no runs before), as an rms in floors over its `n_samples`."""
        sep = {}
        for i, d in enumerate(self.directed):
            before = float(base[i].min()) if base is not None else 0.0
            t = float((added[i] + (base[i] if base is not None else 0.0)).min()) - before
            sep[d] = separation_floors(t, n_samples)
        return {p.name: min(sep[d] for d in p.directed) for p in self.pairs}


def choose(
    crit: DesignCriterion,
    candidates: list[tuple[str, tuple[PlannedRun, ...]]],
    base: list[np.ndarray] | None,
    max_proposals: int | None,
) -> tuple[list[Proposal], list[Proposal], dict[str, float]]:
    """Every proposal scored alone (ranked best first), the greedy plan (each step the proposal that
    adds most to the soft count of pairs told apart, while one adds a pair told apart or raises the
    soft count by a tenth of a pair; at most `max_proposals`), and the plan's separation together."""
    sums = {name: crit.sums(list(runs)) for name, runs in candidates}
    n = {name: sum(crit.count(r) for r in runs) for name, runs in candidates}
    ranking = [
        Proposal(name, runs, sum(float(r.time_s[-1]) for r in runs), crit.separation(base, sums[name], n[name]))
        for name, runs in candidates
    ]
    # by the pairs told apart, ties by the least separation (maximin: the pair told apart least)
    ranking.sort(key=lambda p: (-p.score(), -min(p.separation.values(), default=0.0)))
    chosen: list[Proposal] = []
    together = {p.name: 0.0 for p in crit.pairs}
    while max_proposals is None or len(chosen) < max_proposals:
        best, best_sep = None, together
        for p in ranking:
            if p in chosen:
                continue
            names = [*(c.protocol for c in chosen), p.protocol]
            added = [sum(sums[x][i] for x in names) for i in range(len(crit.directed))]
            sep = crit.separation(base, added, sum(n[x] for x in names))
            if best is None or soft_count(sep) > soft_count(best_sep):
                best, best_sep = p, sep
        if best is None or not _adds(together, best_sep):
            break
        chosen.append(best)
        together = best_sep
    return ranking, chosen, together


def _adds(before: dict[str, float], after: dict[str, float]) -> bool:
    told = sum(s >= SEPARATED_FLOORS for s in before.values())
    return sum(s >= SEPARATED_FLOORS for s in after.values()) > told or soft_count(after) > soft_count(before) + 0.1


def design(campaign: Campaign, diag: Diagnosis, catalogue=CATALOGUE, n_jobs: int = 1) -> Design:
    """The next runs for `campaign`, from its diagnosis `diag` (module docstring)."""
    twin = ReplayedJoint(nominal_params(campaign), joint_stops(campaign.joint))
    hyps, pairs = hypotheses_of(diag, catalogue)
    declared = campaign.instrument.latency_s
    reading = Reading(
        diag.noise_floor.floor_deg,
        np.array([declared]) if declared is not None else LATENCY_GRID_S,
        diag.pressure.floor_kpa if diag.pressure.measured else None,
    )
    if not diag.which.verdict.alarm or len(hyps) < 2:
        return Design(hyps, pairs, reading, [], [], {}, [p.name for p in pairs], twin, str(campaign.folder))
    crit = DesignCriterion(twin, hyps, pairs, reading, n_jobs)
    base = crit.sums(base_runs(campaign, twin))
    rate = campaign.instrument.rate_hz or diag.instrument.observed_rate_hz
    inertia = nominal_inertia(campaign.runs[0].rig_inertia_kg_m2, twin.params)
    candidates = proposals(twin, supplies(campaign), inertia, rate, diag.pressure.measured)
    ranking, chosen, together = choose(crit, candidates, base, MAX_PROPOSALS)
    unseparated = [k for k, s in together.items() if s < SEPARATED_FLOORS]
    return Design(hyps, pairs, reading, ranking, chosen, together, unseparated, twin, str(campaign.folder))


def design_before_campaign(
    joint: str,
    instrument: synth.SimInstrument,
    pressures: bool = False,
    hose_length_m: float | None = None,
    catalogue=CATALOGUE,
    n_jobs: int = 1,
) -> Design:
    """The smallest campaign (protocols of the design library, each at the paper's four supplies) that
    tells every two catalogue families apart read by `instrument` (its noise with the twin's model
    tolerance; its latency fitted unless the instrument declares it), and the pairs it cannot."""
    params = load_joint_params(assets.joint_param_path(joint))
    if hose_length_m is not None:
        params = params._replace(hose_length_m=hose_length_m)
    twin = ReplayedJoint(params, joint_stops(joint))
    hyps, pairs = catalogue_hypotheses(twin, instrument.latency_s, catalogue)
    latencies = np.array([instrument.latency_s]) if "latency_s" in instrument.declare else LATENCY_GRID_S
    reading = Reading(
        math.hypot(instrument.noise_deg, worst_tolerance_deg()),
        latencies,
        math.hypot(PRESSURE_NOISE_KPA, worst_tolerance_kpa()) if pressures else None,
    )
    crit = DesignCriterion(twin, hyps, pairs, reading, n_jobs)
    inertia = nominal_inertia(commanded_run.RIG_INERTIA_KG_M2, params)
    candidates = proposals(twin, list(synth.PRESSURES_MPA), inertia, instrument.rate_hz, pressures)
    ranking, chosen, together = choose(crit, candidates, None, None)
    unseparated = [k for k, s in together.items() if s < SEPARATED_FLOORS]
    return Design(hyps, pairs, reading, ranking, chosen, together, unseparated, twin, f"the catalogue ({joint})")
