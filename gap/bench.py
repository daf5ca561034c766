"""The blind check: campaigns from the plant with hidden effects, diagnosed from their files alone.

Reality = twin.plant.Plant on the wrist rig with the hidden effect in its JointParams (or, for an
angle-dependent load, MuJoCo's own joint spring); each case's campaign (4 pressures x 2 repeats)
is written to disk and read back by the diagnosis, which is told nothing else. What a user meets
varies from case to case: the motion protocol (gap.protocols: reversal, stop-and-go, staircase,
back-and-forth), the reference instrument (gap.synth.ENCODER: 50 Hz, 0.05 deg; gap.synth.CAMERA:
30 Hz, 0.2 deg, 10-40 ms latency drawn per case and never declared, 3 % of frames dropped), and
whether both motor ports' pressures were measured (1 kPa noise). Scores go to DIR/bench.json.
"""

from __future__ import annotations

import json
import math
import shutil
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from gap import protocols, synth
from gap.campaign import load_campaign
from gap.design_round import design_round as run_design_round
from gap.diagnose import diagnose
from gap.effects import BY_NAME, CATALOGUE
from gap.kinds import Verdict
from gap.result import Diagnosis
from gap.verdict import families_of
from twin_plumbing.checks import check_number
from twin_plumbing.errors import UserError
from twin_plumbing.outputs import write_atomic
from wrist_rig import commanded_run

KINDS = ("single", "form", "pair", "outside", "none")
# the ranges of the bench's numbers (check_number), the command line's flags too
BENCH_SHIFT = {"low": 0, "high": 10**6, "integer": True}  # `twin gap bench --shift`: cases along, a bound against typos
BENCH_SEEDS = {"low": 0, "high": 10**9, "integer": True}  # `twin gap bench --seeds`: the campaigns' seed offset


@dataclass
class Case:
    name: str
    kind: str  # one of KINDS
    reality: dict  # JointParams fields of the hidden effect
    expect: tuple[str, ...] = ()  # catalogue effects a correct call names
    exclude: tuple[str, ...] = ()  # catalogue entries withheld from the diagnosis (form cases)
    twin_hose_loss: bool | None = None
    truth: dict = field(default_factory=dict)  # effect name -> true value for parameter recovery
    rig_spring_nm_per_rad: float = 0.0  # a hidden angle-dependent load (MuJoCo joint spring)
    rig_load_nm: float = 0.0  # a hidden static load the same at every angle (MuJoCo applied joint force)
    declared_hose_length_m: float | None = None  # what campaign.toml says of the hose (None: the truth)


PROTOCOLS = ("reversal", "stop_and_go", "staircase", "back_and_forth")
INSTRUMENTS = (synth.ENCODER, synth.CAMERA)


@dataclass(frozen=True)
class Variant:
    """The bench under settings it does not use by default, for a check of how far its figures carry:
    every case on one `protocol` of gap.protocols' library (None: each case's own), each case with
    the setting (protocol, instrument, pressure transducers) of the case `shift` places along, and
    its campaign's seed `seeds` further on."""

    protocol: str | None = None
    shift: int = 0
    seeds: int = 0


def cases() -> list[Case]:
    """The bench's cases: single effects of the catalogue, forms it lacks (scored by family),
    pairs, a ripple outside it, and campaigns that hide no effect."""
    return [
        *single_cases(),
        *form_and_pair_cases(),
        # later singles stay after the others: a case's index sets its protocol, instrument and seeds
        Case("angle_load", "single", {}, ("angle_load",), truth={"angle_load": 20.0}, rig_spring_nm_per_rad=20.0),
        Case(
            "brake_release",
            "single",
            {"brake_release_gauge_pa": 6.0e5},
            ("brake_incomplete_release",),
            truth={"brake_incomplete_release": 6.0e5},
        ),
        Case("brake_holding", "single", {"brake_holding_nm": 40.0}, ("brake_holding",), truth={"brake_holding": 40.0}),
        Case("ripple", "outside", {"ripple_fraction": 0.5}),
        *(Case(f"none_{k}", "none", {}) for k in range(8)),
        *other_form_cases(),
        # last (a case's index sets its setting, so new cases go after the others), two static loads the
        # catalogue's angle_load (a spring about the joint's zero) does not have, family load: 12 N·m
        # the same at every angle (MuJoCo's applied joint force), and a spring of 10 N·m/rad resting
        # at 1 rad, the joint's zero at 10 N·m (its stiffness and that force)
        Case("static_load", "form", {}, ("angle_load",), rig_load_nm=12.0),
        Case("offset_spring", "form", {}, ("angle_load",), rig_spring_nm_per_rad=10.0, rig_load_nm=-10.0),
    ]


def other_form_cases() -> list[Case]:
    """Forms built apart from the catalogue's laws, each in a part of the joint the catalogue has a
    family for (scored by family, as the withheld forms): nothing is withheld, no catalogue entry
    has their law. Each family named in `expect` is a right answer."""
    return [
        # a narrower hose (3 mm against the 4 mm the twin is told, paper eq. 1-5 with the real bore):
        # the twin already has the hose loss, so no candidate of the hose family varies
        Case("narrow_hose", "form", {"hose_diameter_m": 0.003}, ("hose_loss",)),
        # a leak to atmosphere in port A's hose (a cut hose or a loose fitting): the catalogue's
        # hose_leak, scored as a single (kept among the forms: a case's index sets its protocol,
        # instrument and seeds)
        Case("hose_leak", "single", {"hose_leak_area_m2": 3e-7}, ("hose_leak",), truth={"hose_leak": 3e-7}),
        # the brake's piston fills slowly (0.4 s against 0.05 s): it drags at every start only. The
        # catalogue's brake_slow_release, scored as a single (kept here for its index)
        Case(
            "slow_brake_release",
            "single",
            {"brake_release_time_constant_s": 0.4},
            ("brake_slow_release",),
            truth={"brake_slow_release": 0.4},
        ),
        # the brake fed from the supply, not the driven motor port: never drags while released
        Case("brake_fed_by_supply", "form", {"brake_fed_by_motor": 0.0}, ("brake_holding",)),
        # a clogged exhaust silencer (half the exhaust area), the inlet as it was: conductance_error
        # scales both, the dead zone neither
        Case("exhaust_throttle", "form", {"exhaust_area_m2": 0.4e-6}, ("conductance_error",)),
        # the brake's springs engage slowly (0.1 s against 0.02 s: a restricted brake exhaust): every
        # stop slides further, as a weak lining's does, but the lining holds once it bites. The
        # catalogue's brake_slow_engage, scored as a single (kept here for its index)
        Case(
            "slow_brake_engage",
            "single",
            {"brake_engage_time_constant_s": 0.1},
            ("brake_slow_engage",),
            truth={"brake_slow_engage": 0.1},
        ),
        # the gear loses more than its datasheet says (forward efficiency 0.5 against 0.7: a worn or
        # cold strain-wave gear): torque lost in the gear's teeth, in proportion to what it carries;
        # the reducer's part, and friction's
        Case("gear_efficiency", "form", {"efficiency_forward": 0.5}, ("reducer_compliance", "coulomb_friction")),
        # the proportional valve opens less per bar than its datasheet says (k_u 0.137 against 0.196 per
        # bar gauge: a worn spool or a weak solenoid): the supply path only, and only below full
        # opening, which the nominal valve reaches at 5.1 bar. Its right family, the valve, was
        # written down before the case was run
        Case("valve_gain", "form", {"k_u_per_pa": 0.7 * 1.959e-6}, ("conductance_error",)),
        # hoses 14 m long where campaign.toml says 8 (a user who wrote down the wrong length): 1.75
        # times the loss and the volume; the hose family's variations of the part
        # (gap.effects.IN_TWIN_VARIATIONS) are what can name it
        Case("long_hose", "form", {"hose_length_m": 14.0}, ("hose_loss",), declared_hose_length_m=8.0),
    ]


def form_and_pair_cases() -> list[Case]:
    """Forms the catalogue lacks (its entry withheld: scored by family), and two effects at once."""
    return [
        Case(
            "stribeck_as_coulomb",
            "form",
            {"stribeck_excess_nm": 40.0, "stribeck_speed_rad_s": 0.2},
            ("coulomb_friction", "viscous_friction"),
            exclude=("stribeck_friction",),
        ),
        Case(
            "stribeck_as_coulomb_20",
            "form",
            {"stribeck_excess_nm": 20.0, "stribeck_speed_rad_s": 0.2},
            ("coulomb_friction", "viscous_friction"),
            exclude=("stribeck_friction",),
        ),
        Case(
            "lag_as_dead_time",
            "form",
            {"valve_time_constant_s": 0.3},
            ("valve_dead_time", "valve_set_dead_time"),
            exclude=("valve_lag",),
        ),
        Case(
            "lag_as_dead_time_02",
            "form",
            {"valve_time_constant_s": 0.2},
            ("valve_dead_time", "valve_set_dead_time"),
            exclude=("valve_lag",),
        ),
        Case("leak+coulomb", "pair", {"leak_area_m2": 3e-7, "coulomb_nm": 30.0}, ("vane_leakage", "coulomb_friction")),
        Case(
            "leak+coulomb_b", "pair", {"leak_area_m2": 2e-7, "coulomb_nm": 25.0}, ("vane_leakage", "coulomb_friction")
        ),
    ]


def single_cases() -> list[Case]:
    """One catalogue effect hidden in the plant each, with its true value where it has one."""
    p0 = commanded_run.wrist_params()
    return [
        Case("hose_loss", "single", {}, ("hose_loss",), twin_hose_loss=False),
        Case("vane_leakage", "single", {"leak_area_m2": 4e-7}, ("vane_leakage",), truth={"vane_leakage": 4e-7}),
        Case("coulomb", "single", {"coulomb_nm": 30.0}, ("coulomb_friction",), truth={"coulomb_friction": 30.0}),
        Case("viscous", "single", {"viscous_nm_s": 8.0}, ("viscous_friction",), truth={"viscous_friction": 8.0}),
        Case("dead_time", "single", {"solenoid_delay_s": 0.1}, ("valve_dead_time",), truth={"valve_dead_time": 0.1}),
        Case(
            "set_dead_time",
            "single",
            {"valve_set_dead_time_s": 0.1},
            ("valve_set_dead_time",),
            truth={"valve_set_dead_time": 0.1},
        ),
        Case("valve_lag", "single", {"valve_time_constant_s": 0.3}, ("valve_lag",), truth={"valve_lag": 0.3}),
        Case("dead_zone", "single", {"valve_dead_zone": 0.3}, ("valve_dead_zone",), truth={"valve_dead_zone": 0.3}),
        Case(
            "conductance",
            "single",
            {"conductance_scale": 0.6},
            ("conductance_error",),
            truth={"conductance_error": 0.6},
        ),
        Case("heat", "single", {"polytropic_n": 1.05}, ("heat_exchange",), truth={"heat_exchange": 1.05}),
        Case("droop", "single", {"supply_droop_pa_s_per_kg": 2e7}, ("supply_droop",), truth={"supply_droop": 2e7}),
        Case(
            "inertia",
            "single",
            {"rotor_inertia_kg_m2": 2e-5},
            ("inertia_error",),
            truth={"inertia_error": (0.02 + 120**2 * 2e-5) / (0.02 + 120**2 * p0.rotor_inertia_kg_m2)},
        ),
        Case(
            "backlash",
            "single",
            {"reducer_backlash_rad": 0.02},
            ("reducer_backlash",),
            truth={"reducer_backlash": 0.02},
        ),
        Case(
            "compliance",
            "single",
            {"reducer_compliance_rad_per_nm": 1e-3},
            ("reducer_compliance",),
            truth={"reducer_compliance": 1e-3},
        ),
    ]


QUICK = ("vane_leakage", "none_1")  # the slice a test runs: a single effect and none, both read by the camera


def setting(i: int, case: Case, rng: np.random.Generator) -> tuple[str, synth.SimInstrument, bool]:
    """The protocol, instrument and pressure transducers of the i-th case: cycled so that every
    combination occurs and the no-effect cases meet both instruments four times each."""
    proto = PROTOCOLS[i % len(PROTOCOLS)]
    inst = INSTRUMENTS[(i // len(PROTOCOLS) + i) % 2]
    if inst.latency_s > 0:  # a camera's latency, drawn per campaign (assumed range 10-40 ms)
        inst = replace(
            inst,
            latency_s=round(float(rng.uniform(0.010, 0.040)), 3),
            phase_s=round(float(rng.uniform(0.0, 1.0 / inst.rate_hz)), 3),
        )
    return proto, inst, (i // 2) % 2 == 0


def run_bench(
    out: str | Path,
    quick: bool = False,
    jobs: int = 2,
    chamber_pressures: bool | None = None,
    only: str | None = None,
    variant: Variant = Variant(),
    design_round: bool = False,
) -> dict:
    """Every case diagnosed blind; `chamber_pressures` None: as the case's setting cycles, else
    forced; `only`: the cases named in its comma-separated list (`none*`: every name that starts so);
    `variant`: settings the bench does not use by default; `design_round`: each case's diagnosis
    proposes runs (gap.design), played on the same hidden reality and diagnosed again
    (gap.design_round), its scores beside the first."""
    check_only(only, quick)
    check_variant(variant)
    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    pressures = (0.5, 0.8) if quick else synth.PRESSURES_MPA
    results = []
    for i, case in enumerate(tqdm(cases(), desc="gap bench", file=sys.stderr)):
        if not selected(case, quick, only):
            continue  # the case keeps its index: its protocol, instrument and seeds do not depend on the selection
        folder = out / "campaigns" / case.name
        try:
            r = run_case(case, i, folder, pressures, chamber_pressures, jobs, variant, design_round)
        except BaseException as e:
            shutil.rmtree(folder, ignore_errors=True)  # unfinished, as bench.json says: what a stopped bench keeps
            shutil.rmtree(out / "rounds" / case.name, ignore_errors=True)
            if isinstance(e, OSError) and not e.filename:  # a write cut short (a full disk): the case, now removed
                raise OSError(e.errno, e.strerror or str(e), str(folder)) from e
            raise
        results.append(r)
        summary = summarise(results, quick, chamber_pressures, time.perf_counter() - t0, variant)
        if design_round:
            summary["design_round"] = summarise_round(results)
        write_atomic(
            out / "bench.json",
            json.dumps(summary, indent=1, default=lambda x: None if isinstance(x, float) and math.isnan(x) else str(x)),
        )  # after every case, whole: a long run killed keeps what it did
    summary = summarise(results, quick, chamber_pressures, time.perf_counter() - t0, variant)
    if design_round:
        summary["design_round"] = summarise_round(results)
    return summary


def run_case(
    case: Case,
    i: int,
    folder: Path,
    pressures: tuple,
    chamber_pressures: bool | None,
    jobs: int,
    variant: Variant = Variant(),
    design_round: bool = False,
) -> dict:
    """The i-th case's campaign made in `folder` and diagnosed blind: its setting and scores (with
    `design_round`, also the scores after one round of designed runs, in `folder`/../../rounds/case)."""
    proto, inst, with_p = make_case_campaign(case, i, folder, pressures, chamber_pressures, variant)
    catalogue = tuple(e for e in CATALOGUE if e.name not in case.exclude)
    t_diag = time.perf_counter()
    campaign = load_campaign(folder)
    diag = diagnose(campaign, catalogue=catalogue, n_jobs=jobs, progress=False)
    t_diag = time.perf_counter() - t_diag
    r = {
        "case": case.name,
        "kind": case.kind,
        "protocol": proto,
        "instrument": inst.name,
        "latency_s": inst.latency_s,
        "latency_found_s": diag.instrument.latency_s,
        "chamber_pressures": with_p,
        "diagnose_s": t_diag,
        **scores(case, diag),
    }
    if design_round:
        rounds = folder.parent.parent / "rounds" / case.name
        r["round"] = round_of(case, 100 + i + variant.seeds, campaign, diag, rounds, inst, with_p, jobs)
    return r


def round_of(case: Case, seed: int, campaign, diag: Diagnosis, folder: Path, inst, with_p: bool, jobs: int) -> dict:
    """One design round on the case's hidden reality (gap.design_round): its cost and the scores after."""
    catalogue = tuple(e for e in CATALOGUE if e.name not in case.exclude)
    reality = commanded_run.wrist_params()._replace(**case.reality)
    again, cost = run_design_round(
        campaign,
        diag,
        folder,
        reality,
        inst,
        with_p,
        catalogue,
        seed,
        jobs,
        case.rig_spring_nm_per_rad,
        case.rig_load_nm,
    )
    return {**cost, **scores(case, again if again is not None else diag)}


def make_case_campaign(
    case: Case, i: int, folder: Path, pressures: tuple, chamber_pressures: bool | None, variant: Variant = Variant()
) -> tuple[str, synth.SimInstrument, bool]:
    """The i-th case's campaign made in `folder` (as `run_case` diagnoses it): its protocol,
    instrument and whether it measured chamber pressures."""
    proto, inst, with_p = setting(i + variant.shift, case, np.random.default_rng(1000 + i))
    proto = variant.protocol or proto
    with_p = with_p if chamber_pressures is None else chamber_pressures
    synth.make_campaign(
        folder,
        commanded_run.wrist_params()._replace(**case.reality),
        seed=100 + i + variant.seeds,
        pressures_mpa=pressures,
        twin_hose_loss=case.twin_hose_loss,
        motion={q: protocols.library(q)[proto] for q in pressures},
        instrument=inst,
        description=f"(hidden: {case.name}; {proto}; {inst.name})",
        chamber_pressures=with_p,
        rig_spring_nm_per_rad=case.rig_spring_nm_per_rad,
        rig_load_nm=case.rig_load_nm,
        declared_hose_length_m=case.declared_hose_length_m,
    )
    return proto, inst, with_p


def check_variant(variant: Variant) -> None:
    """Refuse (UserError) a protocol the library does not have, a shift or seed offset out of its range
    (BENCH_SHIFT, BENCH_SEEDS, as the command line's flags)."""
    names = tuple(protocols.library(0.5))
    if variant.protocol is not None and variant.protocol not in names:
        raise UserError(f"--protocol {variant.protocol!r}: no such protocol; allowed: {', '.join(names)}")
    check_number("shift", variant.shift, **BENCH_SHIFT)
    check_number("seeds", variant.seeds, **BENCH_SEEDS)


def check_only(only: str | None, quick: bool = False) -> None:
    """Refuse (UserError) an `only` with an item that names no case (a typo would run none, an empty
    one all): each must be a case's name, a kind, or a start of a name followed by `*`; and one that
    leaves no case of the quick slice."""
    if only is None:
        return
    for o in only.split(","):
        if not any(_names(case, o) for case in cases()):
            names = ", ".join(c.name for c in cases())
            raise UserError(
                f"--only {only!r}: {o!r} names no case; allowed: comma-separated case names ({names}), kinds "
                f"({', '.join(KINDS)}) or a name's start followed by * (none*)"
            )
    if quick and not any(selected(case, quick, only) for case in cases()):
        raise UserError(f"--only {only!r} names no case of --quick's; allowed with --quick: {', '.join(QUICK)}")


def _names(case: Case, o: str) -> bool:
    return case.name == o or case.kind == o or (o.endswith("*") and case.name.startswith(o[:-1]))


def selected(case: Case, quick: bool, only: str | None) -> bool:
    """Is `case` in the quick slice (with `quick`) and named by `only` (when given: names, a trailing
    `*` matching the start of a name, or a kind: single, form, pair, outside, none)?"""
    named = only is None or any(_names(case, o) for o in only.split(","))
    return named and not (quick and case.name not in QUICK)


def scores(case: Case, diag: Diagnosis) -> dict:
    """What the diagnosis called, and, for cases with an answer, whether it is the right one, how
    far it shrank the gap and how well it recovered the hidden parameter."""
    w, top = diag.which, diag.which.top
    named = tuple(top.effects) if top else ()
    r = {
        "verdict": w.verdict,
        "top": top.name if top else None,
        "family": w.nearest.family if w.nearest else None,
        "rivals": w.rivals,
        "before_rms_deg": diag.before_rms_deg,
        "after_rms_deg": top.heldout_rms_deg if top else None,
    }
    if case.kind in ("single", "form", "pair"):
        if case.kind == "pair":
            r["top1"] = set(named) == set(case.expect)
        elif case.kind == "form":
            # scored at FAMILY level: the hidden form is withheld from the catalogue, so the right
            # answer is its family's other forms (Stribeck -> Coulomb/viscous friction; valve
            # lag -> the valves' dead times). The call: the diagnosis's family-level answer where
            # it gives one (outside the catalogue; ambiguous, among the explaining candidates'
            # families), else the families of the top candidate's effects (all must be right).
            family = families_of(list(case.expect))
            r["call"] = [w.nearest.family] if w.nearest else sorted(families_of(list(named)))
            r["top1"] = bool(r["call"]) and set(r["call"]) <= family
        else:
            r["top1"] = len(named) >= 1 and named[0] in case.expect and w.verdict.explained
        r["shrink"] = top.heldout_rms_deg / diag.before_rms_deg if top else None
    for eff, true in case.truth.items():
        nominal = BY_NAME[eff].value_of(commanded_run.wrist_params())
        fitted = [c for c in w.ranking if c.name == eff][0].fitted_values[0]
        r["param"] = {
            "effect": eff,
            "true": true,
            "fitted": fitted,
            "nominal": nominal,
            "error_rel_to_effect": abs(fitted - true) / abs(true - nominal),
        }
    return r


def summarise(
    results: list[dict], quick: bool, chamber_pressures: bool | None, wall_s: float, variant: Variant = Variant()
) -> dict:
    """The bench's scores over the cases diagnosed so far."""
    att = [r for r in results if "top1" in r]
    exact = [r for r in att if r["kind"] in ("single", "pair")]
    form = [r for r in att if r["kind"] == "form"]
    none = [r for r in results if r["kind"] == "none"]
    outside = [r for r in results if r["kind"] == "outside"]
    perr = [r["param"]["error_rel_to_effect"] for r in results if "param" in r]

    def rate(rs):
        return sum(r["top1"] for r in rs) / len(rs) if rs else None

    summary = {
        "quick": quick,
        "chamber_pressures_measured": chamber_pressures,
        "variant": {"protocol": variant.protocol, "shift": variant.shift, "seeds": variant.seeds},
        "wall_time_s": wall_s,
        "top1_rate_exact_form": rate(exact),
        "top1_rate_form_differs": rate(form),
        "form_differs_scoring": (
            "family level: the call (the diagnosis's nearest family if outside the catalogue or ambiguous, else "
            "the families of the top candidate's effects) is the withheld form's family "
            "(Stribeck -> friction, valve lag -> valve (the valves' dead times); the forms built apart from "
            "the catalogue's laws: "
            "narrow or longer hose -> hose, brake fed by the supply -> brake, clogged exhaust or a valve opening "
            "less per bar -> valve, a lossy gear -> reducer or friction, a static load the same at every angle "
            "or a spring resting off the joint's zero -> load)"
        ),
        "false_alarm_by_instrument": {
            i.name: _rate_of([Verdict(r["verdict"]).alarm for r in none if r["instrument"] == i.name])
            for i in INSTRUMENTS
        },
        "diagnose_s_median": float(np.median([r["diagnose_s"] for r in results])) if results else None,
        "diagnose_s_max": float(np.max([r["diagnose_s"] for r in results])) if results else None,
        "median_shrink": float(np.median([r["shrink"] for r in att if r["shrink"] is not None])) if att else None,
        "false_alarm_rate": sum(Verdict(r["verdict"]).alarm for r in none) / len(none) if none else None,
        "confident_wrong_rate_outside": sum(r["verdict"] == Verdict.EXPLAINED for r in outside) / len(outside)
        if outside
        else None,
        "median_param_error": float(np.median(perr)) if perr else None,
        "goals": {
            "top1_exact": 0.9,
            "top1_form": 0.8,
            "median_shrink": 0.3,
            "false_alarm": 0.05,
            "confident_wrong": 0.1,
            "median_param_error": 0.1,
        },
        "cases": results,
    }
    return summary


def _rate_of(flags: list[bool]) -> float | None:
    return sum(flags) / len(flags) if flags else None


def summarise_round(results: list[dict]) -> dict:
    """The scores after one design round beside the first diagnosis's, over the cases so far: other
    forms given their family, false alarms, ambiguous verdicts resolved (no longer ambiguous after the
    round; and right where the case is scored), and what the rounds cost."""
    done = [r for r in results if "round" in r]
    form = [r for r in done if r["kind"] == "form"]
    exact = [r for r in done if r["kind"] in ("single", "pair")]
    none = [r for r in done if r["kind"] == "none"]
    ambiguous = [r for r in done if Verdict(r["verdict"]).tied]
    added = [r["round"] for r in done if r["round"]["runs_added"]]
    designed = [r for r in done if Verdict(r["verdict"]).alarm]

    def count(rs, ok) -> str:
        return f"{sum(ok(r) for r in rs)}/{len(rs)}"

    return {
        "forms_right_before": count(form, lambda r: r["top1"]),
        "forms_right_after": count(form, lambda r: r["round"]["top1"]),
        "exact_right_before": count(exact, lambda r: r["top1"]),
        "exact_right_after": count(exact, lambda r: r["round"]["top1"]),
        "false_alarms_before": count(none, lambda r: Verdict(r["verdict"]).alarm),
        "false_alarms_after": count(none, lambda r: Verdict(r["round"]["verdict"]).alarm),
        "ambiguous_before": len(ambiguous),
        "ambiguous_resolved": count(ambiguous, lambda r: not Verdict(r["round"]["verdict"]).tied),
        "ambiguous_resolved_right": count(
            ambiguous, lambda r: not Verdict(r["round"]["verdict"]).tied and r["round"].get("top1", True)
        ),
        "cases_with_runs_added": len(added),
        "runs_added_median": float(np.median([a["runs_added"] for a in added])) if added else 0.0,
        "arm_time_s_median": float(np.median([a["arm_time_s"] for a in added])) if added else 0.0,
        "arm_time_s_max": float(np.max([a["arm_time_s"] for a in added])) if added else 0.0,
        # the design's wall time where it ran (a case with no significant gap has nothing to design)
        "design_s_median": float(np.median([r["round"]["design_s"] for r in designed])) if designed else None,
    }
