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
    "brush_contact_m": (3,),  # where the brush touches: force-weighted contact point, world (NaN: no contact)
    "brush_push_n": (3,),  # total contact force the brush exerts on what it touches, world frame
    "body_pos_m": ("b", 3),  # world position of each body
    "body_quat_wxyz": ("b", 4),  # world orientation of each body
}


class Telemetry:
    """Column buffers for one run: per signal, float64 blocks of a fixed number of samples, a new
    block when the last is full. Nothing is copied or freed while the run grows, so a long run
    holds its record at 8 bytes per value and leaves the allocator no holes (doubling one array
    instead left about twice the record resident after an hour; benchmarks/long_run.py)."""

    def __init__(self, joints: tuple[str, ...], bodies: tuple[str, ...], block: int = 4096):
        self.joints, self.bodies = tuple(joints), tuple(bodies)
        n, b = len(self.joints), len(self.bodies)
        self._dims = {"time_s": ()} | {
            name: tuple(n if d == "n" else b if d == "b" else d for d in shape) for name, shape in SIGNALS.items()
        }
        self._block = block
        self._n = 0
        self._blocks: list[dict[str, np.ndarray]] = []

    def append(self, time_s: float, sample: dict[str, np.ndarray]) -> None:
        i = self._n % self._block
        if i == 0:
            self._blocks.append({k: np.empty((self._block,) + dims) for k, dims in self._dims.items()})
        cols = self._blocks[-1]
        cols["time_s"][i] = time_s
        for name in SIGNALS:
            cols[name][i] = sample[name]
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def time_at(self, i: int) -> float:
        """Time of sample `i` (negative counts from the end)."""
        k = i + self._n if i < 0 else i
        if not 0 <= k < self._n:
            raise IndexError(f"telemetry sample {i} of {self._n}")
        return float(self._blocks[k // self._block]["time_s"][k % self._block])

    def column(self, name: str, start: int = 0) -> np.ndarray:
        """One signal from sample `start` on, as a new array."""
        first = min(start, self._n) // self._block
        parts = [blk[name] for blk in self._blocks[first:]]
        if not parts:
            return np.empty((0,) + self._dims[name])
        whole = np.concatenate(parts) if len(parts) > 1 else parts[0]
        offset = first * self._block
        return whole[start - offset : self._n - offset].copy()

    @property
    def time_s(self) -> np.ndarray:
        """Sample times so far (a copy)."""
        return self.column("time_s")

    def arrays(self, start: int = 0) -> dict[str, np.ndarray]:
        """Columns from sample `start` on as arrays (copies), with "time_s" among them."""
        return {name: self.column(name, start) for name in self._dims}
