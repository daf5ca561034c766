"""The operator's platform: predictor-feedback control of every joint (paper Sec. IV, Fig. 17).

`ArmController` implements twin/sim.py's Controller protocol: each control period it is handed
the sensors the real platform has (time, supply pressure, each proportional valve's pressure) and
returns the commands for the valves and brakes. It never sees the true joint angles: it is told
the start pose once (the operator homes the arm) and from then on predicts.

Per tick: fault checks -> plan sequencing (which joints move toward which targets) -> PID on the
predicted angles (control/pid.py) -> the predictor advances over the period with the commands
just issued (control/predictor.py), the load torques from Pinocchio at the predicted
configuration (control/arm_model.py, one gravity call for all joints, only while something moves;
between looks, their tangent: control/predicted_load.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

import assets
from control import pid
from control.arm_model import ArmModel
from control.compiled_tick import (
    FLOW_ATM,
    FLOW_BRAKE_RELEASE,
    FLOW_DT,
    FLOW_DWELL,
    FLOW_FAULTED,
    FLOW_PLAN,
    FLOW_STEPPING,
    N_FLOW,
    ControllerArrays,
)
from control.open_loop import open_loop_duration
from control.pid import CLOSED, DEFAULT_GAINS, IDLE, OPEN, PidGains, control_step, gains_row
from control.predicted_load import B_CLEARANCE, B_RADIUS, B_REACH, LOAD_UPDATE_RAD, N_BOUND, advance_load
from control.predictor import predict_step
from pneumatics import AIR, Gas, JointParams, load_joint_params, paper_model, params_row
from pneumatics import params as P
from pneumatics.joint import C_BRAKE_RELEASE, N_COMMAND, R_OMEGA, R_THETA, initial_rigid_state, initial_state
from pneumatics.motor import least_displacement_per_rad

MODES = ("closed_loop", "open_loop")
SEQUENCES = ("one_after_another", "together")


class MotionRefused(ValueError):
    """A requested motion the controller will not make (outside the limits, not a number, or
    smaller than the minimum rotation). The arm is left braked."""


class ArmController:
    """Predictor-feedback controller of the arm's joints (or the wrist rig's one joint).

    start_angles_rad: the start pose in drive angles, {joint: rad} or a sequence in `joints` order.
    xml_path: the MJCF Pinocchio reads (assets.ARM_XML for the arm and its scene, assets.WRIST_RIG_XML).
    predictor_params: the predictor's JointParams per joint (default: the parameter files), taken with
        the paper's chamber law whatever their own (`pneumatics.params.paper_model`).
    mode: "closed_loop" (PID on the prediction) or "open_loop" (valve open for a nominal time).
    min_rotation_rad: smaller requested rotations are refused (paper Sec. IV: 20 deg).
    move_timeout_s: a move not finished by then is stopped, braked and reported as a fault.
    open_loop_set_point_pa: the open loop's proportional-valve set point (default: full opening, 1/k_u).
    load_update_rad: the load torques are taken from Pinocchio again once a predicted drive angle has
        moved more than this since they were last taken, their tangent used in between (0: whenever
        any has moved at all; control/predicted_load.py).
    """

    def __init__(
        self,
        start_angles_rad: Mapping[str, float] | Sequence[float],
        xml_path: str | Path = assets.ARM_XML,
        joints: tuple[str, ...] | None = None,
        predictor_params: Mapping[str, JointParams] | None = None,
        gains: PidGains = DEFAULT_GAINS,
        mode: str = "closed_loop",
        min_rotation_rad: float = math.radians(20.0),
        move_timeout_s: float = 20.0,
        open_loop_set_point_pa: float | None = None,
        payload_kg: float | None = None,
        control_period_s: float = 1e-3,
        load_update_rad: float = LOAD_UPDATE_RAD,
        gas: Gas = AIR,
    ):
        if mode not in MODES:
            raise ValueError(f"controller mode = {mode!r}; allowed: {', '.join(MODES)}")
        self.arm = ArmModel(xml_path, joints, payload_kg)
        self.joints = self.arm.joints
        n = len(self.joints)
        params = dict(predictor_params or {})
        for j in self.joints:
            if j not in params:
                params[j] = load_joint_params(assets.joint_param_path(j))
        # the predictor is the paper's model of each joint (DESIGN rule 2): the same parameters, the
        # paper's chamber law (`paper_model`)
        self.joint_params = {j: paper_model(params[j]) for j in self.joints}
        # the rows keep the valves' and brakes' lag factors for the predictor's step, the control period,
        # and each drive's end stops: a prediction stops where the joint does
        stops = self.arm.drive_stops()
        self.params = np.vstack(
            [
                params_row(self.joint_params[j], gas, float(control_period_s), tuple(stops[i]))
                for i, j in enumerate(self.joints)
            ]
        )
        self.gas = gas
        self.mode_name = mode
        self.gains = gains
        self._g = gains_row(gains)
        self.min_rotation_rad = float(min_rotation_rad)
        self.move_timeout_s = float(move_timeout_s)
        self.dt = float(control_period_s)
        self.open_loop_set_point_pa = open_loop_set_point_pa
        self.rotor_inertia = self.params[:, P.RATIO] ** 2 * self.params[:, P.ROTOR_J]
        start = self._as_array(start_angles_rad, "start pose")
        bad = [f"{j} = {v!r}" for j, v in zip(self.joints, start, strict=True) if not math.isfinite(v)]
        if bad:
            raise MotionRefused(f"start pose: {', '.join(bad)} is not a number; allowed: a finite drive angle in rad")
        atm = gas.p_atm_pa
        self.y = np.vstack([initial_rigid_state(a, atm, gas.t_supply_k) for a in start])
        self.x = np.vstack([initial_state(atm, True, 0.0, gas.t_supply_k) for _ in start])
        self.commands = np.zeros((n, N_COMMAND))
        self._make_tables(start)
        # the load's tangent between Pinocchio's looks (control/predicted_load.py)
        self._load_base = np.zeros(n)
        self._load_slope = np.zeros((n, n))
        self._c_inv = np.ascontiguousarray(self.arm.C_inv)
        self._load_bound = np.zeros(N_BOUND)
        self._load_bound[B_REACH] = self.arm.reach_m
        self.load_update_rad = load_update_rad
        self._press: tuple[np.ndarray, np.ndarray] | None = None  # the surface the brush is expected to press
        self._set_load(start)
        self.inertia = self.arm.drive_inertias(start) + self.rotor_inertia
        self._plan: list[tuple[np.ndarray, float]] = []  # (targets with NaN = stays, dwell_s)
        # which target of the last set_targets each of its steps serves, and how many steps were begun
        self._step_targets: list[int] = []
        self._steps_begun = 0
        self._step_joints = np.zeros(n, dtype=bool)
        self._stepping = False  # == self._step_joints.any(), kept as a bool for the tick's speed
        self._step_index: list[int] = []  # == np.flatnonzero(self._step_joints).tolist(), likewise
        self._brake_release_pa = float(np.max(self.params[:, P.BRAKE_START_PA]))  # below it a brake cannot lift at all
        self._dwell_left = 0.0
        self._last_supply = atm
        self.faulted = False
        self.events: list[str] = []  # what happened, for the operator (refusals, arrivals, faults)
        self.time_s = 0.0

    def _make_tables(self, start: np.ndarray) -> None:
        """The per-joint tables control_step works on (control/pid.py), and a named view of each
        column (the views are what the rest of the controller reads and writes)."""
        n = len(self.joints)
        self._modes = np.zeros((n, pid.N_MODES_COLUMNS), dtype=np.int64)
        self._moves = np.zeros((n, pid.N_MOVE_COLUMNS))
        self._drives = np.zeros((n, pid.N_DRIVE_COLUMNS))
        self.mode, self.outcome = self._modes[:, pid.K_MODE], self._modes[:, pid.K_OUTCOME]
        self.target, self.integral = self._moves[:, pid.M_TARGET], self._moves[:, pid.M_INTEGRAL]
        self.elapsed, self.timeout = self._moves[:, pid.M_ELAPSED], self._moves[:, pid.M_TIMEOUT]
        self.open_time, self.retries = self._moves[:, pid.M_OPEN_TIME], self._moves[:, pid.M_RETRIES]
        self.open_set_point = self._moves[:, pid.M_OPEN_SET_POINT]
        self.load, self._load_theta = self._drives[:, pid.D_LOAD], self._drives[:, pid.D_LOAD_THETA]
        self.torque_per_pa, self.pv_full = self._drives[:, pid.D_TORQUE_PER_PA], self._drives[:, pid.D_PV_FULL]
        self.breakaway_pa = self._drives[:, pid.D_BREAKAWAY_POS : pid.D_BREAKAWAY_NEG + 1]
        self.target[:] = start
        self.timeout[:] = self.move_timeout_s
        # the proportional valve's largest set point, gauge Pa: fully open, it passes the supply
        # (updated every tick from the measured supply; 1/k_u, full opening, until then)
        self.pv_full[:] = 1.0 / self.params[:, P.K_U]
        # joint torque per gauge Pa of valve pressure at stall, at the worst vane angle (a stalled motor
        # must break away from wherever its vanes stand; the mean is 1/0.87 of it): least
        # displacement x ratio x efficiency
        self.torque_per_pa[:] = [
            least_displacement_per_rad(pr.stator_radius_m, pr.rotor_radius_m, pr.vane_length_m, pr.n_vanes)
            * pr.ratio
            * pr.efficiency_forward
            for pr in self.joint_params.values()
        ]

    # -- the operator's requests ------------------------------------------------------------
    def _as_array(self, angles, what: str) -> np.ndarray:
        if isinstance(angles, Mapping):
            unknown = [k for k in angles if k not in self.joints]
            if unknown:
                raise MotionRefused(f"{what}: unknown joint {unknown[0]!r}; allowed: {', '.join(self.joints)}")
            return np.array([float(angles.get(j, np.nan)) for j in self.joints])
        a = np.asarray(angles, dtype=float)
        if a.shape != (len(self.joints),):
            raise MotionRefused(f"{what}: {a.shape[0] if a.ndim else 0} angles for the joints {self.joints}")
        return a.copy()

    def set_targets(
        self,
        targets: Sequence[Mapping[str, float]] | Mapping[str, float],
        sequence: str = "one_after_another",
        dwell_s: float | Sequence[float] = 0.0,
    ) -> None:
        """Plan a motion: a sequence of joint-space targets ({joint: drive angle rad}, joints not
        named stay), each reached with its joints moved one after another (base to tool, as linemen
        operate) or together, then held `dwell_s`. Replaces any plan; a move under way is stopped.

        MotionRefused (a ValueError) for a NaN, a target outside a joint's range, or a rotation
        smaller than the minimum; the arm is then braked and the plan empty.
        """
        if sequence not in SEQUENCES:
            raise ValueError(f"sequence = {sequence!r}; allowed: {', '.join(SEQUENCES)}")
        if isinstance(targets, Mapping):
            targets = [targets]
        dwells = [float(dwell_s)] * len(targets) if np.isscalar(dwell_s) else [float(d) for d in dwell_s]
        self._stop_all()
        self._step_targets, self._steps_begun = [], 0
        try:
            plan = self._validated_plan(targets, dwells, sequence)
        except MotionRefused as e:
            self.events.append(f"t = {self.time_s:.3f} s: refused: {e}")
            raise
        self._plan = [(step, dwell) for step, dwell, _ in plan]
        self._step_targets = [k for _, _, k in plan]

    def _validated_plan(self, targets, dwells, sequence) -> list[tuple[np.ndarray, float, int]]:
        """The plan's steps: (drive angles, NaN where a joint stays; dwell_s; the target it serves)."""
        here = self.y[:, R_THETA].copy()
        plan = []
        lo, hi = self.arm.joint_lower, self.arm.joint_upper
        for k, (tgt, dwell) in enumerate(zip(targets, dwells, strict=True)):
            raw = self._as_array(tgt, f"target {k + 1}")
            named = [j for j in tgt] if isinstance(tgt, Mapping) else list(self.joints)
            for j in named:
                v = raw[self.joints.index(j)]
                if not math.isfinite(v):
                    raise MotionRefused(
                        f"target {k + 1}: {j} = {v!r} is not a number; allowed: a finite drive angle in rad"
                    )
            full = np.where(np.isnan(raw), here, raw)
            q, ok = self.arm.joints_within_limits(full)
            if not ok.all():
                i = int(np.flatnonzero(~ok)[0])
                name = self.arm.model.names[i + 1]
                raise MotionRefused(
                    f"target {k + 1}: joint {name} would be at {math.degrees(q[i]):.2f} deg; allowed: "
                    f"{math.degrees(lo[i]):.2f}..{math.degrees(hi[i]):.2f} deg "
                    f"(drive angles {np.round(np.degrees(full), 2).tolist()} deg)"
                )
            delta = full - here
            tol = self.gains.tolerance_rad
            small = (np.abs(delta) > tol) & (np.abs(delta) < self.min_rotation_rad)
            if small.any():
                i = int(np.flatnonzero(small)[0])
                raise MotionRefused(
                    f"target {k + 1}: {self.joints[i]} rotation {math.degrees(delta[i]):.2f} deg "
                    f"(to {math.degrees(full[i]):.2f} deg) is below the minimum rotation; allowed: 0 or "
                    f"|rotation| >= {math.degrees(self.min_rotation_rad):.1f} deg; jog it by hand"
                )
            moving = np.abs(delta) > tol
            if sequence == "together":
                plan.append((np.where(moving, full, np.nan), dwell, k))
            else:
                idx = np.flatnonzero(moving)
                for m, i in enumerate(idx):
                    step = np.full(len(self.joints), np.nan)
                    step[i] = full[i]
                    plan.append((step, dwell if m == len(idx) - 1 else 0.0, k))
                if len(idx) == 0:
                    plan.append((np.full(len(self.joints), np.nan), dwell, k))
            here = full
        return plan

    def _stop_all(self) -> None:
        self.mode[:] = IDLE
        self._plan = []
        self._step_joints[:] = False
        self._step_index = []
        self._stepping = False
        self._dwell_left = 0.0
        self.commands[:] = 0.0  # valves shut, brakes engaged (spring-applied)

    # -- the control period ------------------------------------------------------------------
    def tick(self, sensors) -> np.ndarray:
        """Commands (n, N_COMMAND) for the coming control period from the platform's sensors
        (`time_s`, `supply_pa` absolute, `valve_gauge_pa` per joint). The returned array is reused."""
        self.time_s = float(sensors.time_s)
        supply = float(sensors.supply_pa)
        pv = np.asarray(sensors.valve_gauge_pa, dtype=float)
        if not math.isfinite(supply + sum(pv.tolist())):  # a NaN or inf anywhere propagates into the sum
            self._fault(f"sensor reading not a number (supply {supply!r}, valves {pv.tolist()})")
            supply = self._last_supply
            pv = np.where(np.isfinite(pv), pv, 0.0)
        else:
            self._last_supply = supply
        self.pv_full.fill(max(supply - self.gas.p_atm_pa, 0.0))
        if (self._plan or self._stepping) and not self.faulted:
            gauge = supply - self.gas.p_atm_pa
            if gauge < self._brake_release_pa:
                self._fault(
                    f"supply {gauge / 1e6:.3f} MPa gauge is below the brake release pressure "
                    f"{self._brake_release_pa / 1e6:.3f} MPa"
                )
        if not self.faulted:
            self._sequence(supply)
        result = control_step(
            self._modes,
            self._moves,
            self._drives,
            self.y,
            self.x,
            self.params,
            self._g,
            self.dt,
            self.commands,
        )
        moving, timed_out = result
        stale = moving and advance_load(
            self._drives, self.y, self._load_base, self._load_slope, self._c_inv, self._load_bound
        )
        return self.finish_tick((moving, timed_out, stale), pv, supply)

    def finish_tick(self, control_result, valve_gauge_pa: np.ndarray, supply_pa: float) -> np.ndarray:
        """The tick's part after control_step (whose (moving, timed out, load stale) it is handed):
        a fault's commands, the load from Pinocchio when stale, a time-out, the prediction's step."""
        moving, timed_out, load_stale = control_result
        if self.faulted:
            self.commands[:] = 0.0
        if moving:
            if load_stale:
                self._set_load(self.y[:, R_THETA])
            if timed_out >= 0:
                i = int(timed_out)
                self._fault(
                    f"{self.joints[i]} did not reach {math.degrees(self.target[i]):.2f} deg "
                    f"within {self.timeout[i]:g} s "
                    f"(predicted {math.degrees(self.y[i, R_THETA]):.2f} deg)"
                )
                self.commands[:] = 0.0
        predict_step(
            self.y, self.x, self.commands, valve_gauge_pa, supply_pa, self.load, self.inertia, self.params, self.dt
        )
        return self.commands

    # -- ticks in compiled code (control/compiled_tick.py) -------------------------------------
    def compiled_ticks(self, time_s: float) -> tuple[ArmController | None, float]:
        """(the controller whose ticks `controller_tick` can run, until when): always itself."""
        return self, math.inf

    def compiled_state(self) -> ControllerArrays:
        """The arrays `controller_tick` works on; the flow array is made from the controller's
        scalars (`take_compiled_state` reads it back)."""
        flow = np.zeros(N_FLOW)
        flow[FLOW_DWELL] = self._dwell_left
        flow[FLOW_STEPPING] = float(self._stepping)
        flow[FLOW_PLAN] = float(bool(self._plan))
        flow[FLOW_FAULTED] = float(self.faulted)
        flow[FLOW_BRAKE_RELEASE] = self._brake_release_pa
        flow[FLOW_DT] = self.dt
        flow[FLOW_ATM] = self.gas.p_atm_pa
        return ControllerArrays(
            flow=flow,
            step_joints=self._step_joints,
            modes=self._modes,
            moves=self._moves,
            drives=self._drives,
            y=self.y,
            x=self.x,
            params=self.params,
            g=self._g,
            commands=self.commands,
            load_nm=self.load,
            inertia_kg_m2=self.inertia,
            load_base=self._load_base,
            load_slope=self._load_slope,
            c_inv=self._c_inv,
            load_bound=self._load_bound,
        )

    @property
    def load_update_rad(self) -> float:
        """How far (rad) a predicted drive angle may move before the load is looked up again."""
        return float(self._load_bound[B_RADIUS])

    @load_update_rad.setter
    def load_update_rad(self, radius_rad: float) -> None:
        self._load_bound[B_RADIUS] = float(radius_rad)

    def update_load(self) -> None:
        """The load torques from Pinocchio at the predicted angles (a stale load, mid-tick)."""
        self._set_load(self.y[:, R_THETA])

    def take_compiled_state(self, flow: np.ndarray, time_s: float, supply_pa: float) -> None:
        """After compiled ticks, the last of them at `time_s`: what they changed of the scalars."""
        self._dwell_left = float(flow[FLOW_DWELL])
        self.time_s = float(time_s)
        self._last_supply = float(supply_pa)

    def _set_load(self, theta: np.ndarray) -> None:
        # the load torques from Pinocchio at the predicted configuration, and where they were taken
        self.load[:] = self.arm.load_torques(theta)  # in place: control_step's Belief holds these arrays
        clearance = np.inf
        if self._press is not None:
            self.load += self.arm.press_torques(theta, *self._press)
            clearance = self.arm.press_clearance_m(theta, *self._press)
        self._load_theta[:] = theta
        self._load_base[:] = self.load
        self._load_bound[B_CLEARANCE] = clearance
        if self.load_update_rad > 0.0 and clearance > -np.inf:  # (else never used away from theta)
            self._load_slope[:] = self.arm.load_slope(theta)

    def expect_press(self, surface_m: np.ndarray | None, normal: np.ndarray | None = None) -> None:
        """The surface the coming moves press the brush into (ArmModel.press_torques: a point where
        the tool frame stands when the head's face touches it, the unit normal out of it; world),
        or None. The predictor then meets the head spring's reaction wherever its predicted brush
        is behind the surface, as the true arm does: without it, a press stalled the true joints
        short of the prediction (3-6 mm at the brush in the cleaning study's presses, as-built)."""
        if surface_m is None:
            self._press = None
        else:
            n = np.asarray(normal, dtype=float)
            self._press = (np.asarray(surface_m, dtype=float).copy(), n / np.linalg.norm(n))
        self._set_load(self.y[:, R_THETA])

    def _fault(self, why: str) -> None:
        if not self.faulted:
            self.events.append(f"t = {self.time_s:.3f} s: fault, all brakes engaged: {why}")
        self.faulted = True
        self._stop_all()

    def _sequence(self, supply_pa: float) -> None:
        """Start the next step of the plan when the current one is done (and its dwell is over)."""
        if self._stepping:
            # any joint of the step still busy? (a list: a numpy mask costs ~1.5 us, every tick of a move)
            mode = self.mode.tolist()
            for i in self._step_index:
                if mode[i] != IDLE:
                    return
            for i in np.flatnonzero(self._step_joints):
                self.events.append(
                    f"t = {self.time_s:.3f} s: {self.joints[i]} "
                    f"at {math.degrees(self.y[i, R_THETA]):.2f} deg (predicted), "
                    f"target {math.degrees(self.target[i]):.2f} deg"
                )
            self._step_joints[:] = False
            self._step_index = []
            self._stepping = False
        if self._dwell_left > 0.0:
            self._dwell_left -= self.dt
            return
        if not self._plan:
            return
        step, dwell = self._plan.pop(0)
        self._steps_begun += 1
        self._dwell_left = dwell
        moving = ~np.isnan(step)
        if not moving.any():
            return
        theta = self.y[:, R_THETA]
        self.inertia = self.arm.drive_inertias(theta) + self.rotor_inertia
        self._set_load(theta)
        for i in np.flatnonzero(moving):
            self.target[i] = step[i]
            self.integral[i] = 0.0
            self.elapsed[i] = 0.0
            self.retries[i] = 0.0
            self.timeout[i] = self.move_timeout_s
            if self.mode_name == "open_loop":
                sp = self.pv_full[i] if self.open_loop_set_point_pa is None else self.open_loop_set_point_pa
                self.open_time[i] = open_loop_duration(
                    self.params[i], theta[i], step[i], sp, supply_pa, self.load[i], self.inertia[i], self.dt
                )
                self.open_set_point[i] = math.copysign(sp, step[i] - theta[i])
                self.mode[i] = OPEN
            else:
                self.mode[i] = CLOSED
        self._step_joints = moving
        self._step_index = np.flatnonzero(moving).tolist()
        self._stepping = True

    def clear_fault(self) -> None:
        """The operator acknowledges a fault: the controller takes requests again (the arm stays
        braked until the next plan)."""
        if self.faulted:
            self.events.append(f"t = {self.time_s:.3f} s: fault cleared by the operator")
        self.faulted = False

    def reference(self, joint: str, angle_rad: float, speed_rad_s: float = 0.0) -> None:
        """Set the predictor's angle (and speed) of `joint` from outside: the joint was driven to a
        known stop, or (a bound for studies, not the sensorless arm) the truth is handed in."""
        i = self.joints.index(joint)
        self.y[i, R_THETA] = float(angle_rad)
        self.y[i, R_OMEGA] = float(speed_rad_s)

    def targets_finished(self) -> list[bool]:
        """Per target of the last `set_targets`, whether it was finished: every step of it begun, its
        joints arrived and its dwell over (a fault leaves the step under way and the rest unfinished)."""
        open_step = self._stepping or self._dwell_left > 0.0  # the last step begun is still under way
        finished = self._steps_begun - open_step
        last_step = {k: i for i, k in enumerate(self._step_targets)}
        return [k in last_step and last_step[k] < finished for k in range(max(self._step_targets, default=-1) + 1)]

    def target_in_force(self, targets: Sequence[Mapping[str, float]]) -> dict[str, float]:
        """Per joint, the target in force now (drive angle, rad): the latest of `targets` (those of the
        last `set_targets`) whose steps were begun that names it; {} before the first step."""
        begun = self._step_targets[self._steps_begun - 1] if self._steps_begun else -1
        out: dict[str, float] = {}
        for target in targets[: begun + 1]:
            out.update(target)
        return out

    # -- what the controller believes (Controller protocol) ------------------------------------
    def predicted_angles(self) -> np.ndarray:
        """Predicted drive angles, rad."""
        return self.y[:, R_THETA].copy()

    def predicted_speeds(self) -> np.ndarray:
        return self.y[:, R_OMEGA].copy()

    def target_angles(self) -> np.ndarray:
        """Current target drive angles, rad (the predicted start pose for joints never moved)."""
        return self.target.copy()

    @property
    def done(self) -> bool:
        """True when the plan is finished (or abandoned on a fault) and every joint is braked."""
        # a list's count, not a numpy mask: the task asks every tick, the mask costs ~2 us
        return (
            not self._plan
            and not self._stepping
            and self._dwell_left <= 0.0
            and self.mode.tolist().count(IDLE) == len(self.joints)
        )

    @property
    def brakes_released(self) -> np.ndarray:
        return self.commands[:, C_BRAKE_RELEASE] > 0.5
