"""Step 3's single fits: each catalogue effect's one bounded parameter fitted on each fold's
training runs and on all runs, scored on each fold's withheld runs; a grid (`effect_grid`), refined
around each fold's best point and then around the best on all runs (`_zoom`), every value replayed
once on all runs so that the folds share the replays, then the vertex of a parabola (`_vertex`)."""

from __future__ import annotations

import numpy as np

from gap.campaign_replay import CampaignReplay
from gap.candidate import Candidate
from gap.effects import Effect


def effect_grid(e: Effect, n: int = 8) -> np.ndarray:
    """The values of effect e a fit starts from: its catalogue value for a switch; else n + 1 points
    over its range, evenly or logarithmically (with 0 first where the range starts at 0)."""
    if e.discrete_value is not None:
        return np.array([e.discrete_value])
    if e.log:
        lo = e.low if e.low > 0 else e.high / 100.0
        g = np.geomspace(lo, e.high, n)
        return np.concatenate([[0.0], g]) if e.low == 0 else g
    return np.linspace(e.low, e.high, n + 1)


def fit_single(replay: CampaignReplay, e: Effect, folds) -> Candidate:
    """Effect e's parameter fitted on each fold's training runs and on all runs, scored on each
    fold's withheld runs. Every replay covers all runs, so the folds share them: a grid, then
    ZOOM_LEVELS refinements inside the bracket of each fold's best point (`_zoom`), then per fold
    the vertex of the parabola through its best point and their neighbours (`_vertex`)."""
    n = len(replay.runs)
    every = list(range(n))
    subsets = [list(train) for train, _ in folds] + [every]
    xs, sses, vecs = _zoom(replay, e, effect_grid(e), subsets)
    heldout: list = [None] * n
    heldout_p: list = [None] * n
    fold_values, fold_lat = [], []
    for train, test in folds:
        v = _vertex(xs, sses[:, train].sum(axis=1).min(axis=1))
        lat, res = replay.fold_residuals([(e, v)], train, test)
        fold_values.append([v])
        fold_lat.append(lat)
        for k, r in res.items():
            heldout[k], heldout_p[k] = r
    full = _vertex(xs, sses.sum(axis=1).min(axis=1))
    full_sse, full_vec = replay.run_sses_and_residual([(e, full)], every)
    return Candidate(
        name=e.name,
        effects=[e.name],
        fold_values=fold_values,
        full_values=[full],
        heldout=heldout,
        heldout_p=heldout_p,
        fold_latencies=fold_lat,
        latency_s=float(replay.latencies[int(np.argmin(full_sse.sum(axis=0)))]),
        grid_values=xs,
        grid_residuals=vecs,
        grid_sses=sses,
        full_residual=full_vec,
    )


ZOOM_LEVELS = 3  # refinements of the grid around each fold's best point (the folds share the replays)
ZOOM_POINTS = 4  # new points per refinement, evenly inside the bracket of the best point's neighbours


def _zoom(replay: CampaignReplay, e: Effect, grid: np.ndarray, subsets: list[list[int]]):
    """Effect e on `grid`, refined around the best point of each subset of runs once, then
    ZOOM_LEVELS - 1 times around the last subset's (all runs): (values ascending, SSE per value, run
    and latency, residual vector per value). Each value is replayed once on all runs; brackets the
    subsets share cost one set of points."""
    every = list(range(len(replay.runs)))
    xs = list(grid)
    evals = [replay.run_sses_and_residual([(e, v)], every) for v in xs]
    if e.discrete_value is not None:
        return np.asarray(xs), np.array([s for s, _ in evals]), np.array([r for _, r in evals])
    tol = 1e-9 * (e.high - e.low)
    for level in range(ZOOM_LEVELS):
        if level == 1:  # the folds agree where the effect fits; where it does not, precision is moot
            subsets = subsets[-1:]
        order = np.argsort(xs)
        xa, sa = np.asarray(xs)[order], np.array([evals[i][0] for i in order])
        new: list[float] = []
        for idx in subsets:
            j = int(np.argmin(sa[:, idx].sum(axis=1).min(axis=1)))
            lo, hi = xa[max(j - 1, 0)], xa[min(j + 1, len(xa) - 1)]
            for v in np.linspace(lo, hi, ZOOM_POINTS + 2)[1:-1]:
                if min(abs(v - x) for x in [*xs, *new]) > tol:
                    new.append(float(v))
        xs += new
        evals += [replay.run_sses_and_residual([(e, v)], every) for v in new]
    order = np.argsort(xs)
    return (
        np.asarray(xs)[order],
        np.array([evals[i][0] for i in order]),
        np.array([evals[i][1] for i in order]),
    )


def _vertex(xs: np.ndarray, s: np.ndarray) -> float:
    """The minimum of the parabola through the best of the points (xs ascending, values s) and
    its two neighbours, kept between them; the best point itself at an end of the range."""
    j = int(np.argmin(s))
    if j == 0 or j == len(xs) - 1:
        return float(xs[j])
    (x0, x1, x2), (y0, y1, y2) = xs[j - 1 : j + 2], s[j - 1 : j + 2]
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    if den == 0.0:
        return float(x1)
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    return float(np.clip(x1 - 0.5 * num / den, x0, x2))
