"""What a run records, as columns: the signals every log and plot reads.

A run appends one sample per log period; recorders (rerun, MCAP) and the gap diagnosis read the
columns in bulk. Names carry units; angles in rad, pressures absolute Pa unless `gauge`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

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


@dataclass
class Telemetry:
    """Growable column buffers for one run."""

    joints: tuple[str, ...]
    bodies: tuple[str, ...]
    time_s: list = field(default_factory=list)
    columns: dict[str, list] = field(default_factory=dict)

    def append(self, time_s: float, sample: dict[str, np.ndarray]) -> None:
        self.time_s.append(float(time_s))
        for name in SIGNALS:
            self.columns.setdefault(name, []).append(np.asarray(sample[name], dtype=np.float64).copy())

    def __len__(self) -> int:
        return len(self.time_s)

    def arrays(self, start: int = 0) -> dict[str, np.ndarray]:
        """Columns from sample `start` on as arrays, with "time_s" among them."""
        out = {"time_s": np.asarray(self.time_s[start:], dtype=np.float64)}
        n, b = len(self.joints), len(self.bodies)
        for name, shape in SIGNALS.items():
            dims = tuple(n if s == "n" else b if s == "b" else s for s in shape)
            rows = self.columns.get(name, [])[start:]
            out[name] = np.asarray(rows, dtype=np.float64).reshape((len(rows),) + dims)
        return out
