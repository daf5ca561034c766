"""An arm campaign on disk: logs of the whole arm at work, read and checked (docs/gap_arm.md).

campaign.toml (its schema: `ArmCampaignFile` and the tables below):
    arm = "as_built"                 # the twin the runs are replayed through: "as_built" (assets/as_built)
                                     # or "nominal" (assets/joints alone)
    hose_loss = true                 # optional: the twin's hose loss (default: as the parameter files)
    payload_kg = 20.0                # the payload the twin believes the arm carries
    [instrument]                     # the external angle instrument
    kind = "camera"                  # "camera" (markers on the links) or "encoder" (a test stand)
    rate_hz = 30.0                   # its sample rate
    latency_s = 0.025                # optional: its reading lags the arm by this much (not declared: estimated)
    noise_deg = 0.2                  # optional: its noise, rms (not declared: the kind's default)
    dropout_fraction = 0.03          # optional: the fraction of samples it loses (informative)
    joints = ["shoulder_pitch", ...] # optional: the joints it sees (default: all five)
    [pressures]                      # optional: the platform's port pressure transducers
    noise_pa = 1000.0                # their noise, rms
    [reality]                        # rehearsals only: what the plant had beyond the twin (never read by the diagnosis)
    effect = "elbow_pitch:coulomb_friction"   # "<joint>:<catalogue effect>" or "arm:<arm effect>"
    value = 40.0
    [[runs]]
    file = "run_01.csv"              # CSV, or the twin's own .mcap (`twin run --mcap`)
    start_deg = { base_yaw = 0.0, shoulder_pitch = 90.0, ... }  # every joint's start (drive angles)

Run CSV columns: `time_s`, `supply_pa` (absolute, at the platform), and for each joint J of
assets.JOINTS: `J.direction` (-1/0/+1), `J.brake_released` (0/1), `J.valve_set_gauge_pa` (the
proportional valve's set point, gauge Pa), and where measured `J.p_a_pa`, `J.p_b_pa` (the port
pressures at the platform, absolute Pa) and `J.angle_rad` (the instrument's drive angle; empty
where it has no sample). Commands hold from a row to the next. Anything else is refused in one
line with the file, the line, the field, the value and what is allowed (GapError).
"""

from __future__ import annotations

import csv
import io
import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pydantic
from pydantic import BaseModel, ValidationError

import assets
from gap.arm_effects import candidate_named
from gap.campaign import (
    MAX_ABS_PRESSURE_PA,
    MAX_RUN_DURATION_S,
    MAX_TIME_STEP_S,
    GapError,
    _column,
    _fast_chunk,
    _first,
    _inside,
    _toml_line,
    csv_text,
    joint_ranges_rad,
)
from twin.mcap_log import LogError, read_mcap
from twin_plumbing.fields import FLAG, MISSING, REAL, TABLE, TEXT, choice, first_problem, number, read_toml
from twin_plumbing.paths import input_problem
from wrist_rig import commanded_run

JOINTS = assets.JOINTS
COMMAND_FIELDS = ("direction", "brake_released", "valve_set_gauge_pa")  # per joint, required
MEASURED_FIELDS = ("p_a_pa", "p_b_pa", "angle_rad")  # per joint, optional; empty = not sampled
# a kind's noise when campaign.toml does not say (synth's camera and encoder: gap/synth.py)
DEFAULT_NOISE_DEG = {"camera": 0.2, "encoder": 0.05}
MIN_RUNS = 2  # the diagnosis fits on some runs and judges on others


def column(joint: str, name: str) -> str:
    return f"{joint}.{name}"


TOP_COLUMNS = ("time_s", "supply_pa")
REQUIRED_COLUMNS = TOP_COLUMNS + tuple(column(j, f) for j in JOINTS for f in COMMAND_FIELDS)
OPTIONAL_COLUMNS = tuple(column(j, f) for j in JOINTS for f in MEASURED_FIELDS)


@pydantic.dataclasses.dataclass(frozen=True, config=TABLE)
class ArmInstrument:
    """[instrument]: the external angle instrument. The ranges stop where it is no reference."""

    kind: choice("camera", "encoder")
    rate_hz: number(0.1, 1e5, "Hz")
    latency_s: number(0.0, 1.0, "s") | None = None
    noise_deg: number(0.0, 10.0, "deg rms") | None = None
    dropout_fraction: number(0.0, 0.9, "") = 0.0
    joints: list[choice(*JOINTS, why="is not a joint of the arm")] | None = None

    def seen(self) -> tuple[str, ...]:
        return tuple(self.joints) if self.joints is not None else JOINTS

    def noise_rad(self) -> float:
        return math.radians(self.noise_deg if self.noise_deg is not None else DEFAULT_NOISE_DEG[self.kind])


# the instruments a rehearsal reads its runs with (gap/synth.py's two, for the whole arm), and the
# design's before any campaign (gap.arm_design): a 30 frame/s camera tracking a marker on each link,
# 0.2 deg rms, 25 ms late, 3 % of frames lost; an encoder on each joint of a test stand at 200 Hz,
# 0.05 deg rms, no latency
CAMERA = ArmInstrument(kind="camera", rate_hz=30.0, latency_s=0.025, noise_deg=0.2, dropout_fraction=0.03)
ENCODER = ArmInstrument(kind="encoder", rate_hz=200.0, latency_s=0.0, noise_deg=0.05)


# the platform's port transducers read at 50 Hz (assumed: as the wrist rig's instrument)
PRESSURE_PERIOD_S = commanded_run.SAMPLE_PERIOD_S


@pydantic.dataclasses.dataclass(frozen=True, config=TABLE)
class Pressures:
    """[pressures]: the platform's port pressure transducers."""

    noise_pa: number(0.0, 1e5, "Pa rms") = 1000.0


@pydantic.dataclasses.dataclass(frozen=True, config=TABLE)
class HiddenArmEffect:
    """[reality]: a rehearsal's hidden effect (the bench scores against it; the diagnosis never reads it)."""

    effect: TEXT
    value: REAL


class ArmRunEntry(BaseModel):
    model_config = TABLE

    file: TEXT
    start_deg: dict[str, REAL]


class ArmCampaignFile(BaseModel):
    """campaign.toml of an arm campaign."""

    model_config = TABLE

    arm: choice("as_built", "nominal") = "as_built"
    hose_loss: FLAG | None = None
    payload_kg: number(0.0, 100.0, "kg")
    instrument: ArmInstrument
    pressures: Pressures = Pressures()
    reality: HiddenArmEffect | None = None
    runs: list[ArmRunEntry] = []


@dataclass
class ArmRun:
    """One run: the commands (rows held until the next), the supply, and what was measured."""

    name: str
    path: Path
    start_rad: np.ndarray  # (n_joints,) drive angles at the start
    time_s: np.ndarray  # (n,) from 0
    commands: np.ndarray  # (n, n_joints, 3): direction, valve set point gauge Pa, brake release
    supply_pa: np.ndarray  # (n,) absolute
    angle_rad: np.ndarray  # (n, n_joints) the instrument's drive angles, NaN where none
    port_pa: np.ndarray  # (n, n_joints, 2) the platform's port pressures, NaN where none
    # True: commands[..., 1] is the proportional valve's logged OUTPUT (the twin's MCAP), not its set point
    valve_is_output: bool = False


@dataclass
class ArmCampaign:
    folder: Path
    arm: str
    hose_loss: bool | None
    payload_kg: float
    instrument: ArmInstrument
    pressures: Pressures
    runs: list[ArmRun]
    reality: HiddenArmEffect | None = None
    joints: tuple[str, ...] = field(default=JOINTS)


def _line_in_table(text: str, table: str, key: str) -> int:
    """1-based line of `key = ` inside `table` (its header's line if the key is not there)."""
    start = _toml_line(text, table)
    for i, line in enumerate(text.splitlines()[start:], start + 1):
        if line.lstrip().startswith("["):
            break
        if line.split("=")[0].strip() == key:
            return i
    return start


def _refusal(path: Path, text: str, problem) -> GapError:
    """campaign.toml's refusal in one line: `<file>:<line> (<table>): field = value; allowed: ...`."""
    loc = problem.loc
    if loc and loc[0] == "runs" and len(loc) > 1:
        where = f"{path}:{_toml_line(text, '[[runs]]', loc[1])} ([[runs]] #{loc[1] + 1})"
        key = loc[2:]
    elif loc and loc[0] in ("instrument", "pressures", "reality") and len(loc) > 1:
        where, key = f"{path}:{_line_in_table(text, f'[{loc[0]}]', str(loc[1]))} ([{loc[0]}])", loc[1:]
    else:
        where, key = f"{path}:{_toml_line(text, f'{loc[0]} =') if loc else 0}", loc
    name = ".".join(str(k) for k in key) or str(loc[0] if loc else "")
    if problem.value is MISSING or problem.why == "is not a known field":
        return GapError(f"{where}: {name} {problem.why}; allowed: {problem.allowed}")
    return GapError(f"{where}: {name} = {problem.value!r} {problem.why}; allowed: {problem.allowed}")


def load_arm_campaign(folder: str | Path, min_runs: int = MIN_RUNS) -> ArmCampaign:
    """An arm campaign folder (or its campaign.toml) read and checked, with every run file; at least
    `min_runs` runs (1 for a design's plan, gap.arm_design_report, whose runs join a campaign)."""
    folder = Path(folder)
    path = folder / "campaign.toml" if folder.is_dir() else folder
    if not path.is_file():
        raise GapError(f"{path}: no such campaign file (an arm campaign is a folder with campaign.toml and its runs)")
    doc, text = read_toml(path, GapError, "campaign file")
    try:
        c = ArmCampaignFile.model_validate(doc)
    except ValidationError as e:
        raise _refusal(path, text, first_problem(e, ArmCampaignFile)) from None
    if len(c.runs) < min_runs:
        raise GapError(
            f"{path}: {len(c.runs)} [[runs]]; allowed: at least {min_runs} (the diagnosis fits on some runs and "
            "judges on others), each with file and start_deg"
        )
    if c.reality is not None:
        try:
            candidate_named(c.reality.effect)
        except ValueError:
            raise GapError(
                f"{path}:{_toml_line(text, '[reality]')} ([reality]): effect = {c.reality.effect!r}; allowed: "
                "'<joint>:<effect>' (gap.arm_effects.JOINT_CATALOGUE) or 'arm:<effect>' (ARM_CATALOGUE)"
            ) from None
    runs, seen = [], {}
    for i, entry in enumerate(c.runs):
        where = f"{path}:{_toml_line(text, '[[runs]]', i)} ([[runs]] #{i + 1})"
        start = _start(where, entry.start_deg)
        run_path = _inside(path.parent, entry.file, where)
        first = seen.setdefault(run_path.resolve(), i)
        if first != i:
            raise GapError(f"{where}: file = {entry.file!r} is also [[runs]] #{first + 1}'s; allowed: one file a run")
        runs.append(read_arm_run(run_path, start, where))
    return ArmCampaign(path.parent, c.arm, c.hose_loss, c.payload_kg, c.instrument, c.pressures, runs, c.reality)


def _start(where: str, start_deg: dict[str, float]) -> np.ndarray:
    """A run's start_deg as drive angles in rad: every joint given, each inside its range."""
    missing = [j for j in JOINTS if j not in start_deg]
    if missing:
        raise GapError(f"{where}: start_deg lacks {', '.join(missing)}; allowed: every joint of {', '.join(JOINTS)}")
    out = []
    for j, v in start_deg.items():
        if j not in JOINTS:
            raise GapError(f"{where}: start_deg.{j} is not a joint of the arm; allowed: {', '.join(JOINTS)}")
        lo, hi = (math.degrees(x) for x in joint_ranges_rad()[j])
        # the elbow's drive angle is shoulder + elbow: its range is the sum's
        if j == "elbow_pitch":
            lo, hi = lo + math.degrees(joint_ranges_rad()["shoulder_pitch"][0]), hi + 180.0
        if not (math.isfinite(v) and lo <= v <= hi):
            raise GapError(f"{where}: start_deg.{j} = {v!r}; allowed: {lo:.1f}..{hi:.1f} deg (assets/arm.xml)")
    for j in JOINTS:
        out.append(math.radians(start_deg[j]))
    return np.array(out)


def read_arm_run(path: Path, start_rad: np.ndarray, where: str = "") -> ArmRun:
    problem = input_problem(path)
    if problem or not path.is_file():
        raise GapError(f"{where}: run file {path} {problem or 'is not a file'}; allowed: a CSV or .mcap file")
    run = _read_mcap(path, start_rad) if path.suffix.lower() == ".mcap" else _read_csv(path, start_rad)
    if run.time_s[-1] > MAX_RUN_DURATION_S:
        raise GapError(f"{path}: lasts {run.time_s[-1]:g} s; allowed: at most {MAX_RUN_DURATION_S:g} s a run")
    return run


def _check_header(path: Path, header: list[str]) -> None:
    twice = sorted({c for c in header if header.count(c) > 1})
    if twice:
        raise GapError(f"{path}:1: column {twice[0]} appears more than once; allowed: each column once")
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise GapError(
            f"{path}:1: missing column {missing[0]}"
            + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else "")
            + "; allowed: a header with time_s, supply_pa and, per joint J, "
            "J.direction, J.brake_released, J.valve_set_gauge_pa"
        )
    unknown = [c for c in header if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
    if unknown:
        raise GapError(
            f"{path}:1: unknown column {unknown[0]!r}; allowed: time_s, supply_pa, and J.<field> for J in "
            f"{', '.join(JOINTS)}, field in {', '.join(COMMAND_FIELDS + MEASURED_FIELDS)}"
        )


def _rows(path: Path) -> tuple[list[str], dict[str, tuple[str, ...]], list[int]]:
    """The header and each column's texts, with the rows' line numbers (blank lines skipped)."""
    reader = csv.reader(io.StringIO(csv_text(path), newline=""))
    try:
        header = [h.strip() for h in next(reader, [])]
        if not header:
            raise GapError(f"{path}:1: empty run file; expected a header with {', '.join(TOP_COLUMNS)}, J.direction...")
        _check_header(path, header)
        rows, lines = [], []
        for row in reader:
            if row and len(row) != len(header):
                raise GapError(f"{path}:{reader.line_num}: {len(row)} fields, the header has {len(header)}")
            if row:
                rows.append(row)
                lines.append(reader.line_num)
    except csv.Error as e:
        raise GapError(
            f"{path}:{reader.line_num}: not readable as CSV ({e}); allowed: comma-separated numbers"
        ) from None
    columns = dict(zip(header, zip(*rows, strict=True), strict=True)) if rows else dict.fromkeys(header, ())
    return header, columns, lines


def _value_checks(a: dict[str, np.ndarray]) -> list[tuple[int, str]]:
    """Each value check's first refused row: time increasing by at most MAX_TIME_STEP_S, the
    commands' values, the pressures' ranges (NaN, not sampled, passes)."""
    t = a["time_s"]
    step = np.diff(t, prepend=-math.inf)
    found = _first(np.r_[False, ~(step[1:] > 0)], lambda k: f"time_s = {t[k]:g} does not increase; allowed: increasing")
    found += _first(
        np.r_[False, step[1:] > MAX_TIME_STEP_S],
        lambda k: f"time_s = {t[k]:g} jumps from {t[k - 1]:g}; allowed: steps of at most {MAX_TIME_STEP_S:g} s",
    )
    for j in JOINTS:
        d, b, v = (a[column(j, f)] for f in COMMAND_FIELDS)
        found += _first(
            ~np.isin(d, (-1.0, 0.0, 1.0)), lambda k, j=j, d=d: f"{j}.direction = {d[k]:g}; allowed: -1, 0, +1"
        )
        found += _first(~np.isin(b, (0.0, 1.0)), lambda k, j=j, b=b: f"{j}.brake_released = {b[k]:g}; allowed: 0 or 1")
        found += _first(
            (v < 0) | (v > 3e6), lambda k, j=j, v=v: f"{j}.valve_set_gauge_pa = {v[k]:g}; allowed: gauge Pa in 0..3e6"
        )
    for h in ("supply_pa", *(column(j, f) for j in JOINTS for f in ("p_a_pa", "p_b_pa"))):
        if h in a:
            p = a[h]
            found += _first(
                (p <= 0) | (p >= MAX_ABS_PRESSURE_PA),
                lambda k, h=h, p=p: f"{h} = {p[k]:g}; allowed: absolute Pa above 0 and below {MAX_ABS_PRESSURE_PA:g}",
            )
    return found


def _fast_columns(path: Path) -> dict[str, np.ndarray] | None:
    """The run file's columns by pyarrow's CSV reader (C++: a 60 s run of 60 000 rows in a fraction
    of a second, against about a second for the csv module's rows and their texts' conversion), or
    None where it cannot take the file or a value in it is refused: the row-by-row reading
    (`_checked_columns`) then says which and where."""
    try:
        lines = path.read_bytes().splitlines(keepends=True)
        header = [h.strip() for h in next(csv.reader([lines[0].decode("utf-8-sig")]))] if lines else []
    except (UnicodeDecodeError, csv.Error, OSError):
        return None
    if len(lines) < 2 or len(set(header)) != len(header) or not set(REQUIRED_COLUMNS) <= set(header):
        return None
    if not set(header) <= set(REQUIRED_COLUMNS + OPTIONAL_COLUMNS):
        return None
    a = _fast_chunk(header, lines[1:])
    if a is None:
        return None
    refused = any(np.isinf(v).any() or (not h.endswith(MEASURED_FIELDS) and np.isnan(v).any()) for h, v in a.items())
    return None if refused or _value_checks(a) else a


def _checked_columns(path: Path) -> dict[str, np.ndarray]:
    """The run file's columns read row by row by the csv module, each value checked; GapError at
    the first refused one, naming its line."""
    header, texts, lines = _rows(path)
    a, refusals = {}, []
    for order, h in enumerate(header):
        # a measured column may be empty (not sampled): read under its bare name, which gap.campaign allows
        bare = h.split(".")[-1] if h.endswith(MEASURED_FIELDS) else h
        a[h], found = _column(bare, texts[h])
        refusals += [(k, order, m.replace(bare, h, 1)) for k, m in found]
    if not refusals:
        refusals += [(k, len(header), m) for k, m in _value_checks(a)]
    if refusals:
        k, _, message = min(refusals)
        raise GapError(f"{path}:{lines[k]}: {message}")
    return a


def _read_csv(path: Path, start_rad: np.ndarray) -> ArmRun:
    a = _fast_columns(path)
    if a is None:
        a = _checked_columns(path)
    n = len(a["time_s"])
    if n < 2:
        raise GapError(f"{path}: {n} row(s); allowed: at least 2 rows")
    nan = np.full(n, np.nan)
    commands = np.stack([np.stack([a[column(j, f)] for f in COMMAND_FIELDS], axis=1) for j in JOINTS], axis=1)
    # the platform's command row order is (direction, valve set point, brake release): pneumatics.joint's C_*
    commands = commands[:, :, [0, 2, 1]]
    return ArmRun(
        path.stem,
        path,
        start_rad,
        a["time_s"] - a["time_s"][0],
        commands,
        a["supply_pa"],
        np.stack([a.get(column(j, "angle_rad"), nan) for j in JOINTS], axis=1),
        np.stack([np.stack([a.get(column(j, f), nan) for f in ("p_a_pa", "p_b_pa")], axis=1) for j in JOINTS], axis=1),
    )


def _read_mcap(path: Path, start_rad: np.ndarray) -> ArmRun:
    """A run the twin logged (`twin run --mcap`): its commands, supply and true drive angles every
    log sample (20 ms). Its valve pressure is the valve's OUTPUT (the platform's sensor), so the
    run is marked valve_is_output; it has no port pressures at the platform (NaN)."""
    try:
        arrays, meta = read_mcap(path)
    except LogError as e:
        raise GapError(str(e)) from None
    if not meta["recovery"]["complete"]:
        raise GapError(f"{path}: the log is cut short; allowed: a complete log")
    if tuple(meta["joints"]) != JOINTS:
        raise GapError(
            f"{path}: the log has joints {', '.join(meta['joints'])}; allowed: the arm's {', '.join(JOINTS)}"
        )
    t = np.asarray(arrays["time_s"], dtype=float)
    if len(t) < 2:
        raise GapError(f"{path}: {len(t)} log sample(s); allowed: at least 2")
    commands = np.stack(
        [np.asarray(arrays[k], dtype=float) for k in ("direction", "valve_gauge_pa", "brake_release")], axis=2
    )
    return ArmRun(
        path.stem,
        path,
        start_rad,
        t - t[0],
        commands,
        np.broadcast_to(np.asarray(arrays["supply_pa"], dtype=float).reshape(-1), t.shape).copy(),
        np.asarray(arrays["true_angle_rad"], dtype=float),
        np.full((len(t), len(JOINTS), 2), np.nan),
        valve_is_output=True,
    )


def write_arm_run(path: Path, run: ArmRun, blank: list[tuple[str, str]] = ()) -> None:
    """A run file in the campaign format: commands and supply every row, measured values where
    sampled; the (joint, field) columns of `blank` too, empty where not sampled (a plan's columns for
    the platform to fill)."""
    have = [
        (j, f)
        for f in MEASURED_FIELDS
        for i, j in enumerate(JOINTS)
        if (j, f) in blank
        or np.isfinite(run.angle_rad[:, i] if f == "angle_rad" else run.port_pa[:, i, MEASURED_FIELDS.index(f)]).any()
    ]
    header = (
        list(TOP_COLUMNS) + [column(j, f) for j in JOINTS for f in COMMAND_FIELDS] + [column(j, f) for j, f in have]
    )
    fmt = {"angle_rad": "{:.7f}", "p_a_pa": "{:.0f}", "p_b_pa": "{:.0f}"}
    measured = [
        (
            fmt[f],
            run.angle_rad[:, JOINTS.index(j)]
            if f == "angle_rad"
            else run.port_pa[:, JOINTS.index(j), MEASURED_FIELDS.index(f)],
        )
        for j, f in have
    ]
    with open(path, "w", newline="") as out:
        w = csv.writer(out)
        w.writerow(header)
        for k in range(len(run.time_s)):
            c = run.commands[k]
            # commands and supply as the platform sent them, every digit: a joint near its breakaway
            # turns on a fraction of a N·m, so a rounded set point can move a replay by degrees
            row = [f"{run.time_s[k]:.4f}", repr(float(run.supply_pa[k]))]
            for i in range(len(JOINTS)):
                row += [int(c[i, 0]), int(c[i, 2]), repr(float(c[i, 1]))]
            row += ["" if not math.isfinite(v[k]) else f.format(v[k]) for f, v in measured]
            w.writerow(row)


def campaign_toml(
    instrument: ArmInstrument,
    runs: list[tuple[str, np.ndarray]],
    payload_kg: float,
    arm: str = "as_built",
    hose_loss: bool | None = None,
    reality: HiddenArmEffect | None = None,
    comment: str = "",
) -> str:
    """campaign.toml's text for `runs` (file name, start drive angles rad)."""
    lines = [f"# {comment}"] if comment else []
    lines += [f'arm = "{arm}"', f"payload_kg = {payload_kg!r}"]
    if hose_loss is not None:
        lines.append(f"hose_loss = {'true' if hose_loss else 'false'}")
    lines += ["", "[instrument]", f'kind = "{instrument.kind}"', f"rate_hz = {instrument.rate_hz!r}"]
    for k in ("latency_s", "noise_deg"):
        if getattr(instrument, k) is not None:
            lines.append(f"{k} = {getattr(instrument, k)!r}")
    lines.append(f"dropout_fraction = {instrument.dropout_fraction!r}")
    if instrument.joints is not None:
        lines.append("joints = [" + ", ".join(f'"{j}"' for j in instrument.joints) + "]")
    if reality is not None:
        lines += ["", "[reality]", f'effect = "{reality.effect}"', f"value = {reality.value!r}"]
    for name, start in runs:
        starts = ", ".join(f"{j} = {math.degrees(v)!r}" for j, v in zip(JOINTS, start, strict=True))
        lines += ["", "[[runs]]", f'file = "{name}"', f"start_deg = {{ {starts} }}"]
    return "\n".join(lines) + "\n"


def add_arm_runs(campaign: Path, played: Path, out: Path) -> Path:
    """A campaign in `out`: `campaign`'s files and runs, and a played plan's runs after them (its
    run files and [[runs]] tables; a plan written by `twin gap design --arm`, its columns filled)."""
    plan = load_arm_campaign(played, min_runs=1)
    shutil.copytree(campaign, out)
    lines = [(campaign / "campaign.toml").read_text().rstrip(), "", "# the runs of a design round (gap.arm_design)"]
    for r in plan.runs:
        shutil.copyfile(r.path, out / r.path.name)
        starts = ", ".join(f"{j} = {math.degrees(v)!r}" for j, v in zip(JOINTS, r.start_rad, strict=True))
        lines += ["", "[[runs]]", f'file = "{r.path.name}"', f"start_deg = {{ {starts} }}"]
    (out / "campaign.toml").write_text("\n".join(lines) + "\n")
    return out
