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

Where the cache goes: NUMBA_CACHE_DIR if set, else the user's cache folder (XDG_CACHE_HOME or
~/.cache, then pneumatic-arm-twin). A user whose home cannot be written (a container user with
HOME=/nonexistent, a read-only install run by someone else) gets a private folder of their own in
the system's temporary folder instead, and if that cannot be made either, the laws are compiled in
memory for this process only (a few seconds more at each start); either is said once on stderr.
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import stat
import sys
import tempfile
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


IN_MEMORY = "in-memory"  # TWIN_JIT_CACHE's value once a process found no folder to cache in


def _writable(folder: Path) -> bool:
    """Can this process make `folder` and write a file in it? (As numba itself checks.)"""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
        return True
    except OSError:
        return False


def _private(folder: Path) -> bool:
    """Is `folder` (made here if missing) this user's own, which no one else can write? Numba loads
    pickled code from its cache: a folder in the shared temporary folder that someone else made or
    can write would let them run code as this user."""
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        st = folder.lstat()
    except OSError:
        return False
    mine = not hasattr(os, "getuid") or st.st_uid == os.getuid()
    return stat.S_ISDIR(st.st_mode) and mine and not st.st_mode & 0o022 and _writable(folder)


def _user_cache() -> Path | None:
    """The user's cache folder for the package (XDG_CACHE_HOME or ~/.cache), or None if there is
    no home to find it in."""
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if os.path.isabs(xdg):  # the XDG spec: a relative value is ignored
        return Path(xdg) / "pneumatic-arm-twin"
    try:
        return Path.home() / ".cache" / "pneumatic-arm-twin"
    except (RuntimeError, KeyError):  # no HOME and no entry in the password database
        return None


def cache_root() -> str | None:
    """The folder numba caches compiled laws in (module docstring), or None: compile in memory.
    A fallback is said once on stderr; processes this one starts inherit the choice through the
    environment (NUMBA_CACHE_DIR, TWIN_JIT_CACHE) and say nothing."""
    if os.environ.get("TWIN_JIT_CACHE") == IN_MEMORY:
        return None
    chosen = os.environ.get("NUMBA_CACHE_DIR")
    wanted = Path(chosen) if chosen else _user_cache()
    if wanted is not None and _writable(wanted):
        return str(wanted)
    user = os.getuid() if hasattr(os, "getuid") else "user"  # Windows: the temporary folder is per user
    private = Path(tempfile.gettempdir()) / f"pneumatic-arm-twin-{user}"
    said = f"cannot write the compiled-code cache in {wanted or 'a home folder (none is set)'}"
    log = logging.getLogger(__name__)
    if _private(private):
        log.warning("twin: %s; caching it in %s instead", said, private)
        return str(private)
    log.warning("twin: %s, nor in %s; compiling in memory (each start takes a few seconds more)", said, private)
    os.environ["TWIN_JIT_CACHE"] = IN_MEMORY
    return None


if NO_JIT:

    def njit(fn=None, **_kwargs):
        return fn if fn is not None else (lambda f: f)

    def intrinsic(fn):  # compiled-code helpers have no Python form; callers check NO_JIT
        return fn

    types = None

    def borrowed(array):
        return array

else:
    _CACHE_ROOT = cache_root()
    if _CACHE_ROOT is not None:
        os.environ["NUMBA_CACHE_DIR"] = _CACHE_ROOT  # numba caches only with a folder configured
    import numba
    from numba import types
    from numba.core import cgutils
    from numba.core.extending import intrinsic

    def _compiled(fn, options):
        # numba reads its cache folder when the function is decorated: point it at the module's own
        module = fn.__module__
        _compiling_packages.add(module.partition(".")[0])
        if options.get("cache") and _CACHE_ROOT is None:
            options = {**options, "cache": False}  # no folder to cache in: compiled in memory
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
