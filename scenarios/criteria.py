"""Pass criteria of a scenario, judged on the run's telemetry.

    final_error_deg  |true - last target| of `joint` (every targeted joint if none) at the end <= max
    max_error_deg    |true - target| of `joint` over the whole run (after the first target) <= max
    brush_on_disc    the brush came within `max` m of disc `disc`'s rim (every disc if 0); a
                     distance, not a touch: the cleaning criteria below are the ones that count
    contact_force_n  the brush's peak force on the discs lies in min..max N
    disc_contact_s   the brush pressed on disc `disc` (every disc if 0) above CONTACT_N for an
                     unbroken min..max s (scenarios/cleaning.py: from MuJoCo's contacts)
    disc_force_n     the brush's peak force on the disc lies in min..max N (untouched: fails)
    disc_brushed_m   the length of the disc's rim the brush's face covered lies in min..max m
    disc_rim_share   the share (0..1) of the disc's rim circumference the face went over with the
                     force in the brush's band (scenarios/cleaning.py) lies in min..max
    disc_top_share   the same of the disc's top face (the annulus from the cap to the rim)

A run cut short (`twin run --duration`) judges a disc only if every press target on it was
finished in time, the final errors only if the plan's last target was and every fault has struck,
the brush's overall force once some disc was, and what is measured after the first fault only if
it struck before the cut; the rest are listed as not judged.
    max_drop_m       after the first fault, the payload never fell more than `max` m below where it was
    max_travel_deg   after the first fault, `joint` turned no more than `max` deg
    prediction_error_deg  |true - predicted| of `joint` (every predicted joint) over the run <= max
    task_time_s      when the plan's last target was finished (s) lies in min..max; never: fails
    contact_after_plan_n  the brush's peak force on anything after the plan's last target was
                     finished is <= max N (the arm left leaning on a disc); the plan never finished: fails
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import mujoco
import numpy as np

from scenarios.cleaning import DiscContact, disc_contacts, physics_force_n
from scenarios.schema import Criterion, Fault, Scenario
from scenarios.string import discs_of


@dataclass(frozen=True)
class Verdict:
    kind: str
    subject: str
    value: float
    limit: str
    passed: bool
    judged: bool = True  # False: the run was cut short before this criterion's targets were reached


DISC_KINDS = ("disc_contact_s", "disc_force_n", "disc_brushed_m", "disc_rim_share", "disc_top_share")
AFTER_FAULT_KINDS = ("max_drop_m", "max_travel_deg")  # measured from the first fault on
PLAN_END_KINDS = ("final_error_deg", "task_time_s", "contact_after_plan_n")  # judged once the plan is done


def _deg(x):
    return np.degrees(x)


def judge(
    scenario: Scenario,
    arrays: dict[str, np.ndarray],
    joints: tuple[str, ...],
    bodies: tuple[str, ...],
    model: mujoco.MjModel,
    requested: list[dict[str, float]] | None = None,
    reached: list[bool] | None = None,
    pending: tuple[Fault, ...] = (),
    finished_s: float = math.nan,
) -> list[Verdict]:
    """One verdict per criterion of the scenario (per joint or disc where it names none; at least one
    each: a criterion with nothing to judge fails). `requested`: the scenario's targets in rad;
    final_error_deg is measured against the last one asked of each joint, so a plan the controller
    refused cannot pass it. `reached`: per scenario target, whether it was finished; None: the run
    was not cut short, and everything is judged (a disc the plan never got to fails). `pending`: the
    faults a run cut short stopped before; the final errors are then not judged, nor, if the first
    fault is among them, what is measured after it. `finished_s`: when the plan's last target was
    finished (NaN: it was not)."""
    first_fault_pending = bool(pending) and min(f.at_s for f in pending) <= min(f.at_s for f in scenario.faults)
    out = []
    contacts = disc_contacts(model, arrays) if any(c.kind in DISC_KINDS for c in scenario.criteria) else []
    for c in scenario.criteria:
        if c.kind in DISC_KINDS:
            out.extend(_judge_discs(c, scenario, contacts, reached))
        else:
            if c.kind in PLAN_END_KINDS[1:]:
                verdicts = [_judge_plan_end(c, arrays, finished_s)]
            else:
                verdicts = _judge_one(c, scenario, arrays, joints, bodies, model, requested)
            if reached is not None and c.kind in PLAN_END_KINDS and not (reached and reached[-1]):
                verdicts = [replace(v, passed=False, judged=False) for v in verdicts]
            if (pending and c.kind == "final_error_deg") or (first_fault_pending and c.kind in AFTER_FAULT_KINDS):
                verdicts = [replace(v, passed=False, judged=False) for v in verdicts]  # the fault is still to come
            if (
                reached is not None
                and c.kind == "contact_force_n"
                and not any(disc_reached(scenario, k, reached) for k in range(1, len(discs_of(model)) + 1))
            ):
                verdicts = [replace(v, passed=False, judged=False) for v in verdicts]  # no press finished yet
            out.extend(verdicts or [Verdict(c.kind, c.joint or "-", math.nan, _limit(c), False)])
    return out


def disc_reached(scenario: Scenario, disc: int, reached: list[bool] | None) -> bool:
    """Every press target (negative standoff) on `disc` was finished (True when not cut short)."""
    if reached is None:
        return True
    presses = [i for i, t in enumerate(scenario.targets) if t.brush_at_disc == disc and t.standoff_m < 0]
    return bool(presses) and all(reached[i] for i in presses)


def _judge_discs(
    c: Criterion, scenario: Scenario, contacts: list[DiscContact], reached: list[bool] | None
) -> list[Verdict]:
    out = []
    for dc in contacts:
        if c.disc and dc.disc != c.disc:
            continue
        value = {
            "disc_contact_s": dc.contact_s,
            "disc_force_n": dc.peak_n,
            "disc_brushed_m": dc.brushed_m,
            "disc_rim_share": dc.rim_share,
            "disc_top_share": dc.top_share,
        }[c.kind]
        judged = disc_reached(scenario, dc.disc, reached)
        passed = judged and bool(math.isfinite(value) and _within(value, c))
        out.append(Verdict(c.kind, f"disc_{dc.disc}", value, _limit(c), passed, judged))
    return out


def _judge_plan_end(c: Criterion, a: dict, finished_s: float) -> Verdict:
    """The task's time, or the brush's peak force after the plan's end (0 if nothing touched it
    since); NaN, and so failed, when the plan never finished."""
    if c.kind == "task_time_s":
        value = finished_s
    else:
        after = a["time_s"] > finished_s
        value = float(np.max(physics_force_n(a)[after], initial=0.0)) if math.isfinite(finished_s) else math.nan
    subject = "plan" if c.kind == "task_time_s" else "brush"
    return Verdict(c.kind, subject, value, _limit(c), bool(math.isfinite(value) and _within(value, c)))


def _within(value: float, c: Criterion) -> bool:
    return bool(c.min <= value <= c.max)


def _limit(c: Criterion) -> str:
    if math.isfinite(c.min) and math.isfinite(c.max):
        return f"{c.min:g}..{c.max:g}"
    return f"<= {c.max:g}" if math.isfinite(c.max) else f">= {c.min:g}"


def _judge_one(c: Criterion, scenario: Scenario, a: dict, joints, bodies, model, requested=None) -> list[Verdict]:
    t = a["time_s"]
    fault_t = min((f.at_s for f in scenario.faults), default=0.0)
    after_fault = t >= fault_t
    if c.kind == "prediction_error_deg":
        pred = a["predicted_angle_rad"]
        chosen = [c.joint] if c.joint else [j for i, j in enumerate(joints) if np.isfinite(pred[:, i]).any()]
        verdicts = []
        for joint in chosen:
            i = joints.index(joint)
            # a sample that is not a number (a diverged predictor) makes the value NaN: the criterion fails
            value = float(np.max(np.abs(_deg(a["true_angle_rad"][:, i] - pred[:, i])))) if len(t) else math.nan
            verdicts.append(Verdict(c.kind, joint, value, _limit(c), bool(np.isfinite(value) and _within(value, c))))
        return verdicts
    if c.kind in ("final_error_deg", "max_error_deg"):
        targets = a["target_angle_rad"]
        last_asked = {j: v for target in (requested or []) for j, v in target.items()}
        chosen = (
            [c.joint]
            if c.joint
            else [j for i, j in enumerate(joints) if np.isfinite(targets[:, i]).any() or j in last_asked]
        )
        verdicts = []
        for joint in chosen:
            i = joints.index(joint)
            err = np.abs(_deg(a["true_angle_rad"][:, i] - targets[:, i]))
            if c.kind == "final_error_deg" and joint in last_asked:
                value = float(_deg(abs(a["true_angle_rad"][-1, i] - last_asked[joint])))
            elif c.kind == "final_error_deg":  # a joint no target named: held where the controller held it
                finite = np.flatnonzero(np.isfinite(targets[:, i]))
                value = (
                    float(_deg(abs(a["true_angle_rad"][-1, i] - targets[finite[-1], i]))) if finite.size else math.nan
                )
            else:
                # over the samples with a target (NaN before the first); a true angle that is not a
                # number there makes the value NaN: the criterion fails
                asked = np.isfinite(targets[:, i])
                value = float(np.max(err[asked])) if asked.any() else math.nan
            verdicts.append(Verdict(c.kind, joint, value, _limit(c), bool(np.isfinite(value) and _within(value, c))))
        return verdicts
    if c.kind == "brush_on_disc":
        brush = a["body_pos_m"][:, bodies.index("brush")]
        verdicts = []
        shells = discs_of(model)
        for disc in [c.disc] if c.disc else range(1, len(shells) + 1):
            rim, _ = shells[disc - 1].rim_facing()
            # the brush face is its half-length in front of the brush body's origin, on the tool axis
            gap = np.linalg.norm(brush - rim, axis=1) - 0.03
            value = float(np.min(np.abs(gap)))
            verdicts.append(Verdict(c.kind, f"disc_{disc}", value, _limit(c), _within(value, c)))
        return verdicts
    if c.kind == "contact_force_n":
        value = float(np.max(physics_force_n(a)))  # at the physics rate
        return [Verdict(c.kind, "brush", value, _limit(c), _within(value, c))]
    if c.kind == "max_drop_m":
        z = a["body_pos_m"][after_fault, bodies.index("payload"), 2]
        value = float(z[0] - z.min()) if z.size else math.nan
        return [Verdict(c.kind, "payload", value, _limit(c), bool(np.isfinite(value) and _within(value, c)))]
    if c.kind == "max_travel_deg":
        i = joints.index(c.joint)
        q = _deg(a["true_angle_rad"][after_fault, i])
        value = float(q.max() - q.min()) if q.size else math.nan
        return [Verdict(c.kind, c.joint, value, _limit(c), bool(np.isfinite(value) and _within(value, c)))]
    raise ValueError(f"unknown criterion {c.kind!r}")


def as_dicts(verdicts: list[Verdict]) -> list[dict]:
    return [asdict(v) for v in verdicts]
