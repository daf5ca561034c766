"""The family call's free-form fit: how well each catalogue family, in any shape its members can
take, fits the gap on withheld runs.

A family's effects move the twin in a few characteristic ways: the corrections (twin with the
effect at a value minus the nominal twin) that its members make at every value the single fits
replayed (gap.diagnose.fit_single keeps them). The leading principal shapes of those corrections
(at most MAX_SHAPES, the ones that carry ENERGY of them) are the family's free-form basis: any
linear mix of them is a form the family could take, including forms the catalogue does not list
(Stribeck friction is roughly Coulomb plus a negative viscous term; a valve lag a spread of dead
times). The gap is fitted by least squares on each fold's training runs and scored on its withheld
runs, so a family whose shapes only fit by chance gains nothing. The corrections are the twin's
own, not the measurements: no withheld sample enters the basis. No replay is made here.

Which families the where-profile leaves in the running (`where_eligible`) is told by the profile's
own uncertainty, not by a slack on the misfit: the runs are resampled with replacement and a family
stays eligible unless its where-profile misfit is worse than the best family's in 95 % of the
resamples (one-sided), the same test over runs as a candidate's rivals (gap.verdict).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

MAX_SHAPES = 3  # the same cap for every family: a family with more members gains no more freedom
ENERGY = 0.999  # shapes kept until they carry this fraction of the corrections' energy
N_BOOT = 200  # resamples of the runs for where_eligible


@dataclass(frozen=True)
class FamilyFit:
    """A family's free-form fit: held-out SSE of the gap after it (in the fit's units), the
    number of shapes used, the fitted correction on all runs (a residual vector's layout), and the
    fraction of the gap's where-profile its shapes leave unexplained (`profile_misfit`)."""

    heldout_sse: float
    shapes: int
    correction: np.ndarray
    where_misfit: float


def shapes(corrections: np.ndarray) -> np.ndarray:
    """The leading principal shapes (rows) of a family's corrections (values x samples)."""
    c = corrections[np.linalg.norm(corrections, axis=1) > 0]
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


def fit(
    basis: np.ndarray, gap: np.ndarray, folds: list[tuple[np.ndarray, np.ndarray]], angle: np.ndarray, profile
) -> FamilyFit:
    """`gap` (a residual vector) fitted by the rows of `basis` on each fold's training samples
    (bool masks), scored on its withheld samples; the correction fitted on every sample; the
    where-profile misfit over the angle samples (`angle`, a bool mask; `profile` their matrix)."""
    where_misfit = profile_misfit(basis[:, angle], gap[angle], profile)
    if len(basis) == 0:
        return FamilyFit(float(sum(np.sum(gap[te] ** 2) for _, te in folds)), 0, np.zeros_like(gap), where_misfit)
    sse = 0.0
    for tr, te in folds:
        a, *_ = np.linalg.lstsq(basis[:, tr].T, gap[tr], rcond=None)
        sse += float(np.sum((gap[te] - basis[:, te].T @ a) ** 2))
    a, *_ = np.linalg.lstsq(basis.T, gap, rcond=None)
    return FamilyFit(sse, len(basis), basis.T @ a, where_misfit)


def family_fits(
    bases: dict[str, np.ndarray],
    gap: np.ndarray,
    folds: list[tuple[np.ndarray, np.ndarray]],
    angle: np.ndarray,
    profile: np.ndarray,
) -> dict[str, FamilyFit]:
    """Per family, its free-form fit; `bases` maps a family to its shapes (`shapes` of its members'
    corrections)."""
    return {f: fit(b, gap, folds, angle, profile) for f, b in bases.items()}


def where_eligible(
    bases: dict[str, np.ndarray],
    gap: np.ndarray,
    profile_of: Callable[[np.ndarray | None], np.ndarray],
    run_of: np.ndarray,
    rng: np.random.Generator,
    n_boot: int = N_BOOT,
) -> list[str]:
    """The families (keys of `bases`, each its shapes over the angle samples) whose where-profile
    misfit is not clearly worse than the least any family leaves on all runs: the one-sided 95 %
    lower bound of the difference, over resamples of the runs (`run_of`: each angle sample's run;
    `profile_of(weights)`: the profile matrix with each sample counted by its weight), is <= 0."""
    names = list(bases)

    def misfits(weights):
        profile = profile_of(weights)
        return np.array([profile_misfit(bases[f], gap, profile) for f in names])

    best = int(np.argmin(misfits(None)))
    n_runs = int(run_of.max()) + 1 if run_of.size else 0
    if n_runs < 2:
        return names
    boot = np.array(
        [misfits(np.bincount(rng.integers(0, n_runs, n_runs), minlength=n_runs)[run_of]) for _ in range(n_boot)]
    )
    lower = np.quantile(boot - boot[:, [best]], 0.05, axis=0)
    return [f for f, lo in zip(names, lower, strict=True) if lo <= 0.0]
