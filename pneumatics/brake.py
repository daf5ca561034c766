"""The spring-applied, air-released joint brake (paper Sec. II: one brake per joint, on the joint side).

The springs apply the brake; air from the supply releases it. So the brake releases only when it
is told to and the supply can lift the springs, and it engages on its own when the air goes. Its
engagement e in [0, 1] follows the command as a first-order lag (the springs are faster than the
air that fills the brake's piston), and it holds up to e times its holding torque; beyond that
it slips, with the same torque (dry friction of the brake lining).
"""

from __future__ import annotations

from pneumatics._jit import njit
from pneumatics.valves import lag_toward


@njit
def brake_target(release_command: float, supply_gauge_pa: float, release_gauge_pa: float) -> float:
    """Engagement the brake tends to: 0 when released and the supply can release it, else 1."""
    if release_command > 0.5 and supply_gauge_pa >= release_gauge_pa:
        return 0.0
    return 1.0


@njit
def brake_step(engagement: float, release_command: float, supply_gauge_pa: float, release_gauge_pa: float, engage_tau_s: float, release_tau_s: float, dt_s: float) -> float:
    """Engagement after dt."""
    target = brake_target(release_command, supply_gauge_pa, release_gauge_pa)
    tau = engage_tau_s if target > engagement else release_tau_s
    return lag_toward(engagement, target, dt_s, tau)


@njit
def brake_holding_torque(engagement: float, holding_torque_nm: float) -> float:
    """Torque in N·m up to which the brake holds the joint (and with which it slips)."""
    return engagement * holding_torque_nm
