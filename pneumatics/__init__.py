"""The physics of air for the pneumatic arm: plain functions in SI units, no MuJoCo.

Each law is written once here and used by the plant (twin/), the angle predictor (control/)
and the gap diagnosis (gap/). Pressures are absolute Pa unless a name says `gauge`.
"""

from pneumatics.brake import brake_feed_gauge_pa, brake_holding_torque, brake_step, brake_target
from pneumatics.chamber import carried_temperature, chamber_energy_rates, chamber_pressure_rate, vessel_response
from pneumatics.friction import coulomb_viscous_torque, reducer_output_torque, stribeck_excess
from pneumatics.gas import AIR, Gas, isentropic_temperature
from pneumatics.heat import vane_chamber_heat_transfer, vessel_heat_transfer_coefficient
from pneumatics.hose import friction_factor, hose_mass_flow, hose_pressure_drop, hose_volume, reynolds_number
from pneumatics.motor import (
    chamber_volumes,
    displacement_per_rad,
    least_displacement_per_rad,
    swept_area,
    vane_torque,
    wrap_motor_angle,
)
from pneumatics.orifice import critical_pressure_ratio, flow_function, orifice_mass_flow, orifice_mass_flow_between
from pneumatics.params import JointParams, ParameterError, load_joint_params, paper_model, params_row, validated
from pneumatics.reducer import transmitted_torque
from pneumatics.valves import dead_time_step, lag_toward, proportional_valve_target, solenoid_step, valve_opening

__all__ = [
    "AIR",
    "Gas",
    "JointParams",
    "ParameterError",
    "brake_feed_gauge_pa",
    "brake_holding_torque",
    "brake_step",
    "brake_target",
    "carried_temperature",
    "chamber_energy_rates",
    "chamber_pressure_rate",
    "chamber_volumes",
    "coulomb_viscous_torque",
    "critical_pressure_ratio",
    "dead_time_step",
    "displacement_per_rad",
    "flow_function",
    "friction_factor",
    "hose_mass_flow",
    "hose_pressure_drop",
    "hose_volume",
    "isentropic_temperature",
    "lag_toward",
    "least_displacement_per_rad",
    "load_joint_params",
    "orifice_mass_flow",
    "orifice_mass_flow_between",
    "paper_model",
    "params_row",
    "proportional_valve_target",
    "reducer_output_torque",
    "reynolds_number",
    "solenoid_step",
    "stribeck_excess",
    "swept_area",
    "transmitted_torque",
    "validated",
    "valve_opening",
    "vane_chamber_heat_transfer",
    "vane_torque",
    "vessel_heat_transfer_coefficient",
    "vessel_response",
    "wrap_motor_angle",
]
