"""The run loop: controller ticks, plant steps, telemetry samples (DESIGN, "One control tick").

    controller.tick(sensors) --commands--> plant.step x n --> sensors (next tick)
    telemetry: true state from the plant beside the controller's prediction

The loop itself is control/loop.py's `run_ticks` (the paper's experiments run it too), with the
plant's compiled ticks (twin/compiled_loop.py); here it gets MuJoCo's plant, the telemetry and the
recorders.

The controller is anything with `tick(sensors) -> (n_joints, 3) commands`, `predicted_angles()`
and `target_angles()`; it is handed only `plant.sensors()`, never the plant.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np

from control.loop import run_ticks
from control.schedule import Constant, EventSchedule, Schedule
from pneumatics import joint as J
from twin.events import EventTail
from twin.model import SimulationError
from twin.plant import Plant, Sensors
from twin.sample_row import ROW_SIGNALS
from twin.telemetry import Telemetry

CONTROL_PERIOD_S = 1e-3  # the platform PC's control period (issue: "a 1 ms control period")
LOG_PERIOD_S = 0.02  # 50 samples per simulated second (>= 30 frames/s for playback)


class Controller(Protocol):
    def tick(self, sensors: Sensors) -> np.ndarray: ...
    def predicted_angles(self) -> np.ndarray: ...
    def target_angles(self) -> np.ndarray: ...


class Recorder(Protocol):
    """A log writer. One that also has `write_events(events: list[twin.events.Event])` is given
    the controller's and operator's reports as they come (rerun's text log, foxglove.Log)."""

    def write(self, telemetry: Telemetry, start: int) -> None: ...
    def close(self) -> None: ...


@dataclass
class CommandSchedule:
    """A controller that replays commands given as functions of time (open loop, no prediction):
    the gap diagnosis replays measured runs with it, tests drive the plant with it."""

    commands_at: Callable[[float], np.ndarray]
    n_joints: int

    def tick(self, sensors: Sensors) -> np.ndarray:
        return self.commands_at(sensors.time_s)

    def predicted_angles(self) -> np.ndarray:
        return np.full(self.n_joints, np.nan)

    def target_angles(self) -> np.ndarray:
        return np.full(self.n_joints, np.nan)


def brush_contact(plant: Plant) -> tuple[float, np.ndarray, np.ndarray]:
    """The brush's contacts: (sum of their normal forces N, force-weighted contact point m (NaN
    without contact), total force the brush exerts on what it touches N), world frame.

    MuJoCo's contact frame has the normal first, pointing from geom1 to geom2; the contact force
    in that frame (mj_contactForce) acts on geom2, its opposite on geom1.
    """
    m, d = plant.model, plant.data
    brush = plant.geom_id("brush")
    normal, point, push = 0.0, np.zeros(3), np.zeros(3)
    if brush >= 0 and d.ncon:
        f = np.zeros(6)
        con = d.contact  # the contacts' fields as arrays (one wrapper per contact costs ~1 us each)
        geom1 = con.geom1
        frame, pos = con.frame, con.pos
        for i in np.flatnonzero((geom1 == brush) | (con.geom2 == brush)).tolist():
            mujoco.mj_contactForce(m, d, i, f)
            on_geom2 = frame[i].reshape(3, 3).T @ f[:3]
            push += on_geom2 if geom1[i] == brush else -on_geom2
            normal += f[0]
            point += f[0] * pos[i]
    return normal, (point / normal if normal > 0.0 else np.full(3, np.nan)), push


def sample(plant: Plant, controller: Controller) -> dict[str, np.ndarray]:
    """One telemetry sample of the plant's truth beside the controller's belief."""
    d = plant.data
    contact = brush_contact(plant)
    return {
        "true_angle_rad": plant.drive_angles(),
        "predicted_angle_rad": controller.predicted_angles(),
        "target_angle_rad": controller.target_angles(),
        "pressure_a_pa": plant.air[:, J.S_PA_MOTOR],
        "pressure_b_pa": plant.air[:, J.S_PB_MOTOR],
        "valve_gauge_pa": plant.sensors().valve_gauge_pa,
        "direction": plant.commands[:, J.C_DIRECTION],
        "brake_release": plant.commands[:, J.C_BRAKE_RELEASE],
        "brake_engagement": plant.brake_engagement(),
        "supply_pa": np.asarray(plant.supply_pa),
        "brush_force_n": np.asarray(contact[0]),
        "brush_contact_m": contact[1],
        "brush_push_n": contact[2],
        "brush_peak_n": np.asarray(plant.take_force_peak()),
        "body_pos_m": d.xpos[1:],
        "body_quat_wxyz": d.xquat[1:],
    }


def body_names(plant: Plant) -> tuple[str, ...]:
    m = plant.model
    return tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(1, m.nbody))


def run(
    plant: Plant,
    controller: Controller,
    duration_s: float,
    supply: Schedule | float | None = None,
    events: EventSchedule | None = None,
    recorders: tuple[Recorder, ...] = (),
    telemetry: Telemetry | None = None,
    control_period_s: float = CONTROL_PERIOD_S,
    log_period_s: float = LOG_PERIOD_S,
    flush_period_s: float = 0.5,
) -> Telemetry:
    """Run the closed loop for `duration_s` simulated seconds; returns the telemetry.

    `supply` (a schedule, control/schedule.py, or a constant, absolute Pa) sets the supply each tick;
    `events` applies faults. Recorders get
    the new samples every `flush_period_s` of simulated time and once more at the end, also when
    the run stops on an error, so what was logged stays readable.
    """
    steps_per_tick = max(1, round(control_period_s / plant.dt))
    ticks_per_log = max(1, round(log_period_s / (steps_per_tick * plant.dt)))
    ticks_per_flush = max(1, round(flush_period_s / (steps_per_tick * plant.dt)))
    n_ticks = round(duration_s / (steps_per_tick * plant.dt))
    if telemetry is None:
        telemetry = Telemetry(plant.joints, body_names(plant))
    recording = _Recording(plant, controller, telemetry, recorders, ticks_per_log, ticks_per_flush)
    if isinstance(supply, int | float):
        supply = Constant(supply)
    try:
        run_ticks(
            controller,
            plant,
            steps_per_tick,
            n_ticks,
            supply,
            events,
            recording.on_tick,
            check_warnings=False,
            next_tick=recording.next_tick,
            sample_row=recording.row,
        )
        plant.check_warnings()
        telemetry.append(plant.time, sample(plant, controller))
        recording.check_prediction()
    finally:
        recording.flush()
    return telemetry


class _Recording:
    """`run`'s work at a control tick: a telemetry sample every `ticks_per_log` ticks (MuJoCo's
    warnings checked there too), the new samples to the recorders every `ticks_per_flush`."""

    def __init__(self, plant, controller, telemetry, recorders, ticks_per_log: int, ticks_per_flush: int):
        self.plant, self.controller, self.telemetry, self.recorders = plant, controller, telemetry, recorders
        self.ticks_per_log, self.ticks_per_flush = ticks_per_log, ticks_per_flush
        self.flushed = len(telemetry)
        # the row compiled ticks fill with a sample (twin/sample_row.py), in the telemetry's layout
        assert tuple(telemetry.layout) == ROW_SIGNALS, "twin/sample_row.py writes another layout"
        self.row = np.zeros(telemetry.width)
        self._brush = [telemetry.layout[s] for s in ("brush_force_n", "brush_contact_m", "brush_push_n")]
        self._peak = telemetry.layout["brush_peak_n"]
        # the joints the controller predicts (a number from the start; a command schedule has none)
        self._predicted = np.isfinite(controller.predicted_angles())
        self.checked = len(telemetry)  # samples before this one were checked by `check_prediction`
        self._events = EventTail(controller)

    def on_tick(self, k: int, t: float, row: np.ndarray | None = None) -> None:
        """The run's work at tick k (time t): a sample on a log tick (`row`: taken already by the
        compiled ticks, but for the brush's contacts), the recorders' flush on a flush tick."""
        if k % self.ticks_per_log == 0:
            try:
                self.plant.check_warnings()
            except SimulationError:  # a predictor gone to NaN commands NaN: say that first, if so
                self.check_prediction()
                raise
            if row is None:
                self.telemetry.append(t, sample(self.plant, self.controller))
            else:
                if self.plant.data.ncon:
                    for sl, value in zip(self._brush, brush_contact(self.plant), strict=True):
                        row[sl] = value
                row[self._peak] = self.plant.take_force_peak()
                self.telemetry.append_row(row)
        if k % self.ticks_per_flush == self.ticks_per_flush - 1:
            self.flush()
            self.check_prediction()

    def check_prediction(self) -> None:
        """SimulationError when a sample since the last check has a non-finite predicted angle of a
        joint the controller predicts (its integration diverged): the run's belief is lost. Checked
        at each flush, not each sample: a check a sample cost the whole twin 4-6 % of its speed."""
        predicted = self.telemetry.column("predicted_angle_rad", self.checked)
        lost = self._predicted & ~np.isfinite(predicted)
        first = np.flatnonzero(lost.any(axis=1))
        if first.size:
            i = self.checked + int(first[0])
            joints = ", ".join(j for j, bad in zip(self.telemetry.joints, lost[first[0]], strict=True) if bad)
            t = self.telemetry.time_at(i)
            raise SimulationError(f"the predictor diverged (non-finite predicted angle of {joints}) at t = {t:.4f} s")
        self.checked = len(self.telemetry)

    def next_tick(self, k: int) -> int:
        """The first tick from k on where `on_tick` has work."""
        log = -k % self.ticks_per_log
        flush = (self.ticks_per_flush - 1 - k) % self.ticks_per_flush
        return k + min(log, flush)

    def flush(self) -> None:
        for r in self.recorders:
            r.write(self.telemetry, self.flushed)
        self.flushed = len(self.telemetry)
        if not self.recorders:
            return
        events = self._events.new(self.plant.time)
        if events:
            for r in self.recorders:
                write_events = getattr(r, "write_events", None)
                if write_events is not None:
                    write_events(events)
