"""Where the twin departs: each angle sample labelled by motion phase, supply, direction, load,
angle, speed and time since the first move; the residual broken down by those labels; and the
where-profile, the per-bin means the family call compares (gap.family.profile_misfit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from gap.campaign import MeasuredRun

PHASE_WINDOW_S = 0.3  # start / reversal / braking: this long after the command change
ANGLE_BIN_DEG = 30.0  # the angle (position) factor's bin width


@dataclass(frozen=True)
class Bin:
    """The residual in one bin of a factor (deg), and how many angle samples fell in it."""

    rms_deg: float
    mean_deg: float
    max_abs_deg: float
    n: int


@dataclass(frozen=True)
class Breakdown:
    """The residual per factor, bin label -> Bin (labels sorted as strings)."""

    phase: dict[str, Bin]
    supply_mpa: dict[str, Bin]
    direction: dict[str, Bin]
    load_kg: dict[str, Bin]
    angle_deg: dict[str, Bin]
    speed_rad_s: dict[str, Bin]
    time_since_start_s: dict[str, Bin]

    def by_factor(self) -> dict[str, dict[str, Bin]]:
        return {f: getattr(self, f) for f in FACTORS}


FACTORS = tuple(f.name for f in fields(Breakdown))


def phases(run: MeasuredRun, ts: np.ndarray) -> np.ndarray:
    """Motion phase of each sample from the commands: start, moving, reversal, braking, holding."""
    d = run.direction
    out_idx = np.searchsorted(run.time_s, ts, side="right") - 1
    labels = np.empty(len(ts), dtype=object)
    # walk the command rows once, remembering the last direction change
    t_change = np.zeros(len(d))
    before = np.zeros(len(d))
    tc, prev, lnz = 0.0, 0.0, 0.0
    for i in range(len(d)):
        if i > 0 and d[i] != d[i - 1]:
            tc, prev = run.time_s[i], d[i - 1]
            if d[i - 1] != 0:
                lnz = d[i - 1]
        t_change[i] = tc
        before[i] = prev if prev != 0 else (lnz if d[i] == 0 else prev)
    for j, i in enumerate(np.clip(out_idx, 0, len(d) - 1)):
        since = ts[j] - t_change[i]
        recent = since < PHASE_WINDOW_S and t_change[i] > 0
        if d[i] != 0:
            if recent and before[i] == -d[i]:
                labels[j] = "reversal"
            elif recent:
                labels[j] = "start"
            else:
                labels[j] = "moving"
        else:
            labels[j] = "braking" if recent and before[i] != 0 else "holding"
    return labels


def labels_of(
    run: MeasuredRun, ts: np.ndarray, angle_rad: np.ndarray, speed_rad_s: np.ndarray
) -> dict[str, np.ndarray]:
    """Every factor's label at each sample time `ts` of `run`; angle and speed are the nominal
    twin's at those times (the measured angle would put the instrument's noise into the bins)."""
    idx = np.clip(np.searchsorted(run.time_s, ts, side="right") - 1, 0, len(run.time_s) - 1)
    moving = np.nonzero(run.direction)[0]
    t0 = run.time_s[moving[0]] if len(moving) else 0.0
    ang = np.floor(np.rad2deg(angle_rad) / ANGLE_BIN_DEG) * ANGLE_BIN_DEG
    return {
        "phase": phases(run, ts),
        "supply_mpa": np.array([f"{run.supply_mpa:.2f}"] * len(ts), dtype=object),
        "direction": np.array([{-1.0: "-1", 0.0: "0", 1.0: "+1"}[float(x)] for x in run.direction[idx]], dtype=object),
        "load_kg": np.array([f"{run.payload_kg:g}"] * len(ts), dtype=object),
        "angle_deg": np.array([f"{a:+.0f}..{a + ANGLE_BIN_DEG:+.0f}" for a in ang], dtype=object),
        "speed_rad_s": np.array(["<0.1", "0.1-0.5", "0.5-1", ">1"], dtype=object)[
            np.digitize(np.abs(speed_rad_s), [0.1, 0.5, 1.0])
        ],
        "time_since_start_s": np.array(
            [f"{max(0.0, math.floor((x - t0) / 0.5) * 0.5):.1f}+" if x >= t0 else "before" for x in ts], dtype=object
        ),
    }


def concat_labels(per_run: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {f: np.concatenate([lab[f] for lab in per_run]) for f in FACTORS}


def breakdown(labels: dict[str, np.ndarray], residual_rad: np.ndarray) -> Breakdown:
    """Residual rms, mean and max |.| (deg) and count per bin of each factor."""
    res = np.rad2deg(residual_rad)
    out = {}
    for factor in FACTORS:
        lab = labels[factor]
        out[factor] = {}
        for b in sorted(set(lab), key=str):
            m = lab == b
            out[factor][str(b)] = Bin(
                float(np.sqrt(np.mean(res[m] ** 2))),
                float(np.mean(res[m])),
                float(np.max(np.abs(res[m]))),
                int(m.sum()),
            )
    return Breakdown(**out)


# the factors whose bins make the where-profile of the family call (gap.family.profile_misfit)
PROFILE_BINS = ("supply_mpa", "load_kg", "angle_deg", "speed_rad_s", "time_since_start_s", "phase", "direction")


def profile_bins(labels: dict[str, np.ndarray]) -> np.ndarray:
    """One 0/1 row per bin of each factor that varies (PROFILE_BINS) over the samples: which fall
    in it (a factor that does not vary says nothing about scaling)."""
    rows = []
    for factor in PROFILE_BINS:
        lab = labels[factor]
        bins = sorted(set(lab), key=str)
        if len(bins) >= 2:
            rows += [lab == b for b in bins]
    return np.array(rows, dtype=float).reshape(len(rows), len(next(iter(labels.values()))))


def profile_matrix(labels: dict[str, np.ndarray]) -> np.ndarray:
    """The where-profile as a linear map: one row per bin (`profile_bins`), its samples' mean x
    sqrt(their count), so that profile = matrix @ residual and each bin counts by its samples.
    Signed means: a form that moves the twin ahead in one bin and behind in another keeps that
    pattern."""
    m = profile_bins(labels)
    total = m.sum(axis=1, keepdims=True)
    return np.divide(m, np.sqrt(total), out=np.zeros_like(m), where=total > 0)
