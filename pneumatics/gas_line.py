"""A pneumatic line that carries pressure waves of finite amplitude: a hose as 1-D gas dynamics.

`pneumatics.hose.line_response` runs on it. Its stepping interface is the one of pneumatics/line.py
(the acoustic line the plant may step), so a caller can take either; docs/air_lines.md says what
is checked of each and how they differ.

The law (the one-dimensional Euler equations of an ideal gas in a duct of constant area A, with
the wall's friction and heat as sources; e.g. Shapiro, The Dynamics and Thermodynamics of
Compressible Fluid Flow, 1953, ch. 8 and 26):

    d(rho)/dt   + d(rho u)/dx          = 0
    d(rho u)/dt + d(rho u^2 + p)/dx    = -(4 / d) tau_w
    d(E)/dt     + d(u (E + p))/dx      = (4 / d) q_w,       E = p / (k - 1) + rho u^2 / 2

Why the full equations and not an acoustic line: at the arm's pressure ratios (1.5-7 bar against
the atmosphere) a step is not small. A compression steepens into a shock that outruns the sound
speed (a 7:1 step drives a shock at Mach ~1.7); an expansion spreads, its tail travels at u - c
with the local, colder gas's c, and the outflow at the open end chokes. docs/air_lines.md measures
what each term changes against a linear line.

- wall friction tau_w: the steady Darcy-Weisbach law of pneumatics/darcy.py (Hagen-Poiseuille
  below the Blasius crossover, Blasius above, `hose_resistance_with`) plus Zielke's frequency-
  dependent laminar wall shear (the convolution of the acceleration, Schohl's five exponentials),
  both implicit in the new momentum. Friction's work stays in the gas (E is not touched by it).
- wall heat q_w = h (T_wall - T), h from the duct law of pneumatics/heat.py
  (`duct_heat_transfer_coefficient`: Dittus-Boelter on the local speed, the laminar duct's floor),
  the wall at the line's `temperature_k` (the hose is a heat sink that stays at room temperature).
- wave speed: from the local state, c = sqrt(k p / rho); nothing fitted.

Discretisation: a conservative finite-volume scheme, N - 2 cells of length dx = L / (N - 1) between
the two ends' half-cell plenums. Cell averages
of (rho, rho u, E); at each face the HLLC approximate Riemann solver (Toro, Riemann Solvers and
Numerical Methods for Fluid Dynamics, 3rd ed., 2009, sec. 10.4, Davis' wave speeds) of states
reconstructed linearly from the cells' primitive variables (rho, u, p) with van Leer's limiter
(MUSCL, second order in space, first order in the cells next to the ends), Heun's two-stage SSP Runge-Kutta
in time (second order), sub-steps at a Courant number <= COURANT of the fastest wave the last
sub-step saw. The valve's flow into the inlet plenum is a source inside each stage; friction, heat
and the far end's leak and volume change are split after each sub-step (Lie). Mass
and energy are conserved to round-off: every face's flux leaves one cell and enters the next.

Ends: each end is a plenum, half a cell of the line (the far one with the end volume beside it)
holding its gas at rest, that the first and last full cells meet as an open end: the face's state
is where the wave from the full cell meets the plenum's pressure (the exact half-Riemann state:
a shock above the cell's pressure, an isentropic rarefaction below, Toro ch. 4). Gas flowing out of
a plenum into the line expands isentropically from the plenum at rest (at most to the sonic speed:
choked inflow); gas flowing out of the line into a plenum arrives as a jet at the plenum's static
pressure (its kinetic energy becomes the plenum's heat), choked at the face when the rarefaction
reaches its sonic point. This is the open-end condition of duct gas dynamics (e.g. Winterbone &
Pearson, Theory of Engine Manifold Design, 2000, ch. 7); a closed end without an end volume is a
half-cell plenum too.

- inlet at a given pressure (`advance_from_pressure`, `line_response`'s measured near-end
  pressure): the inlet plenum is held at that pressure and the line's temperature (a stagnation
  state: the measured pressure is read as the fitting's, where the gas is nearly at rest).
- inlet through an orifice (`advance_from_orifice`, the valve of joint.py) or a given flow
  (`advance_from_flow`): the inlet plenum is the valve node; the valve's flow adds or takes mass and
  energy from it inside each Runge-Kutta stage (inflow at the enthalpy of the upstream gas, whose
  temperature `choked_flux` names; outflow at the plenum's own temperature and through its own
  choked flux), linearly implicit through the flow's secant slope so a small plenum meeting a large
  valve relaxes without ringing (the stiffness note of pneumatics/integrators.py).
- far end: the plenum of half a cell and the end volume (m^3), moving at its rate (work p dV on the
  gas), with an extra inflow (a leak) at the line's temperature or out at the plenum's, implicit in
  its slope; or `pinned_pa` > 0: the plenum held at that pressure and the line's temperature.

Cells and sub-steps (`segments_for`, `substeps_for`): N = ceil(CELLS_PER_WAVELENGTH L f / c), at
least MIN_SEGMENTS, for the band f to resolve (BAND_HZ by default), cell length L / (N - 1) (the two
end plenums are half cells); sub-steps over a physics step dt:
M = ceil(s dt / (COURANT dx)), s the fastest wave speed |u| + c last seen (c at the line's
temperature at rest).

Interface for a caller that steps the line every physics step (pneumatics/joint.py's hoses):

- parameters: `row = line_row(length_m, bore_m, temperature_k, r, n, mu_pa_s, segments, unsteady,
  heat)`, a float64 row (columns LR_*; n is the gas's ratio of specific heats k);
  `segments_for(length_m, c_m_s)` picks the segments.
- state: `x = initial_line_state(row, p_pa)`, float64 of `state_size(row)`: the cells' (rho, rho u,
  E), the unsteady friction's terms, and working space (module `_layout`). Read it through
  `far_end_pressure(x, row)`, `far_end_temperature(x, row)`, `cell_pressures(x, row)`,
  `stored_mass(x, row, end_volume_m3)`, `stored_energy`.
- each physics step of dt, one of (advancing x in place):
  `advance_from_pressure(x, row, dt_s, p_start_pa, p_end_pa, end)`: the inlet face at a pressure
  going linearly from p_start to p_end over the step;
  `advance_from_orifice(x, row, dt_s, p_up_pa, area_m2, choked_flux, k, end)`: the first cell fed by
  an orifice from p_up (pneumatics/orifice.py: the valve's port or the exhaust throttle), held over
  the step; `choked_flux` is the upstream gas's (`pneumatics.orifice.choked_flux` at its temperature);
  `advance_from_flow(x, row, dt_s, mass_flow_kg_s, end)`: a given inflow into the first cell, at the
  line's temperature (an outflow at the cell's).
  `end` is a `FarEnd`: the end volume (m^3) at the step's start and its rate (m^3/s) (a vane
  chamber's V and dV/dt), an extra inflow into it (kg/s, e.g. a leak, at the far-end pressure at
  the step's start) and that flow's slope -dm/dp (kg/(s·Pa), >= 0, taken implicitly); or
  `pinned_pa` > 0 holds the chamber beyond the far end at that pressure (a chamber the caller
  integrates with the returned `end_flow_kg_s`).
  Each returns a `LineStep`: the mean mass flow into the line at the inlet and into the far end's
  cell through its face (into the pinned chamber when pinned) over the step (kg/s). (The far end's
  plenum has its own energy here: `FarEnd.gas_rt` and its fields, the acoustic line's, are not used.)
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pneumatics._jit import njit
from pneumatics.darcy import hose_constants, hose_resistance_with
from pneumatics.heat import duct_heat_transfer_coefficient
from pneumatics.integrators import secant_slope
from pneumatics.line import N_UNSTEADY, UNSTEADY_M, UNSTEADY_N, FarEnd, LineStep, wave_speed
from pneumatics.orifice import choked_flux, orifice_mass_flow_with

BAND_HZ = 100.0  # the band a line resolves by default (docs/air_lines.md: accuracy per cost)
CELLS_PER_WAVELENGTH = 24  # at the band's top: Bergh & Tijdeman's resonances within 2.5 % (docs/air_lines.md)
MIN_SEGMENTS = 3  # a line is at least three cells (inlet cell, one interior cell, far-end cell)
COURANT = 0.8  # sub-steps' Courant number: Heun with limited MUSCL is stable to 1 (Toro sec. 13.4)

# columns of a line's parameter row
(
    LR_SEGMENTS,  # N cells, as a float
    LR_DX,  # cell length, m
    LR_AREA,  # bore area, m^2
    LR_RT,  # R T0 of the line's gas at its wall's (and supply's) temperature, J/kg
    LR_N,  # the gas's ratio of specific heats k
    LR_K_LAMINAR,  # `hose_constants` of one cell
    LR_LAMINAR_LIMIT,
    LR_K_BLASIUS,
    LR_C,  # sound speed at T0, m/s
    LR_UNSTEADY,  # 1: the wall shear's frequency-dependent part (Zielke through Schohl's terms) is on; 0: steady only
    LR_MU_R2,  # mu / R^2 of the line's gas and bore, kg/(m^3 s): nu / R^2 = LR_MU_R2 / rho
    LR_MU,  # dynamic viscosity, Pa·s
    LR_R,  # specific gas constant, J/(kg K)
    LR_BORE,  # bore, m
    LR_HEAT,  # 1: heat between the gas and the wall (`duct_heat_transfer_coefficient`); 0: adiabatic wall
) = range(15)
N_LINE_ROW = 15

# Zielke's weighting function through Schohl's terms: UNSTEADY_M, UNSTEADY_N (pneumatics/line.py)

# inlet kinds of `_advance`
_INLET_PRESSURE, _INLET_ORIFICE, _INLET_FLOW = range(3)


@njit
def segments_for(length_m: float, c_m_s: float, band_hz: float = BAND_HZ) -> int:
    """Cells of a line: CELLS_PER_WAVELENGTH per wavelength c / band_hz, at least MIN_SEGMENTS."""
    return max(MIN_SEGMENTS, int(math.ceil(CELLS_PER_WAVELENGTH * length_m * band_hz / c_m_s - 1e-9)))


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
    heat: bool = True,
) -> np.ndarray:
    """A line's parameter row (columns LR_*): geometry, gas (n = its ratio of specific heats), the
    friction constants of one cell, whether the wall shear has its frequency-dependent part
    (`unsteady`) and whether the gas exchanges heat with the wall (`heat`)."""
    row = np.zeros(N_LINE_ROW)
    dx = length_m / (segments - 1.0)  # the two ends' half cells and N - 2 full cells between them
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
    row[LR_R] = r
    row[LR_BORE] = bore_m
    row[LR_HEAT] = 1.0 if heat else 0.0
    return row


class _Layout(NamedTuple):
    # where the parts of a line's state are: the cells' (rho, rho u, E) are x[0:3N], then
    nseg: int  # N, the cells
    terms: int  # the unsteady friction's terms
    speed: int  # the fastest wave speed's slot
    start: int  # the sub-step's start copy of the cells (3 N)
    prim: int  # the primitive variables' working space (3 N)


@njit(inline="always")
def _layout(row: np.ndarray) -> _Layout:
    # the line's state's layout (`_Layout`) for its parameter row
    nseg = int(row[LR_SEGMENTS])
    terms = 3 * nseg
    speed = terms + (N_UNSTEADY * nseg if row[LR_UNSTEADY] != 0.0 else 0)
    return _Layout(nseg, terms, speed, speed + 1, speed + 1 + 3 * nseg)


@njit
def state_size(row: np.ndarray) -> int:
    """Length of a line's state: 3 N cell averages, with unsteady friction N_UNSTEADY wall-shear
    terms per cell, the fastest wave speed, and 6 N of working space."""
    layout = _layout(row)
    return layout.prim + 3 * layout.nseg


@njit
def initial_line_state(row: np.ndarray, p_pa: float) -> np.ndarray:
    """A line at rest: every cell at `p_pa` and the line's temperature, no flow."""
    layout = _layout(row)
    nseg, speed = layout.nseg, layout.speed
    x = np.zeros(state_size(row))
    x[:nseg] = p_pa / row[LR_RT]
    x[2 * nseg : 3 * nseg] = p_pa / (row[LR_N] - 1.0)
    x[speed] = row[LR_C]
    return x


@njit(inline="always")
def _pressure(x: np.ndarray, nseg: int, i: int, gm1: float) -> float:
    rho = x[i]
    q = x[nseg + i]
    return gm1 * (x[2 * nseg + i] - 0.5 * q * q / rho)


@njit(inline="always")
def far_end_pressure(x: np.ndarray, row: np.ndarray) -> float:
    """The far end's pressure (its cell's, which holds the end volume), Pa absolute."""
    nseg = int(row[LR_SEGMENTS])
    return _pressure(x, nseg, nseg - 1, row[LR_N] - 1.0)


@njit
def far_end_temperature(x: np.ndarray, row: np.ndarray) -> float:
    """The far end's gas temperature, K."""
    nseg = int(row[LR_SEGMENTS])
    return far_end_pressure(x, row) / (x[nseg - 1] * row[LR_R])


@njit
def cell_pressures(x: np.ndarray, row: np.ndarray) -> np.ndarray:
    """The cells' pressures, Pa absolute, inlet first."""
    nseg = int(row[LR_SEGMENTS])
    return np.array([_pressure(x, nseg, i, row[LR_N] - 1.0) for i in range(nseg)])


@njit
def substeps_for(row: np.ndarray, dt_s: float, speed_m_s: float = 0.0) -> int:
    """Sub-steps over dt that keep the Courant number s h / dx at or below COURANT, s the fastest
    wave speed (the sound speed at rest when not given)."""
    s = max(speed_m_s, row[LR_C])
    return max(1, int(math.ceil(s * dt_s / (COURANT * row[LR_DX]) - 1e-9)))


@njit
def stored_mass(x: np.ndarray, row: np.ndarray, end_volume_m3: float) -> float:
    """The gas in the line and its end volume, kg."""
    nseg = int(row[LR_SEGMENTS])
    v_cell = row[LR_AREA] * row[LR_DX]
    return v_cell * (np.sum(x[1 : nseg - 1]) + 0.5 * x[0]) + (0.5 * v_cell + end_volume_m3) * x[nseg - 1]


@njit
def stored_energy(x: np.ndarray, row: np.ndarray, end_volume_m3: float) -> float:
    """The gas's internal and kinetic energy in the line and its end volume, J."""
    nseg = int(row[LR_SEGMENTS])
    v_cell = row[LR_AREA] * row[LR_DX]
    e = x[2 * nseg : 3 * nseg]
    return v_cell * (np.sum(e[1 : nseg - 1]) + 0.5 * e[0]) + (0.5 * v_cell + end_volume_m3) * e[nseg - 1]


# --- the gas dynamics --------------------------------------------------------------------------
@njit(inline="always")
def _euler_flux(rho: float, u: float, p: float, gm1: float) -> tuple[float, float, float]:
    m = rho * u
    return m, m * u + p, u * (p / gm1 + 0.5 * m * u + p)


@njit(inline="always")
def _hllc(
    rl: float, ul: float, pl: float, rr: float, ur: float, pr: float, k: float
) -> tuple[float, float, float, float]:
    # Toro's HLLC flux (sec. 10.4) with Davis' wave speeds, and the fastest |wave speed|
    gm1 = k - 1.0
    cl = math.sqrt(k * pl / rl)
    cr = math.sqrt(k * pr / rr)
    sl = min(ul - cl, ur - cr)
    sr = max(ul + cl, ur + cr)
    fastest = max(-sl, sr)
    if sl >= 0.0:
        f0, f1, f2 = _euler_flux(rl, ul, pl, gm1)
        return f0, f1, f2, fastest
    if sr <= 0.0:
        f0, f1, f2 = _euler_flux(rr, ur, pr, gm1)
        return f0, f1, f2, fastest
    ml = rl * (sl - ul)
    mr = rr * (sr - ur)
    s_star = (pr - pl + ml * ul - mr * ur) / (ml - mr)
    if s_star >= 0.0:
        rho, u, p, s, m = rl, ul, pl, sl, ml
    else:
        rho, u, p, s, m = rr, ur, pr, sr, mr
    f0, f1, f2 = _euler_flux(rho, u, p, gm1)
    e = p / gm1 + 0.5 * rho * u * u
    scale = m / (s - s_star)  # rho_K (s_K - u_K) / (s_K - s*)
    u0 = scale
    u1 = scale * s_star
    u2 = scale * (e / rho + (s_star - u) * (s_star + p / m))
    return f0 + s * (u0 - rho), f1 + s * (u1 - rho * u), f2 + s * (u2 - e), fastest


@njit(inline="always")
def _wave_speed_behind(p_b: float, rho: float, u: float, p: float, k: float) -> float:
    # the gas speed where a right-facing wave from the state (rho, u, p) reaches p_b: Toro's f_K
    # (sec. 4.2), a shock above p, an isentropic rarefaction below
    if p_b > p:
        a = 2.0 / ((k + 1.0) * rho)
        b = (k - 1.0) / (k + 1.0) * p
        return u + (p_b - p) * math.sqrt(a / (p_b + b))
    c = math.sqrt(k * p / rho)
    return u + 2.0 * c / (k - 1.0) * (math.exp(math.log(p_b / p) * (k - 1.0) / (2.0 * k)) - 1.0)


@njit(inline="always")
def _plenum_inflow(
    p0: float, rho: float, u: float, p: float, k: float, rt0: float
) -> tuple[float, float, float, float]:
    # the flux of gas flowing from a plenum at rest at (p0, T0 = rt0 / R) isentropically into a line
    # whose first cell is (rho, u, p): the face's speed is where the plenum's isentrope p(u) =
    # p0 (1 - (k - 1) u^2 / (2 c0^2))^(k / (k - 1)) meets the right-facing wave from the cell
    # (`_wave_speed_behind`), found by the Illinois method; at most sonic (choked inflow)
    gm1 = k - 1.0
    c0_sq = k * rt0
    u_sonic = math.sqrt(2.0 * c0_sq / (k + 1.0))

    def residual(v: float) -> float:
        pv = p0 * math.exp(math.log(1.0 - 0.5 * gm1 * v * v / c0_sq) * k / gm1)
        return v - _wave_speed_behind(pv, rho, u, p, k)

    lo, hi = 0.0, u_sonic
    r_lo, r_hi = residual(lo), residual(hi)
    v = hi
    if r_hi > 0.0:
        side = 0
        for _ in range(60):
            v = (lo * r_hi - hi * r_lo) / (r_hi - r_lo)
            r = residual(v)
            if abs(r) < 1e-9 * u_sonic:
                break
            if r > 0.0:
                hi, r_hi = v, r
                if side == -1:
                    r_lo *= 0.5
                side = -1
            else:
                lo, r_lo = v, r
                if side == 1:
                    r_hi *= 0.5
                side = 1
    t_ratio = 1.0 - 0.5 * gm1 * v * v / c0_sq  # T / T0
    p_b = p0 * math.exp(math.log(t_ratio) * k / gm1)
    rho_b = p_b / (rt0 * t_ratio)
    m = rho_b * v
    return m, m * v + p_b, m * k / gm1 * rt0, v + math.sqrt(k * p_b / rho_b)


@njit(inline="always")
def _pressure_face(
    p_b: float, rho: float, u: float, p: float, k: float, rt0: float
) -> tuple[float, float, float, float]:
    # the flux through the inlet face of a line whose first cell is (rho, u, p) when the face is at
    # p_b (module docstring: the half-Riemann state, inflow from a plenum at R T0 = rt0, choked outflow)
    gm1 = k - 1.0
    c = math.sqrt(k * p / rho)
    if u + c <= 0.0:  # supersonic outflow: the cell's state leaves as it is
        f0, f1, f2 = _euler_flux(rho, u, p, gm1)
        return f0, f1, f2, c - u
    u_b = _wave_speed_behind(p_b, rho, u, p, k)
    if u_b > 0.0:
        return _plenum_inflow(p_b, rho, u, p, k, rt0)
    # outflow: the gas behind the wave, a shock's or the rarefaction's (choked at its sonic point)
    ratio = p_b / p
    if ratio > 1.0:
        g = gm1 / (k + 1.0)
        rho_b = rho * (ratio + g) / (g * ratio + 1.0)
        f0, f1, f2 = _euler_flux(rho_b, u_b, p_b, gm1)
        return f0, f1, f2, -u_b + math.sqrt(k * p_b / rho_b)
    c_b = c * math.exp(math.log(ratio) * gm1 / (2.0 * k))
    if u_b < -c_b:  # the fan's sonic point sits at the face: u = -c there, on the cell's Riemann invariant
        c_b = (2.0 * c / gm1 - u) * gm1 / (k + 1.0)
        u_b = -c_b
        ratio = math.exp(math.log(c_b / c) * 2.0 * k / gm1)
    rho_b = rho * math.exp(math.log(ratio) / k)
    f0, f1, f2 = _euler_flux(rho_b, u_b, p * ratio, gm1)
    return f0, f1, f2, c_b - u_b


@njit(inline="always")
def _van_leer(a: float, b: float) -> float:
    if a * b <= 0.0:
        return 0.0
    return 2.0 * a * b / (a + b)


@njit(inline="always")
def _face_states(x: np.ndarray, prim: int, nseg: int, i: int) -> tuple[float, float, float, float, float, float]:
    # the states either side of the face between cells i and i + 1: each cell's primitive variables
    # moved half a cell along their van Leer-limited slope (none in the end cells); back to the
    # cells' own where a reconstruction would not be positive
    r0, u0, p0 = x[prim + i], x[prim + nseg + i], x[prim + 2 * nseg + i]
    r1, u1, p1 = x[prim + i + 1], x[prim + nseg + i + 1], x[prim + 2 * nseg + i + 1]
    rl, ul, pl, rr, ur, pr = r0, u0, p0, r1, u1, p1
    if i >= 2:  # cell 1 meets the inlet's plenum through its own average: no slope there
        rl += 0.5 * _van_leer(r0 - x[prim + i - 1], r1 - r0)
        ul += 0.5 * _van_leer(u0 - x[prim + nseg + i - 1], u1 - u0)
        pl += 0.5 * _van_leer(p0 - x[prim + 2 * nseg + i - 1], p1 - p0)
    if i + 3 < nseg:  # nor in the last full cell, which meets the far plenum through its own average
        rr -= 0.5 * _van_leer(r1 - r0, x[prim + i + 2] - r1)
        ur -= 0.5 * _van_leer(u1 - u0, x[prim + nseg + i + 2] - u1)
        pr -= 0.5 * _van_leer(p1 - p0, x[prim + 2 * nseg + i + 2] - p1)
    if rl <= 0.0 or pl <= 0.0:
        rl, ul, pl = r0, u0, p0
    if rr <= 0.0 or pr <= 0.0:
        rr, ur, pr = r1, u1, p1
    return rl, ul, pl, rr, ur, pr


@njit(inline="always")
def _valve_flow(
    kind: int,
    a: float,
    area_m2: float,
    flux_up: float,
    t_up: float,
    rho: float,
    p: float,
    h: float,
    volume: float,
    row: np.ndarray,
) -> tuple[float, float]:
    # the flow into the inlet's plenum (rho, p) of `volume` (kg/s) and the enthalpy it carries (J/kg):
    # through the valve from a (inflow at the upstream gas's T_up, outflow through the plenum gas's own
    # choked flux), linearly implicit over h through its secant slope (dp = k R T dm / V, so a small
    # plenum meeting a large valve relaxes without ringing), or the given flow a
    k = row[LR_N]
    r = row[LR_R]
    t_cell = p / (rho * r)
    if kind == _INLET_FLOW:
        return a, k / (k - 1.0) * r * (row[LR_RT] / r if a >= 0.0 else t_cell)
    inflow = a >= p
    flux = flux_up if inflow else choked_flux(t_cell, r, k)
    t_in = t_up if inflow else t_cell
    g = secant_slope(orifice_mass_flow_with(a, p, area_m2, flux, k), a - p)
    return g * (a - p) / (1.0 + g * k * r * t_in * h / volume), k / (k - 1.0) * r * t_in


@njit
def _hyperbolic_stage(
    x: np.ndarray,
    row: np.ndarray,
    h: float,
    blend: float,
    kind: int,
    p_b: float,
    area_m2: float,
    flux_up: float,
    t_up: float,
    end_volume: float,
    pinned: float,
) -> tuple[float, float, float]:
    # one Heun stage of the gas dynamics: U <- blend U0 + (1 - blend) (U + h L(U)); returns the mass
    # flows (kg/s) through the inlet face and into the far end (the far cell's inner face, or its outer
    # face into a pinned chamber), and the fastest wave. With an end volume the far cell is a plenum
    # (its segment and the end volume, gas at rest) that the line enters as an open end
    layout = _layout(row)
    nseg, start, prim = layout.nseg, layout.start, layout.prim
    k = row[LR_N]
    gm1 = k - 1.0
    area = row[LR_AREA]
    v_cell = area * row[LR_DX]
    last = nseg - 1
    if kind == _INLET_PRESSURE:  # the inlet's plenum at the given pressure and the line's temperature
        x[0] = p_b / row[LR_RT]
        x[nseg] = 0.0
        x[2 * nseg] = p_b / gm1
    for i in range(nseg):
        rho = x[i]
        u = x[nseg + i] / rho
        x[prim + i] = rho
        x[prim + nseg + i] = u
        x[prim + 2 * nseg + i] = gm1 * (x[2 * nseg + i] - 0.5 * rho * u * u)
    # out of the inlet's plenum into the first full cell (an open end at the plenum's pressure)
    p_in = x[prim + 2 * nseg]
    f0, f1, f2, fastest = _pressure_face(
        p_in, x[prim + 1], x[prim + nseg + 1], x[prim + 2 * nseg + 1], k, p_in / x[prim]
    )
    inlet_flow = f0 * area
    if kind != _INLET_PRESSURE:  # the plenum gives the mass and energy, at rest, and takes the valve's
        inlet_flow, enthalpy = _valve_flow(kind, p_b, area_m2, flux_up, t_up, x[prim], p_in, h, 0.5 * v_cell, row)
        gain = h / (0.5 * v_cell)
        x[0] = blend * x[start] + (1.0 - blend) * (x[0] + gain * (inlet_flow - area * f0))
        j = 2 * nseg
        x[j] = blend * x[start + j] + (1.0 - blend) * (x[j] + gain * (inlet_flow * enthalpy - area * f2))
    gain = h * area / v_cell
    for face in range(2, nseg):  # the face between cells face - 1 and face
        if face < last:
            rl, ul, pl, rr, ur, pr = _face_states(x, prim, nseg, face - 1)
            g0, g1, g2, s = _hllc(rl, ul, pl, rr, ur, pr, k)
        else:  # into the far end's plenum: its pressure at the face, the inlet's state mirrored
            rl, ul, pl = x[prim + last - 1], x[prim + nseg + last - 1], x[prim + 2 * nseg + last - 1]
            if pinned > 0.0:
                p_end, rt_end = pinned, row[LR_RT]
            else:
                p_end = x[prim + 2 * nseg + last]
                rt_end = p_end / x[prim + last]
            g0, g1, g2, s = _pressure_face(p_end, rl, -ul, pl, k, rt_end)
            g0, g2 = -g0, -g2
        fastest = max(fastest, s)
        i = face - 1
        x[i] = blend * x[start + i] + (1.0 - blend) * (x[i] + gain * (f0 - g0))
        j = nseg + i
        x[j] = blend * x[start + j] + (1.0 - blend) * (x[j] + gain * (f1 - g1))
        j += nseg
        x[j] = blend * x[start + j] + (1.0 - blend) * (x[j] + gain * (f2 - g2))
        f0, f1, f2 = g0, g1, g2
    if pinned <= 0.0:  # the far plenum (half a cell and the end volume) takes the mass and energy, at rest
        gain = h * area / (0.5 * v_cell + end_volume)
        x[last] = blend * x[start + last] + (1.0 - blend) * (x[last] + gain * f0)
        j = 2 * nseg + last
        x[j] = blend * x[start + j] + (1.0 - blend) * (x[j] + gain * f2)
    return inlet_flow, f0 * area, fastest


@njit(inline="always")
def _add_flow(x: np.ndarray, nseg: int, i: int, volume: float, mass: float, t_in_k: float, row: np.ndarray) -> None:
    # `mass` (kg, + in) into cell i of `volume`: an inflow at the enthalpy cp T_in with no momentum;
    # an outflow takes its share of the cell's momentum and its enthalpy at the cell's temperature
    k = row[LR_N]
    cp = k / (k - 1.0) * row[LR_R]
    rho = x[i]
    if mass >= 0.0:
        x[2 * nseg + i] += mass * cp * t_in_k / volume
    else:
        u = x[nseg + i] / rho
        p = _pressure(x, nseg, i, k - 1.0)
        x[nseg + i] += mass * u / volume
        x[2 * nseg + i] += mass * (cp * p / (rho * row[LR_R]) + 0.5 * u * u) / volume
    x[i] = rho + mass / volume


@njit
def _wall_sources(x: np.ndarray, row: np.ndarray, h: float, end_volume: float) -> None:
    # the wall's shear (steady Darcy-Weisbach through its secant, Zielke's unsteady part through
    # Schohl's terms, both implicit in the new momentum, against the acceleration over the whole
    # sub-step since the start copy) and heat (explicit: its time, ~ms, is far above a sub-step)
    layout = _layout(row)
    nseg, terms, start = layout.nseg, layout.terms, layout.start
    area = row[LR_AREA]
    dx = row[LR_DX]
    k = row[LR_N]
    r = row[LR_R]
    t_wall = row[LR_RT] / r
    bore = row[LR_BORE]
    kl, limit, kb = row[LR_K_LAMINAR], row[LR_LAMINAR_LIMIT], row[LR_K_BLASIUS]
    unsteady = row[LR_UNSTEADY] != 0.0
    heat = row[LR_HEAT] != 0.0
    shear = 4.0 * row[LR_MU_R2]  # wall force per volume per unit of sum y_k (4 mu / R^2)
    for i in range(nseg):
        # the share of the cell's gas that is in the line (the far end's half cell also holds the end volume)
        share = 1.0 if i < nseg - 1 else 0.5 * area * dx / (0.5 * area * dx + end_volume)  # the inlet's: all line
        rho = x[i]
        q = x[nseg + i]
        resistance = hose_resistance_with(q * area, rho, kl, limit, kb)
        den = 1.0 + h * resistance * area / dx * share
        num = q
        if unsteady:
            u_before = x[start + nseg + i] / x[start + i]
            tau = h * row[LR_MU_R2] / rho
            held = 0.0
            weight = 0.0
            for j in range(N_UNSTEADY):
                b = 1.0 / (1.0 + UNSTEADY_N[j] * tau)
                held += b * x[terms + j * nseg + i]
                weight += b * UNSTEADY_M[j]
            num -= h * shear * share * (held - weight * u_before)
            den += h * shear * share * weight / rho
        q_new = num / den
        x[nseg + i] = q_new
        # friction's work stays in the gas: the kinetic energy it takes becomes internal energy (E is kept)
        if unsteady:
            dv = q_new / rho - u_before
            for j in range(N_UNSTEADY):
                c = terms + j * nseg + i
                x[c] = (x[c] + UNSTEADY_M[j] * dv) / (1.0 + UNSTEADY_N[j] * tau)
        if heat:
            p = (k - 1.0) * (x[2 * nseg + i] - 0.5 * q_new * q_new / rho)
            t_gas = p / (rho * r)
            coefficient = duct_heat_transfer_coefficient(q / rho, p, t_gas, t_wall, bore, r, k)
            x[2 * nseg + i] += h * 4.0 / bore * share * coefficient * (t_wall - t_gas)


@njit
def _advance(
    x: np.ndarray,
    row: np.ndarray,
    dt_s: float,
    kind: int,
    a: float,
    b: float,
    area_m2: float,
    flux_up: float,
    k_up: float,
    end: FarEnd,
) -> LineStep:
    # the three inlets' common loop: `kind` picks the inlet; (a, b) are the inlet's pressure at the
    # step's start and end, the orifice's upstream pressure (a), or the inflow (a)
    layout = _layout(row)
    nseg, speed, start = layout.nseg, layout.speed, layout.start
    k = row[LR_N]
    gm1 = k - 1.0
    rt0 = row[LR_RT]
    t0 = rt0 / row[LR_R]
    v_cell = row[LR_AREA] * row[LR_DX]
    substeps = substeps_for(row, dt_s, x[speed])
    h = dt_s / substeps
    p_end_start = far_end_pressure(x, row)
    pinned = end.pinned_pa
    inlet_mass = 0.0
    end_mass = 0.0
    plenum_start = x[0]  # the inlet's plenum: a pressure inlet sets it, and what it gains came in too
    t_up = 0.0
    if kind == _INLET_ORIFICE and flux_up > 0.0:
        t_up = (choked_flux(1.0, 1.0, k_up) / flux_up) ** 2 / row[LR_R]  # the upstream gas's temperature
    for s in range(substeps):
        volume = end.volume_m3 + end.volume_rate_m3_s * s * h  # the end volume at the sub-step's start
        x[start : start + 3 * nseg] = x[: 3 * nseg]
        p_s = a + (b - a) * s / substeps
        p_e = a + (b - a) * (s + 1) / substeps
        if kind != _INLET_PRESSURE:
            p_s = p_e = a
        in1, end1, fast1 = _hyperbolic_stage(x, row, h, 0.0, kind, p_s, area_m2, flux_up, t_up, volume, pinned)
        in2, end2, fast2 = _hyperbolic_stage(x, row, h, 0.5, kind, p_e, area_m2, flux_up, t_up, volume, pinned)
        x[speed] = max(fast1, fast2)
        inlet_mass += 0.5 * h * (in1 + in2)
        end_mass += 0.5 * h * (end1 + end2)
        _wall_sources(x, row, h, volume)
        last = nseg - 1
        volume_last = 0.5 * v_cell + volume
        if pinned > 0.0:  # the half cell at the pinned chamber's state
            x[last] = pinned / rt0
            x[2 * nseg + last] = pinned / gm1
        else:
            if end.inflow_kg_s != 0.0 or end.inflow_slope_kg_s_pa != 0.0:
                pn = _pressure(x, nseg, last, gm1)
                t_cell = pn / (x[last] * row[LR_R])
                slope = end.inflow_slope_kg_s_pa
                explicit = end.inflow_kg_s - slope * (pn - p_end_start)
                t_in = t0 if explicit >= 0.0 else t_cell
                m = explicit / (1.0 + slope * k * row[LR_R] * t_in * h / volume_last)
                _add_flow(x, nseg, last, volume_last, h * m, t_in, row)
            if end.volume_rate_m3_s != 0.0:
                # the end volume moves: the cell's gas spreads over the new volume, doing work p dV
                new_volume = volume_last + end.volume_rate_m3_s * h
                pn = _pressure(x, nseg, last, gm1)
                scale = volume_last / new_volume
                x[last] *= scale
                x[nseg + last] *= scale
                x[2 * nseg + last] = (x[2 * nseg + last] * volume_last - pn * (new_volume - volume_last)) / new_volume
    if kind == _INLET_PRESSURE:
        inlet_mass += 0.5 * v_cell * (x[0] - plenum_start)
    return LineStep(inlet_mass / dt_s, end_mass / dt_s, 0.0, 0.0, 0.0, 0.0)


@njit
def advance_from_pressure(
    x: np.ndarray, row: np.ndarray, dt_s: float, p_start_pa: float, p_end_pa: float, end: FarEnd
) -> LineStep:
    """Advance a line over dt in place, its inlet face at a pressure going linearly from p_start to p_end."""
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
    """Advance a line over dt in place, its first cell fed by an orifice of effective area `area_m2`
    from `p_up_pa` (either way: negative flow when the cell is higher), held over the step;
    `choked_flux` and k as in `orifice_mass_flow_with`, of the upstream gas (an outflow goes through
    the choked flux of the cell's own gas)."""
    return _advance(x, row, dt_s, _INLET_ORIFICE, p_up_pa, 0.0, area_m2, choked_flux, k, end)


@njit
def advance_from_flow(x: np.ndarray, row: np.ndarray, dt_s: float, mass_flow_kg_s: float, end: FarEnd) -> LineStep:
    """Advance a line over dt in place, a given mass flow into its first cell held over the step."""
    return _advance(x, row, dt_s, _INLET_FLOW, mass_flow_kg_s, 0.0, 0.0, 0.0, 0.0, end)
