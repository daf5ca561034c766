"""One place that decides how the physics is compiled.

Every law in pneumatics/ is a plain Python function. `njit` compiles it with numba (cached on
disk) so that the plant can call it every physics step at the speed of C; the same function is
what the predictor, the reference solver in the tests and the gap diagnosis call. Setting
TWIN_NO_JIT=1 runs the plain Python instead (for debugging and coverage).

Numba's cache notices a change only in the file that defines a function, not in the functions
and constants it inlines from other files. So the cache lives in a folder named after a hash of
every source file that compiles code: any edit to any of them starts a fresh cache.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

_ROOT = Path(__file__).resolve().parent.parent
_COMPILED_PACKAGES = ("pneumatics", "twin", "control", "gap")


def _source_hash() -> str:
    h = hashlib.sha256()
    for package in _COMPILED_PACKAGES:
        for path in sorted((_ROOT / package).glob("*.py")):
            h.update(path.name.encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


NO_JIT = os.environ.get("TWIN_NO_JIT") == "1"

if NO_JIT:

    def njit(fn=None, **_kwargs):
        return fn if fn is not None else (lambda f: f)

    def intrinsic(fn):  # compiled-code helpers have no Python form; callers check NO_JIT
        return fn

    types = None

    def borrowed(array):
        return array

else:
    if "NUMBA_CACHE_DIR" not in os.environ:
        cache_root = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
        os.environ["NUMBA_CACHE_DIR"] = str(cache_root / "pneumatic-arm-twin" / _source_hash())
    import numba
    from numba import types
    from numba.core.extending import intrinsic

    def njit(fn=None, **kwargs):
        options = {"cache": True, "fastmath": False, "error_model": "numpy", **kwargs}
        if fn is None:
            return lambda f: numba.njit(**options)(f)
        return numba.njit(**options)(fn)

    from numba.core import cgutils

    @intrinsic
    def borrowed(typingctx, array):
        """The same array without its reference count, for the hot loops of the physics.

        Numba counts references to an array with atomic increments and decrements each time a
        view (a joint's row) is taken or an array is handed to a function that is not inlined:
        measured, they were 70 % of the air kernel's time (~30 atomic pairs per physics step).
        A borrowed array (null meminfo) skips them. Use it only for arrays that the caller holds
        for the whole call, never for one that is returned or stored.
        """
        if not isinstance(array, types.Array):
            return None

        def codegen(context, builder, signature, args):
            a = context.make_array(array)(context, builder, args[0])
            a.meminfo = cgutils.get_null_value(a.meminfo.type)
            a.parent = cgutils.get_null_value(a.parent.type)
            return a._getvalue()

        return array(array), codegen
