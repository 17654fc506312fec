"""Writing a file atomically: a temporary file beside it, then a rename.

A failure (an exception, a full disk) leaves the old file, or none, never half a file.
The temporary file is ``.mpeg4fba-partial-<pid>-<random>-<name>``, flushed to disk
(``fsync``) before the rename.  A process killed mid-write can't remove its own, so
each successful write removes the stale ones in its folder: ours by name, whose
process is gone.
The new file gets the permissions an ordinary new file would (0666 less the umask),
not the 0600 of a temporary file.  An OSError names the path asked for, never the
temporary file (which the user never heard of).

>>> import os, tempfile
>>> p = os.path.join(tempfile.mkdtemp(), "a.txt")
>>> atomic_write(p, "hello")
>>> open(p).read()
'hello'
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from typing import BinaryIO, Iterator, Union

__all__ = ["atomic_write", "atomic_open", "remove_stale", "PARTIAL"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(path: Union[str, "os.PathLike[str]"], data: Union[bytes, str]) -> None:
    """Write ``data`` (bytes, or text written as UTF-8) to ``path`` atomically."""
    if isinstance(data, str):
        data = data.encode("utf-8")
    with atomic_open(path) as f:
        f.write(data)


@contextlib.contextmanager
def atomic_open(path: Union[str, "os.PathLike[str]"]) -> Iterator[BinaryIO]:
    """A binary file to write ``path`` through, a piece at a time: it becomes ``path``
    when the block ends, and is removed if the block raises.

    >>> import os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "b.txt")
    >>> with atomic_open(p) as f:
    ...     _ = f.write(b"one "); _ = f.write(b"two")
    >>> open(p).read()
    'one two'
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise FileNotFoundError(2, f"the folder {folder} does not exist", path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f"{PARTIAL}{os.getpid()}-",
                                   suffix="-" + os.path.basename(path), dir=folder)
    except OSError as e:
        raise _naming(e, path) from e
    try:
        with os.fdopen(fd, "wb") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())         # the data on disk before the name points at it
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError):
            raise _naming(e, path) from e
        raise
    remove_stale(folder)


PARTIAL = ".mpeg4fba-partial-"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True                  # someone else's process: leave its files alone
    return True


def remove_stale(folder: str) -> list:
    """Remove our partial files in ``folder`` whose writing process has ended; the
    names removed.

    >>> import tempfile
    >>> d = tempfile.mkdtemp()
    >>> _ = open(os.path.join(d, PARTIAL + "999999999-x1-a.wrl"), "w")
    >>> [os.path.basename(p) for p in remove_stale(d)]
    ['.mpeg4fba-partial-999999999-x1-a.wrl']
    """
    removed = []
    try:
        names = [n for n in os.listdir(folder) if n.startswith(PARTIAL)]
    except OSError:
        return removed
    for name in names:
        pid_text = name[len(PARTIAL):].split("-", 1)[0]
        if not pid_text.isdigit() or _alive(int(pid_text)):
            continue
        full = os.path.join(folder, name)
        try:
            os.unlink(full)
            removed.append(full)
        except OSError:
            pass
    return removed


def _naming(error: OSError, path: str) -> OSError:
    """The same error about ``path`` (``os.replace`` and ``mkstemp`` name the temporary file)."""
    if error.errno is None:
        return error
    return type(error)(error.errno, error.strerror, path)
