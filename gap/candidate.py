"""A candidate of the diagnosis: one catalogue effect, or a pair, as fitted per fold and on all
runs, with its residuals on the withheld runs; and the fits' candidates together (`Fits`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gap.result import Timing


@dataclass
class Candidate:
    name: str  # effect name, or "a+b" for a pair
    effects: list[str]
    fold_values: list[list[float]]  # per fold, fitted value of each effect
    full_values: list[float]  # fitted on all runs
    heldout: list[np.ndarray] = field(default_factory=list)  # per run: withheld angle residual (rad)
    heldout_p: list[np.ndarray] = field(
        default_factory=list
    )  # per run: withheld pressure residual (Pa; empty where not measured)
    fold_latencies: list[float] = field(default_factory=list)  # per fold, the instrument latency fitted with it (s)
    latency_s: float = 0.0  # fitted with the full values on all runs
    # singles only: the values replayed, each one's residual vector over all runs
    # (gap.campaign_replay.CampaignReplay.run_sses_and_residual) and its objective per run at every
    # latency of the grid, and the residual vector at the full value
    grid_values: np.ndarray | None = None
    grid_residuals: np.ndarray | None = None
    grid_sses: np.ndarray | None = None
    full_residual: np.ndarray | None = None
    spread: np.ndarray | None = (
        None  # per run, the twin's own spread at the full values (CampaignReplay.spread; when asked)
    )


@dataclass
class Fits:
    """The candidates, each sorted by held-out score, and the wall time of their stages."""

    singles: list[Candidate]
    pairs: list[Candidate]
    skipped: list[str]  # catalogue effects already in the nominal twin
    timing: Timing
