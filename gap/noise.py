"""The measurement noise floor from repeated runs, and the slow drift between repeats told apart
from it.

Two repeats (same commands, supply, start and load) differ by the instrument's noise on each and
by whatever drifted between them (temperature, supply, a slipping clamp). Only samples both repeats
really have are compared: their common sample times, or, where the two were sampled at different
times, the second interpolated onto the first only inside gaps no longer than its own sample
period (never across a dropped sample). Of the difference d(t):
  noise  sigma = rms(d[i+1] - d[i]) / 2 over consecutive compared samples (white noise on each
         repeat gives var(d) = 2 sigma^2 and var(first difference of d) = 4 sigma^2; a slow drift
         barely changes from one sample to the next);
  drift  = sqrt(max(0, mean(d^2) - 2 sigma^2)): the rms of the part of d that is not noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TIME_MATCH_S = 1e-6  # sample times closer than this are the same sample


@dataclass(frozen=True)
class RepeatNoise:
    sigma: float  # noise rms per sample (the series' unit); nan without repeats
    drift: float  # rms of the slow difference between repeats; nan without repeats
    pairs: int  # repeat pairs compared
    samples: int  # difference samples used


def sample_period(t: np.ndarray) -> float:
    """The instrument's sample period: the median spacing of its samples (dropped ones are gaps)."""
    return float(np.median(np.diff(t))) if len(t) > 1 else math.inf


def shared_difference(ta: np.ndarray, va: np.ndarray, tb: np.ndarray, vb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(times, va - vb) at the samples both series really have; see the module docstring."""
    j = np.clip(np.searchsorted(tb, ta), 0, len(tb) - 1)
    j_prev = np.clip(j - 1, 0, len(tb) - 1)
    nearest = np.where(np.abs(tb[j_prev] - ta) < np.abs(tb[j] - ta), j_prev, j)
    same = np.abs(tb[nearest] - ta) < TIME_MATCH_S
    if same.sum() >= 0.5 * min(len(ta), len(tb)):
        return ta[same], va[same] - vb[nearest[same]]
    # different sample times: interpolate b only between two of its samples no farther apart than
    # 1.5 of its sample periods (a dropped sample leaves a gap of two periods: not bridged)
    hi = np.searchsorted(tb, ta)
    ok = (hi > 0) & (hi < len(tb))
    lo = np.clip(hi - 1, 0, len(tb) - 1)
    hi = np.clip(hi, 0, len(tb) - 1)
    ok &= (tb[hi] - tb[lo]) <= 1.5 * sample_period(tb)
    return ta[ok], va[ok] - np.interp(ta[ok], tb, vb)


def repeat_noise(groups: list[list[int]], series) -> RepeatNoise:
    """Noise and drift over all consecutive repeat pairs in `groups` (lists of run indices that are
    repeats); `series(k) -> (times, values)` gives run k's samples."""
    d2, step2, pairs, n = [], [], 0, 0
    for ks in groups:
        for a, b in zip(ks, ks[1:], strict=False):
            (ta, va), (tb, vb) = series(a), series(b)
            if len(ta) < 3 or len(tb) < 3:
                continue
            t, d = shared_difference(ta, va, tb, vb)
            if len(d) < 3:
                continue
            period = min(sample_period(ta), sample_period(tb))
            consecutive = np.diff(t) <= 1.5 * period
            d2.append(d**2)
            step2.append(np.diff(d)[consecutive] ** 2)
            pairs += 1
            n += len(d)
    if not pairs or not sum(len(s) for s in step2):
        return RepeatNoise(math.nan, math.nan, 0, 0)
    sigma = math.sqrt(np.mean(np.concatenate(step2))) / 2.0
    drift = math.sqrt(max(0.0, float(np.mean(np.concatenate(d2))) - 2.0 * sigma**2))
    return RepeatNoise(sigma, drift, pairs, n)
