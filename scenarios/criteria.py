"""Pass criteria of a scenario, judged on the run's telemetry.

Each kind is one row of CRITERIA: its name, the unit of its value, what it measures against which
limit, when a run cut short can judge it (`When`), how it is measured, and what a scenario must
have to use it (checked by scenarios/schema.py, which reads its kinds from here). A new criterion
is one row; docs/scenario_kinds.md lists them.

A run cut short (`twin run --duration`) judges a disc only if every press target on it was
finished in time, the final errors only if the plan's last target was and every fault has struck,
the brush's overall force once some disc was, and what is measured after the first fault only if
it struck before the cut; the rest are listed as not judged.
"""

from __future__ import annotations

import enum
import functools
import math
import operator
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, NamedTuple

import mujoco
import numpy as np

from scenarios.cleaning import DiscContact, disc_contacts, physics_force_n
from scenarios.kinds import registry
from scenarios.string import discs_of

if TYPE_CHECKING:  # types only: the schema imports its criterion kinds from this module
    from scenarios.schema import Criterion, Fault, Scenario


@dataclass(frozen=True, kw_only=True)
class CriterionVerdict:
    """A criterion judged on one subject (a joint, a disc, the brush...): its value, its limit, passed or not."""

    kind: str
    subject: str
    value: float
    limit: str
    passed: bool
    judged: bool = True  # False: the run was cut short before this criterion's targets were reached


class Measured(NamedTuple):
    """One value a criterion is judged by: of a joint, a disc, the brush, the payload, the plan."""

    subject: str
    value: float
    disc: int = 0  # the disc it was measured on (its press targets decide whether it is judged)


@dataclass(frozen=True, kw_only=True)
class Evidence:
    """What the criteria are judged on: the scenario, its run's telemetry, how far the run got."""

    scenario: Scenario
    arrays: dict[str, np.ndarray]
    joints: tuple[str, ...]
    bodies: tuple[str, ...]
    model: mujoco.MjModel
    requested: list[dict[str, float]] | None  # the scenario's targets, rad
    reached: list[bool] | None  # per scenario target, finished (None: the run was not cut short)
    pending: tuple[Fault, ...]  # the faults a run cut short stopped before
    finished_s: float  # when the plan's last target was finished (NaN: it was not)

    @functools.cached_property
    def contacts(self) -> list[DiscContact]:
        """Per disc, what the brush did to it (computed once, by the first disc criterion)."""
        return disc_contacts(self.model, self.arrays)

    @property
    def after_first_fault(self) -> np.ndarray:
        """Per sample, whether the first fault had struck (every sample without faults)."""
        return self.arrays["time_s"] >= min((f.at_s for f in self.scenario.faults), default=0.0)

    @property
    def first_fault_pending(self) -> bool:
        return bool(self.pending) and min(f.at_s for f in self.pending) <= min(f.at_s for f in self.scenario.faults)

    @property
    def plan_finished(self) -> bool:
        """The plan's last target was finished, or the run was not cut short."""
        return self.reached is None or bool(self.reached and self.reached[-1])


class When(enum.Enum):
    """When a run cut short can judge a criterion (a whole run judges every one)."""

    WHOLE_RUN = "on whatever was run"
    PER_DISC = "each disc once every press target on it was finished"
    SOME_DISC = "once every press target on some disc was finished"
    AFTER_FAULT = "from the first fault on: once it has struck"
    PLAN_END = "once the plan's last target was finished"
    FINAL = "once the plan's last target was finished and every fault has struck"

    def judged(self, e: Evidence, m: Measured) -> bool:
        """Whether the run got far enough to judge the criterion on `m`."""
        match self:
            case When.PER_DISC:
                return disc_reached(e.scenario, m.disc, e.reached)
            case When.SOME_DISC:
                discs = range(1, len(discs_of(e.model)) + 1)
                return e.reached is None or any(disc_reached(e.scenario, k, e.reached) for k in discs)
            case When.AFTER_FAULT:
                return not e.first_fault_pending
            case When.PLAN_END:
                return e.plan_finished
            case When.FINAL:
                return e.plan_finished and not e.pending
        return True  # WHOLE_RUN


@dataclass(frozen=True, kw_only=True)
class CriterionKind:
    """One kind of criterion: what the file's `[[criteria]]` table of that kind judges, and how."""

    name: str  # the file's `kind`
    unit: str  # of the value, `min` and `max` ("": a share, 0..1)
    what: str  # what is measured, and the limit it is held to, in words
    when: When
    # the values it is judged by, one per joint, disc, ... (none: the criterion fails)
    measure: Callable[[Criterion, Evidence], list[Measured]]
    # what a scenario must have to use it (scenarios/schema.py refuses it otherwise)
    arm_only: bool = False  # the brush, the discs, the payload or the task's plan: not on the rig
    by_joint: bool = False  # may name one `joint` (none: every joint it applies to)
    joint_required: bool = False  # must name its `joint`
    by_disc: bool = False  # may name one `disc` (0: every disc)
    needs_controller: bool = False  # a controller (not control.mode = 'none'): it moves or predicts
    needs_targets: bool = False  # a controller and [[targets]] (of its joint) to be judged against


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
) -> list[CriterionVerdict]:
    """One verdict per criterion of the scenario (per joint or disc where it names none; at least one
    each: a criterion with nothing to judge fails). `requested`: the scenario's targets in rad;
    final_error_deg is measured against the last one asked of each joint, so a plan the controller
    refused cannot pass it. `reached`: per scenario target, whether it was finished; None: the run
    was not cut short, and everything is judged (a disc the plan never got to fails). `pending`: the
    faults a run cut short stopped before; the final errors are then not judged, nor, if the first
    fault is among them, what is measured after it. `finished_s`: when the plan's last target was
    finished (NaN: it was not)."""
    e = Evidence(
        scenario=scenario,
        arrays=arrays,
        joints=joints,
        bodies=bodies,
        model=model,
        requested=requested,
        reached=reached,
        pending=pending,
        finished_s=finished_s,
    )
    return [v for c in scenario.criteria for v in _verdicts(c, e)]


def _verdicts(c: Criterion, e: Evidence) -> list[CriterionVerdict]:
    """The criterion's verdict on each value its kind measures (a failed one if it measures none)."""
    kind, limit = CRITERIA[c.kind], _limit(c)
    out = []
    for m in kind.measure(c, e):
        judged = kind.when.judged(e, m)
        passed = judged and bool(math.isfinite(m.value) and _within(m.value, c))
        out.append(
            CriterionVerdict(kind=c.kind, subject=m.subject, value=m.value, limit=limit, passed=passed, judged=judged)
        )
    return out or [CriterionVerdict(kind=c.kind, subject=c.joint or "-", value=math.nan, limit=limit, passed=False)]


def disc_reached(scenario: Scenario, disc: int, reached: list[bool] | None) -> bool:
    """Every press target (negative standoff) on `disc` was finished (True when not cut short)."""
    if reached is None:
        return True
    presses = [i for i, t in enumerate(scenario.targets) if t.brush_at_disc == disc and t.standoff_m < 0]
    return bool(presses) and all(reached[i] for i in presses)


def _within(value: float, c: Criterion) -> bool:
    return bool(c.min <= value <= c.max)


def _limit(c: Criterion) -> str:
    if math.isfinite(c.min) and math.isfinite(c.max):
        return f"{c.min:g}..{c.max:g}"
    return f"<= {c.max:g}" if math.isfinite(c.max) else f">= {c.min:g}"


def _deg(x):
    return np.degrees(x)


def _target_joints(c: Criterion, e: Evidence) -> tuple[list[str], dict[str, float]]:
    """The joints an error is measured on (the criterion's, else every joint with a target) and the
    last target asked of each joint (rad)."""
    targets = e.arrays["target_angle_rad"]
    last_asked = {j: v for target in (e.requested or []) for j, v in target.items()}
    if c.joint:
        return [c.joint], last_asked
    return [j for i, j in enumerate(e.joints) if np.isfinite(targets[:, i]).any() or j in last_asked], last_asked


def _final_error(c: Criterion, e: Evidence) -> list[Measured]:
    true, targets = e.arrays["true_angle_rad"], e.arrays["target_angle_rad"]
    chosen, last_asked = _target_joints(c, e)
    out = []
    for joint in chosen:
        i = e.joints.index(joint)
        if joint in last_asked:
            value = float(_deg(abs(true[-1, i] - last_asked[joint])))
        else:  # a joint no target named: held where the controller held it
            finite = np.flatnonzero(np.isfinite(targets[:, i]))
            value = float(_deg(abs(true[-1, i] - targets[finite[-1], i]))) if finite.size else math.nan
        out.append(Measured(joint, value))
    return out


def _max_error(c: Criterion, e: Evidence) -> list[Measured]:
    true, targets = e.arrays["true_angle_rad"], e.arrays["target_angle_rad"]
    out = []
    for joint in _target_joints(c, e)[0]:
        i = e.joints.index(joint)
        # over the samples with a target (NaN before the first); a true angle that is not a number
        # there makes the value NaN: the criterion fails
        asked = np.isfinite(targets[:, i])
        value = float(np.max(np.abs(_deg(true[:, i] - targets[:, i]))[asked])) if asked.any() else math.nan
        out.append(Measured(joint, value))
    return out


def _prediction_error(c: Criterion, e: Evidence) -> list[Measured]:
    pred = e.arrays["predicted_angle_rad"]
    chosen = [c.joint] if c.joint else [j for i, j in enumerate(e.joints) if np.isfinite(pred[:, i]).any()]
    out = []
    for joint in chosen:
        i = e.joints.index(joint)
        # a sample that is not a number (a diverged predictor) makes the value NaN: the criterion fails
        error = np.abs(_deg(e.arrays["true_angle_rad"][:, i] - pred[:, i]))
        out.append(Measured(joint, float(np.max(error)) if len(e.arrays["time_s"]) else math.nan))
    return out


def _brush_on_disc(c: Criterion, e: Evidence) -> list[Measured]:
    brush = e.arrays["body_pos_m"][:, e.bodies.index("brush")]
    shells = discs_of(e.model)
    out = []
    for disc in [c.disc] if c.disc else range(1, len(shells) + 1):
        rim, _ = shells[disc - 1].rim_facing()
        # the brush face is its half-length in front of the brush body's origin, on the tool axis
        gap = np.linalg.norm(brush - rim, axis=1) - 0.03
        out.append(Measured(f"disc_{disc}", float(np.min(np.abs(gap))), disc))
    return out


def _contact_force(c: Criterion, e: Evidence) -> list[Measured]:
    return [Measured("brush", float(np.max(physics_force_n(e.arrays))))]  # at the physics rate


def _per_disc(figure: str) -> Callable[[Criterion, Evidence], list[Measured]]:
    """The measure of a disc criterion: the named figure of each disc's DiscContact (of the
    criterion's disc only, if it names one)."""
    of = operator.attrgetter(figure)
    return lambda c, e: [
        Measured(f"disc_{dc.disc}", of(dc), dc.disc) for dc in e.contacts if not c.disc or dc.disc == c.disc
    ]


def _max_drop(c: Criterion, e: Evidence) -> list[Measured]:
    z = e.arrays["body_pos_m"][e.after_first_fault, e.bodies.index("payload"), 2]
    return [Measured("payload", float(z[0] - z.min()) if z.size else math.nan)]


def _max_travel(c: Criterion, e: Evidence) -> list[Measured]:
    q = _deg(e.arrays["true_angle_rad"][e.after_first_fault, e.joints.index(c.joint)])
    return [Measured(c.joint, float(q.max() - q.min()) if q.size else math.nan)]


def _task_time(c: Criterion, e: Evidence) -> list[Measured]:
    return [Measured("plan", e.finished_s)]


def _contact_after_plan(c: Criterion, e: Evidence) -> list[Measured]:
    """The brush's peak force after the plan's end (0 if nothing touched it since); NaN, and so
    failed, when the plan never finished."""
    if not math.isfinite(e.finished_s):
        return [Measured("brush", math.nan)]
    after = e.arrays["time_s"] > e.finished_s
    return [Measured("brush", float(np.max(physics_force_n(e.arrays)[after], initial=0.0)))]


CRITERIA: dict[str, CriterionKind] = registry(
    CriterionKind(
        name="final_error_deg",
        unit="deg",
        what="|true - last target| of `joint` (every targeted joint if none) at the end <= max",
        when=When.FINAL,
        measure=_final_error,
        by_joint=True,
        needs_targets=True,
    ),
    CriterionKind(
        name="max_error_deg",
        unit="deg",
        what="|true - target| of `joint` over the whole run (after the first target) <= max",
        when=When.WHOLE_RUN,
        measure=_max_error,
        by_joint=True,
        needs_targets=True,
    ),
    CriterionKind(
        name="brush_on_disc",
        unit="m",
        what="the brush came within `max` m of disc `disc`'s rim (every disc if 0); a distance, not a "
        "touch: the disc criteria are the ones that count",
        when=When.WHOLE_RUN,
        measure=_brush_on_disc,
        arm_only=True,
        by_disc=True,
    ),
    CriterionKind(
        name="contact_force_n",
        unit="N",
        what="the brush's peak force on the discs lies in min..max N",
        when=When.SOME_DISC,
        measure=_contact_force,
        arm_only=True,
    ),
    CriterionKind(
        name="disc_contact_s",
        unit="s",
        what="the brush pressed on disc `disc` (every disc if 0) above CONTACT_N for an unbroken min..max s "
        "(scenarios/cleaning.py: from MuJoCo's contacts)",
        when=When.PER_DISC,
        measure=_per_disc("contact_s"),
        arm_only=True,
        by_disc=True,
    ),
    CriterionKind(
        name="disc_force_n",
        unit="N",
        what="the brush's peak force on the disc lies in min..max N (untouched: fails)",
        when=When.PER_DISC,
        measure=_per_disc("peak_n"),
        arm_only=True,
        by_disc=True,
    ),
    CriterionKind(
        name="disc_brushed_m",
        unit="m",
        what="the length of the disc's rim the brush's face covered lies in min..max m",
        when=When.PER_DISC,
        measure=_per_disc("brushed_m"),
        arm_only=True,
        by_disc=True,
    ),
    CriterionKind(
        name="disc_rim_share",
        unit="",
        what="the share (0..1) of the disc's rim circumference the face went over with the force in the "
        "brush's band (scenarios/cleaning.py) lies in min..max",
        when=When.PER_DISC,
        measure=_per_disc("rim_share"),
        arm_only=True,
        by_disc=True,
    ),
    CriterionKind(
        name="disc_top_share",
        unit="",
        what="the same of the disc's top face (the annulus from the cap to the rim)",
        when=When.PER_DISC,
        measure=_per_disc("top_share"),
        arm_only=True,
        by_disc=True,
    ),
    CriterionKind(
        name="max_drop_m",
        unit="m",
        what="after the first fault, the payload never fell more than `max` m below where it was",
        when=When.AFTER_FAULT,
        measure=_max_drop,
        arm_only=True,
    ),
    CriterionKind(
        name="max_travel_deg",
        unit="deg",
        what="after the first fault, `joint` turned no more than `max` deg",
        when=When.AFTER_FAULT,
        measure=_max_travel,
        by_joint=True,
        joint_required=True,
    ),
    CriterionKind(
        name="prediction_error_deg",
        unit="deg",
        what="|true - predicted| of `joint` (every predicted joint) over the run <= max",
        when=When.WHOLE_RUN,
        measure=_prediction_error,
        by_joint=True,
        needs_controller=True,
    ),
    CriterionKind(
        name="task_time_s",
        unit="s",
        what="when the plan's last target was finished (s) lies in min..max; never: fails",
        when=When.PLAN_END,
        measure=_task_time,
        arm_only=True,
        needs_targets=True,
    ),
    CriterionKind(
        name="contact_after_plan_n",
        unit="N",
        what="the brush's peak force on anything after the plan's last target was finished is <= max N (the "
        "arm left leaning on a disc); the plan never finished: fails",
        when=When.PLAN_END,
        measure=_contact_after_plan,
        arm_only=True,
        needs_targets=True,
    ),
)


def as_dicts(verdicts: list[CriterionVerdict]) -> list[dict]:
    return [asdict(v) for v in verdicts]
