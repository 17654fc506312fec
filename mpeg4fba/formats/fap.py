"""ASCII ``.fap`` files (Xface, Greta, VREng, visage): read and write FAP streams.

A file is a header line ``VERSION NAME FPS NFRAMES`` then, for every frame, a mask line
(68 entries of 0/1, one per FAP) and a value line (the frame number, then one value per
masked FAP in FAP order; FAP 1, the viseme, takes 4 integers and FAP 2, the expression,
6).  See ``shared/spec/fap_file_format.md`` section 1.

**Reading** is lenient where real files differ: lines starting with ``#`` and blank
lines are skipped anywhere, CRLF line ends and tabs are fine, the NAME may contain
spaces (VERSION is the first token, FPS and NFRAMES the last two), mask lines may have
more than 68 columns (Greta writes 69: the first 68 are used, and each extra column set
to 1 has one extra value after the FAP values, which is dropped with one
:class:`FapWarning`), values may be integers or floats.  A frame count that disagrees
with the header, or frames not numbered 0..n-1, warn (:class:`FapWarning`) and the data
wins.  Values outside a FAP's range warn (:class:`~mpeg4fba.fba.FapRangeWarning`).
Anything else wrong raises :class:`FapError` naming the file and the 1-based line.

**Version 2.0** (VREng's ``eyes.fap``, ``jag.fap``) is read as it is; VREng alone
divides every 2.0 value by 20 (``FAPV20_DIV``), which no other source documents: pass
``legacy_divisor=20`` to :func:`read_fap` for VREng's reading.  ``stream.version``
keeps the version read.

**Writing** gives the interoperable form: a ``2.1`` header whose name has no spaces,
exactly 68 mask entries, frames numbered from 0, integral values as integers and others
as the shortest float that reads back exactly, LF line ends, no comments.

Reading is numpy end to end (token boundaries, per-line counts, one ``np.fromstring``
for all values), so it runs at tens of MB/s.

Example
-------
>>> mask = "0 0 1" + " 0" * 65          # 68 entries: FAP 3 (open_jaw) only
>>> s = loads_fap(f"2.1 demo 25 2\\n{mask}\\n0 100\\n{mask}\\n1 250.5\\n")
>>> len(s), s.fps, s.name, s[1]["open_jaw"]
(2, 25.0, 'demo', 250.5)
>>> print(dumps_fap(s).splitlines()[4])
1 250.5
>>> loads_fap(dumps_fap(s)) == s
True
"""
from __future__ import annotations

import math
import os
import re
import warnings
from typing import Optional, Union

import numpy as np

from .._numbers import EXACT_INT, fromstring, number_text
from ..fba.stream import FapStream
from ..fba.tables import N_FAPS
from .errors import FormatError
from .fap_writer import dumps_fap, write_fap  # noqa: F401  (the module's writing half)

__all__ = ["read_fap", "loads_fap", "write_fap", "dumps_fap", "FapError", "FapWarning",
           "VERSIONS"]

#: The versions read: 2.1 (every current writer) and the legacy 2.0 (VREng).
VERSIONS = ("2.1", "2.0")

PathLike = Union[str, "os.PathLike[str]"]

# ASCII whitespace as the reader sees it (np.fromstring skips the same characters).
_WS = np.zeros(256, dtype=bool)
_WS[[9, 10, 11, 12, 13, 32]] = True
# Tokens each FAP takes on a value line when its mask bit is 1.
_WIDTH = np.ones(N_FAPS, dtype=np.int64)
_WIDTH[0], _WIDTH[1] = 4, 6
_EXPONENT = re.compile(rb"[eE]")
_POINT = re.compile(rb"\.")
# possessive: a 100,000-digit token followed by a stray byte made the plain form
# backtrack quadratically (minutes, found by the fuzzing run)
_NUMBER = re.compile(r"[+-]?(?:\d++(?:\.\d*+)?|\.\d++)(?:[eE][+-]?\d++)?")
_POW10 = 10.0 ** np.arange(23)  # the powers of ten that are exact doubles
_CHUNK = 16384                  # frames scattered at a time (bounded temporaries)
_BLOCK = 1 << 22                # bytes scanned for token starts at a time


class FapError(FormatError):
    """A ``.fap`` file that can't be read: ``path``, ``line`` (1-based; None when it is
    about the whole file) and ``message``; ``str(error)`` reads ``path:line: message``.

    >>> str(FapError("unsupported version '3.1'", "a.fap", 1))
    "a.fap:1: unsupported version '3.1'"
    """


class FapWarning(UserWarning):
    """Something in a ``.fap`` file that was read anyway (counts, numbering, extra columns)."""


# -- reading ----------------------------------------------------------------------------------
def read_fap(path: PathLike, *, legacy_divisor: float = 1.0) -> FapStream:
    """Read a ``.fap`` file.

    ``legacy_divisor`` divides the low-level values of a version 2.0 file (VREng uses
    20; the default 1 keeps them as written).  Raises :class:`FapError`; warns
    :class:`FapWarning` and :class:`~mpeg4fba.fba.FapRangeWarning`.

    >>> import os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "a.fap")
    >>> write_fap(FapStream.from_values({"open_jaw": [0, 512]}, fps=25), p)
    >>> read_fap(p)[1]["open_jaw"]
    512.0
    """
    path = os.fspath(path)
    with open(path, "rb") as f:
        data = f.read()
    return _parse(data, path, legacy_divisor)


def loads_fap(text: Union[str, bytes], path: Optional[str] = None, *,
              legacy_divisor: float = 1.0) -> FapStream:
    """Read ``.fap`` text (``path`` only names it in messages); see :func:`read_fap`.

    >>> loads_fap("2.1 empty 25 0\\n").fps
    25.0
    >>> try:
    ...     loads_fap("3.1 body 25 0\\n", path="body.bap")
    ... except FapError as e:
    ...     print(e.path, e.line, e.message[:30])
    body.bap 1 unsupported .fap version '3.1'
    """
    data = text.encode("utf-8", "surrogateescape") if isinstance(text, str) else bytes(text)
    return _parse(data, path, legacy_divisor)


class _Problems:
    """The errors found by the vectorised checks; the one earliest in the file wins."""

    def __init__(self) -> None:
        self.found: list = []

    def add(self, line: int, message: str) -> None:
        self.found.append((int(line), message))

    def raise_first(self, path: Optional[str]) -> None:
        if self.found:
            line, message = min(self.found, key=lambda lm: lm[0])
            raise FapError(message, path, line)


def _warn(message: str, path: Optional[str], line: Optional[int]) -> None:
    # text given without a file: the line alone, never a made-up "<string>" file name
    if path:
        where = path + (f":{line}" if line is not None else "")
    else:
        where = f"line {line}" if line is not None else ""
    warnings.warn(f"{where}: {message}" if where else message, FapWarning, stacklevel=4)


def _parse(data: bytes, path: Optional[str], legacy_divisor: float) -> FapStream:
    divisor = float(legacy_divisor)
    if not (divisor > 0 and math.isfinite(divisor)):
        raise ValueError(f"legacy_divisor must be a positive number, not {legacy_divisor!r}")
    arr = np.frombuffer(data, dtype=np.uint8)
    size = len(arr)
    # Whitespace with one more at the end, so "the byte after a token" always exists.
    ws = np.empty(size + 1, dtype=bool)
    ws[:size] = _WS[arr]
    ws[size] = True
    # Byte offsets as int32 when they fit: the token table is the largest array here.
    index = np.int32 if size < 2 ** 31 - 1 else np.int64
    newline = np.flatnonzero(arr == 10).astype(index)
    line_start = np.concatenate(([0], newline + 1)).astype(index)
    line_end = np.concatenate((newline, [size])).astype(index)
    # Token starts: a non-space byte after a space (or at the start).
    tok = _token_starts(ws, index)
    first_tok = np.searchsorted(tok, line_start)
    count = np.diff(np.append(first_tok, len(tok)))
    lead = np.zeros(len(line_start), dtype=np.uint8)
    filled = count > 0
    lead[filled] = arr[tok[first_tok[filled]]]
    content = np.flatnonzero(filled & (lead != ord("#")))
    if not len(content):
        raise FapError("no header line (expected 'VERSION NAME FPS NFRAMES')", path, 1)

    h = int(content[0])
    version, name, fps, declared = _header(data[line_start[h]:line_end[h]], path, h + 1)
    body = content[1:]
    problems = _Problems()
    n = len(body) // 2
    if len(body) % 2:
        problems.add(body[-1] + 1, "mask line without its value line (file truncated?)")
    mask_lines, value_lines = body[0:2 * n:2], body[1:2 * n:2]

    # -- mask lines ------------------------------------------------------------------------
    mcount = count[mask_lines]
    short = np.flatnonzero(mcount < N_FAPS)
    if len(short):
        f = short[0]
        problems.add(mask_lines[f] + 1, f"{mcount[f]} mask entries (expected {N_FAPS}, a 0 or 1 "
                                        "for each FAP)")
    is_mask = np.zeros(len(line_start), dtype=bool)
    is_mask[mask_lines] = True
    mtok = tok[np.repeat(is_mask, count)]
    digit = arr[mtok]
    ok = ((digit == 48) | (digit == 49)) & ws[mtok + 1]
    if not ok.all():
        k = int(np.argmin(ok))
        f = int(np.searchsorted(np.cumsum(mcount), k, side="right"))
        column = k - int(np.sum(mcount[:f])) + 1
        problems.add(mask_lines[f] + 1, f"mask entry '{_token_at(data, int(mtok[k]))}' in "
                                        f"column {column} is not 0 or 1")
    ones = digit == 49
    del ws, mtok, digit, ok
    mask, extra = _mask_matrix(ones, mcount, n)
    del ones

    # -- value lines: counts ---------------------------------------------------------------
    vcount = count[value_lines]
    low = mask[:, 2:].sum(axis=1)
    expected = 1 + low + 4 * mask[:, 0] + 6 * mask[:, 1] + extra
    wrong = np.flatnonzero(vcount != expected)
    if len(wrong):
        f = wrong[0]
        problems.add(value_lines[f] + 1, f"{vcount[f]} numbers on the value line (expected "
                                         f"{expected[f]} for this mask: "
                                         f"{_layout(mask[f], int(extra[f]))})")

    # -- value lines: numbers --------------------------------------------------------------
    vals = _numbers(arr, data, line_start, value_lines, vcount, tok, first_tok, problems, path)
    problems.raise_first(path)
    off = np.cumsum(vcount) - vcount
    frame_no = vals[off]
    if vals.dtype.kind == "f":
        not_int = np.flatnonzero(frame_no != np.round(frame_no))
        if len(not_int):
            f = not_int[0]
            where = int(tok[first_tok[value_lines[f]]])
            problems.add(value_lines[f] + 1,
                         f"frame number '{_token_at(data, where)}' is not an integer")

    # -- scatter the tokens into the stream's arrays ---------------------------------------
    values, visemes, expressions = _scatter(vals, off, mask, data, tok, first_tok, value_lines,
                                            problems)
    problems.raise_first(path)
    if version == "2.0" and divisor != 1.0:
        values /= divisor

    # -- lenient facts: warn ---------------------------------------------------------------
    if extra.any():
        f = int(np.argmax(extra > 0))
        k = int(extra.sum())
        _warn(f"{k} mask entr{'ies' if k != 1 else 'y'} beyond column {N_FAPS} set to 1 (Greta "
              f"writes 69 columns); {'their values were' if k != 1 else 'its value was'} "
              "dropped", path, int(mask_lines[f]) + 1)
    if declared != n:
        _warn(f"the header says {declared} frames but the file has {n}; using {n}", path, h + 1)
    if n and (frame_no != np.arange(n)).any():
        f = int(np.argmax(frame_no != np.arange(n)))
        _warn(f"frames are not numbered 0..{n - 1} in order (frame "
              f"{number_text(frame_no[f])} where {f} was expected); renumbered from 0", path,
              int(value_lines[f]) + 1)
    stream = FapStream(values, mask, fps, visemes, expressions, name=name, version=version)
    # Range warnings, re-issued so that they point at the caller of read_fap/loads_fap.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stream.warn_out_of_range(source=path or "")
    for w in caught:
        warnings.warn(w.message, stacklevel=3)
    return stream


def _header(raw: bytes, path: Optional[str], line: int) -> tuple:
    """(version, name, fps, declared frames) from the header line."""
    text = raw.decode("utf-8", "replace").strip()
    parts = text.split(None, 1)
    rest = parts[1].rsplit(None, 2) if len(parts) > 1 else []
    form = "(expected 'VERSION NAME FPS NFRAMES')"
    if not parts:
        raise FapError(f"the header line is empty {form}", path, line)
    version = parts[0]
    if version not in VERSIONS:
        hint = ("; 3.x is a .bap body animation file" if version.startswith("3.") else
                "; is the header line missing?" if version in ("0", "1") else "")
        raise FapError(f"unsupported .fap version '{version}' (expected 2.1 or 2.0{hint})",
                       path, line)
    if len(rest) < 2:
        raise FapError(f"header '{text}' has too few fields {form}", path, line)
    name = rest[0] if len(rest) == 3 else ""
    try:
        fps = float(rest[-2])
    except ValueError:
        raise FapError(f"header FPS '{rest[-2]}' is not a number {form}", path, line) from None
    if not (fps > 0 and math.isfinite(fps)):
        raise FapError(f"header FPS {rest[-2]} is not a positive frame rate", path, line)
    try:
        declared = int(rest[-1])
    except ValueError:
        raise FapError(f"header NFRAMES '{rest[-1]}' is not an integer {form}", path,
                       line) from None
    if declared < 0:
        raise FapError(f"header NFRAMES {declared} is negative", path, line)
    return version, name, fps, declared


def _token_starts(ws: np.ndarray, index: type) -> np.ndarray:
    """Offsets of the bytes that start a token (non-space after a space or at 0).

    ``ws`` is the whitespace flag of every byte plus one more (True) at the end.  Done in
    blocks, counting first, so no file-sized temporary is made besides the result.

    >>> ws = _WS[np.frombuffer(b" ab  c\\nd ", np.uint8)]
    >>> _token_starts(np.append(ws, True), np.int32).tolist()
    [1, 5, 7]
    """
    size = len(ws) - 1

    def block(a: int) -> np.ndarray:
        b = min(size, a + _BLOCK)
        starts = ~ws[a:b]
        starts &= ws[a - 1:b - 1] if a else np.concatenate(([True], ws[:b - 1]))
        return starts

    counts = [int(np.count_nonzero(block(a))) for a in range(0, size, _BLOCK)]
    tok = np.empty(sum(counts), dtype=index)
    at = 0
    for a, k in zip(range(0, size, _BLOCK), counts):
        tok[at:at + k] = np.flatnonzero(block(a))
        tok[at:at + k] += a
        at += k
    return tok


def _mask_matrix(ones: np.ndarray, mcount: np.ndarray, n: int) -> tuple:
    """(mask [n, 68], ones in the columns beyond 68 per frame) from the flat mask entries."""
    if n and (mcount == mcount[0]).all() and mcount[0] >= N_FAPS:
        table = ones.reshape(n, int(mcount[0]))
        return table[:, :N_FAPS].copy(), table[:, N_FAPS:].sum(axis=1)
    mask = np.zeros((n, N_FAPS), dtype=bool)
    row = np.repeat(np.arange(n), mcount)
    col = np.arange(len(ones)) - np.repeat(np.cumsum(mcount) - mcount, mcount)
    inside = col < N_FAPS
    mask[row[inside], col[inside]] = ones[inside]
    extra = np.bincount(row[~inside], weights=ones[~inside], minlength=n).astype(np.int64)
    return mask, extra


def _layout(mask: np.ndarray, extra: int) -> str:
    """What a value line holds for ``mask``: 'the frame number, 4 for FAP 1, 42 FAP values'."""
    parts = ["the frame number"]
    if mask[0]:
        parts.append("4 for FAP 1")
    if mask[1]:
        parts.append("6 for FAP 2")
    low = int(mask[2:].sum())
    parts.append(f"{low} FAP value{'s' if low != 1 else ''}")
    if extra:
        parts.append(f"{extra} for the mask column{'s' if extra != 1 else ''} beyond {N_FAPS}")
    return ", ".join(parts)


def _token_at(data: bytes, start: int) -> str:
    """The token starting at byte ``start``, for messages."""
    m = re.compile(rb"\S+").match(data, start)
    text = m.group(0) if m else b""
    text = text.decode("utf-8", "replace")
    return text if len(text) <= 40 else text[:37] + "..."


def _numbers(arr: np.ndarray, data: bytes, line_start: np.ndarray, value_lines: np.ndarray,
             vcount: np.ndarray, tok: np.ndarray, first_tok: np.ndarray, problems: _Problems,
             path: Optional[str]) -> np.ndarray:
    """All tokens of the value lines as one flat array (int64 if all are integers).

    Integers go through numpy's integer parser; decimals without an exponent through the
    same parser with the point removed, then an exact division by a power of ten (see
    :func:`_decimals`); anything else through numpy's float parser.
    """
    if not len(value_lines):
        return np.zeros(0, dtype=np.int64)
    # The value lines' bytes (each with its line end), in one buffer.
    line_len = np.diff(np.append(line_start, len(arr)))
    keep = np.zeros(len(line_start), dtype=bool)
    keep[value_lines] = True
    raw = arr[np.repeat(keep, line_len)]       # np.fromstring reads this buffer in place
    total = int(vcount.sum())
    vals: Optional[np.ndarray] = None
    if not _EXPONENT.search(memoryview(raw)):
        vals = _decimals(raw, total) if _POINT.search(memoryview(raw)) else _integers(raw, total)
    if vals is None:
        try:
            vals = fromstring(raw, np.float64)
            if len(vals) != total or not np.isfinite(vals).all():
                vals = None
        except ValueError:
            vals = None
    if vals is None:
        # Error path only: find the first token that is not a plain number.
        lines = data.split(b"\n")
        for ln in value_lines:
            for k, t in enumerate(lines[ln].split()):
                text = t.decode("utf-8", "replace")
                if not _NUMBER.fullmatch(text):
                    problems.add(ln + 1, f"'{_token_at(t, 0)}' is not a number (token {k + 1} "
                                         "of the value line)")
                    return np.zeros(total)
                if not math.isfinite(float(text)):
                    problems.add(ln + 1, f"'{_token_at(t, 0)}' is too large for a float (token "
                                         f"{k + 1} of the value line)")
                    return np.zeros(total)
        problems.add(value_lines[0] + 1, "the value lines could not be read as numbers")
        return np.zeros(total)
    return vals


def _integers(buf: Union[bytes, np.ndarray], total: int) -> Optional[np.ndarray]:
    """``total`` integers below 2**53 in magnitude from ``buf`` (bytes or uint8), or None.

    >>> _integers(b"1 -2 +3\\n", 3).tolist(), _integers(b"1 2.5", 2)
    ([1, -2, 3], None)
    """
    try:
        vals = fromstring(buf, np.int64)
    except ValueError:
        return None
    # numpy saturates integers too big for int64: leave those to the float parser.
    if len(vals) != total or (total and (vals.max() >= EXACT_INT or vals.min() <= -EXACT_INT)):
        return None
    return vals


def _decimals(raw: np.ndarray, total: int) -> Optional[np.ndarray]:
    """``total`` decimals (``-12.5``, ``3``, ``.25``; no exponent) from bytes, or None.

    The point is removed and the digits read as one integer m; the value is then
    m / 10**k for the k digits after the point.  With m < 2**53 and k <= 22 both are
    exact doubles, so the one division is correctly rounded: the same double as
    ``float(token)``.  Anything else (two points, too many digits) returns None.

    >>> _decimals(np.frombuffer(b"0.1 -12.50 7 .25 3.", np.uint8), 5).tolist()
    [0.1, -12.5, 7.0, 0.25, 3.0]
    """
    size = len(raw)
    index = np.int32 if size < 2 ** 31 - 64 else np.int64
    dots = np.flatnonzero(raw == 46).astype(index)

    def at(i: np.ndarray) -> np.ndarray:                # bytes at i; a space past the end
        return np.where(i < size, raw[np.minimum(i, size - 1)], np.uint8(32))

    # Digits after each point: step along while the bytes are digits (a few steps).
    digits_after = np.zeros(len(dots), dtype=np.int8)
    alive = np.ones(len(dots), dtype=bool)
    for j in range(1, len(_POW10) + 1):
        if not alive.any():
            break
        c = at(dots + j)
        alive &= (c >= 48) & (c <= 57)
        digits_after += alive
    # The point must end its token ("1.2.3", "1.5x", 23+ decimals: not this path).
    if len(dots) and (digits_after.max() >= len(_POW10)
                      or not _WS[at(dots + digits_after + 1)].all()):
        return None
    starts = _token_starts(np.append(_WS[raw], True), index)
    owner = np.searchsorted(starts, dots, side="right") - 1   # the token of each point
    del starts
    mantissa = _integers(raw[raw != 46], total)
    if mantissa is None:
        return None
    vals = mantissa.astype(np.float64)
    del mantissa
    vals[owner] /= _POW10[digits_after]
    return vals


def _scatter(vals: np.ndarray, off: np.ndarray, mask: np.ndarray, data: bytes, tok: np.ndarray,
             first_tok: np.ndarray, value_lines: np.ndarray, problems: _Problems) -> tuple:
    """(values [n, 68], visemes [n, 4], expressions [n, 6]) from the flat tokens.

    A value line is: the frame number at ``off``, FAP 1's 4 fields if masked, FAP 2's 6
    if masked, then one token per masked low-level FAP in FAP order.
    """
    n = len(mask)
    values = np.zeros((n, N_FAPS))
    visemes = np.zeros((n, 4), dtype=np.int64)
    expressions = np.zeros((n, 6), dtype=np.int64)
    if not n:
        return values, visemes, expressions
    m0 = mask[:, 0].astype(off.dtype)
    low_start = off + 1 + 4 * m0 + 6 * mask[:, 1]          # first low-level token per frame
    per_line = np.diff(np.append(off, len(vals)))
    if (per_line == per_line[0]).all() and (mask == mask[0]).all():
        # The common case: one layout for every frame, so the tokens are a table.
        table = vals.reshape(n, int(per_line[0]))
        low = mask[0, 2:]
        column = int(low_start[0] - off[0]) + np.cumsum(low) - low
        for c in np.flatnonzero(low):                      # one pass per FAP, not per token
            values[:, c + 2] = table[:, column[c]]
    else:
        for a in range(0, n, _CHUNK):                      # bounded temporaries
            b = min(n, a + _CHUNK)
            low = mask[a:b, 2:]
            at = low_start[a:b, None] + np.cumsum(low, axis=1) - low
            values[a:b, 2:] = np.where(low, vals[np.where(low, at, 0)], 0.0)
    for col, out, first, label in ((0, visemes, off + 1, "FAP 1 (viseme)"),
                                   (1, expressions, off + 1 + 4 * m0, "FAP 2 (expression)")):
        rows = np.flatnonzero(mask[:, col])
        if not len(rows):
            continue
        at = first[rows][:, None] + np.arange(out.shape[1])
        fields = vals[at]
        bad = fields != np.round(fields)
        # held as 32-bit integers: a larger one would wrap (1e12 -> -727379968)
        huge = ~bad & (np.abs(fields) >= 2 ** 31)
        if bad.any() or huge.any():
            r, k = np.argwhere(bad | huge)[0]
            line = value_lines[rows[r]]
            where = int(tok[first_tok[line] + at[r, k] - off[rows[r]]])
            problems.add(line + 1, f"{label} field '{_token_at(data, where)}' is " +
                         ("beyond 32 bits (the fields are small integers)" if huge[r, k]
                          else "not an integer"))
            continue
        out[rows] = fields
    return values, visemes, expressions
