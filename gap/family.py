"""The family call's fits: how well each catalogue family, with its own corrections, fits the gap on
withheld runs, and how much of the gap's where-profile its shapes explain.

A family's effects move the twin in characteristic ways: the corrections (twin with the effect at a
value minus the nominal twin) that its members make at every value the single fits replayed
(gap.single_fits.fit_single keeps them), and for a member the nominal twin already has (the hose loss)
the correction of taking it out, its opposite, and the part at other values (its bore and length:
gap.effects.IN_TWIN_VARIATIONS, replayed); a family may also have a part varied for the call only
(the load's static torque the same at every angle: gap.effects.FAMILY_VARIATIONS, replayed). A
family's fit on withheld runs is its own physics, not an extrapolation: per fold, the member
correction, or the sum of two members' corrections, that fits the training runs best (a form the
catalogue lacks is often close to two of its family's effects at once: Stribeck friction to more
Coulomb and less viscous friction), scored on the withheld runs. The gap and the corrections are
read, per fold, at the instrument latency the family's best correction fits the training runs with
(`fold_latencies`), as each candidate fits its own. A linear mix of a family's
principal shapes, fitted on three supplies and carried to the fourth, was tried first: it left more
of the gap on the withheld runs than it found for nearly every family on the bench's forms (the
mix's coefficients do not carry across supplies when the corrections are far from linear in their
value), so the call rested on chance.

The shapes (at most MAX_SHAPES leading principal shapes of a family's corrections, each correction
counted at unit size so that the largest values replayed do not set them) describe the family's
where-profile: how much of the gap's profile (its mean per bin of supply, load, angle, speed, time
since start, phase and direction) a mix of them explains (`profile_misfit`). The corrections are the
twin's own, not the measurements: no withheld sample enters a fit. No replay is made here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

MAX_SHAPES = 3  # the same cap for every family: a family with more members gains no more freedom
ENERGY = 0.999  # shapes kept until they carry this fraction of the corrections' energy


@dataclass(frozen=True)
class Member:
    """A member's replayed rows: per row the effects added to the nominal twin, the row's residual
    vector at the twin's reference latency (gap.campaign_replay.CampaignReplay.run_sses_and_residual)
    and its objective per run at every latency of the instrument's grid. `mirrored`: the opposite of the first row's
    correction is a row too (for a part the twin already has: more of it, to first order)."""

    effects: list  # per row, [(Effect, value), ...]
    residuals: np.ndarray  # rows x samples
    sses: np.ndarray  # rows x runs x latencies
    mirrored: bool = False

    def corrections(self, gap: np.ndarray, residuals: np.ndarray | None = None) -> np.ndarray:
        """Its corrections (values x samples) of `gap`, from `residuals` read at gap's latency (None:
        its own, at the reference latency)."""
        c = gap[None, :] - (self.residuals if residuals is None else residuals)
        return np.vstack([c, -c[:1]]) if self.mirrored else c


def fold_latencies(members: list[Member], trains: list[list[int]]) -> list[int]:
    """Per fold (its training runs in `trains`), the index of the instrument latency at which the
    family's best replayed row fits the training runs best. The latency is the instrument's nuisance,
    fitted with each hypothesis on its training runs as every candidate fits its own: read at the
    nominal twin's latency, which soaks up part of any gap that runs the twin ahead or behind, a
    family's corrections fit the gap as it looks at a latency the family would not choose (measured:
    a spring resting at 1 rad on staircases read by an encoder, no latency, was read at 45-60 ms,
    and the load family's corrections left 0.37 of the gap on withheld runs there, 0.09 at its own
    latency, 0 ms)."""
    s = np.concatenate([m.sses for m in members])
    return [int(np.argmin(s[:, tr, :].sum(axis=1).min(axis=0))) for tr in trains]


@dataclass(frozen=True)
class Corrections:
    """Per family: its members' corrections (values x samples each) of the gap as read at the
    nominal twin's latency (`reference`, the where-profile's), per fold the same at the latency the
    fold's training runs choose with the family (`fold_latencies`) with the gap read there
    (`per_fold`), and those latencies (s)."""

    reference: dict[str, list[np.ndarray]]
    per_fold: dict[str, list[tuple[list[np.ndarray], np.ndarray]]]
    latency_s: dict[str, list[float]]


@dataclass(frozen=True)
class FamilyFit:
    """A family's fit: the gap left on each withheld sample after its own corrections (`heldout`, a
    residual vector's layout; the gap itself where a sample is never withheld), their SSE (and its
    part on the angle samples), the number of shapes describing it and the fraction of the gap's
    where-profile they leave unexplained (`profile_misfit`)."""

    heldout: np.ndarray
    heldout_sse: float
    heldout_sse_angle: float  # the part of heldout_sse on angle samples (the rest: chamber pressures)
    shapes: int
    where_misfit: float


def shapes(corrections: np.ndarray) -> np.ndarray:
    """The leading principal shapes (rows) of a family's corrections (values x samples), each counted at
    unit size."""
    n = np.linalg.norm(corrections, axis=1)
    c = corrections[n > 0] / n[n > 0, None]
    if len(c) == 0:
        return np.zeros((0, corrections.shape[1]))
    _, s, vt = np.linalg.svd(c, full_matrices=False)
    energy = np.cumsum(s**2) / np.sum(s**2)
    k = min(MAX_SHAPES, int(np.searchsorted(energy, ENERGY) + 1))
    return vt[:k]


def profile_misfit(basis: np.ndarray, gap: np.ndarray, profile: np.ndarray) -> float:
    """How much of the gap's where-profile (`profile` @ gap: gap.where.profile_matrix over the angle
    samples) no mix of the family's shapes' profiles explains, 0..1 (least squares, in-sample:
    the profile has a few dozen bins against at most MAX_SHAPES shapes)."""
    g = profile @ gap
    if len(basis) == 0 or not np.any(g):
        return 1.0
    s = basis @ profile.T
    a, *_ = np.linalg.lstsq(s.T, g, rcond=None)
    return float(np.linalg.norm(g - s.T @ a) / np.linalg.norm(g))


def _superposed_sse(a: np.ndarray, b: np.ndarray | None, g: np.ndarray) -> np.ndarray:
    """|g - a_i - b_j|^2 for every row i of `a` and j of `b` (b None: |g - a_i|^2, one column)."""
    sa = g @ g - 2.0 * (a @ g) + np.sum(a**2, axis=1)
    if b is None:
        return sa[:, None]
    return sa[:, None] + (np.sum(b**2, axis=1) - 2.0 * (b @ g))[None, :] + 2.0 * a @ b.T


def member_fit(
    per_fold: list[tuple[list[np.ndarray], np.ndarray]], gap: np.ndarray, folds: list[tuple[np.ndarray, np.ndarray]]
) -> np.ndarray:
    """The gap left on each fold's withheld samples after the family's best correction on its
    training samples: one member's correction at one of its values, or two members' added
    (`per_fold`: per fold, per member its corrections, values x samples, and the gap they correct,
    both read at the fold's latency); `gap` where never withheld."""
    left = gap.copy()
    for (members, g), (tr, te) in zip(per_fold, folds, strict=True):
        best, correction = math.inf, np.zeros_like(g)
        for i, a in enumerate(members):
            for b in [None, *members[i + 1 :]]:
                s = _superposed_sse(a[:, tr], None if b is None else b[:, tr], g[tr])
                j, k = np.unravel_index(int(np.argmin(s)), s.shape)
                if s[j, k] < best:
                    best, correction = float(s[j, k]), a[j] + (0.0 if b is None else b[k])
        left[te] = g[te] - correction[te]
    return left


def fit(
    reference: list[np.ndarray],
    per_fold: list[tuple[list[np.ndarray], np.ndarray]],
    gap: np.ndarray,
    folds: list[tuple[np.ndarray, np.ndarray]],
    angle: np.ndarray,
    profile,
) -> FamilyFit:
    """`gap` (the nominal twin's residual vector) fitted by the family's own corrections on each
    fold's training samples (bool masks) at the fold's latency (`per_fold`), scored on its withheld
    samples (`member_fit`); the where-profile misfit over the angle samples (`angle`, a bool mask;
    `profile` their matrix) of the shapes of its corrections at the nominal twin's latency
    (`reference`), to `gap`: one target for every family."""
    basis = shapes(np.vstack(reference)) if reference else np.zeros((0, gap.size))
    where_misfit = profile_misfit(basis[:, angle], gap[angle], profile)
    left = member_fit(per_fold, gap, folds) if reference else gap.copy()
    sse = float(sum(np.sum(left[te] ** 2) for _, te in folds))
    sse_angle = float(sum(np.sum(left[te & angle] ** 2) for _, te in folds))
    return FamilyFit(left, sse, sse_angle, len(basis), where_misfit)


def at_least(
    fit: FamilyFit, member_heldout: np.ndarray, folds: list[tuple[np.ndarray, np.ndarray]], angle
) -> FamilyFit:
    """`fit`, or, where it leaves more on the withheld samples, a member's own single fit
    (`member_heldout`: its residual on its withheld runs, a residual vector's layout): choosing on the
    training runs among every correction and sum of two, the family can do worse on withheld runs
    than its best member fitted alone (measured: a lossy gear's friction family 0.37 of the gap
    left, its viscous friction alone 0.21, and the call went to leakage)."""
    sse = float(sum(np.sum(member_heldout[te] ** 2) for _, te in folds))
    if sse >= fit.heldout_sse:
        return fit
    sse_angle = float(sum(np.sum(member_heldout[te & angle] ** 2) for _, te in folds))
    return replace(fit, heldout=member_heldout, heldout_sse=sse, heldout_sse_angle=sse_angle)


def family_fits(
    corrections: Corrections,
    gap: np.ndarray,
    folds: list[tuple[np.ndarray, np.ndarray]],
    angle: np.ndarray,
    profile: np.ndarray,
) -> dict[str, FamilyFit]:
    """Per family, its fit (`fit`) of `gap`, the nominal twin's residual vector."""
    return {f: fit(m, corrections.per_fold[f], gap, folds, angle, profile) for f, m in corrections.reference.items()}
