"""A line's far-end pressure under a sampled inlet pressure, for either line: the plant's acoustic
line (pneumatics/line.py) and the finite-amplitude gas line behind `pneumatics.hose.line_response`
(pneumatics/gas_line.py). One driver, the line chosen by a flag, so that numba can cache it (a step
function passed as an argument cannot be cached)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pneumatics import gas_line, line
from pneumatics._jit import njit
from pneumatics.line import FarEnd

ACOUSTIC_LINE = 0  # pneumatics/line.py
GAS_LINE = 1  # pneumatics/gas_line.py


class InletSubsteps(NamedTuple):
    """A line's steps under an inlet pressure sampled at given times: per step its length (s), the
    inlet pressure at its start and end (Pa, linear between samples), and the sample whose time it
    ends on (-1 inside a sample's span)."""

    dt_s: np.ndarray
    start_pa: np.ndarray
    end_pa: np.ndarray
    sample: np.ndarray


@njit
def inlet_substeps(times_s: np.ndarray, inlet_pa: np.ndarray, max_dt_s: float) -> InletSubsteps:
    """Each span between samples cut into equal steps of at most `max_dt_s`, the inlet linear across
    it: the stepping `far_end_series` follows."""
    counts = np.empty(times_s.size - 1, dtype=np.int64)
    for i in range(times_s.size - 1):
        counts[i] = max(1, int(math.ceil((times_s[i + 1] - times_s[i]) / max_dt_s - 1e-9)))
    n = int(counts.sum())
    plan = InletSubsteps(np.empty(n), np.empty(n), np.empty(n), np.full(n, -1, dtype=np.int64))
    j = 0
    for i in range(times_s.size - 1):
        steps = counts[i]
        dt = (times_s[i + 1] - times_s[i]) / steps
        for s in range(steps):
            plan.dt_s[j] = dt
            plan.start_pa[j] = inlet_pa[i] + (inlet_pa[i + 1] - inlet_pa[i]) * s / steps
            plan.end_pa[j] = inlet_pa[i] + (inlet_pa[i + 1] - inlet_pa[i]) * (s + 1) / steps
            j += 1
        plan.sample[j - 1] = i + 1
    return plan


@njit
def _initial_state(kind: int, row: np.ndarray, p_pa: float) -> np.ndarray:
    return gas_line.initial_line_state(row, p_pa) if kind == GAS_LINE else line.initial_line_state(row, p_pa)


@njit
def _far_end(kind: int, x: np.ndarray, row: np.ndarray) -> float:
    return gas_line.far_end_pressure(x, row) if kind == GAS_LINE else line.far_end_pressure(x, row)


@njit
def _advance(kind: int, x: np.ndarray, row: np.ndarray, dt_s: float, a_pa: float, b_pa: float, end: FarEnd) -> None:
    if kind == GAS_LINE:
        gas_line.advance_from_pressure(x, row, dt_s, a_pa, b_pa, end)
    else:
        line.advance_from_pressure(x, row, dt_s, a_pa, b_pa, end)


@njit
def far_end_series(
    kind: int, row: np.ndarray, end_volume_m3: float, times_s: np.ndarray, inlet_pa: np.ndarray, max_dt_s: float
) -> np.ndarray:
    """The far end's pressure at `times_s` of a line (`kind`: ACOUSTIC_LINE or GAS_LINE, its `row`
    built by that module), at rest at inlet_pa[0], whose inlet follows `inlet_pa` (linear between
    samples) and whose far end is closed by a rigid `end_volume_m3`; steps of at most `max_dt_s`
    (`pneumatics.hose.line_response` checks the arguments)."""
    x = _initial_state(kind, row, inlet_pa[0])
    end = FarEnd(end_volume_m3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    plan = inlet_substeps(times_s, inlet_pa, max_dt_s)
    out = np.empty(times_s.size)
    out[0] = _far_end(kind, x, row)
    for j in range(plan.dt_s.size):
        _advance(kind, x, row, plan.dt_s[j], plan.start_pa[j], plan.end_pa[j], end)
        if plan.sample[j] >= 0:
            out[plan.sample[j]] = _far_end(kind, x, row)
    return out
