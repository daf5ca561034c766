"""The Dask cluster of `--scheduler ADDRESS` (`twin sweep`, `twin gap diagnose`): a client of the
scheduler there, or a one-line refusal before any work when Dask is missing or no scheduler answers."""

from __future__ import annotations

from twin_plumbing.errors import UserError

SCHEDULER_TIMEOUT_S = 10.0  # a scheduler that has not answered by then is taken as unreachable


def dask_client(scheduler: str):
    """A `dask.distributed.Client` of the scheduler at `scheduler` (close it after use); UserError
    if Dask is not installed or no scheduler answers there within SCHEDULER_TIMEOUT_S."""
    try:
        from dask.distributed import Client  # optional (the [cluster] extra): imported where asked for
    except ImportError:
        raise UserError("--scheduler needs Dask: pip install 'pneumatic-arm-twin[cluster]'") from None
    try:
        return Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError, TypeError) as e:
        raise UserError(
            f"--scheduler {scheduler}: no Dask scheduler answers there ({type(e).__name__}: {e}); "
            "allowed: the address of a running scheduler, e.g. tcp://host:8786"
        ) from None
