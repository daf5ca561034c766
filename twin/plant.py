"""The plant: MuJoCo moves the arm, each joint's pneumatic actuator moves MuJoCo.

Per physics step (0.5 ms, the MJCF's timestep): every joint's torque is computed from its chamber
pressures and written into its actuator's ctrl, its brake and Coulomb friction into its drive
tendon's frictionloss; the valves, brake and the four node pressures are advanced over the step
(one half of a ROS2 step over two physics steps, the joint moving as MuJoCo reports:
pneumatics/joint.py, `advance_air_pair`; a joint whose hoses are lines, hose_model = 1, steps them
instead, their states after its joint state in its row of `air`); then MuJoCo steps. The coupling
is explicit in both directions, like MuJoCo's own semi-implicit Euler; tests hold it to scipy's
LSODA on the same equations. A joint whose reducer is not rigid (pneumatics/reducer.py) has its
motor side integrated by the air kernel, not by MuJoCo (twin/kernel.py).

The plant knows the truth. What the operator's platform can read of it is `sensors()`: the supply
pressure and each proportional valve's pressure, nothing more (the real arm has no angle sensor).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import mujoco
import numpy as np

import assets
from pneumatics import AIR, Gas, JointParams, load_joint_params, params_row
from pneumatics import joint as J
from pneumatics import params as P
from pneumatics.reducer import is_rigid, stiffness
from twin.compiled_loop import compiled_ticks
from twin.kernel import (
    MJ_STEP_ADDRESS,
    SUBSTEPS,
    PlantArrays,
    finish_air_pairs,
    keep_force_peak,
    pneumatic_step,
    step_plant,
)
from twin.model import drive_map, ids, load_model, raise_on_new_warnings, warning_counts
from twin_plumbing.errors import ParameterError

# a non-rigid reducer's spring acts on MuJoCo's joint explicitly (twin/kernel.py): its mode on the
# joint side, sqrt(k / J_joint), must stay under this many rad per physics step. Measured on the
# wrist rig (J_joint = 0.02 kg·m^2, 0.5 ms): stable at 1.12 rad/step, unstable from 1.44.
MAX_TRANSMISSION_PHASE_PER_STEP = 1.0
# the brush head's touch sensor (assets/arm.xml): the normal force of its contacts at each physics step
BRUSH_TOUCH = "brush_touch"


class Sensors(NamedTuple):
    """What the operator's platform measures (paper Sec. IV): absolute supply pressure and each
    proportional valve's output pressure (gauge), in Pa. Indexed like `Plant.joints`. (A named
    tuple: made every control tick, it costs a third of a frozen dataclass.)"""

    time_s: float
    supply_pa: float
    valve_gauge_pa: np.ndarray


@dataclass
class PlantState:
    """Everything needed to continue a run exactly: MuJoCo's integration state and the air."""

    mujoco_state: np.ndarray
    air: np.ndarray
    commands: np.ndarray
    supply_pa: float
    sensor_bias_pa: np.ndarray = field(default_factory=lambda: np.zeros(0))
    stuck_direction: np.ndarray = field(default_factory=lambda: np.zeros(0))


class Plant:
    """The arm and its pneumatic actuators."""

    def __init__(
        self,
        model_path: str | Path = assets.SCENE_XML,
        joint_params: dict[str, JointParams] | None = None,
        joints: tuple[str, ...] | None = None,
        gas: Gas = AIR,
        keyframe: str | None = "home",
    ):
        self.model = load_model(model_path)
        self.data = mujoco.MjData(self.model)
        m = self.model
        if joints is None:
            joints = tuple(j for j in assets.JOINTS if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) >= 0)
        self.joints = joints
        joint_params = dict(joint_params or {})
        for j in joints:
            if j not in joint_params:
                joint_params[j] = load_joint_params(assets.joint_param_path(j))
        self.joint_params = {j: joint_params[j] for j in joints}
        self.gas = gas
        self.dt = m.opt.timestep
        # rows keep the valves' and brakes' lag factors for this step (a step set later is still right:
        # the kernel then computes them)
        self.params = np.vstack([params_row(self.joint_params[j], gas, self.dt) for j in joints])
        self.tendon_ids = ids(m, mujoco.mjtObj.mjOBJ_TENDON, [assets.drive_tendon(j) for j in joints])
        self.actuator_ids = ids(m, mujoco.mjtObj.mjOBJ_ACTUATOR, joints)
        self.joint_ids = ids(m, mujoco.mjtObj.mjOBJ_JOINT, joints)
        self.drive_map = drive_map(m, self.tendon_ids)
        # the drive map's qpos and dof addresses as indices (drive_angles, drive_speeds: telemetry)
        self._drive_qpos = self.drive_map[:, :, 0].astype(int)
        self._drive_dofs = self.drive_map[:, :, 1].astype(int)
        self._drive_coefficients = self.drive_map[:, :, 2].copy()
        self._qpos, self._qvel = self.data.qpos, self.data.qvel  # views (each attribute access builds one)
        self._geom_ids: dict[str, int] = {}
        for i in range(len(joints)):
            self._set_drive_tendon(i)
        self.air = self._initial_air()
        self.commands = np.zeros((len(joints), J.N_COMMAND))
        self.supply_pa = gas.p_atm_pa + 0.5e6
        self.sensor_bias_pa = np.zeros(len(joints))
        # a valve stuck open in one direction (a fault): NaN where the valves obey
        self.stuck_direction = np.full(len(joints), np.nan)
        self._any_stuck = False
        if keyframe is not None and mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, keyframe) >= 0:
            mujoco.mj_resetDataKeyframe(m, self.data, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, keyframe))
        self._apply_brakes()
        mujoco.mj_forward(m, self.data)
        self.align_motors()
        for j in joints:
            self._check_transmission(j)
        self._state_size = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION)
        self._warning_numbers = self.data.warning.number  # a view: MuJoCo's counters as they change
        self._note_warnings()
        # the brush's largest contact normal force over the physics steps since it was last taken
        # (`take_force_peak`), from its touch sensor (assets/arm.xml), kept by every step: the
        # criteria judge forces at the physics rate, not at the telemetry's
        self.force_peak_n = np.zeros(1)
        sensor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, BRUSH_TOUCH)
        # what every physics step works on (twin/kernel.py), MuJoCo's buffers as views fetched once
        # (each attribute access builds a new view; Plant.step runs every control tick)
        self.arrays = PlantArrays(
            model_address=m._address,
            data_address=self.data._address,
            air=self.air,
            params=self.params,
            drive_map=self.drive_map,
            tendon_ids=self.tendon_ids,
            actuator_ids=self.actuator_ids,
            qpos=self.data.qpos,
            qvel=self.data.qvel,
            ctrl=self.data.ctrl,
            tendon_frictionloss=m.tendon_frictionloss,
            sensordata=self.data.sensordata,
            force_adr=int(m.sensor_adr[sensor]) if sensor >= 0 else -1,
            force_peak=self.force_peak_n,
        )
        self._valve_gauge_pa = self.air[:, J.S_PV]  # a view (`air` is only ever written in place)
        # False: every physics step goes through `step` (a caller that wraps it, e.g. to record each
        # step); True lets the run loop step this plant's arrays from compiled code (`ticks_batch`)
        self.allow_compiled_ticks = True

    def _initial_air(self) -> np.ndarray:
        # each joint's state row at rest (`pneumatics.joint.initial_state`), followed by its hoses'
        # lines where they are lines (`with_hoses`); the rows as wide as the widest
        rows = [J.with_hoses(J.initial_state(self.gas.p_atm_pa, t_k=self.gas.t_supply_k), row) for row in self.params]
        air = np.zeros((len(rows), max(r.size for r in rows)))
        for i, r in enumerate(rows):
            air[i, : r.size] = r
        return air

    # -- inputs -------------------------------------------------------------------------------
    def set_supply(self, supply_pa: float) -> None:
        """Absolute supply pressure at the platform's regulator, Pa."""
        self.supply_pa = float(supply_pa)

    def command(self, joint: str, direction: int, valve_set_gauge_pa: float, brake_release: bool) -> None:
        """What the platform sends a joint: direction valve (-1, 0, +1), the proportional valve's
        set point (gauge Pa) and whether the brake's release air is on."""
        i = self.joints.index(joint)
        self.commands[i, J.C_DIRECTION] = float(np.sign(direction))
        self.commands[i, J.C_PV_SET_GAUGE_PA] = float(valve_set_gauge_pa)
        self.commands[i, J.C_BRAKE_RELEASE] = 1.0 if brake_release else 0.0

    def stick_valve(self, joint: str, direction: float) -> None:
        """A fault: the joint's valves stick open in `direction` (+1/-1), whatever is commanded."""
        self.stuck_direction[self.joints.index(joint)] = float(np.sign(direction))
        self._any_stuck = True

    def set_joint_params(self, joint: str, params: JointParams) -> None:
        """Change one joint's parameters mid-run (faults: a leak, a stuck valve, ...)."""
        i = self.joints.index(joint)
        was_rigid = is_rigid(self.params[i])
        row = params_row(params, self.gas, self.dt)
        if J.uses_line(self.params[i]) != J.uses_line(row) or (
            J.uses_line(row) and not np.array_equal(J.line_row_of(self.params[i]), J.line_row_of(row))
        ):
            raise ParameterError(
                f"{joint}: [hose] hose_model = {params.hose_model:g} (hose_length_m = {params.hose_length_m:g}, "
                f"hose_diameter_m = {params.hose_diameter_m:g}, hose_loss = {params.hose_loss:g}, hose_law = "
                f"{params.hose_law:g}) changes the joint's hoses mid-run; allowed: the hoses it started with"
            )
        self.joint_params[joint] = params
        self.params[i] = row
        self.air[i, J.S_PAIR] = 0.0  # an air step begun with the old parameters ends at its estimate
        self._set_drive_tendon(i)
        if was_rigid and not is_rigid(self.params[i]):
            self.align_motors([joint])  # the motor side starts where its joint is
        self._check_transmission(joint)

    def align_motors(self, joints: tuple[str, ...] | list[str] | None = None) -> None:
        """Put each joint's motor side (its reducer's input, on the joint side) at its joint's
        angle and speed: an untwisted reducer. Plant() does it at the start; call it after moving
        MuJoCo's qpos/qvel by hand. Only a non-rigid reducer's motor side is used."""
        theta, omega = self.drive_angles(), self.drive_speeds()
        for j in joints if joints is not None else self.joints:
            i = self.joints.index(j)
            self.air[i, J.S_QM] = theta[i]
            self.air[i, J.S_OMEGA_M] = omega[i]

    def _check_transmission(self, joint: str) -> None:
        """ParameterError if a non-rigid reducer's spring is too stiff for MuJoCo's step on this
        joint: its joint-side inertia (drive tendon, this pose) makes its mode too fast."""
        i = self.joints.index(joint)
        row = self.params[i]
        if is_rigid(row):
            return
        m, d = self.model, self.data
        mujoco.mj_forward(m, d)
        lever = np.zeros((1, m.nv))  # the fixed tendon's Jacobian: its coefficients at its dofs
        for _, dof, coef in self.drive_map[i]:
            if coef != 0.0:
                lever[0, int(dof)] += coef
        m_inv_lever = np.zeros((1, m.nv))
        mujoco.mj_solveM(m, d, m_inv_lever, lever)
        inertia = 1.0 / float(lever[0] @ m_inv_lever[0])
        k = stiffness(row[P.BACKLASH], row[P.COMPLIANCE])
        phase = np.sqrt(k / inertia) * self.dt
        if phase > MAX_TRANSMISSION_PHASE_PER_STEP:
            least = self.dt**2 / (MAX_TRANSMISSION_PHASE_PER_STEP**2 * inertia)
            p = self.joint_params[joint]
            raise ParameterError(
                f"{joint}: [effects] reducer_compliance_rad_per_nm = {p.reducer_compliance_rad_per_nm:g} "
                f"(reducer_backlash_rad = {p.reducer_backlash_rad:g}) makes a gear of {k:.4g} N·m/rad "
                f"on {inertia:.4g} kg·m^2 of joint-side inertia, {phase:.2f} rad per {self.dt * 1e3:g} ms "
                "physics step, too stiff for the plant; "
                f"allowed: 0 (rigid) or a compliance >= {least:.3g} rad/(N·m)"
            )

    def _set_drive_tendon(self, i: int) -> None:
        # the motor's rotor and wave generator, reflected through the reducer (ratio^2 J_rotor),
        # and the viscous friction act on the drive coordinate; a non-rigid reducer's rotor is a
        # body of its own, in the air kernel (twin/kernel.py), so MuJoCo must not carry it too
        row, t = self.params[i], self.tendon_ids[i]
        self.model.tendon_armature[t] = row[P.RATIO] ** 2 * row[P.ROTOR_J] if is_rigid(row) else 0.0
        self.model.tendon_damping[t] = row[P.VISCOUS]

    # -- stepping -----------------------------------------------------------------------------
    def step(self, n: int = 1, check_warnings: bool = True) -> None:
        """Advance n physics steps with the inputs held. SimulationError if MuJoCo warns (a caller
        that steps in many small pieces may pass check_warnings=False and call `check_warnings()`)."""
        m, d = self.model, self.data
        commands = self.commands
        if self._any_stuck:
            stuck = ~np.isnan(self.stuck_direction)
            commands = commands.copy()
            commands[stuck, J.C_DIRECTION] = self.stuck_direction[stuck]
            commands[stuck, J.C_PV_SET_GAUGE_PA] = np.inf  # stuck fully open: the supply passes
        if MJ_STEP_ADDRESS is not None:
            step_plant(MJ_STEP_ADDRESS, n, self.arrays, commands, self.supply_pa, self.dt, SUBSTEPS)
        else:  # a MuJoCo build without a loadable shared library, or TWIN_NO_JIT=1: the same steps in Python
            a = self.arrays
            for _ in range(n):
                pneumatic_step(a, commands, self.supply_pa, self.dt, SUBSTEPS)
                mujoco.mj_step(m, d)
                keep_force_peak(a.sensordata, a.force_adr, a.force_peak)
            finish_air_pairs(a.air, a.params, a.drive_map, a.qpos, a.qvel, self.dt)
        if check_warnings:
            self.check_warnings()

    def ticks_batch(self, controller, steps_per_tick, ticks_left, due_s, on_tick, next_tick, sample_row):
        """The run loop's compiled ticks of this plant and `controller` (control/loop.py's
        SteppedPlant, twin/compiled_loop.py), None where they cannot run."""
        return compiled_ticks(
            self,
            controller,
            steps_per_tick,
            ticks_left,
            due_s=due_s,
            next_tick=next_tick,
            on_tick=on_tick,
            sample_row=sample_row,
        )

    def take_force_peak(self) -> float:
        """The brush's largest contact normal force (N) over the physics steps since the last call
        (each 0.5 ms step's, its touch sensor), and start again from zero."""
        peak = float(self.force_peak_n[0])
        self.force_peak_n[0] = 0.0
        return peak

    def check_warnings(self) -> None:
        """SimulationError if MuJoCo warned since the last check (STYLE rule 7)."""
        if self._warning_numbers.tobytes() == self._warnings_seen_bytes:
            return  # no counter changed (the usual case, checked without numpy arithmetic)
        before = self._warnings_seen
        self._note_warnings()
        raise_on_new_warnings(self.data, before, "while stepping the plant")

    def _note_warnings(self) -> None:
        self._warnings_seen = warning_counts(self.data)
        self._warnings_seen_bytes = self._warning_numbers.tobytes()

    def _apply_brakes(self) -> None:
        for row, x, t, w in zip(self.params, self.air, self.tendon_ids, self.drive_speeds(), strict=True):
            self.model.tendon_frictionloss[t] = J.dry_friction_limit(x[J.S_BRAKE], w, row)

    # -- outputs ------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return float(self.data.time)

    def sensors(self) -> Sensors:
        """What the platform can measure. The true angles are not in here, by design."""
        return Sensors(self.data.time, self.supply_pa, self._valve_gauge_pa + self.sensor_bias_pa)

    def drive_angles(self) -> np.ndarray:
        """True drive-coordinate angle of each joint, rad (for logging and tests, not the controller)."""
        return (self._drive_coefficients * self._qpos[self._drive_qpos]).sum(axis=1)

    def drive_speeds(self) -> np.ndarray:
        """True drive-coordinate speed of each joint, rad/s."""
        return (self._drive_coefficients * self._qvel[self._drive_dofs]).sum(axis=1)

    def motor_angles(self) -> np.ndarray:
        """Angle of each joint's motor side on the joint side (motor angle / ratio), rad: the drive
        angle for a rigid reducer."""
        rigid = np.array([is_rigid(row) for row in self.params], dtype=bool)
        return np.where(rigid, self.drive_angles(), self.air[:, J.S_QM])

    def joint_torques(self) -> np.ndarray:
        """Pneumatic drive torque applied to each joint in the last step, N·m (for a non-rigid
        reducer, the torque it transmitted, averaged over the step)."""
        return self.data.ctrl[self.actuator_ids].copy()

    def chamber_pressures(self) -> np.ndarray:
        """(n_joints, 2) absolute pressures of motor chambers A and B, Pa."""
        return self.air[:, [J.S_PA_MOTOR, J.S_PB_MOTOR]].copy()

    def brake_engagement(self) -> np.ndarray:
        return self.air[:, J.S_BRAKE].copy()

    def valve_directions(self) -> np.ndarray:
        """Direction valve position in effect per joint (-1, 0, +1)."""
        return self.air[:, J.S_DIR].copy()

    def geom_id(self, name: str) -> int:
        """MuJoCo's id of the named geom (-1: none), looked up once (telemetry asks every sample)."""
        if name not in self._geom_ids:
            self._geom_ids[name] = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name)
        return self._geom_ids[name]

    def site_position(self, name: str) -> np.ndarray:
        return self.data.site(name).xpos.copy()

    # -- state --------------------------------------------------------------------------------
    def save_state(self) -> PlantState:
        buf = np.empty(self._state_size)
        mujoco.mj_getState(self.model, self.data, buf, mujoco.mjtState.mjSTATE_INTEGRATION)
        return PlantState(
            buf,
            self.air.copy(),
            self.commands.copy(),
            self.supply_pa,
            self.sensor_bias_pa.copy(),
            self.stuck_direction.copy(),
        )

    def restore_state(self, state: PlantState) -> None:
        mujoco.mj_setState(self.model, self.data, state.mujoco_state, mujoco.mjtState.mjSTATE_INTEGRATION)
        self._note_warnings()
        self.air[:] = state.air
        self.commands[:] = state.commands
        self.supply_pa = state.supply_pa
        self.sensor_bias_pa[:] = state.sensor_bias_pa
        self.stuck_direction[:] = state.stuck_direction
        self._any_stuck = bool((~np.isnan(self.stuck_direction)).any())
        self._apply_brakes()
        mujoco.mj_forward(self.model, self.data)
