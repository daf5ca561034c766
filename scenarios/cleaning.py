"""What the brush did to each insulator disc, from MuJoCo's contacts as the run logged them.

Every telemetry sample carries the brush's contact force (the sum of the normal forces of its
contacts, `mj_contactForce`) and the force-weighted contact point (twin/sim.py `brush_contact`).
The brush can touch only the discs (contype/conaffinity, assets/arm.xml and scene.xml), and the
discs are 10 cm or more apart with a 2 cm rim, so a contact point belongs to the disc whose shell
holds it (in the disc's own frame: the string may stand turned or leaning, scenarios/string.py).
Per disc:

    contact_s   the longest unbroken stretch with the force above CONTACT_N (s)
    peak_n      the largest force while touching it (N), at the physics rate: each sample's peak over
                the physics steps since the previous one (`brush_peak_n`, twin/plant.py) counts for
                the disc touched at either end of that stretch
    mean_n      the mean force over the samples above CONTACT_N (N)
    brushed_m   the length of rim the brush's face covered while pressing (m): the union, over
                those samples, of the arcs the face's width spans (a chord of its diameter) centred on the contact point
    rim_share   the share of the rim's circumference (0..1) the face went over with the force in the
                working band (BAND_N): the union of those arcs, over the samples in band whose contact
                lies on the rim (the shell's side), against 2 pi r
    top_share   the share of the top face (0..1: the annulus from the cap's edge to the rim) the face
                went over in band: the face's disc (its radius) laid around each such contact on the
                top face, the cells of a polar grid of the annulus it covers (TOP_CELLS_*)

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
# the brush's working band (N): above the head's 10 N preload with some stroke, below its 50 N
# bottom-out (assets/arm.xml; the shipped scenario's disc_force_n criterion)
BAND_N = (15.0, 55.0)
# the cap's radius (m): the top face is the shell's annulus outside it (assets/scene.xml, disc_cap)
CAP_RADIUS_M = 0.04
TOP_CELLS_RADIAL, TOP_CELLS_AROUND = 18, 160  # the top face's grid: ~5 mm rings, 2.25 deg sectors
# a contact is on the top face where it lies this near the face's plane, inside the rim's edge (m):
# the force-weighted point of a face lying on it is within the contact's penetration of it
FACE_MARGIN_M = 0.005


@dataclass(frozen=True)
class DiscContact:
    disc: int
    contact_s: float
    peak_n: float
    mean_n: float
    brushed_m: float
    rim_share: float = 0.0
    top_share: float = 0.0


def physics_force_n(arrays: dict[str, np.ndarray]) -> np.ndarray:
    """Per sample, the brush's largest contact normal force over the physics steps up to it (N): the
    logged peak (`brush_peak_n`), never below the sample's own force; a log written before the peak
    was logged (NaN) has only the sample's."""
    force = arrays["brush_force_n"]
    peak = arrays.get("brush_peak_n")
    return force if peak is None else np.fmax(force, peak)


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


def _top_share(radial: np.ndarray, azimuth: np.ndarray, face_radius_m: float, rim_m: float) -> float:
    """The share of the top face's annulus (CAP_RADIUS_M..rim_m) within face_radius_m of any of the
    contact points (radial distance and azimuth on the face), on a polar grid of cell centres."""
    if radial.size == 0:
        return 0.0
    edges = np.linspace(CAP_RADIUS_M, rim_m, TOP_CELLS_RADIAL + 1)
    r = 0.5 * (edges[1:] + edges[:-1])
    a = (np.arange(TOP_CELLS_AROUND) + 0.5) * 2 * math.pi / TOP_CELLS_AROUND
    cells = np.stack([np.outer(r, np.cos(a)).ravel(), np.outer(r, np.sin(a)).ravel()], axis=1)
    weight = np.repeat(r, TOP_CELLS_AROUND)  # a cell's area grows with its radius
    points = np.stack([radial * np.cos(azimuth), radial * np.sin(azimuth)], axis=1)
    covered = np.zeros(len(cells), dtype=bool)
    for chunk in np.array_split(points, max(1, len(points) // 256)):
        d2 = np.sum((cells[:, None, :] - chunk[None, :, :]) ** 2, axis=2)
        covered |= (d2 <= face_radius_m**2).any(axis=1)
    return float(weight[covered].sum() / weight.sum())


def disc_contacts(model: mujoco.MjModel, arrays: dict[str, np.ndarray], until_s: float = math.inf) -> list[DiscContact]:
    """Per disc, what the brush did to it up to `until_s`, from the run's contact samples."""
    t = arrays["time_s"]
    keep = t <= until_s
    t, force, point = t[keep], arrays["brush_force_n"][keep], arrays["brush_contact_m"][keep]
    peak = physics_force_n(arrays)[keep]
    disc = disc_of_points(model, np.nan_to_num(point, nan=np.inf))
    brush_radius = float(model.geom("brush").size[0])
    out = []
    for k, shell in enumerate(discs_of(model), start=1):
        on = (disc == k) & (force > CONTACT_N)
        here = disc == k
        touched = peak[here | np.concatenate(([False], here[:-1]))]  # the stretch ending at a sample, or after it
        local = (point[on] - shell.centre_m) @ shell.frame()
        azimuth = np.arctan2(local[:, 1], local[:, 0])
        # in the working band: on the rim's side, or lying on the top face
        band = (force[on] >= BAND_N[0]) & (force[on] <= BAND_N[1])
        radial = np.hypot(local[:, 0], local[:, 1])
        on_rim = band & (radial >= shell.radius_m - FACE_MARGIN_M)
        on_top = band & ~on_rim & (np.abs(local[:, 2] - shell.half_thickness_m) <= FACE_MARGIN_M)
        half_width = math.asin(min(1.0, brush_radius / shell.radius_m))
        out.append(
            DiscContact(
                disc=k,
                contact_s=_longest_run_s(on, t),
                peak_n=float(touched.max()) if touched.size else math.nan,
                mean_n=float(force[on].mean()) if on.any() else math.nan,
                brushed_m=_covered_arc_m(azimuth, half_width, shell.radius_m),
                rim_share=_covered_arc_m(azimuth[on_rim], half_width, shell.radius_m) / (2 * math.pi * shell.radius_m),
                top_share=_top_share(radial[on_top], azimuth[on_top], brush_radius, shell.radius_m),
            )
        )
    return out
