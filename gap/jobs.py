"""Where the diagnosis's fits run: joblib on local threads or on a Dask cluster, and a progress bar
around each stage."""

from __future__ import annotations

import contextlib
import sys

from joblib import Parallel, parallel_config
from tqdm import tqdm

from twin_plumbing.cluster import dask_client


@contextlib.contextmanager
def parallel_jobs(n_jobs: int, scheduler: str | None):
    """joblib's Parallel on local threads (the compiled replay releases the GIL), or on a Dask
    cluster at `scheduler` (as `twin sweep --scheduler`), one client for every stage of the fits."""
    if not scheduler:
        yield lambda jobs: Parallel(n_jobs=n_jobs, backend="threading")(jobs)
        return

    def run(jobs):
        with parallel_config(backend="dask"):
            return Parallel()(jobs)

    with dask_client(scheduler):
        yield run


class stage_bar:
    """A tqdm bar on stderr around a stage (joblib jobs cannot tick it from a Dask worker)."""

    def __init__(self, total: int, desc: str, enabled: bool):
        self.bar = tqdm(total=total, desc=desc, file=sys.stderr, disable=not enabled)

    def __enter__(self):
        return self.bar

    def __exit__(self, *exc):
        self.bar.update(self.bar.total - self.bar.n)
        self.bar.close()
