"""What the brush did to each insulator disc, from MuJoCo's contacts as the run logged them.

Every telemetry sample carries the brush's contact force (the sum of the normal forces of its
contacts, `mj_contactForce`) and the force-weighted contact point (twin/sim.py `brush_contact`).
The brush can touch only the discs (contype/conaffinity, assets/arm.xml and scene.xml), and the
discs are 10 cm or more apart with a 2 cm rim, so a contact point belongs to the disc whose shell
holds it (in the disc's own frame: the string may stand turned or leaning, scenarios/string.py).
Per disc:

    contact_s   the longest unbroken stretch with the force above CONTACT_N (s)
    peak_n      the largest force while touching it (N)
    mean_n      the mean force over the samples above CONTACT_N (N)
    brushed_m   the length of rim the brush's face covered while pressing (m): the union, over
                those samples, of the arcs the face's width spans (a chord of its diameter) centred on the contact point

Nothing here reads the plan: a disc the brush never touched has contact_s 0 and NaN forces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from scenarios.string import Disc, discs_of

N_DISCS = 8  # the shipped scene's string (assets/scene.xml); a scenario's [string] may have another count
# a touch counts above half the head's spring preload (10 N, assets/arm.xml): any press that lifts
# the head off its stop passes it, the contact's first sample of a graze may not
CONTACT_N = 5.0
# a contact point counts for a disc within its shell's half-thickness plus this much (m): the
# force-weighted point of a face pressed on the rim's edge lies within the shell
SHELL_MARGIN_M = 0.01


@dataclass(frozen=True)
class DiscContact:
    disc: int
    contact_s: float
    peak_n: float
    mean_n: float
    brushed_m: float


def disc_of_points(model: mujoco.MjModel, points: np.ndarray) -> np.ndarray:
    """The disc (1..n) whose shell holds each contact point (0: none, or no contact: NaN point)."""
    out = np.zeros(len(points), dtype=int)
    for k, disc in enumerate(discs_of(model), start=1):
        along, radial = _in_disc(disc, points)
        inside = (np.abs(along) <= disc.half_thickness_m + SHELL_MARGIN_M) & (radial <= disc.radius_m + SHELL_MARGIN_M)
        out[inside] = k
    return out


def _in_disc(disc: Disc, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point's height along the disc's axis from its centre, and its distance from the axis."""
    rel = points - disc.centre_m
    with np.errstate(invalid="ignore"):
        along = rel @ disc.axis
        radial = np.linalg.norm(rel - along[:, None] * disc.axis, axis=1)
    return along, radial


def _longest_run_s(mask: np.ndarray, t: np.ndarray) -> float:
    """Duration of the longest run of consecutive True samples (first to last sample, plus one
    sample period, so one sample counts as one period)."""
    if not mask.any():
        return 0.0
    period = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return float(max(t[e] - t[s] for s, e in zip(starts, ends, strict=True)) + period)


def _covered_arc_m(azimuth: np.ndarray, half_width_rad: float, radius_m: float) -> float:
    """Length of the union of arcs [a - w, a + w] on a circle of radius_m."""
    if azimuth.size == 0:
        return 0.0
    if half_width_rad >= math.pi:
        return 2 * math.pi * radius_m
    a = np.sort(np.mod(azimuth, 2 * math.pi))
    gaps = np.diff(np.concatenate((a, [a[0] + 2 * math.pi])))  # between neighbours, around the circle
    covered = 2 * math.pi - np.sum(np.maximum(gaps - 2 * half_width_rad, 0.0))
    return float(covered * radius_m)


def disc_contacts(model: mujoco.MjModel, arrays: dict[str, np.ndarray], until_s: float = math.inf) -> list[DiscContact]:
    """Per disc, what the brush did to it up to `until_s`, from the run's contact samples."""
    t = arrays["time_s"]
    keep = t <= until_s
    t, force, point = t[keep], arrays["brush_force_n"][keep], arrays["brush_contact_m"][keep]
    disc = disc_of_points(model, np.nan_to_num(point, nan=np.inf))
    brush_radius = float(model.geom("brush").size[0])
    out = []
    for k, shell in enumerate(discs_of(model), start=1):
        on = (disc == k) & (force > CONTACT_N)
        touched = force[disc == k]
        local = (point[on] - shell.centre_m) @ shell.frame()
        azimuth = np.arctan2(local[:, 1], local[:, 0])
        out.append(
            DiscContact(
                disc=k,
                contact_s=_longest_run_s(on, t),
                peak_n=float(touched.max()) if touched.size else math.nan,
                mean_n=float(force[on].mean()) if on.any() else math.nan,
                brushed_m=_covered_arc_m(azimuth, math.asin(min(1.0, brush_radius / shell.radius_m)), shell.radius_m),
            )
        )
    return out
