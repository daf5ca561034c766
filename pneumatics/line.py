"""A pneumatic line with gas inertia and wall friction: a hose that carries pressure waves.

The law (one-dimensional isothermal-area duct, convective terms dropped at Mach << 1):

    A d(rho)/dt + dm/dx = 0                                   (mass)
    dm/dt + A dp/dx + A (dp_f/dx)(m) = 0                      (momentum, wall friction dp_f)

with the gas stored by the chambers' own law (pneumatics/chamber.py): a node of volume V takes
dp = n R T dm / V, so a disturbance travels at c = sqrt(n R T). The friction drop dp_f of a
length dx is the steady Darcy-Weisbach law of pneumatics/darcy.py (Hagen-Poiseuille below the
Blasius crossover, Blasius above), reused through `hose_constants` and `hose_resistance_of`.

Wave speed: n is the line's polytropic exponent, k = 1.4 by default, so c = sqrt(k R T)
(343 m/s at 20 °C). A step's front, which sets the delay L/c and the exhaust's steps, is carried
by high frequencies, where the wall's thermal boundary layer is thin and the gas is adiabatic;
Bergh & Tijdeman's polytropic factor tends to k there. Below ~1 Hz in a 4 mm bore the gas in the
line tends to isothermal (c -> sqrt(R T)); docs/air_lines.md measures what the choice costs
against their frequency response.

Discretisation: a staggered finite-volume line, N segments of length dx = L / N. Node pressures
p_0..p_N at the segments' ends (node 0 at the inlet with volume A dx / 2; nodes 1..N-1 with A dx;
node N at the far end with A dx / 2 plus the end volume); segment mass flows m_0..m_{N-1} (kg/s,
positive toward the far end), each with the inertance dx / A. A sub-step of h is symplectic Euler
(the 1-D leapfrog / Yee scheme: exact transport at Courant number 1, stable up to it):

    m_j <- (m_j + h A/dx (p_j - p_{j+1})) / (1 + h A/dx R_j)      friction R_j = dp_f/m, implicit
    p_i <- p_i + h n R T / V_i (m_{i-1} - m_i)                    with the new flows

Mass is conserved to round-off: each flow leaves one node and enters the next in the same
sub-step. The ends are linearly implicit (the stiffness note of pneumatics/integrators.py): an
orifice into the inlet node and the far end's volume change and extra flow are taken at the
sub-step's end through their secant slopes, so a small node meeting a large orifice relaxes
without ringing. Why this and not the method of characteristics: docs/air_lines.md (mass to
round-off, a grid free of the physics step, the same node law as the chambers; measured accuracy
per cost).

Segments and sub-steps (`segments_for`, `substeps_for`): N = ceil(8 L f / c), at least
MIN_SEGMENTS: eight segments per wavelength at the top f of the band to resolve (BAND_HZ = 100 Hz
by default: 19 segments on 8 m, 7 on 3 m, 2 on 0.3 m; the plant's hoses PLANT_BAND_HZ = 50 Hz: 10 on
8 m, 4 on 3 m); over a physics step dt, M = ceil(c dt / dx)
sub-steps (Courant number c h / dx <= 1; one on 8 m at 0.5 ms, two on 0.3 m).

Limits: the momentum flux is dropped (Mach << 1), so the line is not for flows near sonic: a
valve whose effective area is a fair fraction of the bore's, opening a line at 7 bar to the
atmosphere, would drive it past sonic speed (checked up to a quarter of the bore's area).

Interface for a caller that steps the line every physics step (pneumatics/joint.py's hoses):

- parameters: `row = line_row(length_m, bore_m, temperature_k, r, n, mu_pa_s, segments)`, a float64
  row (columns LR_*); `segments_for(length_m, c_m_s)` picks the segments.
- state: `x = initial_line_state(row, p_pa)`, float64 of `state_size(row)` = 2 N + 1:
  x[0..N] node pressures (Pa absolute; x[0] the inlet node, x[N] the far end, the end volume's
  pressure), x[N+1..2N] segment mass flows (kg/s toward the far end). `far_end_pressure(x, row)`.
- each physics step of dt, one of (advancing x in place; M sub-steps of dt / M):
  `advance_from_pressure(x, row, dt_s, p_start_pa, p_end_pa, end)`: the inlet node follows the
  given pressure, linear over the step;
  `advance_from_orifice(x, row, dt_s, p_up_pa, area_m2, choked_flux, k, end)`: the inlet node is fed
  by an orifice from p_up (pneumatics/orifice.py: the valve's port or the exhaust throttle), held
  over the step; the inlet node is then the valve node of joint.py;
  `advance_from_flow(x, row, dt_s, mass_flow_kg_s, end)`: a given inflow into the inlet node;
  `advance_from_port(x, row, dt_s, p_up_pa, area_m2, vent_pa, vent_area_m2, choked_flux, k, end)`: an
  orifice inlet with a second orifice to `vent_pa` beside it (a leak at the valve's end of the hose).
  `end` is a `FarEnd`: the end volume (m^3) at the step's start and its rate (m^3/s) (a vane
  chamber's V and dV/dt), an extra inflow into it (kg/s, e.g. a leak, at the far-end pressure at
  the step's start) and that flow's slope -dm/dp (kg/(s·Pa), >= 0, taken implicitly); or
  `pinned_pa` > 0 holds the far end at that pressure (a chamber the caller integrates with the
  returned `end_flow_kg_s`); `polytropic_n` > 0 gives the far end's node its own exponent (a motor
  chamber's law, where the line's n = k sets the wave speed); `gas_rt` > 0 gives it an energy balance
  of its own gas (R T; a chamber by pneumatics/chamber.py's law: gas from the line at the line's
  temperature, the wall's, gas into the line at the far end's own, heat through `conductance_kg_s`).
  Each returns a `LineStep`: the mean mass flow into the line at the inlet and out of the last
  segment into the far end over the step (kg/s; their difference over dt is what the line stored),
  and with the far end's energy balance its gas's R T at the step's end and the step's heat and work.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pneumatics._jit import njit
from pneumatics.darcy import hose_constants, hose_resistance_of
from pneumatics.integrators import secant_slope
from pneumatics.orifice import orifice_mass_flow_with

BAND_HZ = 100.0  # the band a line resolves by default (docs/air_lines.md: accuracy per cost)
# the band the plant's hoses resolve (pneumatics/params.py): the arm's dynamics use up to 50 Hz; on this
# grid Bergh & Tijdeman's resonances below 50 Hz stay within 1 Hz and a step's delay within 1 ms of L/c
# on 0.3-8 m (docs/air_lines.md "In the plant", tests/test_line.py); 10 segments on 8 m against 19
PLANT_BAND_HZ = 50.0
SEGMENTS_PER_WAVELENGTH = 8  # at the band's top: the leapfrog's phase error there stays under ~1 %
MIN_SEGMENTS = 2  # a line is at least two segments (inlet node, one interior node, far end)

# columns of a line's parameter row
(
    LR_SEGMENTS,  # N, as a float
    LR_DX,  # segment length, m
    LR_AREA,  # bore area, m^2
    LR_RT,  # R T of the line's gas, J/kg
    LR_N,  # polytropic exponent of the nodes (c = sqrt(n R T))
    LR_K_LAMINAR,  # `hose_constants` of one segment
    LR_LAMINAR_LIMIT,
    LR_K_BLASIUS,
    LR_C,  # wave speed, m/s
    LR_UNSTEADY,  # 1: the wall shear's frequency-dependent part (Zielke through Schohl's terms) is on; 0: steady only
    LR_MU_R2,  # mu / R^2 of the line's gas and bore, 1/(m·s) times kg/m^3: nu / R^2 = LR_MU_R2 / rho
    LR_MU,  # dynamic viscosity, Pa·s
) = range(12)
N_LINE_ROW = 12
# the columns' names, in order (a caller that keeps a line's row inside its own names them so)
LINE_ROW_FIELDS = (
    "segments",
    "dx_m",
    "area_m2",
    "rt_j_kg",
    "polytropic_n",
    "k_laminar",
    "laminar_limit_kg_s",
    "k_blasius",
    "wave_speed_m_s",
    "unsteady",
    "mu_r2",
    "mu_pa_s",
)
assert len(LINE_ROW_FIELDS) == N_LINE_ROW

# Zielke's weighting function of laminar unsteady wall shear, W(tau) = sum m_k exp(-n_k tau) in the
# dimensionless time tau = nu t / R^2: Schohl's five terms (G. A. Schohl, "Improved approximate
# method for simulating frequency-dependent friction in transient laminar flow", J. Fluids Eng.
# 115(3), 1993, 420-424), within 4 % of Zielke's exact W for tau = 1e-5 to 0.3 (docs/air_lines.md)
UNSTEADY_M = (1.051, 2.358, 9.021, 29.47, 79.55)
UNSTEADY_N = (26.65, 100.0, 669.6, 6497.0, 57990.0)
N_UNSTEADY = 5

# inlet kinds of `_advance`
_INLET_PRESSURE, _INLET_ORIFICE, _INLET_FLOW = range(3)


class FarEnd(NamedTuple):
    """What closes the line's far end over a physics step (module docstring)."""

    volume_m3: float = 0.0  # end volume at the step's start (beside the line's own half segment)
    volume_rate_m3_s: float = 0.0  # its rate over the step
    inflow_kg_s: float = 0.0  # extra flow into the far end (a leak), at its pressure at the step's start
    inflow_slope_kg_s_pa: float = 0.0  # -d(inflow)/d(pressure) >= 0, taken implicitly
    pinned_pa: float = 0.0  # > 0: the far end held at this pressure (a chamber the caller integrates)
    # > 0: the polytropic exponent of the far end's node (a motor chamber's own law, pneumatics/joint.py);
    # 0: the line's, LR_N
    polytropic_n: float = 0.0
    # > 0: the far end's gas has a temperature of its own, R T (J/kg) at the step's start, and the far
    # end's node an energy balance (pneumatics/chamber.py, its exponent then the gas's k): gas from the
    # line brings the line's R T, gas into the line leaves at the far end's own (the line's wall brings
    # it to the line's temperature, `LineStep.entry_heat_w`); 0: the far end's gas is the line's
    gas_rt: float = 0.0
    inflow_rt: float = 0.0  # with `gas_rt`: the R T the extra inflow carries (either way; J/kg)
    # with `gas_rt`: h A / R of the far end's wall (kg/s), at the line's gas temperature: heat
    # h A (T_line - T) = conductance (R T_line - R T), from the sub-step's start, damped (`_energy_end`)
    conductance_kg_s: float = 0.0


class LineStep(NamedTuple):
    """Mean mass flows of a line over a physics step, kg/s."""

    inlet_flow_kg_s: float  # into the line at its inlet (into the inlet node)
    end_flow_kg_s: float  # out of the last segment into the far end
    # with a far end that has an energy balance (`FarEnd.gas_rt`), else 0: its gas's R T at the step's
    # end (J/kg), and over the step the mean heat from its wall (W), the mean heat the line's wall gave
    # the gas that entered the line from it, cp (T_line - T) per kg (W), and the mean work its gas did
    # on its moving wall (W): its internal energy p V / (k - 1) changed by the enthalpy it exchanged with
    # the line (cp T_line in, cp T out) and the extra inflow (cp T_inflow), plus heat, less work
    end_rt: float = 0.0
    end_heat_w: float = 0.0
    entry_heat_w: float = 0.0
    end_work_w: float = 0.0


@njit
def wave_speed(temperature_k: float, r: float, n: float) -> float:
    """c = sqrt(n R T), m/s: the speed of a small disturbance in the line's gas."""
    return math.sqrt(n * r * temperature_k)


@njit
def segments_for(length_m: float, c_m_s: float, band_hz: float = BAND_HZ) -> int:
    """Segments of a line: SEGMENTS_PER_WAVELENGTH per wavelength c / band_hz, at least MIN_SEGMENTS."""
    return max(MIN_SEGMENTS, int(math.ceil(SEGMENTS_PER_WAVELENGTH * length_m * band_hz / c_m_s - 1e-9)))


@njit
def line_row(
    length_m: float,
    bore_m: float,
    temperature_k: float,
    r: float,
    n: float,
    mu_pa_s: float,
    segments: int,
    unsteady: bool = True,
) -> np.ndarray:
    """A line's parameter row (columns LR_*): geometry, gas, the friction constants of one segment,
    and whether the wall shear has its frequency-dependent part (`unsteady`)."""
    row = np.zeros(N_LINE_ROW)
    dx = length_m / segments
    k_laminar, laminar_limit, k_blasius = hose_constants(dx, bore_m, mu_pa_s)
    row[LR_SEGMENTS] = segments
    row[LR_DX] = dx
    row[LR_AREA] = 0.25 * math.pi * bore_m * bore_m
    row[LR_RT] = r * temperature_k
    row[LR_N] = n
    row[LR_K_LAMINAR] = k_laminar
    row[LR_LAMINAR_LIMIT] = laminar_limit
    row[LR_K_BLASIUS] = k_blasius
    row[LR_C] = wave_speed(temperature_k, r, n)
    row[LR_UNSTEADY] = 1.0 if unsteady else 0.0
    row[LR_MU_R2] = mu_pa_s / (0.25 * bore_m * bore_m)
    row[LR_MU] = mu_pa_s
    return row


@njit
def state_size(row: np.ndarray) -> int:
    """Length of a line's state: N + 1 node pressures, N segment flows, and with unsteady friction
    N_UNSTEADY wall-shear terms per segment."""
    nseg = int(row[LR_SEGMENTS])
    return 2 * nseg + 1 + (N_UNSTEADY * nseg if row[LR_UNSTEADY] != 0.0 else 0)


@njit
def initial_line_state(row: np.ndarray, p_pa: float) -> np.ndarray:
    """A line at rest: every node at `p_pa`, no flow."""
    nseg = int(row[LR_SEGMENTS])
    x = np.zeros(state_size(row))
    x[: nseg + 1] = p_pa
    return x


@njit(inline="always")
def far_end_pressure(x: np.ndarray, row: np.ndarray) -> float:
    """The far end's pressure (the end volume's), Pa absolute."""
    return x[int(row[LR_SEGMENTS])]


@njit
def substeps_for(row: np.ndarray, dt_s: float) -> int:
    """Sub-steps over dt that keep the Courant number c h / dx at or below 1."""
    return max(1, int(math.ceil(row[LR_C] * dt_s / row[LR_DX] - 1e-9)))


@njit
def stored_mass(x: np.ndarray, row: np.ndarray, end_volume_m3: float) -> float:
    """The line's gas and its end volume's, kg, as the nodes' law counts it: sum V_i p_i / (n R T)
    (each kg that flows in raises p V by n R T; the true mass when n = 1)."""
    nseg = int(row[LR_SEGMENTS])
    v_seg = row[LR_AREA] * row[LR_DX]
    total = 0.5 * v_seg * (x[0] + x[nseg]) + end_volume_m3 * x[nseg]
    for i in range(1, nseg):
        total += v_seg * x[i]
    return total / (row[LR_N] * row[LR_RT])


@njit(inline="always")
def _decay_factors(tau: float) -> tuple[float, float, float, float, float]:
    # b_k = 1 / (1 + n_k tau) of Schohl's five terms over a sub-step of dimensionless length tau,
    # by one division: the product of the five denominators inverted, each b_k that inverse times
    # the other four (a pairwise tree of products)
    d0 = 1.0 + UNSTEADY_N[0] * tau
    d1 = 1.0 + UNSTEADY_N[1] * tau
    d2 = 1.0 + UNSTEADY_N[2] * tau
    d3 = 1.0 + UNSTEADY_N[3] * tau
    d4 = 1.0 + UNSTEADY_N[4] * tau
    d01 = d0 * d1
    d23 = d2 * d3
    d0123 = d01 * d23
    inv_all = 1.0 / (d0123 * d4)
    inv_0123 = inv_all * d4
    inv_01 = inv_0123 * d23
    inv_23 = inv_0123 * d01
    return inv_01 * d1, inv_01 * d0, inv_23 * d3, inv_23 * d2, inv_all * d0123


@njit(inline="always")
def _substep(x: np.ndarray, row: np.ndarray, h: float) -> None:
    # one sub-step h of the segments' momentum and the interior nodes' mass (symplectic Euler), in
    # one pass: segment j's new flow from p_j and p_{j+1} (neither moved yet), then node j from the
    # new flows of segments j - 1 and j. The wall shear is implicit in the new flow: its steady part
    # (`hose_resistance_of`, the hose's law) through its secant, its unsteady part (Zielke's convolution of
    # the acceleration, `UNSTEADY_M/N`) through the terms' backward-Euler update.
    nseg = int(row[LR_SEGMENTS])
    area = row[LR_AREA]
    h_a_dx = h * area / row[LR_DX]
    two_rt = 2.0 * row[LR_RT]  # 1 / rho = 2 R T / (p_j + p_{j+1})
    inv_area = 1.0 / area
    limit = row[LR_LAMINAR_LIMIT]
    inv_kl = 1.0 / row[LR_K_LAMINAR]
    inv_kb = 1.0 / row[LR_K_BLASIUS]
    unsteady = row[LR_UNSTEADY] != 0.0
    shear_gain = 4.0 * math.pi * row[LR_MU] * h  # h (A/dx) dx (4 mu / R^2): flow change per unit of sum y_k
    decay_scale = h * row[LR_MU_R2]  # h nu / R^2 = decay_scale / rho
    node_gain = h * row[LR_N] * row[LR_RT] / (area * row[LR_DX])
    terms = 2 * nseg + 1  # the first unsteady term's column; term k of segment j at terms + k nseg + j
    for j in range(nseg):
        pj = x[j]
        pk = x[j + 1]
        mj = x[nseg + 1 + j]
        rho_inv = two_rt / (pj + pk)
        resistance = hose_resistance_of(abs(mj), rho_inv, inv_kl, limit, inv_kb)
        num = mj + h_a_dx * (pj - pk)
        den = 1.0 + h_a_dx * resistance
        if unsteady:
            inv_rho_area = rho_inv * inv_area
            b0, b1, b2, b3, b4 = _decay_factors(decay_scale * rho_inv)
            y0 = x[terms + j]
            y1 = x[terms + nseg + j]
            y2 = x[terms + 2 * nseg + j]
            y3 = x[terms + 3 * nseg + j]
            y4 = x[terms + 4 * nseg + j]
            held = b0 * y0 + b1 * y1 + b2 * y2 + b3 * y3 + b4 * y4  # the terms decayed over the sub-step
            weight = (  # their response to the sub-step's change of velocity
                b0 * UNSTEADY_M[0] + b1 * UNSTEADY_M[1] + b2 * UNSTEADY_M[2] + b3 * UNSTEADY_M[3] + b4 * UNSTEADY_M[4]
            )
            num -= shear_gain * (held - weight * mj * inv_rho_area)
            den += shear_gain * weight * inv_rho_area
            m_new = num / den
            dv = (m_new - mj) * inv_rho_area
            x[terms + j] = b0 * (y0 + UNSTEADY_M[0] * dv)
            x[terms + nseg + j] = b1 * (y1 + UNSTEADY_M[1] * dv)
            x[terms + 2 * nseg + j] = b2 * (y2 + UNSTEADY_M[2] * dv)
            x[terms + 3 * nseg + j] = b3 * (y3 + UNSTEADY_M[3] * dv)
            x[terms + 4 * nseg + j] = b4 * (y4 + UNSTEADY_M[4] * dv)
        else:
            m_new = num / den
        x[nseg + 1 + j] = m_new
    for i in range(1, nseg):
        x[i] += node_gain * (x[nseg + i] - x[nseg + 1 + i])


@njit(inline="always")
def _advance(
    x: np.ndarray,
    row: np.ndarray,
    dt_s: float,
    kind: int,
    a: float,
    b: float,
    area_m2: float,
    choked_flux: float,
    k: float,
    end: FarEnd,
    vent_pa: float = 0.0,
    vent_area_m2: float = 0.0,
) -> LineStep:
    # the three inlets' common loop: `kind` picks how node 0 moves; (a, b) are the inlet's pressure
    # at the step's start and end, the orifice's upstream pressure (a), or the inflow (a); with an
    # orifice inlet, a second orifice of `vent_area_m2` to `vent_pa` (a leak at the inlet) beside it
    nseg = int(row[LR_SEGMENTS])
    substeps = substeps_for(row, dt_s)
    h = dt_s / substeps
    nrt = row[LR_N] * row[LR_RT]
    half_seg = 0.5 * row[LR_AREA] * row[LR_DX]
    inlet_gain = h * nrt / half_seg  # n R T h / V_0
    p_end_start = x[nseg]
    inlet_mass = 0.0
    end_mass = 0.0
    # a far end with an energy balance (`FarEnd.gas_rt`): its gas's mass and R T, and the step's heat and work
    energy = end.gas_rt > 0.0 and end.pinned_pa <= 0.0
    rt_end = end.gas_rt
    gas_mass = p_end_start * (half_seg + end.volume_m3) / rt_end if energy else 0.0
    heat_j = 0.0
    entry_j = 0.0
    work_j = 0.0
    for s in range(substeps):
        _substep(x, row, h)
        m_first = x[nseg + 1]
        m_last = x[2 * nseg]
        # inlet node
        if kind == _INLET_PRESSURE:
            p0 = x[0]
            x[0] = a + (b - a) * (s + 1) / substeps
            inlet_mass += h * m_first + (x[0] - p0) / (nrt / half_seg)
        elif kind == _INLET_ORIFICE:
            p0 = x[0]
            g = secant_slope(orifice_mass_flow_with(a, p0, area_m2, choked_flux, k), a - p0)
            gv = secant_slope(orifice_mass_flow_with(vent_pa, p0, vent_area_m2, choked_flux, k), vent_pa - p0)
            x[0] = (p0 + inlet_gain * (g * a + gv * vent_pa - m_first)) / (1.0 + inlet_gain * (g + gv))
            inlet_mass += h * g * (a - x[0]) + h * gv * (vent_pa - x[0])
        else:
            x[0] += inlet_gain * (a - m_first)
            inlet_mass += h * a
        end_mass += h * m_last
        # far end
        if end.pinned_pa > 0.0:
            x[nseg] = end.pinned_pa
            continue
        volume = half_seg + end.volume_m3 + end.volume_rate_m3_s * (s + 1) * h  # at the sub-step's end
        pn = x[nseg]
        extra = end.inflow_kg_s - end.inflow_slope_kg_s_pa * (pn - p_end_start)  # at the sub-step's start
        if energy:
            x[nseg], heat, entry, work = _energy_end(pn, rt_end, gas_mass, volume, h, m_last, extra, end, row)
            gas_mass += h * (m_last + extra + end.inflow_slope_kg_s_pa * (pn - x[nseg]))
            rt_end = x[nseg] * volume / gas_mass
            heat_j += h * heat
            entry_j += h * entry
            work_j += h * work
            continue
        gain = h * (end.polytropic_n if end.polytropic_n > 0.0 else row[LR_N]) / volume
        x[nseg] = (pn + gain * (row[LR_RT] * (m_last + extra + end.inflow_slope_kg_s_pa * pn))) / (
            1.0 + gain * (row[LR_RT] * end.inflow_slope_kg_s_pa + end.volume_rate_m3_s)
        )
    if not energy:
        return LineStep(inlet_mass / dt_s, end_mass / dt_s, 0.0, 0.0, 0.0, 0.0)
    return LineStep(inlet_mass / dt_s, end_mass / dt_s, rt_end, heat_j / dt_s, entry_j / dt_s, work_j / dt_s)


@njit(inline="always")
def _energy_end(
    pn: float,
    rt: float,
    gas_mass: float,
    volume: float,
    h: float,
    m_last: float,
    extra: float,
    end: FarEnd,
    row: np.ndarray,
) -> tuple[float, float, float, float]:
    # the far end's node by its energy balance over a sub-step h (pneumatics/chamber.py's law in
    # p V / (k - 1) = U, k its exponent): (new pressure, heat from the wall, heat the line's wall gives
    # the gas entering the line, work on the moving wall; W). Linearly implicit as the polytropic node:
    # d(p V) = k (R T_m m + R T_x e) h + (k - 1) Q h - k p_new dV h, the extra inflow's slope and the
    # volume's rate taken at the new pressure; the last segment's flow m brings the line's R T in and
    # takes the node's own R T out. The heat from the sub-step's starting temperature, damped as a
    # backward-Euler step of the gas's temperature under it alone, dT/dt = (k - 1) G (R T_w - R T) / M
    # with G = h A / R: stable for any wall (a short hose's small chamber, `wall_heat_scale` up to 10).
    k = end.polytropic_n if end.polytropic_n > 0.0 else row[LR_N]
    rt_line = row[LR_RT]
    rt_m = rt_line if m_last > 0.0 else rt
    g = end.conductance_kg_s
    heat = g * (rt_line - rt) / (1.0 + h * (k - 1.0) * g / gas_mass)
    slope = end.inflow_slope_kg_s_pa
    dv = end.volume_rate_m3_s
    gain = h * k / volume
    p_new = (pn + gain * (rt_m * m_last + end.inflow_rt * (extra + slope * pn) + (k - 1.0) / k * heat)) / (
        1.0 + gain * (end.inflow_rt * slope + dv)
    )
    gas_k = k / (k - 1.0)  # cp / R
    entry = gas_k * (rt_line - rt) * max(-m_last, 0.0)
    work = dv * (k * p_new - pn) / (k - 1.0)  # d(pV)/(k-1) less the enthalpy and heat it took in
    return p_new, heat, entry, work


@njit
def advance_from_pressure(
    x: np.ndarray, row: np.ndarray, dt_s: float, p_start_pa: float, p_end_pa: float, end: FarEnd
) -> LineStep:
    """Advance a line over dt in place, its inlet at a pressure going linearly from p_start to p_end."""
    return _advance(x, row, dt_s, _INLET_PRESSURE, p_start_pa, p_end_pa, 0.0, 0.0, 0.0, end)


@njit
def advance_from_orifice(
    x: np.ndarray,
    row: np.ndarray,
    dt_s: float,
    p_up_pa: float,
    area_m2: float,
    choked_flux: float,
    k: float,
    end: FarEnd,
) -> LineStep:
    """Advance a line over dt in place, its inlet node fed through an orifice of effective area
    `area_m2` from `p_up_pa` (either way: negative flow when the node is higher), held over the step;
    `choked_flux` and k as in `orifice_mass_flow_with`."""
    return _advance(x, row, dt_s, _INLET_ORIFICE, p_up_pa, 0.0, area_m2, choked_flux, k, end)


@njit
def advance_from_port(
    x: np.ndarray,
    row: np.ndarray,
    dt_s: float,
    p_up_pa: float,
    area_m2: float,
    vent_pa: float,
    vent_area_m2: float,
    choked_flux: float,
    k: float,
    end: FarEnd,
) -> LineStep:
    """`advance_from_orifice` with a second orifice of `vent_area_m2` from the inlet node to `vent_pa`
    beside the first (a leak at the hose's valve end, pneumatics/joint.py), both held over the step
    and implicit; the returned inlet flow is the two orifices' net flow into the line."""
    return _advance(x, row, dt_s, _INLET_ORIFICE, p_up_pa, 0.0, area_m2, choked_flux, k, end, vent_pa, vent_area_m2)


@njit
def advance_from_flow(x: np.ndarray, row: np.ndarray, dt_s: float, mass_flow_kg_s: float, end: FarEnd) -> LineStep:
    """Advance a line over dt in place, a given mass flow into its inlet node held over the step."""
    return _advance(x, row, dt_s, _INLET_FLOW, mass_flow_kg_s, 0.0, 0.0, 0.0, 0.0, end)
