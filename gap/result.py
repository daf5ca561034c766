"""What a diagnosis returns: where the twin departs (gap.where.Breakdown), which effect explains it
(`Which`), how far the gap shrinks on withheld runs (`how_far`), and the facts of the run and the
campaign the report needs. `to_json` writes it as diagnosis.json: the dataclasses are the one
source of its keys."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, is_dataclass
from pathlib import Path

import numpy as np

from gap.instrument import InstrumentFacts
from gap.kinds import Family, Verdict
from gap.verdict import OMIT_NONE, FamilyCall, FamilyEvidence, Refusal
from gap.where import Breakdown

PRIVATE = {"private": True}  # kept in memory for the plots, not written to diagnosis.json


@dataclass(frozen=True)
class TwinFacts:
    hose_loss: bool
    inertia_kg_m2: float  # the nominal twin's joint-side inertia


@dataclass(frozen=True)
class NoiseFloor:
    """The angle's floor: instrument noise, drift between repeats and the twin's tolerance (deg)."""

    measurement_deg: float
    measurement_from: str  # "declared" or "repeats"
    repeat_noise_deg: float  # nan without repeats
    repeat_drift_deg: float  # nan without repeats
    repeat_pairs: int
    repeat_samples: int
    model_tolerance_deg: float
    floor_deg: float
    significance_threshold_deg: float


@dataclass(frozen=True)
class PressureFloor:
    """The chamber pressures' floor (kPa), where the campaign measured them."""

    measured: bool
    noise_kpa: float | None = field(default=None, metadata=OMIT_NONE)
    drift_kpa: float | None = field(default=None, metadata=OMIT_NONE)
    model_tolerance_kpa: float | None = field(default=None, metadata=OMIT_NONE)
    floor_kpa: float | None = field(default=None, metadata=OMIT_NONE)
    before_rms_kpa: float | None = field(default=None, metadata=OMIT_NONE)
    significance_threshold_kpa: float | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class CandidateSummary:
    """A candidate (one effect, or a pair "a+b") as fitted and scored on withheld runs."""

    name: str
    effects: list[str]
    labels: list[str]
    families: list[Family]
    fields: list[str]  # the JointParams (or rig) field of each effect
    nominal_values: list[float]
    fitted_values: list[float]  # fitted on all runs
    fold_values: list[list[float]]  # per fold, each effect's value
    at_bound: list[str | None]  # per effect: "low"/"high" when on a catalogue bound
    off_nominal: list[bool]
    latency_s: float  # the instrument latency fitted with it
    heldout_rms_deg: float
    heldout_pressure_rms_kpa: float | None  # None when no run measured pressures
    score_in_floors: float  # the ranking's key
    heldout_rms_ci95_deg: tuple[float, float]
    shrink: float  # held-out rms / the nominal twin's
    explains: bool
    # the held-out angle rms beyond the twin's own spread on each run (gap.verdict.Judge.beyond_spread_deg),
    # where the rms alone was over the bar
    heldout_beyond_spread_deg: float | None = field(default=None, metadata=OMIT_NONE)
    spread_deg: list[float] | None = field(default=None, metadata=OMIT_NONE)  # per run, the twin's own spread


@dataclass(frozen=True)
class Which:
    """The verdict, the answer and the candidates behind it (rules: gap.verdict)."""

    verdict: Verdict
    top: CandidateSummary | None
    rivals: list[str]
    pairs_refused: list[Refusal]
    nearest: FamilyCall | None  # the family-level answer, for the verdicts that name one (Verdict.names_family)
    families: list[FamilyEvidence]
    ranking: list[CandidateSummary]  # singles, best first
    pairs: list[CandidateSummary]
    skipped_already_in_twin: list[str]


@dataclass(frozen=True)
class PressureError:
    """|error| on the withheld runs at one supply (deg)."""

    mean_deg: float
    max_deg: float
    mean_ci95_deg: tuple[float, float]
    runs: int


@dataclass(frozen=True)
class Timing:
    """Wall time of the fitting stages (s)."""

    singles: float
    pairs: float
    total_fits: float


@dataclass(frozen=True)
class Residuals:
    """Per run: sample times, the nominal twin's residual and the answer's withheld one (rad)."""

    before: list[np.ndarray]
    top: list[np.ndarray] | None
    times: list[np.ndarray]


@dataclass
class Diagnosis:
    campaign: str  # the campaign's folder
    joint: str
    runs: list[str]
    twin: TwinFacts
    folds: str  # how runs were withheld
    instrument: InstrumentFacts
    noise_floor: NoiseFloor
    pressure: PressureFloor
    before_rms_deg: float
    before_rms_ci95_deg: tuple[float, float]
    where: Breakdown
    which: Which
    # how far: model ("before" for the nominal twin, else a candidate's name) -> supply "0.50" -> error
    how_far: dict[str, dict[str, PressureError]]
    replays: int
    timing_s: Timing
    windowed: dict[str, float]  # run -> its recorded length, for runs fitted on their first FIT_WINDOW_S only
    residuals: Residuals = field(metadata=PRIVATE, repr=False)
    out: Path | None = field(default=None, metadata=PRIVATE)  # where the report was written

    # the answer in brief, for a notebook (pneumatic_arm_twin.diagnose); diagnosis.json holds the fields only
    @property
    def verdict(self) -> str:
        """explained, ambiguous, outside the catalogue, or no significant gap (`which.verdict`)."""
        return self.which.verdict

    @property
    def effect(self) -> str | None:
        """The effect that explains the gap: the top candidate's name, or None."""
        return self.which.top.name if self.which.top else None

    @property
    def after_rms_deg(self) -> float | None:
        """The held-out rms angle error with the top candidate (`before_rms_deg`: without), or None."""
        return self.which.top.heldout_rms_deg if self.which.top else None

    def ranking(self) -> dict[str, list]:
        """The single-effect candidates, best first, as columns: name, held-out rms, shrink, fitted values."""
        columns = ("name", "heldout_rms_deg", "shrink", "fitted_values", "explains")
        return {k: [getattr(c, k) for c in self.which.ranking] for k in columns}


def to_json(x):
    """`x` as JSON-ready values: dataclasses by their fields (less the private ones), tuples as
    lists, non-finite floats as None."""
    if is_dataclass(x):
        out = {}
        for f in fields(x):
            v = getattr(x, f.name)
            if not (f.metadata.get("private") or (v is None and f.metadata.get("omit_none"))):
                out[f.name] = to_json(v)
        return out
    if isinstance(x, dict):
        return {k: to_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_json(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x
