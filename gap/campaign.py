"""A calibration campaign on disk: campaign.toml plus one run file per run, read and checked.

campaign.toml:
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
sampled), optional p_a_pa, p_b_pa. Anything else is refused with the file, the line and what is
wrong (GapError).
"""

from __future__ import annotations

import csv
import functools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import assets
from pneumatics import load_joint_params
from pneumatics.gas import AIR
from twin.errors import UserError

REQUIRED_COLUMNS = ("time_s", "direction", "brake_released", "supply_pa", "angle_rad")
OPTIONAL_COLUMNS = ("valve_set_gauge_pa", "valve_opening", "p_a_pa", "p_b_pa")
WRIST_RIG_INERTIA_KG_M2 = 0.02  # assets/wrist_rig.xml, body rig_load
CAMPAIGN_KEYS = ("joint", "payload_kg", "hose_length_m", "rig_inertia_kg_m2", "twin", "instrument", "runs")
RUN_KEYS = ("file", "supply_mpa", "start_deg", "payload_kg", "rig_inertia_kg_m2")
TWIN_KEYS = ("hose_loss",)
MIN_RUNS = 2  # the diagnosis fits on some runs and judges on others
# Run files: a calibration log samples at 1 kHz..50 Hz (the twin's own MCAP at 50 Hz); a step
# longer than this is a hole in the record, not a sample period (assumed).
MAX_TIME_STEP_S = 1.0
# The replay integrates at 1 ms and the effect search replays each run thousands of times; the
# paper's longest run is 30 s. Longer runs are refused rather than left to run for hours (assumed).
MAX_RUN_DURATION_S = 600.0
# A run filed under supply_mpa must have had that supply: a regulator holds it within a few kPa;
# beyond this the run belongs to another pressure (assumed, 1/6 of the paper's 0.5-0.8 MPa steps).
SUPPLY_TOLERANCE_MPA = 0.05
# Measured angles may pass a joint's range by the end stop's give and the instrument's offset.
ANGLE_MARGIN_DEG = 5.0  # assumed
MAX_ABS_PRESSURE_PA = 3e6  # above any supply of this class (0.5-0.8 MPa gauge, paper)
# [instrument] fields and their allowed ranges (a reading 1 s late or a 10 deg noise is no reference)
INSTRUMENT_FIELDS = (("latency_s", 0.0, 1.0, "s"), ("noise_deg", 0.0, 10.0, "deg rms"), ("rate_hz", 0.1, 1e5, "Hz"))


class GapError(UserError):
    """A campaign or run file that cannot be diagnosed: names the file, the line and what is wrong."""


@dataclass
class Run:
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
    payload_kg: float = 0.0  # the load of this run (campaign.toml, per run or for all)
    rig_inertia_kg_m2: float = WRIST_RIG_INERTIA_KG_M2  # joint-side inertia of the rig with that load

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


@dataclass(frozen=True)
class Instrument:
    """What the campaign declares of its reference angle instrument; None = not declared."""

    latency_s: float | None = None
    noise_deg: float | None = None
    rate_hz: float | None = None


@dataclass
class Campaign:
    folder: Path
    joint: str
    payload_kg: float
    hose_length_m: float
    rig_inertia_kg_m2: float
    twin_hose_loss: float | None
    runs: list[Run]
    instrument: Instrument = field(default_factory=Instrument)


def _number(
    where: str, table: dict, key: str, low: float, high: float, unit: str, default: float | None = None
) -> float:
    if key not in table:
        if default is not None:
            return default
        raise GapError(f"{where}: {key} is missing; allowed: a number in {low:g}..{high:g} {unit}")
    v = table[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not low <= v <= high:
        raise GapError(f"{where}: {key} = {v!r}; allowed: a number in {low:g}..{high:g} {unit}")
    return float(v)


def _unknown_keys(where: str, table: dict, allowed: tuple[str, ...], what: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise GapError(f"{where}: {what}{unknown[0]} is not a known field; allowed: {', '.join(allowed)}")


@functools.lru_cache(maxsize=1)
def joint_ranges_rad() -> dict[str, tuple[float, float]]:
    """Each joint's range from the arm's MJCF (the one file MuJoCo and Pinocchio read)."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(assets.ARM_XML))
    return {j: (float(model.joint(j).range[0]), float(model.joint(j).range[1])) for j in assets.JOINTS}


def _inside(folder: Path, name: str, where: str) -> Path:
    """The run file `name` of a campaign in `folder`; refused unless it lies inside the folder
    (no absolute path, no `..`, no symbolic link that leads out): a campaign reads only its own files."""
    if Path(name).is_absolute() or ".." in Path(name).parts:
        raise GapError(f"{where}: file = {name!r} leaves the campaign folder; allowed: a file name inside {folder}")
    path = folder / name
    if not path.resolve().is_relative_to(folder.resolve()):
        raise GapError(
            f"{where}: file = {name!r} leads out of the campaign folder (to {path.resolve()}); allowed: a file inside {folder}"
        )
    return path


def _check_run(run: Run, where: str, joint: str) -> None:
    """What a run must hold beyond its own file's format: its supply is the one it is filed
    under, its angles lie in the joint's range, it is no longer than the replay can afford."""
    gauge_mpa = (float(np.mean(run.supply_pa)) - AIR.p_atm_pa) / 1e6
    if abs(gauge_mpa - run.supply_mpa) > SUPPLY_TOLERANCE_MPA:
        raise GapError(
            f"{where}: supply_mpa = {run.supply_mpa:g}, but {run.path.name}'s supply_pa averages {gauge_mpa:.3f} MPa gauge; "
            f"allowed: within {SUPPLY_TOLERANCE_MPA:g} MPa of the logged supply"
        )
    lo, hi = (math.degrees(v) for v in joint_ranges_rad()[joint])
    angles = np.degrees(run.angle_rad[run.sampled])
    bad = np.flatnonzero((angles < lo - ANGLE_MARGIN_DEG) | (angles > hi + ANGLE_MARGIN_DEG))
    if bad.size:
        k = int(np.flatnonzero(run.sampled)[bad[0]])
        raise GapError(
            f"{run.path}: angle_rad = {run.angle_rad[k]:g} at time_s = {run.time_s[k]:g} is outside {joint}'s range; "
            f"allowed: {lo - ANGLE_MARGIN_DEG:.1f}..{hi + ANGLE_MARGIN_DEG:.1f} deg (assets/arm.xml range +- {ANGLE_MARGIN_DEG:g} deg)"
        )
    steps = np.diff(run.time_s)
    if steps.size and steps.max() > MAX_TIME_STEP_S:
        k = int(np.argmax(steps))
        raise GapError(
            f"{run.path}: time_s jumps from {run.time_s[k]:g} to {run.time_s[k + 1]:g} s (relative to the first row); "
            f"allowed: steps of at most {MAX_TIME_STEP_S:g} s"
        )
    if run.time_s[-1] > MAX_RUN_DURATION_S:
        raise GapError(f"{run.path}: lasts {run.time_s[-1]:g} s; allowed: at most {MAX_RUN_DURATION_S:g} s a run")


def _toml_line(text: str, needle: str, occurrence: int = 0) -> int:
    """1-based line of the `occurrence`-th line containing `needle` (for error messages), 0 if none."""
    seen = 0
    for i, line in enumerate(text.splitlines(), 1):
        if needle in line:
            if seen == occurrence:
                return i
            seen += 1
    return 0


def load_campaign(folder: str | Path) -> Campaign:
    folder = Path(folder)
    path = folder / "campaign.toml" if folder.is_dir() else folder
    folder = path.parent
    if not path.is_file():
        raise GapError(
            f"{path}: no such campaign file (a campaign is a folder with campaign.toml and one file per run)"
        )
    text = path.read_text()
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise GapError(f"{path}: not valid TOML: {e}") from None
    _unknown_keys(f"{path}", doc, CAMPAIGN_KEYS, "")
    joint = doc.get("joint")
    if joint not in assets.JOINTS:
        raise GapError(
            f"{path}:{_toml_line(text, 'joint')}: joint = {joint!r} is not a joint of the arm; allowed: {', '.join(assets.JOINTS)}"
        )
    payload = _number(f"{path}", doc, "payload_kg", 0.0, 100.0, "kg", default=0.0)
    hose = _number(f"{path}", doc, "hose_length_m", 0.01, 100.0, "m")
    rig_j = _number(f"{path}", doc, "rig_inertia_kg_m2", 0.0, 100.0, "kg·m^2", default=WRIST_RIG_INERTIA_KG_M2)
    twin = doc.get("twin", {})
    if not isinstance(twin, dict):
        raise GapError(f"{path}: twin = {twin!r}; allowed: a table [twin] with {', '.join(TWIN_KEYS)}")
    _unknown_keys(f"{path}:{_toml_line(text, '[twin]')}", twin, TWIN_KEYS, "[twin] ")
    hl = twin.get("hose_loss")
    if hl is not None and not isinstance(hl, bool):
        raise GapError(f"{path}:{_toml_line(text, 'hose_loss')}: [twin] hose_loss = {hl!r}; allowed: true or false")
    inst = doc.get("instrument", {})
    if not isinstance(inst, dict):
        raise GapError(
            f"{path}:{_toml_line(text, 'instrument')}: instrument must be a table [instrument] with latency_s, noise_deg, rate_hz"
        )
    _unknown_keys(
        f"{path}:{_toml_line(text, '[instrument]')}", inst, tuple(f[0] for f in INSTRUMENT_FIELDS), "[instrument] "
    )
    where_inst = f"{path}:{_toml_line(text, '[instrument]')} ([instrument])"
    instrument = Instrument(
        *(_number(where_inst, inst, k, lo, hi, unit) if k in inst else None for k, lo, hi, unit in INSTRUMENT_FIELDS)
    )
    runs_doc = doc.get("runs")
    if not isinstance(runs_doc, list) or not all(isinstance(r, dict) for r in runs_doc) or len(runs_doc) < MIN_RUNS:
        n = len(runs_doc) if isinstance(runs_doc, list) else 0
        raise GapError(
            f"{path}: {n} [[runs]]; allowed: at least {MIN_RUNS} [[runs]] tables (the diagnosis fits on some runs and judges on others), each with file, supply_mpa, start_deg"
        )
    runs = []
    ranges = joint_ranges_rad()
    for i, r in enumerate(runs_doc):
        line = _toml_line(text, "[[runs]]", i)
        where = f"{path}:{line} ([[runs]] #{i + 1})"
        _unknown_keys(where, r, RUN_KEYS, "")
        f = r.get("file")
        if not isinstance(f, str):
            got = "file is missing" if f is None else f"file = {f!r}"
            raise GapError(f"{where}: {got}; allowed: the name of a run file in {folder}")
        supply = _number(where, r, "supply_mpa", 0.0, 2.0, "MPa gauge")
        start = r.get("start_deg")
        if not isinstance(start, dict) or joint not in start:
            raise GapError(
                f"{where}: start_deg must give the start angle of every joint, at least {joint!r}; e.g. start_deg = {{ {joint} = 0.0 }}"
            )
        for j, v in start.items():
            if j not in assets.JOINTS:
                raise GapError(f"{where}: start_deg names unknown joint {j!r}; allowed: {', '.join(assets.JOINTS)}")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise GapError(f"{where}: start_deg.{j} = {v!r} is not a number (degrees)")
            lo, hi = (math.degrees(x) for x in ranges[j])
            if not lo <= v <= hi:
                raise GapError(
                    f"{where}: start_deg.{j} = {v!r} is outside the joint's range; allowed: {lo:.1f}..{hi:.1f} deg (assets/arm.xml)"
                )
        run = read_run_file(_inside(folder, f, where), supply, math.radians(start[joint]), where, joint)
        _check_run(run, where, joint)
        run.payload_kg = _number(where, r, "payload_kg", 0.0, 100.0, "kg", default=payload)
        run.rig_inertia_kg_m2 = _number(where, r, "rig_inertia_kg_m2", 0.0, 100.0, "kg·m^2", default=rig_j)
        runs.append(run)
    return Campaign(folder, joint, payload, hose, rig_j, None if hl is None else (1.0 if hl else 0.0), runs, instrument)


def read_run_file(path: Path, supply_mpa: float, start_rad: float, where: str = "", joint: str = "wrist_pitch") -> Run:
    if not path.is_file():
        raise GapError(f"{where}: run file {path} does not exist")
    if path.suffix.lower() == ".mcap":
        return _read_mcap_run(path, supply_mpa, start_rad, joint)
    return _read_csv_run(path, supply_mpa, start_rad, joint)


def _read_csv_run(path: Path, supply_mpa: float, start_rad: float, joint: str) -> Run:
    with open(path, newline="") as f:
        reader = csv.reader(f)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise GapError(f"{path}:1: empty run file; expected a header with {', '.join(REQUIRED_COLUMNS)}") from None
        missing = [c for c in REQUIRED_COLUMNS if c not in header]
        if missing:
            raise GapError(
                f"{path}:1: missing column(s) {', '.join(missing)}; required: {', '.join(REQUIRED_COLUMNS)}; optional: {', '.join(OPTIONAL_COLUMNS)}"
            )
        unknown = [c for c in header if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
        if unknown:
            raise GapError(
                f"{path}:1: unknown column(s) {', '.join(unknown)}; allowed: {', '.join(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)}"
            )
        if "valve_opening" in header and "valve_set_gauge_pa" in header:
            raise GapError(f"{path}:1: both valve_opening and valve_set_gauge_pa; allowed: at most one of them")
        cols = {h: [] for h in header}
        for line_no, row in enumerate(reader, 2):
            if not row:
                continue
            if len(row) != len(header):
                raise GapError(f"{path}:{line_no}: {len(row)} fields, the header has {len(header)}")
            for h, v in zip(header, row):
                v = v.strip()
                if v == "" or v.lower() == "nan":
                    if h in ("angle_rad", "p_a_pa", "p_b_pa"):
                        cols[h].append(math.nan)
                        continue
                    raise GapError(f"{path}:{line_no}: {h} is empty; allowed: a number")
                try:
                    x = float(v)
                except ValueError:
                    raise GapError(f"{path}:{line_no}: {h} = {v!r} is not a number") from None
                if not math.isfinite(x):
                    raise GapError(f"{path}:{line_no}: {h} = {v!r} is not finite")
                cols[h].append(x)
            t = cols["time_s"]
            if len(t) > 1 and not t[-1] > t[-2]:
                raise GapError(
                    f"{path}:{line_no}: time_s = {t[-1]:g} does not increase (previous {t[-2]:g}); allowed: time strictly increasing from row to row"
                )
            d = cols["direction"][-1]
            if d not in (-1.0, 0.0, 1.0):
                raise GapError(f"{path}:{line_no}: direction = {d:g}; allowed: -1, 0, +1")
            b = cols["brake_released"][-1]
            if b not in (0.0, 1.0):
                raise GapError(f"{path}:{line_no}: brake_released = {b:g}; allowed: 0 or 1")
            if "valve_set_gauge_pa" in cols and not 0.0 <= cols["valve_set_gauge_pa"][-1] <= 3e6:
                raise GapError(
                    f"{path}:{line_no}: valve_set_gauge_pa = {cols['valve_set_gauge_pa'][-1]:g}; allowed: gauge Pa in 0..3e6"
                )
            if "valve_opening" in cols and not 0.0 <= cols["valve_opening"][-1] <= 1.0:
                raise GapError(f"{path}:{line_no}: valve_opening = {cols['valve_opening'][-1]:g}; allowed: 0..1")
            for h in ("supply_pa", "p_a_pa", "p_b_pa"):
                v = cols[h][-1] if h in cols else math.nan
                if not math.isnan(v) and not 0.0 < v < MAX_ABS_PRESSURE_PA:
                    raise GapError(
                        f"{path}:{line_no}: {h} = {v:g}; allowed: absolute Pa above 0 and below {MAX_ABS_PRESSURE_PA:g}"
                    )
    a = {h: np.asarray(v, dtype=np.float64) for h, v in cols.items()}
    n = len(a["time_s"])
    if n < 2 or np.isfinite(a["angle_rad"]).sum() < 2:
        raise GapError(
            f"{path}: needs at least 2 rows and 2 angle samples, has {n} rows and {int(np.isfinite(a['angle_rad']).sum())} samples"
        )
    if "valve_set_gauge_pa" in a:
        valve = a["valve_set_gauge_pa"]
    elif "valve_opening" in a:
        valve = a["valve_opening"] / load_joint_params(assets.joint_param_path(joint)).k_u_per_pa
    else:
        valve = a["supply_pa"] - AIR.p_atm_pa
    extra = {k: a[k] for k in ("p_a_pa", "p_b_pa") if k in a}
    return Run(
        path.stem,
        path,
        supply_mpa,
        start_rad,
        a["time_s"] - a["time_s"][0],
        a["direction"],
        a["brake_released"],
        valve,
        a["supply_pa"],
        a["angle_rad"],
        extra,
    )


def _read_mcap_run(path: Path, supply_mpa: float, start_rad: float, joint: str = "wrist_pitch") -> Run:
    """A run logged by the twin itself (twin.mcap_log.McapRecorder): commands, supply, valve output
    pressure and true angle of `joint` at every log sample (20 ms by default).

    The logged valve_gauge_pa is the proportional valve's OUTPUT (plant.sensors(): S_PV + sensor
    bias), not its set point: the run is marked valve_is_output so the replay sets the valve state
    from it instead of lagging it a second time. Direction and brake_release are the commands (the
    solenoid delay and the brake act on them in the replay, as in the plant). Commands are held
    between log samples, so command changes between samples are seen up to one log period late.
    """
    from twin.mcap_log import read_mcap  # noqa: PLC0415  (twin.mcap_log needs the mcap packages)

    arrays, meta = read_mcap(path)
    recovery = meta["recovery"]
    if not recovery["complete"]:
        raise GapError(
            f"{path}: the log is cut short ({recovery['stopped_by'] or 'no footer'}; {recovery['samples']} samples, "
            f"{recovery['duration_s']:.2f} s readable); allowed: a complete log (`twin replay` shows what a cut one holds)"
        )
    joints = list(meta["joints"])
    if joint not in joints:
        raise GapError(f"{path}: the log has joints {', '.join(joints)}, not the campaign's joint {joint!r}")
    j = joints.index(joint)
    t = np.asarray(arrays["time_s"], dtype=float)
    if len(t) < 2:
        raise GapError(f"{path}: {len(t)} log sample(s); a run needs at least 2")
    return Run(
        path.stem,
        path,
        supply_mpa,
        start_rad,
        t - t[0],
        np.asarray(arrays["direction"])[:, j].astype(float),
        np.asarray(arrays["brake_release"])[:, j].astype(float),
        np.asarray(arrays["valve_gauge_pa"])[:, j].astype(float),
        np.broadcast_to(np.asarray(arrays["supply_pa"], dtype=float).reshape(-1), t.shape).copy(),
        np.asarray(arrays["true_angle_rad"])[:, j].astype(float),
        valve_is_output=True,
    )


def supply_gauge_pa(run: Run) -> float:
    return float(np.mean(run.supply_pa)) - AIR.p_atm_pa
