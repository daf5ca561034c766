"""A design's runs as files a platform plays: a plan folder in the campaign format (gap.campaign):
campaign.toml with one [[runs]] table per run, and one CSV per run with the commands at 1 ms
(time_s, direction, brake_released, valve_set_gauge_pa, supply_pa) and the instruments' columns
left empty (angle_rad, and p_a_pa, p_b_pa where the campaign measures chamber pressures) for the
platform to fill as it plays them. Filled, the plan is a campaign of its own (`load_campaign` reads
it) and its runs join the campaign they were designed for (`add_runs`).

`play_plan` plays a plan on the plant (gap.synth: MuJoCo and the pneumatics with hidden effects, the
bench's reality) from the files alone, as a platform would.
"""

from __future__ import annotations

import csv
import shutil
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import assets
from gap import synth
from gap.campaign import Campaign, GapError
from gap.discrimination import PlannedRun
from pneumatics import JointParams
from wrist_rig import commanded_run

COMMAND_COLUMNS = ("time_s", "direction", "brake_released", "valve_set_gauge_pa", "supply_pa")


@dataclass(frozen=True)
class Header:
    """What a plan's campaign.toml says besides its runs: the campaign's own (`of_campaign`)."""

    joint: str = commanded_run.JOINT
    payload_kg: float = 0.0
    hose_length_m: float = 8.0  # assets/joints/wrist_pitch.toml hose_length_m
    rig_inertia_kg_m2: float = commanded_run.RIG_INERTIA_KG_M2
    twin_hose_loss: bool | None = None
    instrument: tuple[tuple[str, float], ...] = ()  # what the campaign declares of its instrument
    pressures: bool = False  # the runs carry chamber-pressure columns

    @classmethod
    def of_campaign(cls, c: Campaign, pressures: bool) -> Header:
        declared = tuple((k, v) for k, v in vars(c.instrument).items() if v is not None)
        return cls(c.joint, c.payload_kg, c.hose_length_m, c.rig_inertia_kg_m2, c.twin_hose_loss, declared, pressures)

    def toml_lines(self, comment: str) -> list[str]:
        lines = [
            f"# {comment}",
            f'joint = "{self.joint}"',
            f"payload_kg = {self.payload_kg!r}",
            f"hose_length_m = {self.hose_length_m!r}",
            f"rig_inertia_kg_m2 = {self.rig_inertia_kg_m2!r}",
        ]
        if self.twin_hose_loss is not None:
            lines += ["", "[twin]", f"hose_loss = {'true' if self.twin_hose_loss else 'false'}"]
        if self.instrument:
            lines += ["", "[instrument]", *(f"{k} = {v!r}" for k, v in self.instrument)]
        return lines


def run_table(file: str, supply_mpa: float, start_deg: float, joint: str) -> list[str]:
    """One [[runs]] table: its file, supply and start pose (the joint under test at `start_deg`,
    the others at 0)."""
    pose = ", ".join(f"{j} = {start_deg if j == joint else 0.0!r}" for j in assets.JOINTS)
    return ["", "[[runs]]", f'file = "{file}"', f"supply_mpa = {supply_mpa!r}", f"start_deg = {{ {pose} }}"]


def write_plan(runs: list[PlannedRun], header: Header, folder: Path, comment: str) -> list[Path]:
    """The plan folder: campaign.toml and one CSV per run (commands filled, instruments empty)."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = header.toml_lines(comment)
    empty = ["angle_rad", *(("p_a_pa", "p_b_pa") if header.pressures else ())]
    paths = []
    for r in runs:
        path = folder / f"design_{r.name}.csv"
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow([*COMMAND_COLUMNS, *empty])
            for k in range(len(r.time_s)):
                w.writerow(
                    [
                        f"{r.time_s[k]:.4f}",
                        int(r.direction[k]),
                        int(r.brake_released[k]),
                        f"{r.valve_gauge_pa[k]:.1f}",
                        f"{r.supply_pa[k]:.1f}",
                        *[""] * len(empty),
                    ]
                )
        lines += run_table(path.name, r.supply_mpa, float(np.degrees(r.start_rad)), header.joint)
        paths.append(path)
    (folder / "campaign.toml").write_text("\n".join(lines) + "\n")
    return paths


@dataclass(frozen=True)
class Recorded:
    """A plan run's command rows as a motion the plant plays (wrist_rig.commanded_run.simulate_run): each row held
    until the next (zero-order hold, as the platform sends them)."""

    time_s: np.ndarray
    direction: np.ndarray
    valve_gauge_pa: np.ndarray
    brake_released: np.ndarray

    def total_s(self) -> float:
        return float(self.time_s[-1])

    def commands(self, t_s: np.ndarray, supply_gauge_pa: float, k_u_per_pa: float):
        i = np.clip(np.searchsorted(self.time_s, np.asarray(t_s) + 1e-9, side="right") - 1, 0, len(self.time_s) - 1)
        return self.direction[i], self.valve_gauge_pa[i], self.brake_released[i]


@dataclass(frozen=True)
class PlanEntry:
    file: str
    supply_mpa: float
    start_deg: float
    motion: Recorded


def read_plan(folder: Path) -> tuple[dict, list[PlanEntry]]:
    """A plan folder's campaign.toml (as a dict) and its runs' commands."""
    path = folder / "campaign.toml"
    try:
        doc = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise GapError(
            f"{path}: cannot read the plan ({e}); allowed: a plan folder written by `twin gap design`"
        ) from None
    entries = []
    for i, entry in enumerate(doc.get("runs", [])):
        run_path = folder / entry["file"]
        try:
            with open(run_path, newline="") as f:
                rows = list(csv.DictReader(f))
            cols = {c: np.array([float(r[c]) for r in rows]) for c in COMMAND_COLUMNS}
        except (OSError, KeyError, ValueError) as e:
            raise GapError(
                f"{path} ([[runs]] #{i + 1}): {entry['file']}: cannot read its commands ({e}); "
                f"allowed: a CSV with the columns {', '.join(COMMAND_COLUMNS)}"
            ) from None
        motion = Recorded(cols["time_s"], cols["direction"], cols["valve_set_gauge_pa"], cols["brake_released"])
        entries.append(
            PlanEntry(entry["file"], float(entry["supply_mpa"]), float(entry["start_deg"][doc["joint"]]), motion)
        )
    return doc, entries


def play_plan(
    plan: Path,
    played: Path,
    reality: JointParams,
    instrument: synth.SimInstrument,
    rng: np.random.Generator,
    chamber_pressures: bool,
    rig_spring_nm_per_rad: float = 0.0,
    rig_load_nm: float = 0.0,
) -> Path:
    """The plan in `plan` played on the plant with `reality` (and the rig's hidden loads), read by
    `instrument` (and the chamber-pressure transducers): its files with the instruments' columns
    filled, and its campaign.toml, in `played`."""
    _, entries = read_plan(plan)
    played.mkdir(parents=True, exist_ok=True)
    for e in entries:
        run = commanded_run.simulate_run(
            reality,
            e.supply_mpa,
            e.motion,
            np.radians(e.start_deg),
            log_period_s=1e-3,
            rig_spring_nm_per_rad=rig_spring_nm_per_rad,
            rig_load_nm=rig_load_nm,
        )
        synth.write_run_csv(played / e.file, run, synth.measure(run, instrument, rng, chamber_pressures))
    shutil.copyfile(plan / "campaign.toml", played / "campaign.toml")
    return played


def add_runs(campaign: Path, played: Path, out: Path) -> Path:
    """A campaign in `out`: `campaign`'s files and runs, and the played plan's runs after them."""
    shutil.copytree(campaign, out)
    doc, entries = read_plan(played)
    lines = [(campaign / "campaign.toml").read_text().rstrip(), "", "# the runs of a design round (gap.design)"]
    for e in entries:
        shutil.copyfile(played / e.file, out / e.file)
        lines += run_table(e.file, e.supply_mpa, e.start_deg, doc["joint"])
    (out / "campaign.toml").write_text("\n".join(lines) + "\n")
    return out
