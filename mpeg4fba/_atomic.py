"""Writing a file atomically: a temporary file beside it, then a rename.

A failure (an exception, a full disk) leaves the old file, or none, never half a file.
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

import os
import tempfile
from typing import Union

__all__ = ["atomic_write"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(path: Union[str, "os.PathLike[str]"], data: Union[bytes, str]) -> None:
    """Write ``data`` (bytes, or text written as UTF-8) to ``path`` atomically."""
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise FileNotFoundError(2, f"the folder {folder} does not exist", path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=os.path.basename(path), dir=folder)
    except OSError as e:
        raise _naming(e, path) from e
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
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


def _naming(error: OSError, path: str) -> OSError:
    """The same error about ``path`` (``os.replace`` and ``mkstemp`` name the temporary file)."""
    if error.errno is None:
        return error
    return type(error)(error.errno, error.strerror, path)
