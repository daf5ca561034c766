"""Synthetic calibration campaigns: the plant (MuJoCo + pneumatics) with hidden effects plays the
real arm, and its runs are written to disk exactly as a user's measured campaign would be.

Each run is one motion with every phase the diagnosis breaks the residual into: brake released
and a start from rest, a move with the valve fully open, a direct reversal at opening 0.95 (a set
point of 4.85 bar: partial at the higher supplies, and above the wrist's motor-fed brake's full
release, 4.75 bar, so the wrist does reverse; at 0.6 it stayed braked), braking, and holding.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

import assets
from pneumatics import JointParams, load_joint_params
from pneumatics.gas import AIR
from twin.mcap_log import McapRecorder
from twin.plant import Plant
from twin.sim import CommandSchedule, run

JOINT = "wrist_pitch"
PRESSURES_MPA = (0.5, 0.6, 0.7, 0.8)  # paper Fig. 10-16: the supplies of the model validation
SAMPLE_PERIOD_S = 0.02  # the reference instrument: 50 Hz (slower than the 1 ms commands)
NOISE_RAD = np.deg2rad(0.05)  # assumed: an encoder-class reference instrument, 0.05 deg rms
# assumed: a 0-1 MPa piezoresistive transducer on each motor port, 0.25 % FS accuracy class; its
# sample noise taken as 1 kPa rms
NOISE_PA = 1.0e3
RIG_INERTIA_KG_M2 = 0.02  # assets/wrist_rig.xml rig_load


@dataclass(frozen=True)
class SimInstrument:
    """A reference angle instrument as the synthetic campaigns simulate it: it samples the plant's
    true angle at `rate_hz` (phase `phase_s`), `latency_s` late, with seeded Gaussian noise, and
    drops each sample with probability `drop_fraction`. `declare` writes what a user would put in
    campaign.toml's [instrument] (the fields named there), the rest is left to the diagnosis."""

    name: str = "encoder_50hz"
    rate_hz: float = 50.0
    noise_deg: float = float(np.rad2deg(NOISE_RAD))
    latency_s: float = 0.0
    drop_fraction: float = 0.0
    phase_s: float = 0.0
    declare: tuple[str, ...] = ()

    def sample_times(self, t_end_s: float, rng: np.random.Generator | None) -> np.ndarray:
        """Sample times rounded to the 1 ms command rows the run file has, dropped ones left out."""
        t = np.round(np.arange(self.phase_s, t_end_s + 1e-9, 1.0 / self.rate_hz), 3)
        if self.drop_fraction > 0 and rng is not None:
            t = t[rng.random(len(t)) >= self.drop_fraction]
        return t


# the two instruments of the bench: an encoder on the joint, and a camera tracking a marker
ENCODER = SimInstrument()
# assumed: a 30 frame/s machine-vision camera, 0.2 deg rms marker noise, 10-40 ms from exposure to
# timestamp (the bench draws the latency per campaign), 3 % of frames lost
CAMERA = SimInstrument("camera_30hz", 30.0, 0.2, 0.025, 0.03)


@dataclass(frozen=True)
class Motion:
    """Command timeline of one run (times in s). The first move's valve set point is the supply
    itself (fully open, delivering the supply); the reversal's is opening_2 / k_u (a partial
    opening that also regulates the delivered pressure down to it)."""

    direction: int = 1  # first move's direction
    t_release_s: float = 0.1  # brake release + first move starts
    t_move_s: float = 0.5  # duration of the first move (fully open)
    t_reverse_s: float = 0.6  # duration of the reversed move
    opening_2: float = 0.95
    t_hold_s: float = 0.6  # braking + holding
    duration_s: float = 0.0  # 0: the sum of the phases

    def total_s(self) -> float:
        return self.duration_s or self.t_release_s + self.t_move_s + self.t_reverse_s + self.t_hold_s

    def commands(
        self, t_s: np.ndarray, supply_gauge_pa: float, k_u_per_pa: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(direction, valve set point gauge Pa, brake_release) at the given times."""
        t1 = self.t_release_s
        t2 = t1 + self.t_move_s
        t3 = t2 + self.t_reverse_s
        d = np.zeros_like(t_s)
        u = np.zeros_like(t_s)
        b = np.zeros_like(t_s)
        first = (t_s >= t1 - 1e-9) & (t_s < t2 - 1e-9)
        second = (t_s >= t2 - 1e-9) & (t_s < t3 - 1e-9)
        d[first] = self.direction
        u[first] = supply_gauge_pa
        d[second] = -self.direction
        u[second] = self.opening_2 / k_u_per_pa
        b[first | second] = 1.0
        return d, u, b


def wrist_params() -> JointParams:
    return load_joint_params(assets.joint_param_path(JOINT))


def _plant_and_schedule(
    reality: JointParams,
    supply_mpa: float,
    motion: Motion,
    start_rad: float,
    rig_spring_nm_per_rad: float = 0.0,
    rig_load_nm: float = 0.0,
):
    plant = Plant(assets.WRIST_RIG_XML, joint_params={JOINT: reality})
    i = plant.joints.index(JOINT)
    # a hidden angle-dependent load: MuJoCo's own joint spring (passive force -k (q - qpos_spring),
    # qpos_spring = 0 from the model's reference pose), not the replay's law
    plant.model.jnt_stiffness[plant.model.joint(JOINT).id] = rig_spring_nm_per_rad
    # and a hidden static load the same at every angle: MuJoCo's applied joint force, which mj_step
    # keeps (the plant applies its drive as actuator forces), toward negative angles for a positive load
    plant.data.qfrc_applied[plant.model.joint(JOINT).dofadr[0]] = -rig_load_nm
    plant.data.qpos[plant.model.joint(JOINT).qposadr[0]] = start_rad
    mujoco.mj_forward(plant.model, plant.data)
    plant.align_motors()
    plant.set_supply(AIR.p_atm_pa + supply_mpa * 1e6)
    k_u = reality.k_u_per_pa
    n = len(plant.joints)

    def commands_at(t: float) -> np.ndarray:
        d, u, b = motion.commands(np.array([t]), supply_mpa * 1e6, k_u)
        c = np.zeros((n, 3))
        c[i] = (d[0], u[0], b[0])
        return c

    return plant, CommandSchedule(commands_at, n), i


def simulate_run(
    reality: JointParams,
    supply_mpa: float,
    motion: Motion,
    start_rad: float = 0.0,
    log_period_s: float = SAMPLE_PERIOD_S,
    rig_spring_nm_per_rad: float = 0.0,
    rig_load_nm: float = 0.0,
) -> dict[str, np.ndarray]:
    """Run the plant (twin.plant.Plant on the wrist rig) through `motion` (a Motion or a
    gap.protocols.Protocol); 1 ms command rows and the true angle and chamber pressures every
    `log_period_s` (NaN between samples)."""
    plant, schedule, i = _plant_and_schedule(reality, supply_mpa, motion, start_rad, rig_spring_nm_per_rad, rig_load_nm)
    supply_pa = plant.supply_pa
    tel = run(plant, schedule, motion.total_s(), supply=supply_pa, log_period_s=log_period_s)
    arr = tel.arrays()
    t_cmd = np.round(np.arange(0.0, motion.total_s() + 1e-9, 1e-3), 6)
    d, u, b = motion.commands(t_cmd, supply_mpa * 1e6, reality.k_u_per_pa)
    idx = np.round(np.asarray(arr["time_s"]) / 1e-3).astype(int)
    ok = idx < len(t_cmd)
    sampled = {}
    for out, column in (("angle_rad", "true_angle_rad"), ("p_a_pa", "pressure_a_pa"), ("p_b_pa", "pressure_b_pa")):
        sampled[out] = np.full(t_cmd.shape, np.nan)
        sampled[out][idx[ok]] = np.asarray(arr[column])[ok, i]
    return {
        "time_s": t_cmd,
        "direction": d,
        "brake_released": b,
        "valve_set_gauge_pa": u,
        "supply_pa": np.full(t_cmd.shape, supply_pa),
        **sampled,
    }


def write_mcap_run(
    path: Path, reality: JointParams, supply_mpa: float, motion: Motion | None = None, start_rad: float = 0.0
) -> Path:
    """Run the plant through `motion` and log it with the twin's own MCAP recorder
    (twin.mcap_log.McapRecorder, a sample every 20 ms): a run file the campaign reader accepts."""
    motion = motion or Motion()
    plant, schedule, _ = _plant_and_schedule(reality, supply_mpa, motion, start_rad)
    rec = McapRecorder(path, plant.model, plant.joints, {"scenario_name": "gap synthetic run", "seed": 0})
    try:
        run(plant, schedule, motion.total_s(), recorders=(rec,))
    finally:
        rec.close()
    return Path(path)


def measure(
    run: dict[str, np.ndarray],
    instrument: SimInstrument,
    rng: np.random.Generator | None,
    chamber_pressures: bool = False,
    noise_pa: float = NOISE_PA,
) -> dict[str, np.ndarray]:
    """What the rig's instruments record of a plant run logged every 1 ms: the angle at the
    instrument's sample times, read `latency_s` late, with its noise; with `chamber_pressures`
    both motor ports' transducers (no latency) every SAMPLE_PERIOD_S with `noise_pa`. NaN where
    an instrument has no sample."""
    t = run["time_s"]
    out = {}
    ts = instrument.sample_times(t[-1], rng)
    angle = np.full(t.shape, np.nan)
    rows = np.round(ts / 1e-3).astype(int)
    angle[rows] = np.interp(ts - instrument.latency_s, t, run["angle_rad"])
    if rng is not None and instrument.noise_deg > 0:
        angle[rows] += rng.normal(0.0, np.deg2rad(instrument.noise_deg), len(rows))
    out["angle_rad"] = angle
    if chamber_pressures:
        every = np.zeros(t.shape, dtype=bool)
        every[:: int(round(SAMPLE_PERIOD_S / 1e-3))] = True
        for c in ("p_a_pa", "p_b_pa"):
            out[c] = np.where(every, run[c], np.nan)
            if rng is not None and noise_pa > 0:
                out[c][every] += rng.normal(0.0, noise_pa, every.sum())
    return out


def write_run_csv(path: Path, run: dict[str, np.ndarray], measured: dict[str, np.ndarray]) -> None:
    """Write a run file (columns as the campaign format): the commands of `run` and the
    instruments' readings `measured` (see `measure`)."""
    fmt = {"angle_rad": "{:.7f}", "p_a_pa": "{:.0f}", "p_b_pa": "{:.0f}"}
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time_s", "direction", "brake_released", "valve_set_gauge_pa", "supply_pa", *measured])
        for k in range(len(run["time_s"])):
            fixed = [
                f"{run['time_s'][k]:.4f}",
                int(run["direction"][k]),
                int(run["brake_released"][k]),
                f"{run['valve_set_gauge_pa'][k]:.1f}",
                f"{run['supply_pa'][k]:.1f}",
            ]
            w.writerow(fixed + ["" if not np.isfinite(v[k]) else fmt[c].format(v[k]) for c, v in measured.items()])


def paper_motions(reality: JointParams, pressures_mpa=PRESSURES_MPA, turn_deg: float = 60.0) -> dict[float, Motion]:
    """The paper's validation runs (Sec. IV, Fig. 10-16): at each supply the wrist turns about
    `turn_deg` at full opening, then brakes and holds. The first move lasts until the plant with
    `reality` crosses `turn_deg` (one long run per pressure finds the time); no reversal."""
    out = {}
    for mpa in pressures_mpa:
        probe = Motion(t_move_s=3.0, t_reverse_s=0.0, t_hold_s=0.0)
        run = simulate_run(reality, mpa, probe)
        m = np.isfinite(run["angle_rad"])
        t, a = run["time_s"][m], run["angle_rad"][m]
        crossed = np.nonzero(a >= np.deg2rad(turn_deg))[0]
        if not len(crossed):
            raise ValueError(f"the plant does not turn {turn_deg} deg in {probe.t_move_s} s at {mpa} MPa")
        out[mpa] = Motion(t_move_s=round(float(t[crossed[0]]) - probe.t_release_s, 3), t_reverse_s=0.0)
    return out


def make_campaign(
    folder: str | Path,
    reality: JointParams,
    seed: int = 0,
    pressures_mpa=PRESSURES_MPA,
    repeats: int = 2,
    twin_hose_loss: bool | None = None,
    motion=None,
    instrument: SimInstrument = ENCODER,
    description: str = "",
    chamber_pressures: bool = False,
    rig_spring_nm_per_rad: float = 0.0,
    rig_load_nm: float = 0.0,
    declared_hose_length_m: float | None = None,
) -> Path:
    """Write campaign.toml and one CSV per run (pressure x motion x repeat) from the plant with `reality`
    (and a hidden static load on the rig: a spring about the joint's zero, a torque the same at
    every angle), every run through `motion` (a Motion or gap.protocols.Protocol, or
    a dict of them by supply MPa; a list of them at a supply: each its own runs, their files
    lettered a, b, ...), read by `instrument`; with `chamber_pressures` the runs also
    carry both motor ports' pressures, as a calibration rig with a transducer on each port would
    measure them. campaign.toml declares the real hose length unless `declared_hose_length_m`
    says otherwise (a user who wrote down the wrong one)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    motion = motion or Motion()
    lines = [
        f"# synthetic campaign generated by gap.synth from the plant {description}".rstrip(),
        f'joint = "{JOINT}"',
        "payload_kg = 0.0  # the wrist rig turns about a vertical axis: no gravity load",
        f"hose_length_m = {reality.hose_length_m if declared_hose_length_m is None else declared_hose_length_m}",
        f"rig_inertia_kg_m2 = {RIG_INERTIA_KG_M2}  # assets/wrist_rig.xml rig_load",
    ]
    if twin_hose_loss is not None:
        lines += ["", "[twin]", f"hose_loss = {'true' if twin_hose_loss else 'false'}"]
    if instrument.declare:
        lines += ["", "[instrument]"] + [f"{k} = {getattr(instrument, k)!r}" for k in instrument.declare]
    for mpa in pressures_mpa:
        at = motion[mpa] if isinstance(motion, dict) else motion
        kinds = list(at) if isinstance(at, list | tuple) else [at]
        for m, kind in enumerate(kinds):
            # the plant is deterministic: repeats differ by what the instruments add
            run = simulate_run(
                reality,
                mpa,
                kind,
                log_period_s=1e-3,
                rig_spring_nm_per_rad=rig_spring_nm_per_rad,
                rig_load_nm=rig_load_nm,
            )
            tag = f"_{chr(ord('a') + m)}" if len(kinds) > 1 else ""
            for r in range(repeats):
                name = f"run_{int(round(mpa * 100)):03d}{tag}_{r + 1}.csv"
                write_run_csv(folder / name, run, measure(run, instrument, rng, chamber_pressures))
                lines += [
                    "",
                    "[[runs]]",
                    f'file = "{name}"',
                    f"supply_mpa = {mpa}",
                    f"start_deg = {{ {', '.join(f'{j} = 0.0' for j in assets.JOINTS)} }}",
                ]
    (folder / "campaign.toml").write_text("\n".join(lines) + "\n")
    return folder
