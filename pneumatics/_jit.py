"""One place that decides how the physics is compiled.

Every law in pneumatics/ is a plain Python function. `njit` compiles it with numba (cached on
disk) so that the plant can call it every physics step at the speed of C; the same function is
what the predictor, the reference solver in the tests and the gap diagnosis call. Setting
TWIN_NO_JIT=1 runs the plain Python instead (for debugging and coverage).
"""

from __future__ import annotations

import os

if os.environ.get("TWIN_NO_JIT") == "1":

    def njit(fn=None, **_kwargs):
        return fn if fn is not None else (lambda f: f)

else:
    import numba

    def njit(fn=None, **kwargs):
        options = {"cache": True, "fastmath": False, "error_model": "numpy", **kwargs}
        if fn is None:
            return lambda f: numba.njit(**options)(f)
        return numba.njit(**options)(fn)
