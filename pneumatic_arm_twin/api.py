"""What pneumatic_arm_twin offers (see its docstring): thin wrappers over scenarios/, twin/ and
gap/ that return objects with arrays instead of the command line's files."""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gap import CATALOGUE, Campaign, GapError, load_campaign, make_campaign, write_report
from gap.diagnose import diagnose as _diagnose  # not gap.diagnose: the submodule's name hides gap's function
from gap.floors import MODEL_TOLERANCE_DEG
from gap.result import Diagnosis
from scenarios.recording import open_recorders
from scenarios.runner import run_scenario, scenario_files
from scenarios.schema import Scenario, ScenarioError, load, with_overrides
from scenarios.study import Row, rows_table, run_study
from scenarios.sweep import summary_table, write_csv
from scenarios.sweep import sweep as _sweep
from twin.mcap_log import read_mcap
from twin.pictures import plot_angles_png
from twin.telemetry import SIGNALS
from wrist_rig.commanded_run import wrist_params


def shipped_scenario_path(name: str) -> Path:
    """The file of a scenario shipped with the package, by name (`insulator_cleaning`)."""
    shipped = {p.stem: p for p in scenario_files()}
    if name not in shipped:
        names = ", ".join(sorted(shipped))
        raise ScenarioError(f"{name}: no such scenario file, nor a shipped scenario (shipped: {names})")
    return shipped[name]


def dotted(overrides: dict) -> dict:
    """Overrides as dotted keys: nested dicts (`{"supply": {"pressure_mpa": 0.7}}`) are flattened
    (`{"supply.pressure_mpa": 0.7}`); dotted keys are kept as they are."""
    out = {}
    for key, value in overrides.items():
        if isinstance(value, dict):
            out |= {f"{key}.{k}": v for k, v in dotted(value).items()}
        else:
            out[key] = value
    return out


def scenario(name_or_path: str | Path | Scenario, overrides: dict | None = None, **dotted_overrides) -> Scenario:
    """A scenario: one given, a file, or a shipped scenario by name (`insulator_cleaning`), with
    `overrides` as nested dicts (`{"supply": {"pressure_mpa": 0.7}}`) or dotted keys
    (`{"supply.pressure_mpa": 0.7}`, also as `**{...}`), checked like the file."""
    if isinstance(name_or_path, Scenario):
        sc = name_or_path
    else:
        sc = load(name_or_path if Path(name_or_path).is_file() else shipped_scenario_path(str(name_or_path)))
    changes = dotted(overrides or {}) | dotted_overrides
    return with_overrides(sc, changes) if changes else sc


def flat_columns(arrays: dict[str, np.ndarray], joints: tuple[str, ...], bodies: tuple[str, ...]) -> dict:
    """Telemetry arrays as 1-D columns named `signal`, `signal.joint`, `signal.x`, `signal.body.x`."""
    out = {"time_s": arrays["time_s"]}
    for name, shape in SIGNALS.items():
        a = arrays[name]
        axes = "wxyz" if name.endswith("wxyz") else "xyz"
        if shape == ():
            out[name] = a
        elif shape == ("n",):
            out |= {f"{name}.{j}": a[:, k] for k, j in enumerate(joints)}
        elif shape[0] == "b":
            out |= {f"{name}.{b}.{x}": a[:, i, c] for i, b in enumerate(bodies) for c, x in enumerate(axes)}
        else:
            out |= {f"{name}.{x}": a[:, c] for c, x in enumerate(axes)}
    return out


def _dataframe(columns: dict, index: str | None = None):
    import pandas as pd  # on use: pandas takes 0.5 s to import, and only tables need it

    df = pd.DataFrame(columns)
    return df.set_index(index) if index else df


@dataclass
class Log:
    """A run's telemetry: arrays as twin.telemetry.Telemetry.arrays() gives them, and the joints
    and bodies they are ordered by."""

    _arrays: dict[str, np.ndarray]
    joints: tuple[str, ...]
    bodies: tuple[str, ...]
    meta: dict = field(default_factory=dict)

    def arrays(self) -> dict[str, np.ndarray]:
        """Each signal as an array over samples (50 per simulated second): (T,), (T, joints), ..."""
        return dict(self._arrays)

    def table(self) -> dict[str, np.ndarray]:
        """The telemetry as flat 1-D columns (see flat_columns)."""
        return flat_columns(self._arrays, self.joints, self.bodies)

    def to_dataframe(self):
        """The table as a pandas DataFrame indexed by simulated time, s (its index "time_s")."""
        return _dataframe(self.table(), index="time_s")

    def plot_angles(self, path, only_moving: bool = True) -> Path:
        """The README's angles figure of this run (PNG)."""
        return plot_angles_png(self._arrays, path, joints=self.joints, only_moving=only_moving)


@dataclass
class Run(Log):
    """A scenario's run: its telemetry (Log), whether it passed, and `twin run --json`'s summary."""

    passed: bool = False
    summary: dict = field(default_factory=dict)


def run(
    name_or_path: str | Path | Scenario,
    *,
    duration_s: float | None = None,
    seed: int | None = None,
    rrd=None,
    mcap=None,
    camera_fps: float = 0.0,
    start_time: str | None = None,
    overrides: dict | None = None,
    **dotted_overrides,
) -> Run:
    """Run a scenario (shortened to `duration_s`, with another `seed`, `overrides` as nested dicts
    or dotted keys), logging to `rrd` / `mcap` if given, as `twin run` does (`start_time`: its
    --start-time)."""
    sc = scenario(name_or_path, overrides, **dotted_overrides)
    if seed is not None:
        sc = with_overrides(sc, {"seed": seed})
    recorders = open_recorders(sc, Path(rrd) if rrd else None, Path(mcap) if mcap else None, camera_fps, start_time)
    try:
        result = run_scenario(sc, recorders=tuple(recorders), duration_s=duration_s)
    finally:
        for r in recorders:
            r.close()
    tel = result.telemetry
    meta = {"scenario_name": sc.name, "seed": sc.seed}
    return Run(tel.arrays(), tel.joints, tel.bodies, meta, result.passed, result.summary())


def read_log(path) -> Log:
    """A run logged with `twin run --mcap` (a file cut short gives what it holds; `meta["recovery"]`
    says how much)."""
    arrays, meta = read_mcap(path)
    return Log(arrays, tuple(meta["joints"]), tuple(meta["bodies"]), meta)


@dataclass
class Sweep:
    """A sweep's summaries, one per run, in the points' order."""

    summaries: list[dict]

    def table(self) -> dict[str, list]:
        """One row per run as columns (see scenarios.sweep.summary_row): {column: [value per run]}."""
        columns, rows = summary_table(self.summaries)
        return {c: [row.get(c) for row in rows] for c in columns}

    def to_dataframe(self):
        return _dataframe(self.table())

    def to_csv(self, path) -> Path:
        return write_csv(self.summaries, path)


def sweep(
    name_or_path: str | Path | Scenario,
    grid: dict[str, list] | None = None,
    *,
    monte_carlo: int = 0,
    workers: int = 1,
    duration_s: float | None = None,
    progress: bool = False,
    scheduler: str | None = None,
) -> Sweep:
    """Run a scenario over a grid of fields (nested dicts or dotted keys, each a list of values)
    and/or `monte_carlo` child seeds (`twin sweep`); on a Dask cluster at `scheduler` if given
    (e.g. "tcp://host:8786"), else on `workers` local processes."""
    points = dotted(grid or {})
    summaries = _sweep(scenario(name_or_path), points, monte_carlo, workers, scheduler, duration_s, progress=progress)
    return Sweep(summaries)


@dataclass
class Study:
    """The cleaning study (`twin study cleaning`): every run's summary and a row per strategy and
    supply over its seeds (scenarios.study.Row)."""

    summaries: list[dict]
    rows: list[Row]

    def table(self) -> dict[str, list]:
        return rows_table(self.rows)

    def to_dataframe(self):
        """A row per strategy and supply, as a pandas DataFrame."""
        return _dataframe(self.table())


def study(
    strategies: list[str] | None = None,
    supplies_mpa: list[float] | None = None,
    *,
    seeds: int = 2,
    workers: int = 0,
    duration_s: float | None = None,
    progress: bool = False,
) -> Study:
    """The insulator-cleaning task per strategy x supply x seed (scenarios/study.py), in memory."""
    from scenarios.schema import STRATEGIES
    from scenarios.study import SUPPLIES_MPA, rows

    summaries = run_study(
        list(strategies or STRATEGIES),
        list(supplies_mpa or SUPPLIES_MPA),
        seeds=seeds,
        workers=workers,
        duration_s=duration_s,
        progress=progress,
    )
    return Study(summaries, rows(summaries))


def synthetic_campaign(reality=None, **kwargs) -> Campaign:
    """A calibration campaign made by the plant (gap.make_campaign's arguments: seed,
    pressures_mpa, repeats, motion, instrument, ...), held in memory: the wrist rig with `reality`
    (pneumatics JointParams; default the nominal wrist, wrist_rig.commanded_run.wrist_params()) as the real
    arm, each run measured by the campaign's instrument."""
    with tempfile.TemporaryDirectory(prefix="twin-campaign-") as folder:
        return load_campaign(make_campaign(folder, reality or wrist_params(), **kwargs))


def diagnose(
    campaign,
    *,
    out=None,
    effects: list[str] | None = None,
    model_tolerance_deg: float | None = None,
    jobs: int = 2,
    progress: bool = False,
    scheduler: str | None = None,
) -> Diagnosis:
    """Diagnose a calibration campaign (`twin gap diagnose`): a folder, or a gap.Campaign in
    memory (synthetic_campaign); `effects` limits the catalogue to those names; `out` also writes
    diagnosis.json, report.md and the plots there; `scheduler` runs the fits on that Dask cluster.
    The answer in brief: `verdict`, `effect`, `before_rms_deg`, `after_rms_deg`, `ranking()`; the
    rest is diagnosis.json's fields (gap.result.Diagnosis)."""
    catalogue = CATALOGUE
    if effects is not None:
        known = {e.name for e in CATALOGUE}
        unknown = [e for e in effects if e not in known]
        if unknown:
            raise GapError(f"effects {unknown}: not in the catalogue ({', '.join(sorted(known))})")
        catalogue = tuple(e for e in CATALOGUE if e.name in effects)
    tol = MODEL_TOLERANCE_DEG if model_tolerance_deg is None else model_tolerance_deg
    loaded = campaign if isinstance(campaign, Campaign) else load_campaign(campaign)
    d = _diagnose(
        loaded, catalogue=catalogue, model_tolerance_deg=tol, n_jobs=jobs, progress=progress, scheduler=scheduler
    )
    if out is not None:
        write_report(d, out)
    return d
