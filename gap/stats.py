"""The diagnosis's statistics over runs: rms of residuals, misfit in units of the floors, and
bootstrap intervals that resample whole runs (scipy.stats.bootstrap, percentile method, with the
diagnosis's seeded generator)."""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import bootstrap

N_BOOT = 1000  # resamples of an interval unless a caller asks for fewer


def rms_deg(residuals: list[np.ndarray]) -> float:
    return float(np.rad2deg(math.sqrt(np.mean(np.concatenate(residuals) ** 2))))


def residual_vector(angle: list[np.ndarray], pressure: list[np.ndarray], pressure_weight: float) -> np.ndarray:
    """Runs' residuals as one vector whose squared norm is the fit's objective: per run its angle
    (rad), then its chamber pressures (Pa) x sqrt(pressure_weight)."""
    w = math.sqrt(pressure_weight)
    return np.concatenate([np.r_[a, w * p] for a, p in zip(angle, pressure, strict=True)] or [np.zeros(0)])


def rms_beyond_deg(residuals: list[np.ndarray], spread_rad: np.ndarray) -> float:
    """What `residuals` (per run, rad) leave beyond each run's own spread (rad), as an rms in deg:
    per run its mean square less the spread's square, not below 0, weighted by its samples."""
    n = np.array([r.size for r in residuals], dtype=float)
    ms = np.array([np.mean(r**2) if r.size else 0.0 for r in residuals])
    return float(np.rad2deg(math.sqrt(np.sum(n * np.maximum(ms - spread_rad**2, 0.0)) / max(np.sum(n), 1.0))))


def rms_kpa(residuals: list[np.ndarray]) -> float | None:
    """Pressure residual rms in kPa over the runs that measured it (None if none did)."""
    r = np.concatenate(residuals) if residuals else np.empty(0)
    return float(math.sqrt(np.mean(r**2)) / 1e3) if r.size else None


def _in_floors(angle: np.ndarray, pressure: np.ndarray, floor_deg: float, floor_kpa: float) -> np.ndarray:
    return np.concatenate([np.rad2deg(angle) / floor_deg, pressure / (floor_kpa * 1e3)])


def run_ms(angle: list[np.ndarray], pressure: list[np.ndarray], floor_deg: float, floor_kpa: float) -> np.ndarray:
    """Per run: mean square misfit in units of the floors (angle samples and pressure samples)."""
    return np.array(
        [np.mean(_in_floors(a, p, floor_deg, floor_kpa) ** 2) for a, p in zip(angle, pressure, strict=True)]
    )


def run_ms_beyond(
    angle: list[np.ndarray], pressure: list[np.ndarray], spread_rad: np.ndarray, floor_deg: float, floor_kpa: float
) -> np.ndarray:
    """Per run: what its mean square misfit in floors (as `run_ms`) leaves beyond what a true model's
    would: in each channel, its mean square less the floor's (1) and, in the angle, less the run's
    own spread's square (rad; `rms_beyond_deg`), not below 0, weighted by the channels' samples."""
    out = []
    for a, p, s in zip(angle, pressure, spread_rad, strict=True):
        ms_a = float(np.mean((np.rad2deg(a) / floor_deg) ** 2)) if a.size else 0.0
        ms_p = float(np.mean((p / (floor_kpa * 1e3)) ** 2)) if p.size else 0.0
        beyond_a = max(ms_a - 1.0 - (math.degrees(s) / floor_deg) ** 2, 0.0)
        out.append((a.size * beyond_a + p.size * max(ms_p - 1.0, 0.0)) / max(a.size + p.size, 1))
    return np.array(out)


def normalised_rms(angle: list[np.ndarray], pressure: list[np.ndarray], floor_deg: float, floor_kpa: float) -> float:
    """rms misfit of all samples, angle and pressure, each in units of its own floor."""
    misfit = np.concatenate([_in_floors(a, p, floor_deg, floor_kpa) for a, p in zip(angle, pressure, strict=True)])
    return float(math.sqrt(np.mean(misfit**2)))


def bootstrap_ci(
    values_per_run: list[np.ndarray], rng: np.random.Generator, n_boot: int = N_BOOT, root: bool = False
) -> tuple[float, float]:
    """95% interval of the mean of the concatenated samples (its square root with `root`: an rms
    from squared values), resampling whole runs with replacement."""
    n = len(values_per_run)
    if n == 0:
        return (math.nan, math.nan)
    sums = np.array([float(np.sum(v)) for v in values_per_run])
    counts = np.array([len(v) for v in values_per_run])

    def pooled_mean(s: np.ndarray, c: np.ndarray, axis: int = -1) -> np.ndarray:
        m = s.sum(axis=axis) / np.maximum(c.sum(axis=axis), 1)
        return np.sqrt(m) if root else m

    if n == 1:  # one run: every resample is that run (scipy needs two observations)
        v = float(pooled_mean(sums, counts))
        return v, v
    ci = bootstrap(
        (sums, counts), pooled_mean, n_resamples=n_boot, paired=True, vectorized=True, method="percentile", rng=rng
    ).confidence_interval
    return float(ci.low), float(ci.high)


def rms_ci_deg(residuals: list[np.ndarray], rng: np.random.Generator) -> tuple[float, float]:
    return bootstrap_ci([np.rad2deg(r) ** 2 for r in residuals], rng, 300, root=True)


def mean_lower_bound(values: np.ndarray, rng: np.random.Generator, n_boot: int = 400) -> float:
    """One-sided 95% lower bound of the mean of `values` (one per run), resampling runs."""
    if len(values) < 2:  # one run: every resample is that run
        return float(np.mean(values)) if len(values) else math.nan
    ci = bootstrap(
        (values,), np.mean, n_resamples=n_boot, vectorized=True, method="percentile", alternative="greater", rng=rng
    ).confidence_interval
    return float(ci.low)
