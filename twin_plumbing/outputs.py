"""Where results go: output places checked before the work, written atomically, kept if the place
fails after the work, and never written by two runs at once (DESIGN rule 6, "nothing lost").

    check_output(path, "--out", inputs=[scenario])   # before any work: UserError if it cannot be
    with OutputLock([rrd, mcap]): ...                # refuses a second writer of the same file
    write_atomic(path, text)                         # temp file in the same folder, then os.replace
    saved = keep_result(path, write, "summaries")    # the chosen place, else a fallback; says where
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from filelock import lock_descriptor

from twin_plumbing.errors import UserError
from twin_plumbing.paths import is_special, path_problem
from twin_plumbing.signals import shielded, stop_behind

log = logging.getLogger(__name__)


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _same(a: Path, b: Path) -> bool:
    a, b = Path(a), Path(b)
    if a.resolve() == b.resolve():
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


# the most a name grows by in the places made beside an output: write_atomic's temp file
# (.NAME.xxxxxxxx.tmp), OutputLock's .NAME.lock, publish_folder's .NAME.partial-xxxxxxxx and
# fallback_places' NAME-saved-YYYYmmdd-HHMMSS-PID (a 7-digit pid)
NAME_GROWTH = 32


def _name_max(folder: Path) -> int:
    try:
        return os.pathconf(_nearest_existing(folder), "PC_NAME_MAX")
    except (OSError, ValueError):
        return 255


def check_output(
    path: Path,
    flag: str,
    *,
    folder: bool = False,
    streamed: bool = False,
    inputs: Iterable[Path] = (),
    others: dict[str, Path] | None = None,
) -> None:
    """Refuse an output place before any work: it must differ from every input and from the other
    outputs (`others`: flag -> path), be of the right kind (file or folder) and be writable, which
    is tried by creating its folder and a scratch file in it; its name must leave room for the
    places made beside it (NAME_GROWTH). A device or pipe takes only an output `streamed` into it
    (a recording written as it goes): one replaced whole (write_atomic) would put a file where the
    device was. UserError names the flag and path."""
    path = Path(path)
    problem = path_problem(path)
    if problem:
        raise UserError(f"{flag} {path}: {problem}; allowed: a path in a writable folder")
    longest = _name_max(path.parent) - NAME_GROWTH
    length = len(os.fsencode(path.name))
    if length > longest:
        raise UserError(
            f"{flag} {path}: its name is {length} bytes long; allowed: at most {longest} "
            f"(the file system's {longest + NAME_GROWTH}, less room for the temporary and lock files made beside it)"
        )
    if is_special(path) and (folder or not streamed):
        raise UserError(
            f"{flag} {path}: is a device, a pipe or a socket, which this output would replace with a file; "
            f"allowed: a {'folder' if folder else 'file'} (existing or to be made)"
        )
    for inp in inputs:
        if inp is not None and _same(path, inp):
            raise UserError(
                f"{flag} {path}: is an input of this command ({inp}); allowed: a place that is not one of its inputs"
            )
    for other_flag, other in (others or {}).items():
        if other is not None and _same(path, other):
            raise UserError(f"{flag} {path}: is also {other_flag}; allowed: a different file for each output")
    if folder:
        if path.exists() and not path.is_dir():
            raise UserError(f"{flag} {path}: is a file; allowed: a folder (existing or to be made)")
        directory = path
    else:
        if path.is_dir():
            raise UserError(f"{flag} {path}: is a folder; allowed: a file name")
        directory = path.parent
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".twin-probe-", dir=directory)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise UserError(
            f"{flag} {path}: cannot write in {directory} ({e.strerror}); allowed: a path in a writable folder"
        ) from None


def write_atomic(path: Path, data: str | bytes) -> None:
    """Write `data` to `path` whole or not at all: a temp file in the same folder, then os.replace.
    A reader never sees half a file, and a failed write leaves the old file as it was."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(
            fd, path.stat().st_mode & 0o7777 if path.is_file() else 0o666 & ~_umask()
        )  # mkstemp's 0600 is for secrets
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(e, OSError) and not e.filename:  # a write's error names no file: this one's
            raise OSError(e.errno, e.strerror or str(e), str(path)) from e
        raise


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def fallback_places(path: Path) -> list[Path]:
    """Where a result goes when its chosen place fails: beside it (the nearest existing folder
    above it), then the working folder, then the system's temporary folder; each under a name
    with a time stamp so nothing older is overwritten."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    name = f"{path.stem}-saved-{stamp}-{os.getpid()}{path.suffix}"
    places = []
    base = _nearest_existing(Path(path).parent)
    for folder in (base if base.is_dir() else base.parent, Path.cwd(), Path(tempfile.gettempdir())):
        if folder.resolve() not in [p.parent.resolve() for p in places]:
            places.append(folder / name)
    return places


def keep_result(path: Path, write: Callable[[Path], object], what: str) -> Path:
    """Write a finished result with `write(place)` at `path`; if that fails (the folder vanished,
    the disk filled, ...), write it at the first fallback place that works and say so on stderr.
    Returns where it went; UserError only if no place at all took it."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write(path)
        return path
    except OSError as e:
        reason = f"{e.strerror or e}"
    for place in fallback_places(path):
        try:
            write(place)
        except OSError:
            continue
        log.warning("could not write %s to %s (%s); saved them to %s instead", what, path, reason, place)
        return place
    tried = ", ".join(map(str, fallback_places(path)))
    raise UserError(f"{path}: could not write {what} ({reason}), nor in any fallback place ({tried})")


class OutputLock:
    """Exclusive locks on output places for the life of a run: a second run writing the same
    file or folder is refused at once (UserError), whatever name it reaches it by. The lock is
    taken on a hidden file beside the output's real place (`.NAME.lock` beside the path with every
    symbolic link resolved), so a symbolic link to the file or to a folder above it, `..`, a
    relative path and a bind mount of the folder all meet one lock file. It is locked with
    filelock's primitive (flock on Unix, LockFileEx on Windows), so a killed run's lock dies with
    its process, and removed when the run ends."""

    def __init__(self, paths: Iterable[Path | None]):
        self.paths = [Path(p) for p in paths if p is not None]
        self._held: list[tuple[Path, int]] = []

    @staticmethod
    def lock_path(path: Path) -> Path:
        real = Path(path).resolve()  # the place itself, by whichever name it was given
        return real.parent / f".{real.name}.lock"

    def __enter__(self) -> OutputLock:
        try:
            for p in self.paths:
                self._acquire(p)
        except BaseException:
            self.release()
            raise
        return self

    def _acquire(self, path: Path) -> None:
        lock = self.lock_path(path)
        lock.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                taken = lock_descriptor(fd, blocking=False)
            except BaseException:
                os.close(fd)
                raise
            if not taken:
                os.close(fd)
                raise UserError(
                    f"{path}: another run is writing this file now; allowed: a file no other run is writing"
                )
            try:
                same = os.stat(lock).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:  # else the holder removed it between our open and our lock: take the new one
                self._held.append((lock, fd))
                with contextlib.suppress(OSError):  # who holds it, for a person looking; a full disk leaves it empty
                    os.ftruncate(fd, 0)
                    os.write(fd, f"{os.getpid()}\n".encode())
                return
            os.close(fd)

    def release(self) -> None:
        for lock, fd in self._held:
            with contextlib.suppress(OSError):  # Windows keeps an open file: it stays, unlocked
                os.unlink(lock)
            os.close(fd)
        self._held.clear()

    def __exit__(self, *exc) -> None:
        self.release()


PUBLISHED = ".twin-published"  # in a folder publish_folder filled: the names it moved in, one a line


def published(out: Path) -> set[str]:
    """The names in folder `out` that publish_folder moved there (its record, PUBLISHED)."""
    try:
        return set((Path(out) / PUBLISHED).read_text().splitlines()) - {""}
    except (OSError, UnicodeDecodeError):
        return set()


def check_replaceable(out: Path, flag: str, names: Iterable[str]) -> None:
    """Before any work: refuse (UserError) if folder `out` holds one of `names` that no earlier
    publish_folder put there: the user's own file or folder, which the results would replace."""
    out = Path(out)
    ours = published(out)
    for name in names:
        target = out / name
        if (target.exists() or target.is_symlink()) and name not in ours:
            kind = "folder" if target.is_dir() else "file"
            raise UserError(
                f"{flag} {out}: holds a {kind} {name} that no earlier run of this command wrote, and this run "
                f"would replace it; allowed: an empty or new folder, or the --out of an earlier run"
            )


_WRITES = os.O_WRONLY | os.O_RDWR | os.O_CREAT
_last_written: dict[Path, Path | None] = {}  # a running work's staging folder -> the last file opened to write in it
_hooked: list[bool] = []  # the audit hook is there (it cannot be removed: added once per process)


def _note_writes(event: str, args: tuple) -> None:
    """An audit hook (sys.addaudithook): the file each work last opened for writing, by any open
    (Python's, os.open, a library's), so a write error that names no file is laid at the right one
    even where its writer has removed it since (Pillow removes the picture it could not finish)."""
    if event != "open" or not _last_written or isinstance(args[0], int) or not args[2] & _WRITES:
        return
    path = Path(os.path.abspath(os.fsdecode(args[0])))
    for staging in list(_last_written):
        if path.is_relative_to(staging):
            _last_written[staging] = path


@contextlib.contextmanager
def _watching(staging: Path):
    """Inside, _last_written[staging] follows the files opened for writing in `staging`; after, the
    dict yielded holds the last one ("last")."""
    if not _hooked:
        sys.addaudithook(_note_writes)
        _hooked.append(True)
    _last_written[staging] = None
    seen: dict[str, Path | None] = {}
    try:
        yield seen
    finally:
        seen["last"] = _last_written.pop(staging, None)


def publish_folder(
    out: Path, work: Callable[[Path], object], what: str, replaces: Iterable[str] = (), keep_on_stop: bool = False
):
    """Run `work(folder)`, which computes and writes its files into `folder`, in a fresh folder
    beside `out`; then move each file into `out` (os.replace: each arrives whole). A subfolder of
    `out` is replaced only if an earlier publish_folder put it there (PUBLISHED records what it
    moved in): never the user's own. `replaces`: the names the work will write, checked before the
    work (check_replaceable). If `out` cannot take them after the work, the fresh folder is kept
    under a visible name and the user told where. `keep_on_stop`: a work stopped by Ctrl-C or
    SIGTERM has its files so far moved in too (a work whose every file is whole when written, such
    as gap bench's cases), then the stop goes on. Returns (work's result, the folder the files are in)."""
    out = Path(out)
    check_replaceable(out, "--out", replaces)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(os.path.abspath(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=out.parent)))
    staging.chmod(0o777 & ~_umask())  # a folder like any other once it is kept
    try:
        with _watching(staging) as seen:
            result = work(staging)
    except OSError as e:  # the work could not write one of its files (a full disk, a quota, ...)
        with shielded():
            failure = _write_failed(e, staging, out, what, seen["last"])
        raise failure from None
    except BaseException as e:
        if keep_on_stop and stop_behind(e) is not None and any(p.is_file() for p in staging.rglob("*")):
            with shielded():  # a second signal does not cut the move short
                folder = _move_in(staging, out, what)
            log.warning("stopped; %s finished so far are in %s", what, folder)
        else:  # the work failed or was stopped: nothing finished to keep
            shutil.rmtree(staging, ignore_errors=True)
        raise
    return result, _move_in(staging, out, what)


def _write_failed(e: OSError, staging: Path, out: Path, what: str, last: Path | None) -> UserError:
    """The one-line error for a work that failed writing into `staging`, `last` the file it last
    opened for writing there. A failed write that names its file or folder left it as it was, whole
    or absent (write_atomic's; gap bench removes the case it was making). One that does not (a plain
    write) was writing `last`: cut short, it is removed (unless its writer already did). The files
    written before it are kept beside `out` under a visible name, which the error says."""
    files = sorted((p for p in staging.rglob("*") if p.is_file()), key=lambda p: p.stat().st_mtime_ns)
    named = Path(e.filename) if e.filename else None
    whole = named is not None and named.is_relative_to(staging)
    damaged = named if whole else (last or (files[-1] if files else None))
    cause = e.strerror or str(e)
    if damaged is None:  # it failed before any file was written
        shutil.rmtree(staging, ignore_errors=True)
        return UserError(f"{out}: could not write {what} ({cause}); nothing was written")
    where = out / damaged.relative_to(staging)
    if not whole:
        with contextlib.suppress(OSError):
            damaged.unlink()
    kept = [p for p in files if p.exists()]
    how = "it holds its earlier version, whole" if damaged.exists() else "it is not there"
    if not whole and damaged in files:
        how = "it is not there (cut short, removed)"
    if not kept:
        shutil.rmtree(staging, ignore_errors=True)
        return UserError(f"{where}: could not be written ({cause}), the first of {what}; nothing else was written")
    folder = staging.with_name(f"{out.name}-saved-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}")
    try:
        staging.rename(folder)
    except OSError:
        folder = staging
    return UserError(
        f"{where}: could not be written ({cause}), so {how}; "
        f"{what} written before it ({len(kept)} files) are kept in {folder}"
    )


def _move_in(staging: Path, out: Path, what: str) -> Path:
    """Move the entries of `staging` into `out`; where they are in the end (`out`, or staging kept
    under a visible name beside it if `out` cannot take them)."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        ours = published(out)
        for entry in sorted(staging.iterdir()):
            target = out / entry.name
            if entry.is_dir() and target.is_dir() and not target.is_symlink():
                if entry.name not in ours:
                    raise OSError(errno.EEXIST, f"{target} is a folder this command did not write")
                shutil.rmtree(target)  # a subfolder an earlier run of this command wrote (gap bench's campaigns)
            os.replace(entry, target)
            ours.add(entry.name)
            write_atomic(out / PUBLISHED, "".join(f"{name}\n" for name in sorted(ours)))
        staging.rmdir()
        return out
    except OSError as e:
        kept = staging.with_name(f"{out.name}-saved-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}")
        try:
            staging.rename(kept)
        except OSError:
            kept = staging
        log.warning("could not write %s to %s (%s); they are in %s", what, out, e.strerror or e, kept)
        return kept
