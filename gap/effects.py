"""The catalogue of candidate effects: each is a JointParams field (or the inertia scale) with
bounds. Adding an effect to the twin is `params._replace(field=value)`: configuration of the one
model in pneumatics/, never a second model.
"""

from __future__ import annotations

from dataclasses import dataclass

from pneumatics import JointParams

INERTIA = "inertia_scale"  # not a JointParams field: scales the joint-side inertia given to the replay


@dataclass(frozen=True)
class Effect:
    name: str
    label: str
    field: str  # JointParams field, or INERTIA
    low: float
    high: float
    log: bool = False  # search grid spaced logarithmically (value 0 allowed as the low end)
    discrete_value: float | None = None  # a switch: added with this value, nothing to fit
    family: str = ""
    equation: str = ""

    def value_of(self, params: JointParams) -> float:
        return 1.0 if self.field == INERTIA else float(getattr(params, self.field))

    def apply(self, params: JointParams, value: float) -> tuple[JointParams, float]:
        """(params with the effect at `value`, inertia scale)."""
        if self.field == INERTIA:
            return params, float(value)
        return params._replace(**{self.field: float(value)}), 1.0


# Bounds: physically plausible ranges for the wrist class (assets/joints/wrist_pitch.toml values
# are the nominal: coulomb 15 N·m, viscous 3 N·m·s/rad, solenoid 15 ms, valve tau 0.1 s). The leak
# area's grid is logarithmic: a worn vane's gap area spans orders of magnitude.
CATALOGUE: tuple[Effect, ...] = (
    Effect("hose_loss", "hose pressure loss", "hose_loss", 0.0, 1.0, discrete_value=1.0, family="hose", equation="Darcy-Weisbach hose resistance on both ports (paper eq. 1-5)"),
    Effect("vane_leakage", "vane leakage", "leak_area_m2", 0.0, 2.0e-6, log=True, family="leakage", equation="orifice A->B past the vanes, area fitted (m^2)"),
    Effect("coulomb_friction", "Coulomb friction", "coulomb_nm", 0.0, 60.0, family="friction", equation="Coulomb level C_s (N·m), Karnopp stick rule"),
    Effect("stribeck_friction", "Stribeck friction", "stribeck_excess_nm", 0.0, 60.0, family="friction", equation="static-minus-Coulomb excess (N·m), exp(-(w/ws)^2)"),
    Effect("viscous_friction", "viscous friction", "viscous_nm_s", 0.0, 20.0, family="friction", equation="C_f (N·m·s/rad)"),
    Effect("valve_dead_time", "direction valve dead time (solenoid delay)", "solenoid_delay_s", 0.0, 0.3, family="valve timing", equation="direction valve switches after a delay (s)"),
    Effect("valve_set_dead_time", "proportional valve dead time", "valve_set_dead_time_s", 0.0, 0.3, family="valve timing", equation="the proportional valve's set point takes effect after a delay (s)"),
    Effect("valve_lag", "valve lag (valve time constant)", "valve_time_constant_s", 0.005, 0.6, log=True, family="valve timing", equation="proportional valve first-order lag tau (s)"),
    Effect("valve_dead_zone", "valve dead zone", "valve_dead_zone", 0.0, 0.6, family="valve", equation="u' = (u - dz)/(1 - dz)"),
    Effect("conductance_error", "valve conductance error", "conductance_scale", 0.3, 2.5, log=True, family="valve", equation="valve areas x scale"),
    Effect("heat_exchange", "heat exchange (polytropic exponent)", "polytropic_n", 1.0, 1.4, family="thermal", equation="chamber law with n in 1..1.4"),
    Effect("supply_droop", "supply droop under flow", "supply_droop_pa_s_per_kg", 0.0, 5.0e7, family="supply", equation="p_s' = p_s - k * choked inlet flow (Pa·s/kg)"),
    Effect("inertia_error", "payload/inertia error", INERTIA, 0.3, 3.0, log=True, family="load", equation="joint-side inertia x scale"),
    # the reducer (pneumatics/reducer.py): lost motion up to 0.05 rad (3 deg, a badly worn gear;
    # a strain-wave gear has ~3e-4 rad) and compliance up to 2e-3 rad/N·m (7x softer than the
    # size-17 gear's 1/K1 ~ 3e-4); both grids logarithmic, they span orders of magnitude
    Effect("reducer_backlash", "reducer backlash", "reducer_backlash_rad", 0.0, 0.05, log=True, family="reducer", equation="dead zone of width b between motor and joint side (rad)"),
    Effect("reducer_compliance", "reducer compliance", "reducer_compliance_rad_per_nm", 0.0, 2.0e-3, log=True, family="reducer", equation="torsional spring 1/k between motor and joint side (rad/N·m)"),
)
NOT_IN_CATALOGUE = (
    "torque ripple with motor angle (ripple_fraction exists in pneumatics/ and the bench hides it, "
    "but it is deliberately left out of the catalogue as the bench's outside-catalogue effect)",
)
BY_NAME = {e.name: e for e in CATALOGUE}
