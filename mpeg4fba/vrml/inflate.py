"""Reading a file that may be gzip-compressed, with bounded inflation.

A small gzip file can inflate to gigabytes (a "decompression bomb"), so gzip data is
inflated a chunk at a time under two caps, and reading stops with a VRMLError naming
the file and the limit as soon as either is passed:

* ``max_inflated`` (default :data:`MAX_INFLATED`, 2 GiB): the most bytes inflated.
* ``max_ratio`` (default :data:`MAX_RATIO`, 1000): the most bytes inflated per
  compressed byte consumed, checked once more than :data:`RATIO_FREE` (16 MiB) is
  inflated.  Deflate cannot exceed about 1030:1 and gets near it only on runs of one
  repeated byte, which is what bombs are made of; real VRML inflates 2 to 15 times,
  and even an animation repeating a small mesh every frame about 100 times.
  ``0`` turns the ratio cap off.

A function's own keyword arguments win; otherwise the limits set by
:func:`inflate_limits` for the block being run (the CLI's ``--max-inflated`` and
``--max-ratio``), else the defaults.

Example
-------
>>> import gzip, os, tempfile
>>> p = os.path.join(tempfile.mkdtemp(), "a.wrl.gz")
>>> _ = open(p, "wb").write(gzip.compress(b"#VRML V2.0 utf8\\n" + b" " * 4000))
>>> len(read_maybe_gzipped(p))
4016
>>> read_maybe_gzipped(p, max_inflated=1000)
Traceback (most recent call last):
...
mpeg4fba.vrml.errors.VRMLError: ...: gzip data inflates to more than 1000 bytes ...
"""
from __future__ import annotations

import contextlib
import contextvars
import os
import zlib
from typing import Iterator, Optional, Union

from .errors import VRMLError

__all__ = ["read_maybe_gzipped", "inflate_limits", "MAX_INFLATED", "MAX_RATIO", "RATIO_FREE"]

#: Default cap on the bytes a gzip file inflates to (2 GiB).
MAX_INFLATED = 2 << 30
#: Default cap on inflated bytes per compressed byte (0: no cap).
MAX_RATIO = 1000
#: The ratio cap applies only once more than this is inflated (16 MiB).
RATIO_FREE = 16 << 20

_IN_CHUNK = 64 << 10      # compressed bytes read at a time
_OUT_CHUNK = 1 << 20      # most bytes inflated per step, so a step can't blow up
_GZIP = 16 + zlib.MAX_WBITS   # zlib's window bits for gzip framing (checks CRC and size)

_limits: contextvars.ContextVar = contextvars.ContextVar(
    "mpeg4fba_inflate_limits", default=(MAX_INFLATED, MAX_RATIO))


def _checked(max_inflated: Optional[int], max_ratio: Optional[float]) -> tuple:
    """The limits to use: the arguments given, the rest from the current defaults."""
    default_inflated, default_ratio = _limits.get()
    inflated = default_inflated if max_inflated is None else max_inflated
    ratio = default_ratio if max_ratio is None else max_ratio
    if isinstance(inflated, bool) or not isinstance(inflated, int) or inflated <= 0:
        raise ValueError(f"max_inflated must be a whole number of bytes > 0, not {inflated!r}")
    if isinstance(ratio, bool) or not isinstance(ratio, (int, float)) or not ratio >= 0:
        raise ValueError(f"max_ratio must be a number >= 0 (0: no ratio cap), not {ratio!r}")
    return inflated, ratio


@contextlib.contextmanager
def inflate_limits(max_inflated: Optional[int] = None,
                   max_ratio: Optional[float] = None) -> Iterator[None]:
    """Within the block, gzip files are read under these limits unless a call gives its
    own (None keeps the one in force).

    >>> with inflate_limits(max_inflated=4 << 30, max_ratio=0):
    ...     _limits.get()
    (4294967296, 0)
    """
    token = _limits.set(_checked(max_inflated, max_ratio))
    try:
        yield
    finally:
        _limits.reset(token)


def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return str(n)  # pragma: no cover


def read_maybe_gzipped(path: Union[str, os.PathLike], max_inflated: Optional[int] = None,
                       max_ratio: Optional[float] = None) -> Union[bytes, bytearray]:
    """The bytes of ``path``, inflated when they start with gzip's magic bytes, under
    ``max_inflated`` and ``max_ratio`` (None: the limits in force, see the module).

    VRMLError naming the file for an unreadable file, corrupt or truncated gzip data,
    and data that inflates past a limit (the message says which, and how to raise it).
    """
    p = str(path)
    inflated, ratio = _checked(max_inflated, max_ratio)
    try:
        with open(p, "rb") as f:
            if f.peek(2)[:2] != b"\x1f\x8b":
                return f.read()
            return _gunzip(f, p, inflated, ratio)
    except OSError as e:
        raise VRMLError(f"can't read the file: {e.strerror}", p) from None


def _gunzip(f, path: str, max_inflated: int, max_ratio: float) -> bytearray:
    """Inflate the gzip members of the open file ``f``, a bounded chunk at a time."""
    out = bytearray()
    d = zlib.decompressobj(_GZIP)
    data = b""                 # compressed bytes read but not yet consumed
    consumed = 0               # compressed bytes zlib has consumed (for the ratio)
    in_member = False          # a member has begun and not yet ended
    exhausted = False          # the file has no more bytes
    while True:
        if not data and not exhausted:
            data = f.read(_IN_CHUNK)
            exhausted = not data
        if not data and not in_member:
            return out
        before = len(data)
        try:
            # at most _OUT_CHUNK bytes; with no input it drains what zlib still holds
            chunk = d.decompress(data, _OUT_CHUNK)
        except zlib.error as e:
            raise VRMLError(f"corrupt or truncated gzip data: {e}", path) from None
        in_member = True
        if d.eof:              # a member ended: what follows must be another member
            data = d.unused_data
            d = zlib.decompressobj(_GZIP)
            in_member = False
        else:
            data = d.unconsumed_tail
        consumed += before - len(data)
        if chunk:
            out += chunk
            _check(len(out), consumed, path, max_inflated, max_ratio)
        elif in_member and not data and exhausted:
            raise VRMLError("corrupt or truncated gzip data: the file ends inside the "
                            "compressed data", path)


def _check(inflated: int, consumed: int, path: str, max_inflated: int,
           max_ratio: float) -> None:
    if inflated > max_inflated:
        raise VRMLError(
            f"gzip data inflates to more than {_size(max_inflated)} (the limit "
            f"max_inflated={max_inflated}); reading stopped.  If the file is trusted, raise the "
            f"limit: max_inflated=<bytes> when loading, or 'mpeg4fba --max-inflated <size>'",
            path)
    if max_ratio and inflated > RATIO_FREE and inflated > max_ratio * consumed:
        raise VRMLError(
            f"gzip data inflates more than {max_ratio:g} times its size ({_size(consumed)} "
            f"to over {_size(inflated)}, past the limit max_ratio={max_ratio:g}): it looks "
            f"like a decompression bomb; reading stopped.  If the file is trusted, raise the "
            f"limit: max_ratio=<ratio> when loading (0: none), or 'mpeg4fba --max-ratio "
            f"<ratio>'", path)
