"""What a run records, as columns: the signals every log and plot reads.

A run appends one sample per log period; recorders (rerun, MCAP) and the gap diagnosis read the
columns in bulk. Names carry units; angles in rad, pressures absolute Pa unless `gauge`.
"""

from __future__ import annotations

import numpy as np

# signal name -> shape of one sample, given n joints and b bodies ("n", "b" are placeholders)
SIGNALS: dict[str, tuple] = {
    "true_angle_rad": ("n",),  # drive-coordinate angle the plant really has
    "predicted_angle_rad": ("n",),  # what the controller's predictor believes
    "target_angle_rad": ("n",),  # the controller's current set point (NaN: none)
    "pressure_a_pa": ("n",),  # motor chamber A
    "pressure_b_pa": ("n",),  # motor chamber B
    "valve_gauge_pa": ("n",),  # proportional valve pressure as its sensor reads it
    "direction": ("n",),  # direction valve command (-1, 0, +1)
    "brake_release": ("n",),  # brake release command (0/1)
    "brake_engagement": ("n",),  # brake's true engagement (0 released .. 1 holding)
    "supply_pa": (),  # supply pressure
    "brush_force_n": (),  # normal force of the brush on the insulator discs
    "body_pos_m": ("b", 3),  # world position of each body
    "body_quat_wxyz": ("b", 4),  # world orientation of each body
}


class Telemetry:
    """Column buffers for one run: one preallocated float64 array per signal, doubled when full,
    so a long run holds its record at 8 bytes per value and nothing more."""

    def __init__(self, joints: tuple[str, ...], bodies: tuple[str, ...], capacity: int = 1024):
        self.joints, self.bodies = tuple(joints), tuple(bodies)
        n, b = len(self.joints), len(self.bodies)
        self._dims = {name: tuple(n if d == "n" else b if d == "b" else d for d in shape) for name, shape in SIGNALS.items()}
        self._n = 0
        self._time = np.empty(capacity)
        self._cols = {name: np.empty((capacity,) + dims) for name, dims in self._dims.items()}

    def append(self, time_s: float, sample: dict[str, np.ndarray]) -> None:
        if self._n == len(self._time):
            self._time = np.resize(self._time, 2 * self._n)
            self._cols = {k: np.concatenate([v, np.empty_like(v)]) for k, v in self._cols.items()}
        self._time[self._n] = time_s
        for name, col in self._cols.items():
            col[self._n] = sample[name]
        self._n += 1

    def __len__(self) -> int:
        return self._n

    @property
    def time_s(self) -> np.ndarray:
        """Sample times so far (a read-only view)."""
        v = self._time[: self._n]
        v.flags.writeable = False
        return v

    def arrays(self, start: int = 0) -> dict[str, np.ndarray]:
        """Columns from sample `start` on as arrays (copies), with "time_s" among them."""
        out = {"time_s": self._time[start : self._n].copy()}
        for name, col in self._cols.items():
            out[name] = col[start : self._n].copy()
        return out
