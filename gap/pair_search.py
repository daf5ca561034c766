"""Step 3's pair search, when no single effect brings the gap to the floor: the pairs of the
PAIR_POOL best singles pre-screened by adding their corrections (no replay, `superposed_sse`), the
PAIR_SCREEN best and every pair of the best single screened by replay in-sample (`screened_pairs`,
`screen_pair`), and the best N_PAIRS_CV fitted on all runs by a Nelder-Mead search that follows the
valley of two effects acting alike (`_valley_search`, `full_pair_fit`), refitted per fold from there
(`fold_pair_fit`; the chosen pairs' folds run as one batch of jobs)."""

from __future__ import annotations

import numpy as np
from joblib import delayed
from scipy.optimize import minimize

from gap.campaign_replay import CampaignReplay
from gap.candidate import Candidate
from gap.effects import BY_NAME, Effect
from gap.jobs import stage_bar
from gap.single_fits import effect_grid

N_PAIRS_CV = 3  # pairs given the full cross-validated fit after the in-sample screen
# pairs are formed from the best PAIR_POOL singles (28 pairs, not the 210 of all 21): a pair's
# members each explain part of its gap, so each is expected to rank high alone; a pair of two
# low-ranked singles is not searched. Counted: the full screen was ~70 % of the replays of a
# diagnosis with the pair stage
PAIR_POOL = 8
# of those 28, the replayed screen sees every pair of the best single (the member most likely to be
# one of two effects at work) and the PAIR_SCREEN whose corrections, simply added, fit best
# (superposed_sse: no replay). Adding corrections ignores how two effects interact: a vane leak and
# more Coulomb friction both take torque, and near a stall they take more together than apart. With
# the sum alone, two held-out campaigns of that pair (the paper's 60-degree moves, a
# camera; back-and-forth moves, a camera) ranked it 6th and 7th, unscreened, while its replayed
# screen was 8-10 times lower than any screened pair's: a wrong pair or a single was called
PAIR_SCREEN = 5


# A pair's two parameters are searched by Nelder-Mead in grid-index coordinates (a logarithmic grid
# searched logarithmically) from the best local minima of a coarse 2-D grid. Two effects that act alike
# (leak vs friction) leave a narrow curved valley: a pattern search on halving steps from the grid
# stops on its wall, in-sample worse than the pair's better member alone (on the bench's staircase
# leak + Coulomb pair: 0.136 against the leak's 0.049 and 0.0004 at the true values), while the
# simplex turns along the valley. Budgets of replays per search, counted on that case:
PAIR_EVALS = 60  # the search on all runs (the screen on distinct runs, the full fit)
FOLD_EVALS = 20  # each fold's refit on its training runs, from the full fit's point
FOLD_STEP = 0.1  # its initial simplex, in grid steps: a fold's optimum lies near all runs'
SEARCH_XTOL = 0.01  # in grid steps
PAIR_GRID_POINTS = 5  # the pair's coarse grid, points per effect (`pair_grid`)
PAIR_STARTS = 2  # the search starts from the grid's best local minima, at most this many (`_grid_starts`)


def _valley_search(
    replay: CampaignReplay,
    ea: Effect,
    eb: Effect,
    ga: np.ndarray,
    gb: np.ndarray,
    runs: list[int],
    start,
    step: float,
    evals: int,
) -> tuple[tuple[float, float], float]:
    """Nelder-Mead over the pair's grid-index coordinates (clipped to the grid) from `start`, its
    objective the SSE of `runs` at their best latency; returns (the point, its SSE)."""
    hi = np.array([len(ga) - 1, len(gb) - 1], dtype=float)
    seen: dict[tuple[float, float], float] = {}

    def sse(u) -> float:
        key = tuple(float(x) for x in np.clip(u, 0.0, hi))
        if key not in seen:
            seen[key] = float(replay.run_sses(_pair_at(ea, eb, ga, gb, key), runs).sum(axis=0).min())
        return seen[key]

    u0 = np.clip(np.asarray(start, dtype=float), 0.0, hi)
    simplex = [
        u0,
        u0 + [step if u0[0] + step <= hi[0] else -step, 0.0],
        u0 + [0.0, step if u0[1] + step <= hi[1] else -step],
    ]
    minimize(
        sse,
        u0,
        method="Nelder-Mead",
        options={"initial_simplex": simplex, "maxfev": evals, "xatol": SEARCH_XTOL, "fatol": 0.0},
    )
    best = min(seen, key=seen.get)  # every point tried, the start included
    return best, seen[best]


def _grid_starts(sse: np.ndarray, cols: list[int], n: int = PAIR_STARTS) -> list[tuple[float, float]]:
    """The grid's local minima over runs `cols` (no lower point among its 8 neighbours), best first,
    at most `n`: the starts of the valley search. Two effects acting alike can leave two basins
    (more leak and less friction, or the reverse, both near the data); the grid's best point lies
    in the wrong one as often as not, and the simplex does not cross the ridge between them."""
    s = sse[:, :, cols].sum(axis=2).min(axis=2)
    padded = np.pad(s, 1, constant_values=np.inf)
    neighbours = np.stack(
        [padded[1 + di : 1 + di + s.shape[0], 1 + dj : 1 + dj + s.shape[1]] for di in (-1, 0, 1) for dj in (-1, 0, 1)]
    )
    minima = np.argwhere(s <= neighbours.min(axis=0))
    order = np.argsort(s[minima[:, 0], minima[:, 1]], kind="stable")[:n]
    return [(float(minima[k, 0]), float(minima[k, 1])) for k in order]


def _multi_start_search(
    replay: CampaignReplay,
    ea: Effect,
    eb: Effect,
    ga: np.ndarray,
    gb: np.ndarray,
    runs: list[int],
    sse: np.ndarray,
    cols,
) -> tuple[tuple[float, float], float]:
    """The valley search from each of the grid's best local minima (`_grid_starts` over `cols`),
    the best point found."""
    found = [_valley_search(replay, ea, eb, ga, gb, runs, u, 0.5, PAIR_EVALS) for u in _grid_starts(sse, cols)]
    return min(found, key=lambda x: x[1])


def _pair_at(ea: Effect, eb: Effect, ga: np.ndarray, gb: np.ndarray, u: tuple[float, float]):
    """The pair's effects at grid-index coordinates u (piecewise linear between grid points)."""
    return [
        (ea, float(np.interp(u[0], np.arange(len(ga)), ga))),
        (eb, float(np.interp(u[1], np.arange(len(gb)), gb))),
    ]


def screen_pair(replay: CampaignReplay, a: Candidate, b: Candidate, runs: list[int], n_grid: int = 5) -> float:
    """In-sample SSE of a pair on `runs`: a coarse 2-D grid, then the valley search from its best
    local minima (`_multi_start_search`), so that the ranking does not depend on where the grid happens to
    fall (a grid, not refits from the singles' values alone: an effect fitted alone can be far
    from its value in the pair, having soaked up the other)."""
    ea, eb = BY_NAME[a.name], BY_NAME[b.name]
    ga, gb, sse = pair_grid(replay, a, b, runs, n_grid)
    return _multi_start_search(replay, ea, eb, ga, gb, runs, sse, list(range(len(runs))))[1]


def pair_grid(
    replay: CampaignReplay, a: Candidate, b: Candidate, runs: list[int] | None = None, n_grid: int = PAIR_GRID_POINTS
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SSE of every run on a coarse 2-D grid of the pair's parameters: (grid_a, grid_b,
    sse[i, j, run, latency]).
    A grid rather than coordinate descent from the singles' values: a single effect's value,
    fitted alone, can be far from its value in the pair (it soaks up the other effect)."""
    ea, eb = BY_NAME[a.name], BY_NAME[b.name]
    ga, gb = _grids(ea, eb, n_grid)
    runs = list(range(len(replay.runs))) if runs is None else runs
    sse = np.array([[replay.run_sses([(ea, va), (eb, vb)], runs) for vb in gb] for va in ga])
    return ga, gb, sse


def full_pair_fit(replay: CampaignReplay, a: Candidate, b: Candidate) -> tuple[float, float]:
    """The pair's point (grid-index coordinates) fitted on all runs: the coarse 2-D grid
    (`pair_grid`), then the valley search from its best local minima (`_multi_start_search`)."""
    every = list(range(len(replay.runs)))
    ga, gb, sse = pair_grid(replay, a, b)
    return _multi_start_search(replay, BY_NAME[a.name], BY_NAME[b.name], ga, gb, every, sse, every)[0]


def fold_pair_fit(replay: CampaignReplay, a: Candidate, b: Candidate, full, fold):
    """The pair refitted on a fold's training runs from its point on all runs `full` (a short valley
    search): (its values, the latency its training runs choose, the withheld runs' residuals)."""
    ea, eb = BY_NAME[a.name], BY_NAME[b.name]
    ga, gb = _grids(ea, eb)
    train, test = fold
    u = _valley_search(replay, ea, eb, ga, gb, list(train), full, FOLD_STEP, FOLD_EVALS)[0]
    effects = _pair_at(ea, eb, ga, gb, u)
    lat, res = replay.fold_residuals(effects, train, test)
    return [v for _, v in effects], lat, res


def pair_candidate(replay: CampaignReplay, a: Candidate, b: Candidate, full, per_fold) -> Candidate:
    """The pair's candidate from its point on all runs and its folds' refits (`fold_pair_fit`)."""
    ea, eb = BY_NAME[a.name], BY_NAME[b.name]
    n = len(replay.runs)
    heldout: list = [None] * n
    heldout_p: list = [None] * n
    for _, _, res in per_fold:
        for k, r in res.items():
            heldout[k], heldout_p[k] = r
    (_, va), (_, vb) = _pair_at(ea, eb, *_grids(ea, eb), full)
    return Candidate(
        name=f"{a.name}+{b.name}",
        effects=[a.name, b.name],
        fold_values=[values for values, _, _ in per_fold],
        full_values=[va, vb],
        heldout=heldout,
        heldout_p=heldout_p,
        fold_latencies=[lat for _, lat, _ in per_fold],
        latency_s=replay.latency_of([(ea, va), (eb, vb)], list(range(n))),
    )


def _grids(ea: Effect, eb: Effect, n_grid: int = PAIR_GRID_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """The pair's coarse grids (`pair_grid`'s)."""
    return effect_grid(ea, n_grid), effect_grid(eb, n_grid)


def pair_stage(replay: CampaignReplay, singles: list[Candidate], folds, run_jobs, progress: bool) -> list[Candidate]:
    """Pairs of the PAIR_POOL best singles (`screened_pairs`) screened in-sample (`screen_pair`)
    over one run per distinct command and supply (repeats differ only by measurement noise); the
    best N_PAIRS_CV get the full grid on all runs and the cross-validated fit."""
    combos = screened_pairs(singles[:PAIR_POOL], replay.gap_vector)  # singles come sorted by held-out score
    distinct = sorted({pr.run.signature(): k for k, pr in reversed(list(enumerate(replay.runs)))}.values())
    with stage_bar(len(combos), "gap: pairs", progress):
        screen = run_jobs(delayed(screen_pair)(replay, a, b, distinct) for a, b in combos)
    chosen = [combos[i] for i in np.argsort(screen)[:N_PAIRS_CV]]
    # the full fits, then every pair's folds together: the stage's jobs are not held up by the last
    # pair's folds run one after another
    fulls = run_jobs(delayed(full_pair_fit)(replay, a, b) for a, b in chosen)
    jobs = [(i, fold) for i in range(len(chosen)) for fold in folds]
    refits = run_jobs(delayed(fold_pair_fit)(replay, *chosen[i], fulls[i], fold) for i, fold in jobs)
    return [
        pair_candidate(replay, a, b, full, [r for (j, _), r in zip(jobs, refits, strict=True) if j == i])
        for i, ((a, b), full) in enumerate(zip(chosen, fulls, strict=True))
    ]


def screened_pairs(pool: list[Candidate], gap: np.ndarray) -> list[tuple[Candidate, Candidate]]:
    """The pairs of `pool` (best single first) the replayed screen sees: every pair of the best
    single, and the PAIR_SCREEN pairs whose corrections, simply added, fit `gap` best."""
    combos = [(a, b) for i, a in enumerate(pool) for b in pool[i + 1 :]]
    added = set(np.argsort([superposed_sse(a, b, gap) for a, b in combos], kind="stable")[:PAIR_SCREEN])
    return [c for i, c in enumerate(combos) if c[0] is pool[0] or i in added]


def superposed_sse(a: Candidate, b: Candidate, gap: np.ndarray) -> float:
    """A pair's least misfit over both singles' replayed values with the two corrections simply
    added (no replay): the pre-screen that picks the PAIR_SCREEN pairs the replayed screen sees."""
    da, db = a.grid_residuals - gap, b.grid_residuals - gap  # minus each single's correction
    sse = (
        gap @ gap
        + np.sum(da**2, axis=1)[:, None]
        + np.sum(db**2, axis=1)[None, :]
        + 2.0 * (da @ gap)[:, None]
        + 2.0 * (db @ gap)[None, :]
        + 2.0 * da @ db.T
    )
    return float(sse.min())
