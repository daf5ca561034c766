"""One place that decides how the physics is compiled.

Every law in pneumatics/ is a plain Python function. `njit` compiles it with numba (cached on
disk) so that the plant can call it every physics step at the speed of C; the same function is
what the predictor, the reference solver in the tests and the gap diagnosis call. Setting
TWIN_NO_JIT=1 runs the plain Python instead (for debugging and coverage).

Numba's cache notices a change only in the file that defines a function, not in the functions
and constants it inlines from other files. So each module's compiled code is cached in a folder
named after a hash of its own source and of every module it imports from a package that
compiles code, followed down through their imports (`_cache_key`): an edit to any of them starts
a fresh cache for that module. Each module's own imports say what it depends on; this file names
no package but its own.
"""

from __future__ import annotations

import hashlib
import os
import re
import sys
from pathlib import Path

NO_JIT = os.environ.get("TWIN_NO_JIT") == "1"
_OWN_PACKAGE = __name__.partition(".")[0]
_compiling_packages = {_OWN_PACKAGE}  # top-level packages of the modules that called `njit`
_cache_keys: dict[str, str] = {}  # module name -> hash of its source and its dependencies'
# an import statement at a line's start (`from a.b import (c, d)` over several lines, `import a.b as c`)
_IMPORT = re.compile(r"^(?:from\s+([\w.]+)\s+import\s+(\([^)]*\)|[^\n]*)|import\s+([\w., ]+))", re.M)
_sources: dict[str, tuple[bytes, list[str]]] = {}  # module name -> (its source, the modules it imports)


def _source(module_name: str) -> tuple[bytes, list[str]]:
    """A module's source and the modules its `import` and `from ... import` statements name (a
    name imported from a package counts as its submodule when it is one)."""
    if module_name in _sources:
        return _sources[module_name]
    path = getattr(sys.modules.get(module_name), "__file__", None)
    if path is None:
        return b"", []
    source = Path(path).read_bytes()
    found = []
    for package, names, modules in _IMPORT.findall(source.decode()):
        found += [m.split(" as ")[0].strip() for m in modules.split(",") if m.strip()]
        if package:
            found.append(package)
            for name in names.strip("()").replace("\n", " ").split(","):
                sub = f"{package}.{name.split(' as ')[0].strip()}"
                if sub in sys.modules:
                    found.append(sub)
    _sources[module_name] = (source, found)
    return _sources[module_name]


def _cache_key(module_name: str) -> str:
    """Hash of a module's source and of every module it depends on in a package that compiles
    code (its own package and the ones below it that its imports reach), transitively."""
    if module_name in _cache_keys:
        return _cache_keys[module_name]
    seen: set[str] = set()
    todo = [module_name]
    while todo:
        name = todo.pop()
        if name in seen or name.partition(".")[0] not in _compiling_packages or name not in sys.modules:
            continue
        seen.add(name)
        todo += _source(name)[1]
    h = hashlib.sha256()
    for name in sorted(seen):
        h.update(name.encode())
        h.update(_source(name)[0])
    _cache_keys[module_name] = h.hexdigest()[:16]
    return _cache_keys[module_name]


if NO_JIT:

    def njit(fn=None, **_kwargs):
        return fn if fn is not None else (lambda f: f)

    def intrinsic(fn):  # compiled-code helpers have no Python form; callers check NO_JIT
        return fn

    types = None

    def borrowed(array):
        return array

else:
    _CACHE_ROOT = os.environ.get("NUMBA_CACHE_DIR") or str(
        Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "pneumatic-arm-twin"
    )
    os.environ["NUMBA_CACHE_DIR"] = _CACHE_ROOT  # numba caches only with a folder configured
    import numba
    from numba import types
    from numba.core import cgutils
    from numba.core.extending import intrinsic

    def _compiled(fn, options):
        # numba reads its cache folder when the function is decorated: point it at the module's own
        module = fn.__module__
        _compiling_packages.add(module.partition(".")[0])
        if options.get("cache"):
            numba.config.CACHE_DIR = os.path.join(_CACHE_ROOT, _cache_key(module))
        return numba.njit(**options)(fn)

    def njit(fn=None, **kwargs):
        options = {"cache": True, "fastmath": False, "error_model": "numpy", **kwargs}
        if fn is None:
            return lambda f: _compiled(f, options)
        return _compiled(fn, options)

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
