"""A calibration campaign on disk: campaign.toml plus one run file per run, read and checked.

campaign.toml (its schema: `CampaignFile`, `RunEntry`, `TwinSwitches`, `Instrument` below):
    joint = "wrist_pitch"            # the joint under test (assets.JOINTS)
    payload_kg = 0.0                 # payload on the rig (the wrist rig turns about a vertical axis: no load torque)
    hose_length_m = 8.0              # valve -> motor hose, each port
    rig_inertia_kg_m2 = 0.02         # optional; joint-side inertia of the rig (assets/wrist_rig.xml)
    [twin]                           # optional: the nominal twin's switches
    hose_loss = false                # default: as the joint's parameter file
    [instrument]                     # optional: the reference angle instrument, each field optional
    latency_s = 0.02                 # its reading lags the joint by this much (not declared: estimated)
    noise_deg = 0.2                  # its noise, rms (not declared: estimated from repeats)
    rate_hz = 30.0                   # its sample rate (checked against the files; dropped samples counted)
    [[runs]]
    file = "run_050_1.csv"           # CSV (or the twin's own .mcap, see read_run_file)
    supply_mpa = 0.5                 # gauge, the paper's convention
    start_deg = { wrist_pitch = 0.0, ... }   # start pose of every joint (others stay braked)
    payload_kg = 5.0                 # optional: this run's payload (default: the campaign's)
    rig_inertia_kg_m2 = 0.05         # optional: this run's joint-side inertia with that payload

Run CSV columns: time_s, direction (-1/0/+1), brake_released (0/1), valve_set_gauge_pa (the
proportional valve's set point P_v, gauge Pa, optional) or valve_opening (0..1, optional: the set
point u / k_u; at most one of the two; neither = the set point equals the supply, i.e. the valve
wide open delivering the supply), supply_pa (absolute), angle_rad (reference instrument, empty/NaN where not
sampled), optional p_a_pa, p_b_pa. The file is read by the standard library's csv
module and its columns converted by numpy; anything else is refused with the file, the line and
what is wrong (GapError).
"""

from __future__ import annotations

import codecs
import csv
import dataclasses
import functools
import io
import itertools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pydantic
from pydantic import BaseModel, ValidationError

import assets
from pneumatics import load_joint_params
from pneumatics.gas import AIR
from pneumatics.params import SPEC
from twin.mcap_log import read_mcap
from twin_plumbing.errors import UserError
from twin_plumbing.fields import FLAG, MISSING, REAL, TABLE, TEXT, Problem, choice, first_problem, number, read_toml
from twin_plumbing.paths import input_problem, path_problem
from wrist_rig import commanded_run

REQUIRED_COLUMNS = ("time_s", "direction", "brake_released", "supply_pa", "angle_rad")
OPTIONAL_COLUMNS = ("valve_set_gauge_pa", "valve_opening", "p_a_pa", "p_b_pa")
NAN_COLUMNS = ("angle_rad", "p_a_pa", "p_b_pa")  # empty or nan: not sampled
MIN_RUNS = 2  # the diagnosis fits on some runs and judges on others
# MeasuredRun files: a calibration log samples at 1 kHz..50 Hz (the twin's own MCAP at 50 Hz); a step
# longer than this is a hole in the record, not a sample period (assumed).
MAX_TIME_STEP_S = 1.0
# The replay integrates at 1 ms and the effect search replays each run thousands of times; the
# paper's longest run is 30 s. Longer runs are refused rather than left to run for hours (assumed).
MAX_RUN_DURATION_S = 600.0
# The effect search replays each run thousands of times at 1 ms, so its cost grows with the runs'
# length (about 1 s of wall time per simulated second of a campaign, benchmarks.bench_gap's 16-run
# campaign): a run longer than this is fitted on its first FIT_WINDOW_S seconds, from its start,
# where its state is the one campaign.toml declares (a window further in would start from a state
# the file does not give). A calibration protocol repeats its moves; the first window holds them.
# The report names the runs cut so. 16 runs of 600 s at 1 kHz: diagnosed in the time of 16 runs
# of FIT_WINDOW_S (README, "Reliability").
FIT_WINDOW_S = 8.0
CHUNK_ROWS = 65_536  # a run file's rows converted and checked at a time (a few MB of text; 1 min at 1 kHz)
# A run filed under supply_mpa must have had that supply: a regulator holds it within a few kPa;
# beyond this the run belongs to another pressure (assumed, 1/6 of the paper's 0.5-0.8 MPa steps).
SUPPLY_TOLERANCE_MPA = 0.05
# Measured angles may pass a joint's range by the end stop's give and the instrument's offset.
ANGLE_MARGIN_DEG = 5.0  # assumed
MAX_ABS_PRESSURE_PA = 3e6  # above any supply of this class (0.5-0.8 MPa gauge, paper)
PAYLOAD_KG = number(0.0, 100.0, "kg")
RIG_INERTIA_RANGE = number(0.0, 100.0, "kg·m^2")  # campaign.toml's rig_inertia_kg_m2


class GapError(UserError):
    """A campaign or run file that cannot be diagnosed: names the file, the line and what is wrong."""


@dataclass(kw_only=True)
class MeasuredRun:
    """One run of a calibration campaign as its file holds it: the commands the rig sent, the
    supply and the reference instrument's angle of the joint under test (built by keyword)."""

    name: str
    path: Path
    supply_mpa: float
    start_rad: float  # joint under test
    time_s: np.ndarray
    direction: np.ndarray
    brake_released: np.ndarray
    valve_gauge_pa: np.ndarray  # proportional valve set point (or logged output, see valve_is_output), gauge Pa
    supply_pa: np.ndarray
    angle_rad: np.ndarray  # NaN where not sampled
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    # False: valve_gauge_pa is the valve's set point (CSV runs); True: it is the valve's logged
    # OUTPUT pressure (the twin's MCAP logs), which the replay imposes on the valve state directly.
    valve_is_output: bool = False
    recorded_s: float | None = None  # the run file's length, where the fit uses only its first FIT_WINDOW_S
    payload_kg: float = 0.0  # the load of this run (campaign.toml, per run or for all)
    rig_inertia_kg_m2: float = commanded_run.RIG_INERTIA_KG_M2  # joint-side inertia of the rig with that load

    @property
    def sampled(self) -> np.ndarray:
        return np.isfinite(self.angle_rad)

    def signature(self) -> tuple:
        """Runs with the same commands and supply are repeats of one another."""
        return (
            round(self.supply_mpa, 4),
            round(self.start_rad, 6),
            self.payload_kg,
            self.rig_inertia_kg_m2,
            self.direction.tobytes(),
            np.round(self.valve_gauge_pa, -2).tobytes(),
            self.brake_released.tobytes(),
        )


@pydantic.dataclasses.dataclass(frozen=True, config=TABLE)
class Instrument:
    """What the campaign declares of its reference angle instrument ([instrument]); None = not
    declared. A reading 1 s late or a 10 deg noise is no reference: the ranges stop there."""

    latency_s: number(0.0, 1.0, "s") | None = None
    noise_deg: number(0.0, 10.0, "deg rms") | None = None
    rate_hz: number(0.1, 1e5, "Hz") | None = None


@dataclass(kw_only=True)
class Campaign:
    """A calibration campaign (campaign.toml and its runs), built by keyword."""

    folder: Path
    joint: str
    payload_kg: float
    hose_length_m: float
    rig_inertia_kg_m2: float
    twin_hose_loss: float | None
    runs: list[MeasuredRun]
    instrument: Instrument = field(default_factory=Instrument)


class TwinSwitches(BaseModel):
    """[twin]: the nominal twin's switches."""

    model_config = TABLE

    hose_loss: FLAG | None = None  # None: as the joint's parameter file


class RunEntry(BaseModel):
    """One [[runs]] table."""

    model_config = TABLE

    file: TEXT  # a run file inside the campaign's folder (CSV, or the twin's own .mcap)
    supply_mpa: number(0.0, 2.0, "MPa gauge")
    start_deg: dict[str, REAL]  # joint -> deg, at least the joint under test (checked by _check_start)
    payload_kg: PAYLOAD_KG | None = None  # None: the campaign's
    rig_inertia_kg_m2: RIG_INERTIA_RANGE | None = None  # None: the campaign's


class CampaignFile(BaseModel):
    """campaign.toml."""

    model_config = TABLE

    joint: choice(*assets.JOINTS, why="is not a joint of the arm")
    payload_kg: PAYLOAD_KG = 0.0
    hose_length_m: number(SPEC["hose_length_m"].low, SPEC["hose_length_m"].high, "m")  # the parameter file's range
    rig_inertia_kg_m2: RIG_INERTIA_RANGE = commanded_run.RIG_INERTIA_KG_M2
    twin: TwinSwitches = TwinSwitches()
    instrument: Instrument = Instrument()
    runs: list[RunEntry] = []  # at least MIN_RUNS (checked so that the message says why)


@functools.lru_cache(maxsize=1)
def joint_ranges_rad() -> dict[str, tuple[float, float]]:
    """Each joint's range from the arm's MJCF (the one file MuJoCo and Pinocchio read)."""
    model = mujoco.MjModel.from_xml_path(str(assets.ARM_XML))
    return {j: (float(model.joint(j).range[0]), float(model.joint(j).range[1])) for j in assets.JOINTS}


def _inside(folder: Path, name: str, where: str) -> Path:
    """The run file `name` of a campaign in `folder`; refused unless it lies inside the folder
    (no absolute path, no `..`, no symbolic link that leads out): a campaign reads only its own files."""
    if Path(name).is_absolute() or ".." in Path(name).parts:
        raise GapError(f"{where}: file = {name!r} leaves the campaign folder; allowed: a file name inside {folder}")
    path = folder / name
    problem = path_problem(path)
    if problem:
        raise GapError(f"{where}: file = {name!r} {problem}; allowed: a file inside {folder}")
    if not path.resolve().is_relative_to(folder.resolve()):
        raise GapError(
            f"{where}: file = {name!r} leads out of the campaign folder (to {path.resolve()}); "
            f"allowed: a file inside {folder}"
        )
    return path


def _check_run(run: MeasuredRun, where: str, joint: str) -> None:
    """What a run must hold beyond its own file's format: its supply is the one it is filed
    under, its angles lie in the joint's range, it is no longer than the replay can afford."""
    gauge_mpa = (float(np.mean(run.supply_pa)) - AIR.p_atm_pa) / 1e6
    if abs(gauge_mpa - run.supply_mpa) > SUPPLY_TOLERANCE_MPA:
        raise GapError(
            f"{where}: supply_mpa = {run.supply_mpa:g}, but {run.path.name}'s supply_pa averages "
            f"{gauge_mpa:.3f} MPa gauge; "
            f"allowed: within {SUPPLY_TOLERANCE_MPA:g} MPa of the logged supply"
        )
    lo, hi = (math.degrees(v) for v in joint_ranges_rad()[joint])
    angles = np.degrees(run.angle_rad[run.sampled])
    bad = np.flatnonzero((angles < lo - ANGLE_MARGIN_DEG) | (angles > hi + ANGLE_MARGIN_DEG))
    if bad.size:
        k = int(np.flatnonzero(run.sampled)[bad[0]])
        raise GapError(
            f"{run.path}: angle_rad = {run.angle_rad[k]:g} at time_s = {run.time_s[k]:g} is outside {joint}'s range; "
            f"allowed: {lo - ANGLE_MARGIN_DEG:.1f}..{hi + ANGLE_MARGIN_DEG:.1f} deg "
            f"(assets/arm.xml range +- {ANGLE_MARGIN_DEG:g} deg)"
        )
    jump = _first_jump(run.time_s)
    if jump is not None:
        raise _jump_error(str(run.path), run.time_s, jump)
    if run.time_s[-1] > MAX_RUN_DURATION_S:
        raise GapError(f"{run.path}: lasts {run.time_s[-1]:g} s; allowed: at most {MAX_RUN_DURATION_S:g} s a run")


def _first_jump(t_rel: np.ndarray) -> int | None:
    """The first row after which time steps by more than MAX_TIME_STEP_S (a hole), or None."""
    over = np.flatnonzero(np.diff(t_rel) > MAX_TIME_STEP_S)
    return int(over[0]) if over.size else None


def _jump_error(where: str, t_rel: np.ndarray, k: int) -> GapError:
    return GapError(
        f"{where}: time_s jumps from {t_rel[k]:g} to {t_rel[k + 1]:g} s (relative to the first row); "
        f"allowed: steps of at most {MAX_TIME_STEP_S:g} s"
    )


def _toml_line(text: str, needle: str, occurrence: int = 0) -> int:
    """1-based line of the `occurrence`-th line containing `needle` (for error messages), 0 if none."""
    seen = 0
    for i, line in enumerate(text.splitlines(), 1):
        if needle in line:
            if seen == occurrence:
                return i
            seen += 1
    return 0


def _key_line(text: str, key: str) -> int:
    """1-based line where the top-level `key` is set (for error messages), 0 if none."""
    m = re.search(rf"^\s*{re.escape(key)}\s*=", text, re.M)
    return text.count("\n", 0, m.start()) + 1 if m else 0


def _at(path: Path, line: int) -> str:
    return f"{path}:{line}" if line else str(path)


def _refusal(path: Path, text: str, p: Problem) -> GapError:
    """The one-line refusal of campaign.toml: `<file>:<line> (<table>): key = value; allowed: ...`."""
    head, rest = p.loc[0], p.loc[1:]
    if head == "runs" and rest:
        where, key = f"{_at(path, _toml_line(text, '[[runs]]', rest[0]))} ([[runs]] #{rest[0] + 1})", rest[1:]
    elif head in ("twin", "instrument") and rest:
        line = _at(path, _toml_line(text, f"[{head}]"))
        if p.why == "is not a known field":
            return GapError(f"{line}: [{head}] {rest[0]} is not a known field; allowed: {p.allowed}")
        where, key = f"{line} ([{head}])", rest
    else:
        where, key = _at(path, _key_line(text, str(head))), p.loc
    name = ".".join(str(k) for k in key if k != "[key]")
    allowed = f"the name of a run file in {path.parent}" if key == ("file",) else p.allowed
    if p.value is MISSING or p.why == "is not a known field":
        return GapError(f"{where}: {name} {p.why}; allowed: {allowed}")
    why = "" if p.why in ("is not allowed", "is outside the allowed range") else f" {p.why}"
    return GapError(f"{where}: {name} = {p.value!r}{why}; allowed: {allowed}")


def _campaign_file(folder: str | Path) -> tuple[Path, str, CampaignFile]:
    """campaign.toml (in `folder`, or `folder` itself), its text and its checked contents."""
    folder = Path(folder)
    problem = path_problem(folder)
    if problem:
        raise GapError(f"{folder}: {problem}; allowed: a campaign folder (campaign.toml and one file per run)")
    path = folder / "campaign.toml" if folder.is_dir() else folder
    problem = input_problem(path)
    if problem:
        raise GapError(f"{path}: {problem}; allowed: a campaign file this user can read")
    if not path.is_file():
        raise GapError(
            f"{path}: no such campaign file (a campaign is a folder with campaign.toml and one file per run)"
        )
    doc, text = read_toml(path, GapError, "campaign file")
    try:
        c = CampaignFile.model_validate(doc)
    except ValidationError as e:
        raise _refusal(path, text, first_problem(e, CampaignFile)) from None
    if len(c.runs) < MIN_RUNS:
        raise GapError(
            f"{path}: {len(c.runs)} [[runs]]; allowed: at least {MIN_RUNS} [[runs]] tables (the diagnosis fits on "
            "some runs and judges on others), each with file, supply_mpa, start_deg"
        )
    return path, text, c


def _check_start(where: str, start: dict[str, float], joint: str) -> None:
    """A run's start_deg: the joint under test among them, every joint the arm's, inside its range."""
    if joint not in start:
        raise GapError(
            f"{where}: start_deg must give the start angle of every joint, at least {joint!r}; "
            f"e.g. start_deg = {{ {joint} = 0.0 }}"
        )
    for j, v in start.items():
        if j not in assets.JOINTS:
            raise GapError(f"{where}: start_deg names unknown joint {j!r}; allowed: {', '.join(assets.JOINTS)}")
        if not math.isfinite(v):
            raise GapError(f"{where}: start_deg.{j} = {v!r} is not a number (degrees)")
        lo, hi = (math.degrees(x) for x in joint_ranges_rad()[j])
        if not lo <= v <= hi:
            raise GapError(
                f"{where}: start_deg.{j} = {v!r} is outside the joint's range; "
                f"allowed: {lo:.1f}..{hi:.1f} deg (assets/arm.xml)"
            )


def load_campaign(folder: str | Path) -> Campaign:
    """A campaign folder (or its campaign.toml) read and checked, with every run file."""
    path, text, c = _campaign_file(folder)
    runs, files = [], {}
    for i, entry in enumerate(c.runs):
        where = f"{_at(path, _toml_line(text, '[[runs]]', i))} ([[runs]] #{i + 1})"
        _check_start(where, entry.start_deg, c.joint)
        start_rad = math.radians(entry.start_deg[c.joint])
        run_path = _inside(path.parent, entry.file, where)
        first = files.setdefault(run_path.resolve(), i)
        if first != i:  # one recording counted twice would pass for two repeats that agree exactly
            raise GapError(
                f"{where}: file = {entry.file!r} is also [[runs]] #{first + 1}'s; allowed: a file of its own for "
                "each run (repeats are separate recordings)"
            )
        run = read_run_file(run_path, entry.supply_mpa, start_rad, where, c.joint)
        _check_run(run, where, c.joint)
        run = fit_window(run)
        run.payload_kg = c.payload_kg if entry.payload_kg is None else entry.payload_kg
        run.rig_inertia_kg_m2 = c.rig_inertia_kg_m2 if entry.rig_inertia_kg_m2 is None else entry.rig_inertia_kg_m2
        runs.append(run)
    hose_loss = None if c.twin.hose_loss is None else float(c.twin.hose_loss)
    return Campaign(
        folder=path.parent,
        joint=c.joint,
        payload_kg=c.payload_kg,
        hose_length_m=c.hose_length_m,
        rig_inertia_kg_m2=c.rig_inertia_kg_m2,
        twin_hose_loss=hose_loss,
        runs=runs,
        instrument=c.instrument,
    )


def fit_window(run: MeasuredRun) -> MeasuredRun:
    """`run`, or its first FIT_WINDOW_S seconds if it is longer (recorded_s: its whole length)."""
    if run.time_s[-1] <= FIT_WINDOW_S:
        return run
    keep = run.time_s <= FIT_WINDOW_S
    cut = {
        name: getattr(run, name)[keep]
        for name in ("time_s", "direction", "brake_released", "valve_gauge_pa", "supply_pa", "angle_rad")
    }
    extra = {k: v[keep] for k, v in run.extra.items()}
    return dataclasses.replace(run, **cut, extra=extra, recorded_s=float(run.time_s[-1]))


def read_run_file(
    path: Path, supply_mpa: float, start_rad: float, where: str = "", joint: str = "wrist_pitch"
) -> MeasuredRun:
    problem = input_problem(path)
    if problem:
        raise GapError(f"{where}: run file {path} {problem}; allowed: a CSV or .mcap file")
    if path.is_dir():
        raise GapError(f"{where}: run file {path} is a folder; allowed: a CSV or .mcap file")
    if not path.is_file():
        raise GapError(f"{where}: run file {path} does not exist; allowed: a CSV or .mcap file")
    if path.suffix.lower() == ".mcap":
        return _read_mcap_run(path, supply_mpa, start_rad, joint)
    return _read_csv_run(path, supply_mpa, start_rad, joint)


def _not_utf8(path: Path) -> GapError:
    """Where the run file stops being UTF-8 text: its line and byte, found by decoding it again in
    pieces (it is never held whole)."""
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    line = 1
    with open(path, "rb") as f:
        while piece := f.read(1 << 16):
            try:
                decoder.decode(piece)
            except UnicodeDecodeError as e:  # e.object: the few bytes held back from before, then piece
                line += e.object.count(b"\n", 0, e.start)
                return GapError(
                    f"{path}:{line}: byte 0x{e.object[e.start]:02x} is not UTF-8 text ({e.reason}); "
                    "allowed: a UTF-8 (or ASCII) CSV"
                )
            line += piece.count(b"\n")
    return GapError(f"{path}: not UTF-8 text; allowed: a UTF-8 (or ASCII) CSV")


def csv_text(path: Path) -> str:
    """A run file's whole text (the arm's campaigns read theirs whole): UTF-8, a byte-order mark at
    its start allowed; GapError naming the line and byte where it is not."""
    try:
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _not_utf8(path) from None


def _read_csv_columns(path: Path) -> dict[str, np.ndarray]:
    """The run file's columns by name, read as a stream of CHUNK_ROWS lines at a time, each
    converted to numbers and checked before the next is read: the file is refused (GapError) at
    the first chunk that holds a refused row (its earliest, as a row-by-row reader would find it:
    the earliest row, and in it the first column, then the checks in order) or that ends past
    MAX_RUN_DURATION_S, so a file far too long costs its first 600 s to refuse, not its whole
    length. A chunk is converted by pyarrow's CSV reader (C++: 600 000 rows in ~1 s, against ~5 s
    for the csv module's rows and numpy's conversion of their texts); one it cannot take whole, or
    that holds a refused value or a blank line, is read again by the csv module, row by row, for
    the refusal's line and words. UTF-8 text, a byte-order mark at its start allowed (a
    spreadsheet's export)."""
    chunks: list[dict[str, np.ndarray]] = []
    with open(path, "rb") as f:
        header = _header_of(path, f.readline())
        last_line = 1  # the file's lines read so far
        while lines := list(itertools.islice(f, CHUNK_ROWS)):
            first_line, last_line = last_line + 1, last_line + len(lines)
            a = _fast_chunk(header, lines)
            if a is None or _refused_values(a, chunks):
                a, cut = _exact_chunk(path, header, lines, first_line, chunks)
                if cut:  # a row with a wrong number of fields: the rows before it are checked, then it is refused
                    raise GapError(cut)
            else:
                _check_times(path, a, list(range(first_line, last_line + 1)), chunks)
            chunks.append(a)
    if not chunks:
        return {h: np.zeros(0) for h in header}
    return {h: np.concatenate([c[h] for c in chunks]) for h in header}


def _header_of(path: Path, line: bytes) -> list[str]:
    """The run file's header from its first line, checked (_check_header)."""
    try:
        text = line.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _not_utf8(path) from None
    header = next(csv.reader([text]), None)
    if not header:
        raise GapError(f"{path}:1: empty run file; expected a header with {', '.join(REQUIRED_COLUMNS)}")
    header = [h.strip() for h in header]
    _check_header(path, header)
    return header


def _fast_chunk(header: list[str], lines: list[bytes]) -> dict[str, np.ndarray] | None:
    """The chunk's columns as float64 (NaN where a field is empty) by pyarrow, or None where it
    cannot take them (a field that is no number, a wrong number of fields, a blank line, bytes
    that are not text, a line longer than the csv module takes a field): the row-by-row reading
    then says which and where."""
    if max(map(len, lines)) > csv.field_size_limit():
        return None
    options = pa_csv.ConvertOptions(
        column_types=dict.fromkeys(header, pa.float64()),
        null_values=[""],  # only an empty field is "not sampled"; the csv path refuses "NA" and the like
        strings_can_be_null=False,
        quoted_strings_can_be_null=False,
    )
    try:
        table = pa_csv.read_csv(
            io.BytesIO(b"".join(lines)),
            read_options=pa_csv.ReadOptions(column_names=header, use_threads=False),
            convert_options=options,
        )
    except (pa.ArrowInvalid, pa.ArrowTypeError, UnicodeDecodeError):
        return None
    if table.num_rows != len(lines):  # pyarrow skips blank lines: the rows' lines would be lost
        return None
    return {h: table.column(h).to_numpy(zero_copy_only=False).astype(np.float64) for h in header}


def _refused_values(a: dict[str, np.ndarray], before: list[dict[str, np.ndarray]]) -> bool:
    """Does the chunk hold a value some check refuses (then it is read again row by row, which
    says the refusal in the file's own words)?"""
    bad = any(np.isinf(v).any() or (h not in NAN_COLUMNS and np.isnan(v).any()) for h, v in a.items())
    t = a["time_s"]
    return bad or bool(_row_checks(a)) or bool(before and t.size and not t[0] > before[-1]["time_s"][-1])


def _exact_chunk(
    path: Path, header: list[str], lines: list[bytes], first_line: int, before: list[dict[str, np.ndarray]]
) -> tuple[dict[str, np.ndarray], str]:
    """The chunk read row by row by the csv module (blank lines skipped, their lines counted) and
    checked (GapError at its first refused row); and the refusal of a row with a wrong number of
    fields, where the reading stops ("" if none)."""
    try:
        text = [line.decode("utf-8") for line in lines]
    except UnicodeDecodeError:
        raise _not_utf8(path) from None
    rows, numbers, cut = [], [], ""
    reader = csv.reader(text)
    try:
        for row in reader:
            line = first_line + reader.line_num - 1
            if row and len(row) != len(header):
                cut = f"{path}:{line}: {len(row)} fields, the header has {len(header)}"
                break
            if row:
                rows.append(row)
                numbers.append(line)
    except csv.Error as e:  # e.g. a field over the csv module's limit (131072 characters), a NUL
        line = first_line + reader.line_num - 1
        raise GapError(
            f"{path}:{line}: not readable as CSV ({e}); allowed: comma-separated numbers, one row a line"
        ) from None
    return _checked_chunk(path, header, rows, numbers, before), cut


def _checked_chunk(
    path: Path, header: list[str], rows: list[list[str]], lines: list[int], before: list[dict[str, np.ndarray]]
) -> dict[str, np.ndarray]:
    """One chunk of rows as columns of numbers; GapError at its first refused row, or where it runs
    past MAX_RUN_DURATION_S from the file's first row (`before`: the chunks already read)."""
    columns = dict(zip(header, zip(*rows, strict=True), strict=True)) if rows else dict.fromkeys(header, ())
    a, refusals = {}, []
    for order, h in enumerate(header):
        a[h], found = _column(h, columns[h])
        refusals += [(k, order, m) for k, m in found]
    t = a["time_s"]
    if before and t.size and not t[0] > before[-1]["time_s"][-1]:  # the row check below sees this chunk only
        previous = before[-1]["time_s"][-1]
        message = f"time_s = {t[0]:g} does not increase (previous {previous:g}); allowed: time strictly increasing"
        refusals.append((0, len(header), message))
    refusals += [(k, len(header) + order, m) for order, (k, m) in enumerate(_row_checks(a))]
    if refusals:
        k, _, message = min(refusals)
        raise GapError(f"{path}:{lines[k]}: {message}")
    _check_times(path, a, lines, before)
    return a


def _check_times(path: Path, a: dict[str, np.ndarray], lines: list[int], before: list[dict[str, np.ndarray]]) -> None:
    """GapError where the chunk's time steps over a hole (MAX_TIME_STEP_S) or passes
    MAX_RUN_DURATION_S from the file's first row (`before`: the chunks already read)."""
    t = a["time_s"]
    first = before[0]["time_s"][0] if before else (t[0] if t.size else 0.0)
    t_rel = np.r_[before[-1]["time_s"][-1] if before else first, t] - first  # with the row before the chunk
    jump = _first_jump(t_rel)
    if jump is not None:
        raise _jump_error(str(path), t_rel, jump)
    over = np.flatnonzero(t - first > MAX_RUN_DURATION_S)
    if over.size:
        k = int(over[0])
        raise GapError(
            f"{path}:{lines[k]}: time_s = {t[k]:g} is {t[k] - first:g} s after the first row; "
            f"allowed: runs of at most {MAX_RUN_DURATION_S:g} s (the file is refused here, not read on)"
        )


def _check_header(path: Path, header: list[str]) -> None:
    twice = sorted({c for c in header if header.count(c) > 1})
    if twice:
        raise GapError(f"{path}:1: column(s) {', '.join(twice)} appear more than once; allowed: each column once")
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise GapError(
            f"{path}:1: missing column(s) {', '.join(missing)}; required: {', '.join(REQUIRED_COLUMNS)}; "
            f"optional: {', '.join(OPTIONAL_COLUMNS)}"
        )
    unknown = [c for c in header if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
    if unknown:
        raise GapError(
            f"{path}:1: unknown column(s) {', '.join(unknown)}; "
            f"allowed: {', '.join(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)}"
        )
    if "valve_opening" in header and "valve_set_gauge_pa" in header:
        raise GapError(f"{path}:1: both valve_opening and valve_set_gauge_pa; allowed: at most one of them")


def _column(name: str, texts: tuple[str, ...]) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """A CSV column as float64 (NaN where empty, `nan` or unreadable) and its first refusal as
    (row, message) ([] if none): not a number, empty where a number is needed, not finite."""
    try:
        values = np.array(texts, dtype=np.float64)  # each text parsed as Python's float() does
        words = np.zeros(len(texts), dtype=bool)
    except ValueError:  # an empty field or a word: parse one by one to tell which
        parsed = [_float_or_none(t) for t in texts]
        words = np.array([p is None for p in parsed])
        values = np.array([math.nan if p is None else p for p in parsed], dtype=np.float64)
    found = _first(words, lambda k: f"{name} = {texts[k].strip()!r} is not a number")
    if name not in NAN_COLUMNS:
        found += _first(np.isnan(values) & ~words, lambda k: f"{name} is empty; allowed: a number")
    found += _first(np.isinf(values), lambda k: f"{name} = {texts[k].strip()!r} is not finite")
    return values, [min(found)] if found else []


def _float_or_none(text: str) -> float | None:
    """float(text); NaN if empty; None if it is no number."""
    if not text.strip():
        return math.nan
    try:
        return float(text)
    except ValueError:
        return None


def _first(mask: np.ndarray, message: object) -> list[tuple[int, str]]:
    """[(first row where `mask` holds, its message)], or [] if none; `message(k)` writes it."""
    rows = np.flatnonzero(mask)
    return [(int(rows[0]), message(int(rows[0])))] if rows.size else []


def _row_checks(a: dict[str, np.ndarray]) -> list[tuple[int, str]]:
    """Each value check's first refused row, as (row, message): time increasing, the commands'
    values, the valve and pressure ranges (NaN, i.e. unreadable or not sampled, passes here)."""
    t, d, b = a["time_s"], a["direction"], a["brake_released"]
    found = _first(
        np.r_[False, ~(t[1:] > t[:-1])],
        lambda k: (
            f"time_s = {t[k]:g} does not increase (previous {t[k - 1]:g}); "
            "allowed: time strictly increasing from row to row"
        ),
    )
    found += _first(~np.isin(d, (-1.0, 0.0, 1.0)), lambda k: f"direction = {d[k]:g}; allowed: -1, 0, +1")
    found += _first(~np.isin(b, (0.0, 1.0)), lambda k: f"brake_released = {b[k]:g}; allowed: 0 or 1")
    if "valve_set_gauge_pa" in a:
        v = a["valve_set_gauge_pa"]
        found += _first((v < 0.0) | (v > 3e6), lambda k: f"valve_set_gauge_pa = {v[k]:g}; allowed: gauge Pa in 0..3e6")
    if "valve_opening" in a:
        u = a["valve_opening"]
        found += _first((u < 0.0) | (u > 1.0), lambda k: f"valve_opening = {u[k]:g}; allowed: 0..1")
    for h in ("supply_pa", "p_a_pa", "p_b_pa"):
        if h in a:
            p = a[h]
            found += _first(
                (p <= 0.0) | (p >= MAX_ABS_PRESSURE_PA),
                lambda k, h=h, p=p: f"{h} = {p[k]:g}; allowed: absolute Pa above 0 and below {MAX_ABS_PRESSURE_PA:g}",
            )
    return found


def _read_csv_run(path: Path, supply_mpa: float, start_rad: float, joint: str) -> MeasuredRun:
    a = _read_csv_columns(path)
    n, samples = len(a["time_s"]), int(np.isfinite(a["angle_rad"]).sum())
    if n < 2 or samples < 2:
        raise GapError(f"{path}: needs at least 2 rows and 2 angle samples, has {n} rows and {samples} samples")
    if "valve_set_gauge_pa" in a:
        valve = a["valve_set_gauge_pa"]
    elif "valve_opening" in a:
        valve = a["valve_opening"] / load_joint_params(assets.joint_param_path(joint)).k_u_per_pa
    else:
        valve = a["supply_pa"] - AIR.p_atm_pa
    extra = {k: a[k] for k in ("p_a_pa", "p_b_pa") if k in a}
    return MeasuredRun(
        name=path.stem,
        path=path,
        supply_mpa=supply_mpa,
        start_rad=start_rad,
        time_s=a["time_s"] - a["time_s"][0],
        direction=a["direction"],
        brake_released=a["brake_released"],
        valve_gauge_pa=valve,
        supply_pa=a["supply_pa"],
        angle_rad=a["angle_rad"],
        extra=extra,
    )


def _read_mcap_run(path: Path, supply_mpa: float, start_rad: float, joint: str = "wrist_pitch") -> MeasuredRun:
    """A run logged by the twin itself (twin.mcap_log.McapRecorder): commands, supply, valve output
    pressure and true angle of `joint` at every log sample (20 ms by default).

    The logged valve_gauge_pa is the proportional valve's OUTPUT (plant.sensors(): S_PV + sensor
    bias), not its set point: the run is marked valve_is_output so the replay sets the valve state
    from it instead of lagging it a second time. Direction and brake_release are the commands (the
    solenoid delay and the brake act on them in the replay, as in the plant). Commands are held
    between log samples, so command changes between samples are seen up to one log period late.
    """
    arrays, meta = read_mcap(path)
    recovery = meta["recovery"]
    if not recovery["complete"]:
        raise GapError(
            f"{path}: the log is cut short ({recovery['stopped_by'] or 'no footer'}; {recovery['samples']} samples, "
            f"{recovery['duration_s']:.2f} s readable); "
            "allowed: a complete log (`twin replay` shows what a cut one holds)"
        )
    joints = list(meta["joints"])
    if joint not in joints:
        raise GapError(f"{path}: the log has joints {', '.join(joints)}, not the campaign's joint {joint!r}")
    j = joints.index(joint)
    t = np.asarray(arrays["time_s"], dtype=float)
    if len(t) < 2:
        raise GapError(f"{path}: {len(t)} log sample(s); a run needs at least 2")
    return MeasuredRun(
        name=path.stem,
        path=path,
        supply_mpa=supply_mpa,
        start_rad=start_rad,
        time_s=t - t[0],
        direction=np.asarray(arrays["direction"])[:, j].astype(float),
        brake_released=np.asarray(arrays["brake_release"])[:, j].astype(float),
        valve_gauge_pa=np.asarray(arrays["valve_gauge_pa"])[:, j].astype(float),
        supply_pa=np.broadcast_to(np.asarray(arrays["supply_pa"], dtype=float).reshape(-1), t.shape).copy(),
        angle_rad=np.asarray(arrays["true_angle_rad"])[:, j].astype(float),
        valve_is_output=True,
    )


def supply_gauge_pa(run: MeasuredRun) -> float:
    return float(np.mean(run.supply_pa)) - AIR.p_atm_pa
