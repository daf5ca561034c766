"""Faults that strike a run at a given time, applied to the plant (never to the controller).

supply_lost       the supply falls to atmosphere (the brakes' springs engage)
hose_leak         port A's hose leaks to atmosphere through `value` m^2
valve_stuck_open  the joint's direction valve sticks in its +1 position, fully open
brake_fails       the joint's brake no longer engages (holding torque 0)
sensor_bias       the joint's proportional-valve pressure sensor reads `value` Pa high
"""

from __future__ import annotations

import math
from collections.abc import Callable

from pneumatics import AIR
from scenarios.schema import Fault
from twin.plant import Plant


def fault_events(faults: tuple[Fault, ...]) -> tuple[Callable[[Plant, float], None], Callable[[float], bool]]:
    """(events(plant, t) applying each fault once its time has come, supply_lost(t)); `events.pending`
    lists the faults it has not applied yet."""
    pending = sorted(faults, key=lambda f: f.at_s)
    supply_lost_at = min((f.at_s for f in faults if f.kind == "supply_lost"), default=float("inf"))

    def events(plant: Plant, t: float) -> None:
        if t >= supply_lost_at:
            plant.set_supply(AIR.p_atm_pa)
        while pending and pending[0].at_s <= t:
            fault = pending.pop(0)
            apply_fault(plant, fault)

    def due_s(t: float) -> float:
        # when `events` next does something a call before did not: the next fault (the lost supply
        # stays lost: a call after it only sets it again)
        return min(pending[0].at_s if pending else math.inf, supply_lost_at if t < supply_lost_at else math.inf)

    events.due_s = due_s  # the run loop may skip calling `events` until then (twin/compiled_loop.py)
    events.pending = pending  # the faults not applied yet, in time order (after a run: those it never reached)
    return events, lambda t: t >= supply_lost_at


def apply_fault(plant: Plant, fault: Fault) -> None:
    if fault.kind == "supply_lost":
        plant.set_supply(AIR.p_atm_pa)
        return
    j = plant.joints.index(fault.joint)
    params = plant.joint_params[fault.joint]
    if fault.kind == "hose_leak":
        plant.set_joint_params(fault.joint, params._replace(hose_leak_area_m2=fault.value))
    elif fault.kind == "brake_fails":
        plant.set_joint_params(fault.joint, params._replace(brake_holding_nm=0.0))
    elif fault.kind == "sensor_bias":
        plant.sensor_bias_pa[j] = fault.value
    elif fault.kind == "valve_stuck_open":
        plant.stick_valve(fault.joint, +1.0)
