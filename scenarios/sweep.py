"""Sweeps: one scenario over a grid of field values or a Monte Carlo of seeds, in parallel.

Each point is a whole scenario run with its own seed; child seeds come from
`np.random.SeedSequence(seed).spawn(n)` (STYLE rule 6), so a sweep gives the same results on 1
worker, on 2, or on a Dask cluster. Local workers are processes forked from this one once it has
run a first, tiny point (`warm_up`): every worker starts with the modules imported, the compiled
kernels loaded and the scene parsed, so the start-up (~4 s a process: imports 2.7 s, numba's cached
kernels 1.6 s) is paid once, not once per worker or per run. Where forking is not safe (other
threads running in this process, or no `fork` on the platform) they are joblib's processes, each
paying its own start-up. `scheduler` hands the same jobs to a Dask cluster through joblib's Dask
backend.

The results are one summary per run (`twin run --json`'s); `summary_table` flattens them into one
row per run for a spreadsheet or a DataFrame, and `write_csv` writes that table (`twin sweep --out
X.json` puts it beside the JSON as X.csv).
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import multiprocessing
import threading
import tomllib
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import joblib
import numpy as np
from tqdm import tqdm

from scenarios.runner import run_scenario
from scenarios.schema import Scenario, ScenarioError, with_overrides
from twin_plumbing.checks import DURATION_S, MONTE_CARLO, WORKERS, check_number
from twin_plumbing.cluster import dask_client
from twin_plumbing.outputs import write_atomic


def grid_points(grid: dict[str, list]) -> list[dict]:
    """Every combination of the grid's values, as override dicts, in a fixed order."""
    keys = list(grid)
    return [dict(zip(keys, values, strict=True)) for values in itertools.product(*(grid[k] for k in keys))]


def child_seeds(seed: int, n: int) -> list[int]:
    """n independent seeds derived from one (numpy SeedSequence)."""
    return [int(s.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1)) for s in np.random.SeedSequence(seed).spawn(n)]


def sweep_points(
    scenario: Scenario, grid: dict[str, list], monte_carlo: int, cases: list[dict] | None = None
) -> list[dict]:
    """Overrides for each run: the grid (or the `cases`, a list of override dicts, one factor at a
    time), each point repeated over `monte_carlo` child seeds."""
    if monte_carlo and "seed" in grid:  # the child seeds would replace the grid's, all points alike
        raise ScenarioError(
            f"{scenario.path}: the seed is swept twice, by the grid (seed = {grid['seed']}) and by "
            f"monte_carlo = {monte_carlo} (child seeds of the scenario's seed, {scenario.seed}); "
            "allowed: one of them (--set seed=... or --monte-carlo N)"
        )
    points = [dict(c) for c in cases] if cases is not None else grid_points(grid) if grid else [{}]
    if monte_carlo:
        seeds = child_seeds(scenario.seed, monte_carlo)
        points = [{**p, "seed": s} for p in points for s in seeds]
    for p in points:
        with_overrides(scenario, p)  # refuse a bad field or value before any work starts
    return points


def _run_point(scenario: Scenario, overrides: dict, duration_s: float | None) -> dict:
    result = run_scenario(with_overrides(scenario, overrides), duration_s=duration_s)
    return {"overrides": overrides, **result.summary()}


WARM_UP_S = 0.002  # two control ticks: enough to load every compiled kernel a run calls


def warm_up(scenario: Scenario) -> None:
    """Run `scenario` for two control ticks here: imports done, numba's kernels loaded from its
    cache, so processes forked afterwards start warm."""
    run_scenario(scenario, duration_s=WARM_UP_S)


def sweep(
    scenario: Scenario,
    grid: dict[str, list] | None = None,
    monte_carlo: int = 0,
    workers: int = 0,
    scheduler: str | None = None,
    duration_s: float | None = None,
    progress: bool = True,
    fork: bool = True,
    finished: dict[int, dict] | None = None,
    cases: list[dict] | None = None,
) -> list[dict]:
    """Run every point (the grid's, or `cases`: see `sweep_points`); returns one summary per point,
    in the points' order.

    workers 0 means all local cores. With `scheduler` (a Dask scheduler address) the points run on
    that cluster instead (needs the `cluster` extra: dask[distributed]). `fork=False` makes the
    local workers joblib's (loky) processes, each starting cold. `finished`, if given, is filled
    with each summary as its run ends (point index -> summary): what a sweep stopped by Ctrl-C or
    SIGTERM has to keep.
    """
    finished = {} if finished is None else finished
    check_number("monte_carlo", monte_carlo, **MONTE_CARLO)
    check_number("workers", workers, **WORKERS)
    if duration_s is not None:
        check_number("duration_s", duration_s, **DURATION_S)
    points = sweep_points(scenario, grid or {}, monte_carlo, cases)
    n_jobs = min(workers or joblib.cpu_count(), len(points))
    if not scheduler and n_jobs > 1 and fork and _can_fork():
        return _on_forked_workers(n_jobs, scenario, points, duration_s, progress, finished)
    jobs = (joblib.delayed(_run_point)(scenario, p, duration_s) for p in points)
    if scheduler:
        return _on_dask(scheduler, jobs, len(points), progress, finished)
    results = joblib.Parallel(n_jobs=n_jobs, return_as="generator")(jobs)
    return _collected(results, len(points), progress, finished)


def _collected(results: Iterable[dict], n_points: int, progress: bool, finished: dict[int, dict]) -> list[dict]:
    """The summaries of an in-order stream of results, each recorded in `finished` as it comes."""
    for i, summary in enumerate(tqdm(results, total=n_points, disable=not progress, desc="sweep")):
        finished[i] = summary
    return [finished[i] for i in range(n_points)]


def _can_fork() -> bool:
    # forking a process with other threads running can copy a lock another thread holds; tqdm's
    # monitor (left by any earlier progress bar) only sleeps on its own event
    others = [t for t in threading.enumerate() if t is not threading.main_thread() and t is not tqdm.monitor]
    return "fork" in multiprocessing.get_all_start_methods() and not others


def _on_forked_workers(
    n_jobs: int, scenario: Scenario, points: list[dict], duration_s, progress: bool, finished: dict[int, dict]
) -> list[dict]:
    """The points on `n_jobs` processes forked from this one after `warm_up`, in the points' order."""
    warm_up(scenario)
    with ProcessPoolExecutor(n_jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        # the workers are forked at the first submit, before any thread (the pool's, tqdm's) starts
        futures = {pool.submit(_run_point, scenario, p, duration_s): i for i, p in enumerate(points)}
        try:
            for f in tqdm(as_completed(futures), total=len(points), disable=not progress, desc="sweep"):
                finished[futures[f]] = f.result()
            return [finished[i] for i in range(len(points))]
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)  # the runs in progress end; those not begun never do
            for f, i in futures.items():  # what the runs in progress returned is kept with the rest
                if f.done() and not f.cancelled() and f.exception() is None:
                    finished.setdefault(i, f.result())
            raise


def _on_dask(scheduler: str, jobs: Iterable, n_points: int, progress: bool, finished: dict[int, dict]) -> list[dict]:
    """The jobs on the Dask cluster at `scheduler`, through joblib's Dask backend."""
    client = dask_client(scheduler)
    try:
        with joblib.parallel_config(backend="dask"):
            return _collected(joblib.Parallel(return_as="generator")(jobs), n_points, progress, finished)
    finally:
        client.close()


def parse_grid(items: list[str], where: str = "--set") -> dict[str, list]:
    """`field=v1,v2,...` strings into a grid; values are read as TOML scalars (numbers, true, "text")."""
    grid, given = {}, {}
    for item in items:
        if "=" not in item:
            raise ScenarioError(f"{where} {item!r}: expected FIELD=VALUE[,VALUE...], e.g. supply.pressure_mpa=0.5,0.6")
        key, _, values = item.partition("=")
        key = key.strip()
        if key in grid:  # a second --set of one field would silently replace the first's values
            raise ScenarioError(
                f"{where} {item!r}: {key} is given twice; allowed: each field once, with all its values "
                f"({key}={given[key]},{values.strip()})"
            )
        given[key] = values.strip()
        parsed = []
        for v in values.split(","):
            try:
                parsed.append(tomllib.loads(f"v = {v.strip()}")["v"])
            except tomllib.TOMLDecodeError:
                parsed.append(v.strip())
        grid[key] = parsed
    return grid


def summary_row(summary: dict) -> dict[str, object]:
    """One run's summary as flat columns: its overrides (`set.<field>`), the run's outcome and the
    criteria it was cut short before (`not_judged`, `;`-separated), per joint `<joint>.<quantity>`
    (degrees), per criterion `<kind>[<subject>].value|passed` (passed empty where not judged)."""
    row: dict[str, object] = {f"set.{k}": v for k, v in summary.get("overrides", {}).items()}
    row |= {k: summary.get(k) for k in ("scenario", "seed", "passed", "duration_s", "error", "refused")}
    if "partial" in summary:  # a stopped sweep's table of the runs it finished
        row["partial"] = summary["partial"]
    row["not_judged"] = "; ".join(summary.get("not_judged", []))
    for joint, values in summary.get("joints", {}).items():
        row |= {f"{joint}.{k}": v for k, v in values.items()}
    for c in summary.get("criteria", []):
        passed = c["passed"] if c.get("judged", True) else None
        row |= {f"{c['kind']}[{c['subject']}].value": c["value"], f"{c['kind']}[{c['subject']}].passed": passed}
    return row


def summary_table(results: list[dict]) -> tuple[list[str], list[dict[str, object]]]:
    """Columns (in first-seen order) and one row per run; a run without a column leaves it empty."""
    rows = [summary_row(r) for r in results]
    columns = list(dict.fromkeys(k for row in rows for k in row))
    return columns, rows


def write_csv(results: list[dict], path: str | Path) -> Path:
    """The sweep's table as CSV (None: an empty cell); numbers as Python writes them (exact)."""
    columns, rows = summary_table(results)
    path = Path(path)
    text = io.StringIO(newline="")
    writer = csv.DictWriter(text, fieldnames=columns, restval="")
    writer.writeheader()
    writer.writerows({k: "" if v is None else v for k, v in row.items()} for row in rows)
    write_atomic(path, text.getvalue())
    return path


def partial_path(json_path: str | Path) -> Path:
    """Where a stopped sweep whose summaries were to go to `json_path` keeps those of the runs it
    finished: beside it, NAME.partial.json (its table, by table_path, NAME.partial.csv)."""
    json_path = Path(json_path)
    return json_path.with_name(f"{json_path.stem}.partial{json_path.suffix or '.json'}")


def write_summaries(results: list[dict], json_path: str | Path, partial: bool = False) -> tuple[Path, Path]:
    """The summaries as JSON at `json_path` and their table beside it (table_path), both whole
    (write_atomic); `partial` (a stopped sweep's finished runs) adds a column partial = True to
    the table. Returns both paths."""
    json_path = Path(json_path)
    write_atomic(json_path, json.dumps(results, indent=2))
    rows = [{**r, "partial": True} for r in results] if partial else results
    return json_path, write_csv(rows, table_path(json_path))


def table_path(json_path: str | Path) -> Path:
    """Where the table of a sweep whose summaries go to `json_path` is written: beside it, .csv
    (.table.csv when the JSON path itself ends in .csv)."""
    json_path = Path(json_path)
    return json_path.with_suffix(".table.csv" if json_path.suffix == ".csv" else ".csv")
