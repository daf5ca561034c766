"""The reference instrument as a nuisance: what it adds to the residual that is no effect of the arm.

An instrument reads the joint late (a camera's exposure, transport and processing: 10-40 ms),
with a zero offset, at its own rate, and drops samples. A campaign may declare its latency, noise
and rate ([instrument] in campaign.toml). What it does not declare is estimated before any effect
of the arm is looked at, and reported as the instrument's:
  offset   the mean reading before the first command (the joint is braked at its start angle)
           minus the start angle, over all runs: one zero for the campaign's one instrument;
  latency  fitted with every candidate (the nominal twin included) on the same runs as its
           parameters: a shift of the twin's angle in time, searched on LATENCY_GRID_S. Only a
           delay (a reading cannot lead the joint). A latency shifts every event, the braked stops
           included, where a valve's dead time delays only the motions it starts: the joint fit
           tells them apart. The reported latency is the one fitted with the diagnosis's answer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gap.campaign import Campaign, Instrument, MeasuredRun
from gap.noise import sample_period

# 0..60 ms in 5 ms: a camera's 10-40 ms and more than a 30 Hz frame beyond; no wider, for a latency
# also soaks up part of any gap that makes the twin run ahead of the arm
LATENCY_GRID_S = np.round(np.arange(0.0, 0.06 + 1e-9, 0.005), 6)


@dataclass(frozen=True)
class Nuisance:
    offset_rad: float  # subtracted from every reading
    offset_samples: int  # rest samples it was estimated from (0: none, offset 0)
    latencies_s: np.ndarray  # the latency grid the fits search ([declared] if declared)


def first_command_time(run: MeasuredRun) -> float:
    moving = np.nonzero((run.direction != 0) | (run.brake_released > 0.5))[0]
    return float(run.time_s[moving[0]]) if len(moving) else math.inf


def estimate(campaign: Campaign) -> Nuisance:
    rest = []
    for r in campaign.runs:
        m = r.sampled & (r.time_s < first_command_time(r))
        rest.append(r.angle_rad[m] - r.start_rad)
    rest = np.concatenate(rest) if rest else np.empty(0)
    declared = campaign.instrument.latency_s
    grid = np.array([declared]) if declared is not None else LATENCY_GRID_S
    return Nuisance(float(np.mean(rest)) if rest.size else 0.0, int(rest.size), grid)


@dataclass(frozen=True)
class Declared:
    """What campaign.toml's [instrument] declared (None: not declared)."""

    latency_s: float | None
    noise_deg: float | None
    rate_hz: float | None


@dataclass(frozen=True)
class InstrumentFacts:
    """What the diagnosis knows of the instrument: declared, estimated, observed in the files."""

    declared: Declared
    latency_s: float  # the one fitted with the diagnosis's answer (or the declared one)
    latency_estimated: bool
    offset_deg: float
    offset_rest_samples: int
    observed_rate_hz: float
    rate_mismatch: bool  # the observed rate departs from the declared one by more than 5 %
    dropped_samples: int
    samples: int


def describe(instrument: Instrument, nuisance: Nuisance, latency_s: float, runs: list[MeasuredRun]) -> InstrumentFacts:
    """What the diagnosis knows of the instrument: declared, estimated, observed in the files."""
    periods = [sample_period(r.time_s[r.sampled]) for r in runs]
    period = float(np.median(periods))
    expected = sum(int(round((r.time_s[r.sampled][-1] - r.time_s[r.sampled][0]) / period)) + 1 for r in runs)
    got = sum(int(r.sampled.sum()) for r in runs)
    rate = 1.0 / period if period > 0 else math.nan
    return InstrumentFacts(
        declared=Declared(instrument.latency_s, instrument.noise_deg, instrument.rate_hz),
        latency_s=latency_s,
        latency_estimated=instrument.latency_s is None,
        offset_deg=math.degrees(nuisance.offset_rad),
        offset_rest_samples=nuisance.offset_samples,
        observed_rate_hz=rate,
        rate_mismatch=instrument.rate_hz is not None and abs(rate - instrument.rate_hz) > 0.05 * instrument.rate_hz,
        dropped_samples=max(0, expected - got),
        samples=got,
    )
