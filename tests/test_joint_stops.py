"""The one-joint model at its stops (pneumatics/joint.py; the predictor's model and the gap replay).

DESIGN rule 8: integrated at the 1 ms control tick, the model must agree at every stick/slip and
brake event with a reference that locates the event (tests/located_events.py: the same laws as a
hybrid system, each switch found by root finding, no fixed step, no stick window). The runs are
what a calibration rig does to a joint: go at full opening, brake from full speed while the valve
still drives (the brake engages against the drive), shut the valve, rest, go again.

Cases: every supply of the paper's range (0.5-0.8 MPa); a brake weaker than the drive, which
slips under it until the valve shuts; a load torque the brake holds between moves; a compliant
and a backlash reducer (the gear's motor side a body of its own). Each checks, within 0.1 deg,
the angle at every stop and at the end, and that the joint does not creep while braked.

Before the fix (friction flipping between RK4 stages, brake and valves held at one end of the
step) the same runs ended 1.7-12 deg from the reference at 0.5 MPa; see docs/validation/plant.md,
"The one-joint model at its stops", for the figures.
"""

from __future__ import annotations

import numpy as np
import pytest
from located_events import Command, solve

import assets
from pneumatics import load_joint_params, paper_model, params_row
from wrist_rig.one_joint import replay_run

WRIST = load_joint_params(assets.JOINTS_DIR / "wrist_pitch.toml")
P_ATM = 101_325.0
DT_S = 1e-3  # the platform's control tick
INERTIA = 0.164  # kg·m^2, the wrist's joint-side inertia with the reflected rotor (DESIGN starting set)
STOP_TOLERANCE_DEG = 0.1  # issue 12: final and per-stop angles within 0.1 deg of the reference


def stop_and_go(
    supply_gauge_pa: float, cycles: int = 3, go_s: float = 0.5, drive_while_braking_s: float = 0.1, rest_s: float = 0.3
) -> tuple[list[Command], float, list[tuple[float, float]]]:
    """Commands of `cycles` moves at full opening, each braked while the valve still drives;
    (commands, duration, rest windows (from, to) in which the joint must stand still)."""
    commands, rests, t = [], [], 0.0
    for _ in range(cycles):
        commands.append(Command(t, +1.0, supply_gauge_pa, 1.0))
        commands.append(Command(t + go_s, +1.0, supply_gauge_pa, 0.0))  # brake on, drive still on
        commands.append(Command(t + go_s + drive_while_braking_s, 0.0, 0.0, 0.0))  # valve shut
        t += go_s + drive_while_braking_s + rest_s
        rests.append((t - 0.5 * rest_s, t))
    return commands, t, rests


def model_run(
    p: np.ndarray, commands: list[Command], t_end: float, supply_pa: float, load_nm: float
) -> tuple[np.ndarray, np.ndarray]:
    """The one-joint model (the gap replay's compiled loop) under the commands, on the 1 ms grid."""
    n = int(round(t_end / DT_S))
    times = np.arange(n) * DT_S
    rows = np.zeros((n, 3))
    for c in commands:
        rows[times >= c.time_s - 1e-12] = (c.direction, c.valve_set_gauge_pa, c.brake_release)
    t, theta, *_ = replay_run(
        p, times, rows[:, 0], rows[:, 1], rows[:, 2], np.full(n, supply_pa), False, 0.0, INERTIA, load_nm, t_end, DT_S
    )
    return t, theta


def compare(params, supply_gauge_pa: float, load_nm: float = 0.0, cycles: int = 3) -> dict:
    p = params_row(params)
    supply = P_ATM + supply_gauge_pa
    commands, t_end, rests = stop_and_go(supply_gauge_pa, cycles)
    t, theta = model_run(p, commands, t_end, supply, load_nm)
    ref = solve(p, commands, t_end, inertia_kg_m2=INERTIA, load_nm=load_nm, supply_pa=supply, t_eval=t)
    assert np.allclose(ref.t, t)
    at_rest = [(t >= a) & (t <= b) for a, b in rests]
    return {
        "travel_deg": float(np.degrees(np.ptp(ref.theta))),
        "stops": len(ref.stops),
        "per_stop_error_deg": [float(np.degrees(theta[w][-1] - ref.theta[w][-1])) for w in at_rest],
        "final_error_deg": float(np.degrees(theta[-1] - ref.theta[-1])),
        "creep_deg": max(float(np.degrees(np.ptp(theta[w]))) for w in at_rest),
        "reference_creep_deg": max(float(np.degrees(np.ptp(ref.theta[w]))) for w in at_rest),
    }


def check(result: dict, cycles: int = 3) -> None:
    print(f"\n{result}")
    assert result["stops"] >= cycles  # the reference came to rest in every pause
    assert result["travel_deg"] > 10.0 * cycles  # every move really went
    assert result["reference_creep_deg"] == 0.0
    assert result["creep_deg"] < 1e-9  # braked means still: no creep through an engaged brake
    assert max(abs(e) for e in result["per_stop_error_deg"]) < STOP_TOLERANCE_DEG
    assert abs(result["final_error_deg"]) < STOP_TOLERANCE_DEG


ILL_CONDITIONED = pytest.mark.xfail(
    strict=True, reason="energy balance: an ill-conditioned run, 0.1 deg missed (docstring)"
)


@pytest.mark.parametrize(
    "supply_mpa, law",
    [
        pytest.param(0.5, "energy balance", marks=ILL_CONDITIONED),
        pytest.param(0.6, "energy balance", marks=ILL_CONDITIONED),
        (0.7, "energy balance"),
        (0.8, "energy balance"),
        (0.5, "paper"),
        (0.6, "paper"),
        (0.7, "paper"),
        (0.8, "paper"),
    ],
)
def test_braked_from_full_speed_stops_where_the_located_reference_stops(supply_mpa: float, law: str) -> None:
    """The wrist's brake (100 N·m + 15 N·m Coulomb) against 30-60 N·m of drive: drive below holding.
    By the energy balance (`chamber_heat = 1`) and by the paper's law (the predictor's).

    Known to fail with the energy balance at 0.5 and 0.6 MPa (0.23 deg at the third stop, 0.15 deg at
    the second): the model converges on the reference as its step shrinks (0.002 deg at 0.5 ms), but
    these runs are ill-conditioned there. A joint resting 0.01 deg further on moves the reference's
    third stop by 0.19 deg (the paper's law: 0.004 deg): the rest angle shifts the vane torque
    (d/dphi of the chambers' geometry at 120 times the angle), and the next breakaway, where the
    releasing brake's margin closes at ~0.5 N·m per ms, comes milliseconds earlier or later."""
    check(
        compare(WRIST._replace(chamber_heat=1.0) if law == "energy balance" else paper_model(WRIST), supply_mpa * 1e6)
    )


def test_a_brake_weaker_than_the_drive_slips_until_the_valve_shuts() -> None:
    # 10 N·m of brake + 15 N·m Coulomb under 35-60 N·m of drive at 0.6 MPa: drive above holding, the
    # joint slides on through the braking phase and stops only once the valve has shut
    check(compare(WRIST._replace(brake_holding_nm=10.0), 0.6e6))


def test_a_load_the_brake_holds_between_moves() -> None:
    # 12 N·m of load against the move (a slewing wrist tilted ~30 deg with the 20 kg payload): the
    # joint decelerates faster, and the brake holds the load in every pause
    check(compare(WRIST, 0.7e6, load_nm=12.0))


@pytest.mark.parametrize(
    "reducer",
    [
        {
            "reducer_compliance_rad_per_nm": 2.0e-4
        },  # the size-17 gear's own compliance (pneumatics/params.py: CSF-17 K3)
        {"reducer_backlash_rad": 2.0e-3, "reducer_compliance_rad_per_nm": 2.0e-4},  # a worn gear's lost motion
    ],
    ids=["compliant", "backlash"],
)
def test_a_non_rigid_reducer_stops_where_the_located_reference_stops(reducer: dict) -> None:
    check(compare(WRIST._replace(**reducer), 0.6e6))


# Stribeck friction (pneumatics/friction.py: 20 N·m of static over Coulomb friction, gone by 0.2 rad/s,
# the gap bench's Stribeck form) belongs to the dry-friction limit: the joint breaks away only once
# the drive passes the static level, then slides on Coulomb friction
STRIBECK = {"stribeck_excess_nm": 20.0, "stribeck_speed_rad_s": 0.2}


@pytest.mark.parametrize("supply_mpa", [0.5, 0.6, 0.7, 0.8])
def test_a_joint_with_stribeck_friction_breaks_away_and_stops_where_the_located_reference_does(
    supply_mpa: float,
) -> None:
    # one move: the breakaway at the static level and the stop through the Stribeck region. Later
    # moves start where this one stopped, and at 0.6 MPa the drive passes the static level so slowly
    # that the vanes' ripple at a stop 0.06 deg off moves the next breakaway by 8 ms (a knife edge
    # the diagnosis meets as the twin's own spread, gap.campaign_replay.CampaignReplay.spread)
    check(compare(WRIST._replace(**STRIBECK), supply_mpa * 1e6, cycles=1), cycles=1)


def test_a_drive_between_coulomb_and_static_friction_leaves_the_joint_at_rest() -> None:
    # at 0.5 MPa the wrist's drive peaks between its Coulomb (15 N·m) and static (15 + 40 N·m)
    # friction: the reference holds it at rest, and so must the model (a Stribeck excess that is
    # zero at rest, as a smoothed drive torque makes it, would let it go as if Coulomb alone)
    p = params_row(WRIST._replace(stribeck_excess_nm=40.0, stribeck_speed_rad_s=0.2))
    supply = P_ATM + 0.5e6
    commands, t_end, _ = stop_and_go(0.5e6, cycles=1)
    t, theta = model_run(p, commands, t_end, supply, 0.0)
    ref = solve(p, commands, t_end, inertia_kg_m2=INERTIA, supply_pa=supply, t_eval=t)
    coulomb_only = model_run(params_row(WRIST), commands, t_end, supply, 0.0)[1]
    assert np.degrees(np.ptp(coulomb_only)) > 10.0  # without the excess the drive moves it
    assert np.degrees(np.ptp(ref.theta)) < 1e-9
    assert np.degrees(np.ptp(theta)) < 1e-9
