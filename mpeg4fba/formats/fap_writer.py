"""Writing ASCII ``.fap`` files (:mod:`mpeg4fba.formats.fap`, whose module doc gives the
format and the form written): numpy end to end, a block of frames at a time.  Imported
from there (``from mpeg4fba.formats.fap import write_fap``)."""
from __future__ import annotations

import os
from typing import Union

import numpy as np

from .._atomic import atomic_write
from .._numbers import EXACT_INT, number_text, ranges
from ..fba.stream import FapStream
from ..fba.tables import N_FAPS

__all__ = ["dumps_fap", "write_fap"]

PathLike = Union[str, "os.PathLike[str]"]

_CHUNK = 16384                  # frames formatted at a time


# -- writing ----------------------------------------------------------------------------------
def dumps_fap(stream: FapStream) -> str:
    """The ``.fap`` text of ``stream``, in the standard 2.1 form (see the module notes).

    >>> s = FapStream.from_values({3: [0, 1.5]}, fps=12.5, name="my face")
    >>> print(dumps_fap(s).splitlines()[0])
    2.1 my_face 12.5 2
    """
    return _dump_bytes(stream).decode("utf-8")


def write_fap(stream: FapStream, path: PathLike) -> None:
    """Write ``stream`` to ``path`` (through a temporary file and a rename).

    >>> import os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "b.fap")
    >>> s = FapStream.from_values({"head_yaw": [0, 1000, 2000]}, fps=25)
    >>> from mpeg4fba.formats.fap import read_fap
    >>> write_fap(s, p); read_fap(p) == s
    True
    """
    atomic_write(os.fspath(path), _dump_bytes(stream))


def _dump_bytes(stream: FapStream) -> bytes:
    name = "_".join(str(stream.name or "").split()) or "mpeg4fba"
    n = len(stream)
    head = f"2.1 {name} {number_text(stream.fps)} {n}\n".encode("utf-8")
    chunks = [head]
    for a in range(0, n, _CHUNK):
        chunks.append(_frames_bytes(stream, a, min(n, a + _CHUNK)))
    return b"".join(chunks)


def _frames_bytes(stream: FapStream, a: int, b: int) -> bytes:
    """Mask and value lines of frames a..b-1, formatted with numpy."""
    mask = stream.mask[a:b]
    m = len(mask)
    # Mask lines: '0 1 0 ... 0\n', 2 bytes per entry.
    mbytes = np.full((m, 2 * N_FAPS), 32, dtype=np.uint8)
    mbytes[:, 0::2] = 48 + mask
    mbytes[:, -1] = 10
    # Value lines: frame number, FAP 1 and 2 fields, low-level values, as one token table.
    table = np.concatenate([np.arange(a, b, dtype=np.float64)[:, None],
                            stream.visemes[a:b].astype(np.float64),
                            stream.expressions[a:b].astype(np.float64),
                            stream.values[a:b, 2:]], axis=1)
    present = np.concatenate([np.ones((m, 1), bool), np.repeat(mask[:, :1], 4, axis=1),
                              np.repeat(mask[:, 1:2], 6, axis=1), mask[:, 2:]], axis=1)
    per_row = present.sum(axis=1)
    tokens = table[present]
    sep = np.full(len(tokens), 32, dtype=np.uint8)
    sep[np.cumsum(per_row) - 1] = 10
    vbytes, vtok_len = _format_tokens(tokens, sep)
    row_of_tok = np.repeat(np.arange(m), per_row)
    vlen = np.bincount(row_of_tok, weights=vtok_len, minlength=m).astype(np.int64)
    # Interleave: mask line i, then value line i.
    row_len = 2 * N_FAPS + vlen
    row_off = np.cumsum(row_len) - row_len
    out = np.empty(int(row_len.sum()), dtype=np.uint8)
    out[(row_off[:, None] + np.arange(2 * N_FAPS)).ravel()] = mbytes.ravel()
    out[ranges(row_off + 2 * N_FAPS, vlen)] = vbytes
    return out.tobytes()


def _format_tokens(x: np.ndarray, sep: np.ndarray) -> tuple:
    """(bytes of every number followed by its separator, length of each) without a loop.

    Integral values below 2**53 are written as integers, digit by digit with numpy;
    others with numpy's shortest round-trip repr (the same digits as Python's repr).

    >>> b, l = _format_tokens(np.array([0, -12, 2.5, 1e300]), np.array([32, 32, 32, 10], np.uint8))
    >>> b.tobytes(), l.tolist()
    (b'0 -12 2.5 1e+300\\n', [2, 4, 4, 7])
    """
    integral = (x == np.round(x)) & (np.abs(x) < EXACT_INT)
    width = np.zeros(len(x), dtype=np.int64)
    ints = np.abs(x[integral]).astype(np.int64)
    neg = x[integral] < 0
    ndig = np.searchsorted(10 ** np.arange(1, 17, dtype=np.int64), ints, side="right") + 1
    width[integral] = ndig + neg
    floats = x[~integral].astype("S32")
    fmat = floats.view(np.uint8).reshape(len(floats), 32) if len(floats) else \
        np.zeros((0, 32), np.uint8)
    width[~integral] = (fmat != 0).sum(axis=1)
    cols = int(width.max()) + 1 if len(x) else 1
    grid = np.zeros((len(x), cols), dtype=np.uint8)
    irow = np.flatnonzero(integral)
    if len(irow):
        iw = width[irow]
        grid[irow[neg], 0] = ord("-")
        rest = ints.copy()
        for j in range(int(ndig.max())):                 # one pass per digit place
            live = ndig > j
            grid[irow[live], iw[live] - 1 - j] = 48 + rest[live] % 10
            rest //= 10
    frow = np.flatnonzero(~integral)
    if len(frow):
        grid[frow, :min(32, cols)] = fmat[:, :min(32, cols)]
    grid[np.arange(len(x)), width] = sep
    flat = grid.ravel()
    return flat[flat != 0], width + 1
