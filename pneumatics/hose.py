"""The air hoses between the platform and the arm: their friction law and a line's response.

The friction law (paper eq. 1-4, Darcy-Weisbach with Blasius' and Hagen-Poiseuille's factors)
lives in pneumatics/darcy.py and is re-exported here; the hose as a line with gas inertia, which
carries pressure waves, in pneumatics/line.py. `line_response` is the user's way to size a line.
"""

from __future__ import annotations

import math

import numpy as np

from pneumatics import gas_line as _line
from pneumatics.darcy import (
    BLASIUS_LAMINAR_RE,
    friction_factor,
    hose_constants,
    hose_mass_flow,
    hose_mass_flow_with,
    hose_pressure_drop,
    hose_resistance_with,
    hose_volume,
    reynolds_number,
)
from pneumatics.gas import AIR
from pneumatics.line_series import GAS_LINE, far_end_series

__all__ = [
    "BLASIUS_LAMINAR_RE",
    "friction_factor",
    "hose_constants",
    "hose_mass_flow",
    "hose_mass_flow_with",
    "hose_pressure_drop",
    "hose_resistance_with",
    "hose_volume",
    "line_response",
    "reynolds_number",
]

LINE_STEP_S = 0.5e-3  # `line_response`'s longest step (the line sub-steps it at its Courant number)


def line_response(
    length_m: float,
    bore_m: float,
    end_volume_m3: float,
    times_s: np.ndarray,
    inlet_pa: np.ndarray,
    temperature_k: float,
) -> np.ndarray:
    """Far-end pressure (Pa, absolute) at `times_s` of an air line with gas inertia and wall friction
    (pneumatics/gas_line.py) whose inlet pressure follows `inlet_pa` (Pa absolute, sampled at `times_s`,
    linear between samples) and whose far end is closed by a rigid volume `end_volume_m3`; the line
    starts at rest at inlet_pa[0], its gas at `temperature_k`, air of pneumatics.gas.AIR.

    Raises ValueError naming the argument, its value and what is allowed.
    """
    times = np.asarray(times_s, dtype=float)
    inlet = np.asarray(inlet_pa, dtype=float)
    _check_line_arguments(length_m, bore_m, end_volume_m3, times, inlet, temperature_k)
    c = _line.wave_speed(temperature_k, AIR.r_j_per_kg_k, AIR.k)
    cells = max(LINE_RESPONSE_MIN_CELLS, _line.segments_for(length_m, c, LINE_RESPONSE_BAND_HZ))
    row = _line.line_row(length_m, bore_m, temperature_k, AIR.r_j_per_kg_k, AIR.k, AIR.mu_pa_s, cells)
    return far_end_series(GAS_LINE, row, end_volume_m3, times, inlet, LINE_STEP_S)


# `line_response`'s grid, finer than the plant's (it runs offline): within ~0.005 bar rms of a grid
# four times as fine on 1-8 m steps of 3 and 7 bar (docs/air_lines.md, grid convergence)
LINE_RESPONSE_BAND_HZ = 200.0
LINE_RESPONSE_MIN_CELLS = 60
LINE_LENGTH_M = (0.3, 100.0)  # the lengths the line is checked over (docs/air_lines.md)
LINE_BORE_M = (1.0e-3, 50.0e-3)  # and the bores
LINE_TEMPERATURE_K = (200.0, 400.0)  # air as an ideal gas of constant viscosity (pneumatics.gas.AIR)


def _check_line_arguments(
    length_m: float, bore_m: float, end_volume_m3: float, times: np.ndarray, inlet: np.ndarray, temperature_k: float
) -> None:
    # `line_response`'s arguments, each against what is allowed, in the order of the signature
    for name, value, (low, high) in (
        ("length_m", length_m, LINE_LENGTH_M),
        ("bore_m", bore_m, LINE_BORE_M),
        ("temperature_k", temperature_k, LINE_TEMPERATURE_K),
    ):
        if not low <= value <= high:
            raise ValueError(f"line_response: {name} = {value!r} is outside {low:g}-{high:g}")
    if not (math.isfinite(end_volume_m3) and end_volume_m3 >= 0.0):
        raise ValueError(f"line_response: end_volume_m3 = {end_volume_m3!r} must be finite and >= 0 (m^3)")
    if times.ndim != 1 or times.size < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0.0):
        raise ValueError(
            f"line_response: times_s (shape {times.shape}) must be a 1-D array of at least 2 finite, strictly "
            "increasing times (s)"
        )
    if inlet.shape != times.shape or not np.all(np.isfinite(inlet)) or np.any(inlet <= 0.0):
        raise ValueError(
            f"line_response: inlet_pa (shape {inlet.shape}, min {np.min(inlet) if inlet.size else None!r}) must be "
            f"finite absolute pressures > 0 Pa, one per time of times_s (shape {times.shape})"
        )
