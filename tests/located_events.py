"""A reference for the one-joint model that locates every stick/slip and valve event.

The model under test (`pneumatics.joint.single_joint_step`, at the 1 ms control tick) decides dry
friction inside fixed steps. This reference shares only the laws with it (`pressure_rates`,
`joint_torque`, `transmitted_torque`, the brake's target and the valves' targets) and integrates
them as a hybrid system with scipy's LSODA: each body (the joint; the motor side of a non-rigid
reducer) is in one of three modes, sliding up, sliding down or stuck, the right-hand side is
smooth inside a mode, and the switches are located as events (DESIGN rule 8):

* sliding: friction opposes the mode's direction; the event is the speed crossing zero, where the
  body sticks if its dry friction can hold the drive there, or turns round;
* stuck: speed and acceleration are zero; the events are the drive crossing the friction limit
  either way (breakaway).

The motor side's dry friction is the gear's efficiency (`joint_torque`: eta_f driving, 1/eta_b
back-driven), with the same stuck band as `joint.motor_side_drive`.

The air: with the paper's chamber law (chamber_heat = 0) the kernel's `pressure_rates`; with the
energy balance (chamber_heat = 1) `energy_air_rates` below, written apart from the kernel's rate
function, in the conserved quantities: each node's mass and internal energy change by the flows,
each carrying c_p T of the gas it leaves, by the wall's heat and by the work p dV/dt, and p, T
follow from m, U and V (the kernel writes dp/dt, dT/dt directly, pneumatics/chamber.py). It shares
with the kernel only the laws of the parts: the orifice at its upstream gas's temperature, the
hose's friction, the motor's geometry, the film coefficients, the valve's opening and pressure.

Valves are continuous here: the proportional valve's output is a first-order lag of its set point
integrated as a state, the direction valve switches exactly `solenoid_delay_s` after its command,
the brake's engagement lags toward the target its air gives, as a state. Commands are held from
one row's time to the next. No Karnopp window, no fixed step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import LSODA
from scipy.optimize import brentq

from pneumatics import params as P
from pneumatics.brake import brake_feed_gauge_pa, brake_target
from pneumatics.friction import stribeck_excess
from pneumatics.heat import duct_heat_transfer_coefficient, vane_chamber_heat_transfer_coefficient
from pneumatics.hose import hose_mass_flow
from pneumatics.joint import effective_supply, joint_torque, pressure_rates
from pneumatics.motor import chamber_geometry
from pneumatics.orifice import orifice_mass_flow_between
from pneumatics.reducer import damping, inertia_split, is_rigid, stiffness, transmitted_torque
from pneumatics.valves import proportional_valve_target, regulated_pressure, valve_opening

# state of the reference: angle, speed, four node pressures, valve output (gauge), brake engagement,
# motor side (joint side of the gear: angle, speed), the four nodes' gas temperatures
THETA, OMEGA, PA_V, PA_M, PB_V, PB_M, PV, BRAKE, QM, WM, TA_V, TA_M, TB_V, TB_M = range(14)
N = 14


def energy_air_rates(
    p: np.ndarray,
    pressures: np.ndarray,
    temperatures: np.ndarray,
    phi: float,
    w_motor: float,
    direction: float,
    valve_gauge_pa: float,
    supply_pa: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(dp/dt, dT/dt) of the four nodes (valve end and motor end of port A's hose, then B's) by the
    energy balance, from each node's mass and energy budget (module docstring)."""
    r, k, t_w, atm = p[P.GAS_R], p[P.GAS_K], p[P.GAS_T], p[P.GAS_P_ATM]
    cv = r / (k - 1.0)
    cp = cv + r
    two_nodes = p[P.HOSE_LOSS] != 0.0
    v_a, v_b, slope = chamber_geometry(
        phi, p[P.STATOR], p[P.ROTOR], p[P.VANE_L], p[P.N_VANES], p[P.DEAD_V], p[P.HALF_PITCH_V]
    )
    hose_v = math.pi / 4.0 * p[P.HOSE_D] ** 2 * p[P.HOSE_L]
    hose_wall = math.pi * p[P.HOSE_D] * p[P.HOSE_L]
    dv_a = slope * w_motor
    if two_nodes:
        volumes = np.array([hose_v / 2, v_a + hose_v / 2, hose_v / 2, v_b + hose_v / 2])
        dvol = np.array([0.0, dv_a, 0.0, -dv_a])
    else:  # one node per port: the motor node holds the chamber and the whole hose
        volumes = np.array([v_a + hose_v, v_a + hose_v, v_b + hose_v, v_b + hose_v])
        dvol = np.array([dv_a, dv_a, -dv_a, -dv_a])
    mass_rate = np.zeros(4)
    energy_rate = np.zeros(4)  # dU/dt before the work

    def flow(m_into_b: float, a: int | None, b: int | None, t_outside: float) -> None:
        # m_into_b kg/s from node a (None: outside at t_outside) to node b (None: outside); the
        # enthalpy carried is c_p T of the side the gas leaves
        upstream = a if m_into_b > 0 else b
        t_from = temperatures[upstream] if upstream is not None else t_outside
        for node, sign in ((a, -1.0), (b, 1.0)):
            if node is not None:
                mass_rate[node] += sign * m_into_b
                energy_rate[node] += sign * cp * m_into_b * t_from

    opening = valve_opening(valve_gauge_pa, p[P.K_U], p[P.DEAD_ZONE])
    supplied = pressures[0] if direction > 0 else pressures[2]
    p_s = regulated_pressure(
        effective_supply(supply_pa, valve_gauge_pa, opening, direction, supplied, p), valve_gauge_pa, atm
    )
    inlet = p[P.A_IN] * p[P.COND_SCALE] * opening
    exhaust = p[P.A_EX] * p[P.COND_SCALE]
    valve_a, valve_b = 0, 2  # the nodes the valves feed (the motor nodes themselves with one node a port)
    motor_a, motor_b = (1, 3) if two_nodes else (0, 2)
    valve_flows = []
    for node, on in ((valve_a, direction > 0), (valve_b, direction < 0)):
        source, area = (p_s, inlet) if on else (atm, exhaust)
        m = orifice_mass_flow_between(source, pressures[node], area, t_w, temperatures[node], r, k)
        flow(m, None, node, t_w)
        valve_flows.append(m)
    # port A's hose leak (at its valve end) and the vane leak A -> B
    m = orifice_mass_flow_between(pressures[valve_a], atm, p[P.HOSE_LEAK_A], temperatures[valve_a], t_w, r, k)
    flow(m, valve_a, None, t_w)
    m = orifice_mass_flow_between(
        pressures[motor_a], pressures[motor_b], p[P.LEAK_A], temperatures[motor_a], temperatures[motor_b], r, k
    )
    flow(m, motor_a, motor_b, t_w)
    hose_flows = valve_flows  # one node a port: the gas in the hose moves at the valve's flow
    if two_nodes:
        hose_flows = []
        for a, b in ((valve_a, motor_a), (valve_b, motor_b)):
            t_mean = 0.5 * (temperatures[a] + temperatures[b])
            hose_flows.append(
                hose_mass_flow(pressures[a], pressures[b], t_mean, p[P.HOSE_L], p[P.HOSE_D], r, p[P.GAS_MU])
            )
            flow(hose_flows[-1], a, b, t_w)
    # the wall's heat at the supply temperature, times the scale: the hose's wall (half of it a node
    # with two nodes a port, all of it with one) at the hose's mean speed, and the motor chamber's by
    # the vane cell's correlation
    heat = np.zeros(4)
    wall = hose_wall / 2 if two_nodes else hose_wall
    for node, port in ((0, 0), (1, 0), (2, 1), (3, 1)):
        pr, tk = pressures[node], temperatures[node]
        speed = hose_flows[port] * r * tk / (pr * math.pi / 4.0 * p[P.HOSE_D] ** 2)
        ha = duct_heat_transfer_coefficient(speed, pr, tk, t_w, p[P.HOSE_D], r, k) * wall
        if node in (motor_a, motor_b):
            h_cell = vane_chamber_heat_transfer_coefficient(w_motor, pr, tk, t_w, p[P.STATOR], p[P.CELL_D_H], r, k)
            ha += h_cell * p[P.CELL_AREA_PER_V] * (v_a if port == 0 else v_b)
        heat[node] = p[P.WALL_HEAT] * ha * (t_w - tk)
    # U = c_v m T = p V / (k - 1): dp/dt = ((k - 1) dU/dt - p dV/dt) / V; T = p V / (m R)
    dp = ((k - 1.0) * (energy_rate + heat - pressures * dvol) - pressures * dvol) / volumes
    mass = pressures * volumes / (r * temperatures)
    dt = temperatures * (dp / pressures + dvol / volumes - mass_rate / mass)
    if not two_nodes:  # the valve node is the motor node: both columns follow it
        dp[1], dp[3], dt[1], dt[3] = dp[0], dp[2], dt[0], dt[2]
    return dp, dt


@dataclass(frozen=True)
class Command:
    """What the platform sends from `time_s` on (held until the next command)."""

    time_s: float
    direction: float  # -1, 0, +1
    valve_set_gauge_pa: float
    brake_release: float  # 0 or 1


@dataclass(frozen=True)
class Solution:
    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    p_a: np.ndarray  # motor-end pressure of port A, absolute Pa
    p_b: np.ndarray
    brake: np.ndarray  # engagement, 0 released .. 1 engaged
    stops: list[float]  # times at which the joint came to rest (located)
    t_a: np.ndarray  # motor-end gas temperature of port A, K
    t_b: np.ndarray


class _Joint:
    """The laws of one joint, evaluated in a given friction mode."""

    def __init__(self, p: np.ndarray, inertia_kg_m2: float, load_nm: float, supply_pa: float) -> None:
        self.p = p
        self.load = load_nm
        self.supply = supply_pa
        self.ratio = p[P.RATIO]
        self.rigid = is_rigid(p)
        self.inertia = inertia_kg_m2
        self.j_m, self.j_j = inertia_split(inertia_kg_m2, self.ratio**2 * p[P.ROTOR_J])
        self.k = stiffness(p[P.BACKLASH], p[P.COMPLIANCE])
        self.c = damping(self.k, self.j_m)
        self.half_gap = 0.5 * p[P.BACKLASH]

    def dry_limit(self, y: np.ndarray, omega: float) -> float:
        """Coulomb, the Stribeck excess at speed `omega` (the static level at 0), the engaged brake."""
        p = self.p
        excess = stribeck_excess(omega, p[P.STRIBECK_EXCESS], p[P.STRIBECK_SPEED])
        return p[P.COULOMB] + excess + y[BRAKE] * p[P.BRAKE_HOLD]

    def tau_t(self, y: np.ndarray) -> float:
        return transmitted_torque(y[QM] - y[THETA], y[WM] - y[OMEGA], self.half_gap, self.k, self.c)

    def joint_drive(self, y: np.ndarray, slide: float = 0.0) -> float:
        """Net torque on the joint side before its dry friction and viscous drag; a rigid gear's
        efficiency is the one of the direction the joint slides in (forward when stuck)."""
        drive = joint_torque(y[PA_M], y[PB_M], self.ratio * y[THETA], slide, self.p) if self.rigid else self.tau_t(y)
        return drive - self.load

    def motor_drive(self, y: np.ndarray, direction: float) -> float:
        return joint_torque(y[PA_M], y[PB_M], self.ratio * y[QM], direction, self.p)


class _Modes:
    """(joint mode, motor mode): +1/-1 sliding, 0 stuck. The rigid joint has no motor mode."""

    def __init__(self, joint: _Joint) -> None:
        self.j = joint

    def decide(self, y: np.ndarray, joint_mode: float, motor_mode: float) -> tuple[float, float]:
        """Modes at a point where a speed is zero or a breakaway fired: stuck if friction holds."""
        j = self.j
        if joint_mode == 0.0 or y[OMEGA] == 0.0:
            drive = j.joint_drive(y)
            limit = j.dry_limit(y, 0.0)
            joint_mode = 0.0 if abs(drive) <= limit else math.copysign(1.0, drive)
        if j.rigid:
            return joint_mode, joint_mode
        if motor_mode == 0.0 or y[WM] == 0.0:
            tau = j.tau_t(y)
            forward, backward = j.motor_drive(y, 1.0), j.motor_drive(y, -1.0)
            motor_mode = 1.0 if forward > tau else (-1.0 if backward < tau else 0.0)
        return joint_mode, motor_mode


def _rates(
    t, y, j: _Joint, modes: tuple[float, float], direction: float, valve_set: float, release: float
) -> np.ndarray:
    p = j.p
    s, s_m = modes
    out = np.zeros(N)
    limit = j.dry_limit(y, y[OMEGA])
    if s != 0.0:
        out[THETA] = y[OMEGA]
        out[OMEGA] = (j.joint_drive(y, s) - s * limit - p[P.VISCOUS] * y[OMEGA]) / (j.inertia if j.rigid else j.j_j)
    if j.rigid:
        out[QM], out[WM] = out[THETA], out[OMEGA]
        phi, w_motor = j.ratio * y[THETA], j.ratio * y[OMEGA]
    else:
        if s_m != 0.0:
            out[QM] = y[WM]
            out[WM] = (j.motor_drive(y, s_m) - j.tau_t(y)) / j.j_m
        phi, w_motor = j.ratio * y[QM], j.ratio * y[WM]
    if p[P.CHAMBER_HEAT] == 0.0:
        out[PA_V : PB_M + 1] = pressure_rates(
            y[PA_V], y[PA_M], y[PB_V], y[PB_M], phi, w_motor, direction, y[PV], j.supply, p
        )
    else:
        out[PA_V : PB_M + 1], out[TA_V : TB_M + 1] = energy_air_rates(
            p, y[PA_V : PB_M + 1], y[TA_V : TB_M + 1], phi, w_motor, direction, y[PV], j.supply
        )
    target = proportional_valve_target(valve_set, j.supply - p[P.GAS_P_ATM])
    out[PV] = (target - y[PV]) / p[P.VALVE_TAU] if p[P.VALVE_TAU] > 0.0 else 0.0
    feed = brake_feed_gauge_pa(p[P.BRAKE_FED_BY_MOTOR], j.supply, y[PA_M], y[PB_M], p[P.GAS_P_ATM])
    engage = brake_target(release, feed, p[P.BRAKE_START_PA], p[P.BRAKE_RELEASE_PA])
    tau = p[P.BRAKE_TAU_ON] if engage > y[BRAKE] else p[P.BRAKE_TAU_OFF]
    out[BRAKE] = (engage - y[BRAKE]) / tau
    return out


def _events(j: _Joint, modes: tuple[float, float]) -> list:
    """Terminal events that end the current modes, each tagged with what it means:
    ("joint" | "motor", the mode that follows: None = stuck or turned round, decided there; +-1 = breakaway)."""
    s, s_m = modes
    events = []

    def add(fn, direction, tag):
        fn.terminal = True
        fn.direction = direction
        fn.tag = tag
        events.append(fn)

    if s != 0.0:
        add(lambda t, y, *a: y[OMEGA], -s, ("joint", None))
    else:
        add(lambda t, y, *a: j.joint_drive(y) - j.dry_limit(y, 0.0), 1.0, ("joint", 1.0))
        add(lambda t, y, *a: -j.joint_drive(y) - j.dry_limit(y, 0.0), 1.0, ("joint", -1.0))
    if not j.rigid:
        if s_m != 0.0:
            add(lambda t, y, *a: y[WM], -s_m, ("motor", None))
        else:
            add(lambda t, y, *a: j.motor_drive(y, 1.0) - j.tau_t(y), 1.0, ("motor", 1.0))
            add(lambda t, y, *a: j.tau_t(y) - j.motor_drive(y, -1.0), 1.0, ("motor", -1.0))
    return events


def _breakpoints(commands: list[Command], delay_s: float, t_end_s: float) -> list[tuple[float, float, float, float]]:
    """(time, direction in effect, valve set point, brake release) from each change on."""
    changes = {0.0, t_end_s}
    for c in commands:
        changes.update((c.time_s, c.time_s + delay_s))
    points = sorted(t for t in changes if t <= t_end_s)

    def held(t):
        last = None
        for c in commands:
            if c.time_s <= t + 1e-12:
                last = c
        return last

    def direction_at(t):
        # the solenoid's position: the last command issued at least delay_s ago
        last = None
        for c in commands:
            if c.time_s + delay_s <= t + 1e-12:
                last = c
        return last.direction if last is not None else 0.0

    out = []
    for t in points[:-1]:
        c = held(t)
        out.append((t, direction_at(t), c.valve_set_gauge_pa if c else 0.0, c.brake_release if c else 0.0))
    out.append((points[-1], 0.0, 0.0, 0.0))
    return out


def _until_event(fun, t0: float, y0: np.ndarray, t1: float, events: list, t_eval: np.ndarray, atol: np.ndarray):
    """LSODA from t0 toward t1, stopped at the first event; (t, y, tags that fired, sample times,
    samples). The events are tested on the solver's own step ends and located by root finding on
    its dense output in between (scipy's solve_ivp roots them on the dense output alone, whose ends
    LSODA does not meet exactly; LSODA is needed for the stiff exhaust near atmosphere)."""
    solver = LSODA(fun, t0, y0, t1, rtol=1e-9, atol=atol, max_step=1e-3)
    g_old = [e(t0, y0) for e in events]
    ts, ys = [], []

    def sample(t_a, t_b, dense):
        inside = t_eval[(t_eval >= t_a) & (t_eval <= t_b)]
        if inside.size:
            ts.append(inside)
            ys.append(dense(inside))

    while True:
        t_prev = solver.t
        message = solver.step()
        assert solver.status != "failed", (message, t0, t1, t_prev, solver.t)
        t_new, y_new = solver.t, solver.y.copy()
        dense = solver.dense_output()
        g_new = [e(t_new, y_new) for e in events]
        roots = []
        for e, a, b in zip(events, g_old, g_new, strict=True):
            if (e.direction > 0 and a <= 0.0 < b) or (e.direction < 0 and a >= 0.0 > b):

                def h(t, e=e, a=a, b=b, t_prev=t_prev, t_new=t_new, dense=dense):
                    return a if t == t_prev else (b if t == t_new else e(t, dense(t)))

                roots.append((t_prev if a == 0.0 else brentq(h, t_prev, t_new, xtol=1e-13), e.tag))
        if roots:
            t_event = min(r for r, _ in roots)
            y_event = y_new if t_event == t_new else dense(t_event)
            sample(t_prev, t_event, dense)
            return t_event, y_event.copy(), [tag for r, tag in roots if r - t_event < 1e-9], ts, ys
        sample(t_prev, t_new, dense)
        if solver.status == "finished":
            return t_new, y_new, [], ts, ys
        g_old = g_new


def solve(
    p: np.ndarray,
    commands: list[Command],
    t_end_s: float,
    *,
    theta0_rad: float = 0.0,
    inertia_kg_m2: float,
    load_nm: float = 0.0,
    supply_pa: float,
    t_eval: np.ndarray,
) -> Solution:
    """The joint from rest (brake engaged, air at atmosphere) through `commands`, sampled at `t_eval`."""
    t_end_s = max(t_end_s, float(t_eval[-1]))  # a grid made by rounding may end a hair past t_end
    joint = _Joint(np.asarray(p, dtype=float), inertia_kg_m2, load_nm, supply_pa)
    modes = _Modes(joint)
    atm = p[P.GAS_P_ATM]
    t_w = p[P.GAS_T]
    y = np.array([theta0_rad, 0.0, atm, atm, atm, atm, 0.0, 1.0, theta0_rad, 0.0, t_w, t_w, t_w, t_w])
    mode = modes.decide(y, 0.0, 0.0)
    ts, ys, stops = [], [], []
    segments = _breakpoints(commands, p[P.SOLENOID_DELAY], t_end_s)
    atol = np.array([1e-10, 1e-9, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-10, 1e-10, 1e-9, 1e-6, 1e-6, 1e-6, 1e-6])
    for (t0, direction, valve_set, release), (t1, *_rest) in zip(segments, segments[1:], strict=False):
        t = t0
        while t1 - t > 1e-12:
            fun = lambda t_, y_, m=mode, d=direction, v=valve_set, r=release: _rates(t_, y_, joint, m, d, v, r)  # noqa: E731
            t_stop, y, fired, t_samples, y_samples = _until_event(fun, t, y, t1, _events(joint, mode), t_eval, atol)
            ts += t_samples
            ys += y_samples
            if fired:  # an event ended a mode
                s, s_m = mode
                for body, after in fired:
                    if body == "joint":
                        if after is None:  # the speed crossed zero: stick there, or turn round
                            y[OMEGA] = 0.0
                            s = modes.decide(y, 0.0, s_m)[0]
                            if s == 0.0:
                                stops.append(t_stop)
                        else:
                            s = after
                    else:
                        if after is None:
                            y[WM] = 0.0
                            s_m = modes.decide(y, s, 0.0)[1]
                        else:
                            s_m = after
                mode = (s, s if joint.rigid else s_m)
            t = t_stop
    t_all = np.concatenate(ts)
    y_all = np.concatenate(ys, axis=1)
    _, first = np.unique(t_all, return_index=True)
    t_all, y_all = t_all[first], y_all[:, first]
    return Solution(
        t_all, y_all[THETA], y_all[OMEGA], y_all[PA_M], y_all[PB_M], y_all[BRAKE], stops, y_all[TA_M], y_all[TB_M]
    )
