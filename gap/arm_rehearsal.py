"""Rehearsal arm campaigns: the twin's own scenario runs, with the plant's reality changed by one
hidden effect, read through an instrument model and written as an arm campaign (gap/arm_campaign.py).

Each run is the scenario run as `twin run` runs it (its controller, predictor, task and supply:
scenarios.runner), on a plant that is the campaign's twin plus the hidden effect, at a supply of
the campaign's list. Every 1 ms control tick records what the platform sent (each joint's
direction, valve set point, brake release), the supply at the regulator, the true drive angles and
the port pressures at the platform; the instrument then samples the angles (its rate, latency,
noise, dropouts, the joints it sees) and the pressure transducers the ports (PRESSURE_PERIOD_S,
their noise).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from control.loop import run_ticks
from control.schedule import EveryTick
from gap import synth
from gap.arm_campaign import (
    CAMERA,
    JOINTS,
    PRESSURE_PERIOD_S,
    ArmInstrument,
    ArmRun,
    HiddenArmEffect,
    campaign_toml,
    load_arm_campaign,
    write_arm_run,
)
from gap.arm_diagnose import twin_of as campaign_twin
from gap.arm_effects import ArmSetup, candidate_named
from gap.arm_replay import TICK_S, arm_plant, replay, shared_draw
from gap.campaign import GapError
from pneumatics import JointParams
from pneumatics.gas import AIR
from pneumatics.joint import S_PA_VALVE, S_PB_VALVE
from scenarios import controllers
from scenarios.runner import resolve_targets
from scenarios.schema import Scenario, Supply, joint_params_for, nominal_params, reality_params
from scenarios.supply import supply_profile
from scenarios.task import TaskController

PRESSURE_NOISE_PA = synth.NOISE_PA  # 0.25 % of a 0-1 MPa transducer's span, as the rig's (gap.synth)


def twin_of(scenario: Scenario) -> tuple[dict[str, JointParams], ArmSetup]:
    """The twin a scenario's run is replayed through: its reality's base arm and hose switch, its payload."""
    params = joint_params_for(reality_params(scenario), replace(scenario.reality, effects={}))
    return params, ArmSetup(payload_kg=scenario.payload_kg)


def hidden(
    params: dict[str, JointParams], setup: ArmSetup, reality: HiddenArmEffect | None
) -> tuple[dict[str, JointParams], ArmSetup]:
    """The twin with the rehearsal's hidden effect."""
    if reality is None:
        return params, setup
    return candidate_named(reality.effect).apply(params, setup, JOINTS, reality.value)


def start_angles(scenario: Scenario, params: dict[str, JointParams]) -> np.ndarray:
    """The scenario's start pose as drive angles (the home keyframe with its start angles over it)."""
    plant = arm_plant(params, ArmSetup(payload_kg=scenario.payload_kg), np.zeros(len(JOINTS)))
    plant.data.qpos[:] = plant.model.key("home").qpos if scenario.start_pose == "home" else 0.0
    for j, deg in scenario.start_angles_deg.items():
        plant.data.joint(j).qpos[0] = math.radians(deg)
    return plant.drive_angles()


def simulate(
    scenario: Scenario, params: dict[str, JointParams], setup: ArmSetup, duration_s: float
) -> tuple[ArmRun, np.ndarray, np.ndarray]:
    """The scenario run on the plant (`params`, `setup`): (the run with the platform's commands and
    supply every tick, the true drive angles and the platform's port pressures every tick)."""
    start = start_angles(scenario, params)
    plant = arm_plant(params, setup, start)
    rng = np.random.default_rng(scenario.seed)
    targets = resolve_targets(scenario, plant)
    predictor = joint_params_for(nominal_params(scenario.joints), scenario.predictor)
    controller, refusal = controllers.build(scenario, plant, predictor, targets)
    if refusal:
        raise GapError(f"{scenario.path}: the controller refused the plan ({refusal})")
    if scenario.control.mode != "none":
        controller.set_targets([])
        controller = TaskController(controller, scenario, plant, targets, np.random.default_rng([scenario.seed, 1]))
    supply = supply_profile(scenario.supply, duration_s, rng)
    steps = max(1, round(TICK_S / plant.dt))
    n = int(round(duration_s / TICK_S))
    log_t, log_c, log_s, log_a, log_p = [], [], [], [], []
    droop = setup.supply_line_droop_pa_s_per_kg

    def shared_line(p, t: float) -> None:
        # the supply every valve sees: the regulator's, less the shared line's droop under the draw
        log_s.append(p.supply_pa)
        if droop > 0.0:
            p.supply_pa = max(AIR.p_atm_pa, p.supply_pa - droop * shared_draw(p.air, p.params, p.supply_pa))

    def record(k: int, t: float) -> None:
        log_t.append(t)
        log_c.append(plant.commands.copy())
        log_a.append(plant.drive_angles())
        log_p.append(plant.air[:, [S_PA_VALVE, S_PB_VALVE]].copy())

    run_ticks(controller, plant, steps, n, supply, EveryTick(shared_line), record)
    plant.check_warnings()
    nan = np.full((len(log_t), len(JOINTS)), np.nan)
    run = ArmRun(
        scenario.name,
        Path(scenario.path),
        start,
        np.asarray(log_t),
        np.asarray(log_c),
        np.asarray(log_s),
        nan,
        np.stack([nan, nan], axis=2),
    )
    return run, np.asarray(log_a), np.asarray(log_p)


def observe(
    run: ArmRun,
    angle_rad: np.ndarray,
    port_pa: np.ndarray,
    instrument: ArmInstrument,
    rng: np.random.Generator,
    noise_pa: float = PRESSURE_NOISE_PA,
) -> ArmRun:
    """The run as the instruments record it: the drive angles at the instrument's frames (its
    rate, read `latency_s` late, with its noise; a lost frame loses every joint), the joints it does
    not see left NaN; the port pressures every PRESSURE_PERIOD_S with `noise_pa`."""
    t = run.time_s
    frames = np.arange(0.0, t[-1] + 1e-9, 1.0 / instrument.rate_hz)
    frames = frames[rng.random(len(frames)) >= instrument.dropout_fraction]
    rows = np.unique(np.searchsorted(t, frames - 1e-9))
    rows = rows[rows < len(t)]
    latency = instrument.latency_s or 0.0
    angle = np.full(angle_rad.shape, np.nan)
    for i, j in enumerate(JOINTS):
        if j in instrument.seen():
            angle[rows, i] = np.interp(t[rows] - latency, t, angle_rad[:, i]) + rng.normal(
                0.0, instrument.noise_rad(), len(rows)
            )
    port = np.full(port_pa.shape, np.nan)
    every = np.unique(np.searchsorted(t, np.arange(0.0, t[-1] + 1e-9, PRESSURE_PERIOD_S) - 1e-9))
    every = every[every < len(t)]
    port[every] = port_pa[every] + rng.normal(0.0, noise_pa, port_pa[every].shape)
    return replace(run, angle_rad=angle, port_pa=port)


def at_supply(scenario: Scenario, supply_mpa: float | None, seed: int) -> Scenario:
    """The scenario at a constant supply of `supply_mpa` (None: its own) with `seed`."""
    if supply_mpa is None:
        return replace(scenario, seed=seed)
    return replace(scenario, supply=Supply(kind="constant", pressure_mpa=supply_mpa), seed=seed)


def make_arm_campaign(
    folder: str | Path,
    scenarios: list[Scenario],
    supplies_mpa: tuple[float | None, ...] = (None,),
    reality: HiddenArmEffect | None = None,
    instrument: ArmInstrument = CAMERA,
    seed: int = 0,
    duration_s: float = 60.0,
    declare_latency: bool = True,
) -> Path:
    """Write an arm campaign: every scenario at every supply, on the twin with `reality`'s hidden
    effect, read through `instrument`. campaign.toml records the hidden effect under [reality]."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    entries = []
    base = scenarios[0]
    for scenario in scenarios:
        for supply in supplies_mpa:
            s = at_supply(scenario, supply, scenario.seed)
            params, setup = twin_of(s)
            truth, angles, ports = simulate(s, *hidden(params, setup, reality), min(duration_s, s.duration_s))
            name = f"{s.name}_{int(round((supply or s.supply.pressure_mpa) * 100)):03d}.csv"
            write_arm_run(folder / name, observe(truth, angles, ports, instrument, rng))
            entries.append((name, truth.start_rad))
    declared = instrument if declare_latency else replace(instrument, latency_s=None)
    text = campaign_toml(
        declared,
        entries,
        base.payload_kg,
        base.reality.arm,
        base.reality.hose_loss,
        reality,
        comment="rehearsal campaign made by gap.arm_rehearsal from the twin's own scenario runs",
    )
    (folder / "campaign.toml").write_text(text)
    return folder


def play_arm_plan(
    plan: Path, played: Path, reality: HiddenArmEffect | None, instrument: ArmInstrument, seed: int
) -> Path:
    """A plan of `twin gap design --arm` played from its files on the plant with `reality`'s hidden
    effect, read by `instrument` and the port transducers: its run files with the instruments'
    columns filled, and its campaign.toml, in `played`. The commands are open loop (the plan's), so
    the plant steps exactly as the replay does (gap.arm_replay: the same kernel, tick for tick)."""
    doc = load_arm_campaign(plan, min_runs=1)
    played.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    twin = campaign_twin(doc)
    params, setup = hidden(twin.params, twin.setup, reality)
    for r in doc.runs:
        truth = replay(r, params, setup)
        n = len(r.time_s)
        write_arm_run(played / r.path.name, observe(r, truth.angle_rad[:n], truth.port_pa[:n], instrument, rng))
    (played / "campaign.toml").write_text((plan / "campaign.toml").read_text())
    return played
