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
    "brush_peak_n": (),  # the largest brush_force_n over the physics steps since the previous sample
    "body_pos_m": ("b", 3),  # world position of each body
    "body_quat_wxyz": ("b", 4),  # world orientation of each body
}


class Telemetry:
    """Column buffers for one run: per signal, float64 blocks of a fixed number of samples, a new
    block when the last is full. Nothing is copied or freed while the run grows, so a long run
    holds its record at 8 bytes per value and leaves the allocator no holes (doubling one array
    instead left about twice the record resident after an hour; benchmarks/long_run.py).

    A block is one (samples, width) array whose columns are the signals, "time_s" first and then
    SIGNALS in order, each flattened (`layout`): a sample is one row, which the compiled ticks can
    fill whole (twin/sample_row.py); each signal's columns are read as views of the blocks."""

    def __init__(self, joints: tuple[str, ...], bodies: tuple[str, ...], block: int = 4096):
        self.joints, self.bodies = tuple(joints), tuple(bodies)
        n, b = len(self.joints), len(self.bodies)
        self._dims = {"time_s": ()} | {
            name: tuple(n if d == "n" else b if d == "b" else d for d in shape) for name, shape in SIGNALS.items()
        }
        self.layout: dict[str, slice] = {}
        width = 0
        for name, dims in self._dims.items():
            size = int(np.prod(dims, dtype=int))
            self.layout[name] = slice(width, width + size)
            width += size
        self.width = width
        self._block = block
        self._n = 0
        self._blocks: list[dict[str, np.ndarray]] = []  # per block, each signal's view of its rows
        self._rows: list[np.ndarray] = []  # the blocks, (block, width)

    def _row(self) -> np.ndarray:
        # the next sample's row (a new block when the last is full)
        i = self._n % self._block
        if i == 0:
            rows = np.empty((self._block, self.width))
            self._rows.append(rows)
            self._blocks.append(
                {k: rows[:, sl].reshape((self._block,) + self._dims[k]) for k, sl in self.layout.items()}
            )
        self._n += 1
        return self._rows[-1][i]

    def append(self, time_s: float, sample: dict[str, np.ndarray]) -> None:
        row = self._row()
        row[0] = time_s
        for name in SIGNALS:
            row[self.layout[name]] = np.ravel(sample[name])

    def append_row(self, row: np.ndarray) -> None:
        """Append a sample given as one row of `width` values in `layout`'s order."""
        self._row()[:] = row

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
