"""What the file system says of a path before it is read or written: every command looks its
inputs and outputs up here first, so a path it cannot look up is a user's error in one line, not
a traceback from deep in the reading."""

from __future__ import annotations

import errno
import os
from pathlib import Path


def path_problem(path: Path) -> str | None:
    """Why the file system cannot look `path` up at all (a loop of symbolic links, a name longer
    than it takes, a file where the path needs a folder), or None: the path may exist or not."""
    try:
        os.stat(path)
        Path(path).resolve()  # a loop above a dangling link: RuntimeError before Python 3.13, OSError since
    except FileNotFoundError:
        return None
    except RuntimeError:
        return "is a loop of symbolic links"
    except OSError as e:
        if e.errno == errno.ENOENT:
            return None
        if e.errno == errno.ENOTDIR:
            file = next((p for p in reversed(Path(path).parents) if p.is_file()), None)
            if file is not None:
                return f"passes through {file}, a file, as if it were a folder"
        return {
            errno.ELOOP: "is a loop of symbolic links",
            errno.ENAMETOOLONG: "has a name longer than the file system takes",
            errno.ENOTDIR: "passes through a file as if it were a folder",
        }.get(e.errno, f"cannot be looked up ({e.strerror})")
    return None


NOT_REGULAR = "is not a regular file (a pipe, a device or a socket)"


def is_special(path: Path) -> bool:
    """Is something at `path` that is neither a file nor a folder (a pipe, a device, a socket)? A
    pipe read would block and /dev/zero never end; one replaced whole would lose the device."""
    path = Path(path)
    return path.exists() and not path.is_file() and not path.is_dir()


def input_problem(path: Path) -> str | None:
    """Why `path` cannot be read as an input file (`path_problem`, something there that is not a
    regular file: a pipe, a device, a socket, or a file this user may not read), or None: it may
    still be missing or a folder."""
    problem = path_problem(path) or (NOT_REGULAR if is_special(path) else None)
    if problem or not Path(path).is_file():
        return problem
    try:
        open(path, "rb").close()  # what the permissions (and root's capabilities) allow, as the reader will meet it
    except OSError as e:
        return f"cannot be read ({e.strerror})"
    return None
