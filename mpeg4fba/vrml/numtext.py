"""Long number lists to text, a block at a time, in numpy.

The writer's cost on mesh files is turning numbers into text.  ``repr`` of each float
and ``str`` of each int, joined in Python, write at about half the reading speed;
here the digits of a whole block are computed as arrays, laid out in a byte matrix
(one row per number, zero bytes where a row is shorter) and squeezed into one
string.  The text is exactly what ``repr``/``str`` would give, joined the same way.

Floats: a double ``x`` with ``1e-4 <= |x| < 2**22`` (or 0) that equals ``m / 1e9``
for the integer ``m = rint(|x| * 1e9)`` is written as the decimal ``m / 10**9`` with
its trailing zeros dropped.  That decimal reads back as ``x`` (IEEE division and
decimal reading both round correctly), and below ``2**22`` two different 9-decimal
numbers are never the same double (the spacing of doubles there is under 1e-9),
so it is the shortest such text: the one ``repr`` gives.  Any other number
(more decimals, larger, tiny, nan) is written by ``repr`` itself.

>>> float_text(np.array([1.0, -0.5, 0.1, 1e-7, 123456.789]), 0, "")
'1 -0.5 0.1 1e-07 123456.789'
>>> int_text(np.array([0, 1, 2, -1, 2, 3, 4, -1]), "  ", faces=True)
'0 1 2 -1,\\n  2 3 4 -1'
"""
from __future__ import annotations

import numpy as np

__all__ = ["float_text", "int_text", "VECTOR_MIN"]

VECTOR_MIN = 128       # shorter lists are joined in Python: numpy's set-up costs more

_P10 = 10 ** np.arange(19, dtype=np.int64)
_LIMIT = float(1 << 22)            # the whole part then has 7 digits: 3 groups of 3


def _tables() -> tuple:
    """Digit tables, one uint32 per group value holding its 3 ASCII digits and a zero
    byte: 0-999 the group's digits; 1000-1999 the same without leading zeros (lead;
    "0" for 0) or without trailing zeros (trail); 2000 nothing."""
    lt = np.zeros((2001, 4), np.uint8)
    tt = np.zeros((2001, 4), np.uint8)
    for i in range(1000):
        t = f"{i:03d}"
        lt[i, :3] = tt[i, :3] = np.frombuffer(t.encode(), np.uint8)
        a = t.lstrip("0") or "0"
        lt[1000 + i, 3 - len(a):3] = np.frombuffer(a.encode(), np.uint8)
        b = t.rstrip("0")
        tt[1000 + i, :len(b)] = np.frombuffer(b.encode(), np.uint8)
    return lt.view(np.uint32).ravel(), tt.view(np.uint32).ravel()


_LEAD, _TRAIL = _tables()


def _groups(v: np.ndarray, n_groups: int) -> list:
    """The 3-digit groups of non-negative int64 ``v``, most significant first."""
    return [v // _P10[3 * (n_groups - 1 - k)] % 1000 for k in range(n_groups)]


def _n_groups(largest: int) -> int:
    """How many 3-digit groups the digits of ``largest`` (>= 0) take."""
    return (len(str(largest)) + 2) // 3


def _lead_digits(out: np.ndarray, v: np.ndarray) -> None:
    """Write ``v``'s digits into the uint32 columns ``out`` (one per group): right-aligned,
    zero bytes before them."""
    n_groups = out.shape[1]
    started = np.zeros(len(v), bool)
    for k, g in enumerate(_groups(v, n_groups)):
        first = ~started & (g != 0) if k < n_groups - 1 else ~started
        out[:, k] = _LEAD[np.where(started, g, np.where(first, 1000 + g, 2000))]
        started |= first


def _trail_digits(out: np.ndarray, v: np.ndarray) -> None:
    """Write ``v``'s digits, zero-padded left to 3 per column of ``out``, with its
    trailing zeros as zero bytes (all of them when ``v`` is 0)."""
    n_groups = out.shape[1]
    ended = np.zeros(len(v), bool)
    groups = _groups(v, n_groups)
    for k in range(n_groups - 1, -1, -1):
        g = groups[k]
        last = ~ended & (g != 0)
        out[:, k] = _TRAIL[np.where(ended, g, np.where(last, 1000 + g, 2000))]
        ended |= last


def _layout(n: int, widths: tuple, newline_after: np.ndarray, indent: str) -> tuple:
    """A zeroed (n, sum(widths) + separator) byte matrix, its column blocks of
    ``widths`` as views, and the separator after each number written in: " ", or
    ",\n" + indent where ``newline_after``, nothing after the last."""
    nl = (",\n" + indent).encode("ascii")
    out = np.zeros((n, sum(widths) + len(nl)), np.uint8)
    views, at = [], 0
    for w in widths:
        views.append(out[:, at:at + w])
        at += w
    sep = out[:, at:]
    sep[:, 0] = 32
    sep[np.flatnonzero(newline_after)] = np.frombuffer(nl, np.uint8)
    sep[-1] = 0
    return out, views


def _text(rows: np.ndarray) -> str:
    return rows.tobytes().translate(None, b"\0").decode("ascii")


def _with_text(rows: np.ndarray, where: np.ndarray, texts: list, width: int) -> np.ndarray:
    """``rows`` with the first ``width`` bytes of the rows at ``where`` replaced by
    ``texts`` (the matrix widened if a text is longer)."""
    if not texts:
        return rows
    enc = np.array([t.encode("ascii") for t in texts])        # bytes, zero-padded
    size = enc.dtype.itemsize
    if size > width:
        rows = np.concatenate([rows[:, :width], np.zeros((len(rows), size - width), np.uint8),
                               rows[:, width:]], 1)
        width = size
    rows[where, :width] = 0
    rows[where, :size] = enc.view(np.uint8).reshape(len(texts), -1)
    return rows


def float_text(x: np.ndarray, per_line: int, indent: str) -> str:
    """Float64 ``x`` as ``repr`` texts without a trailing ``.0``, ``per_line`` to a line
    (lines joined by ``",\\n" + indent``; 0: one line)."""
    n = len(x)
    if n == 0:
        return ""
    a = np.abs(x)
    with np.errstate(invalid="ignore", over="ignore"):
        m = np.rint(a * 1e9)
        ok = ((a >= 1e-4) & (a < _LIMIT) | (a == 0)) & (m / 1e9 == a)
    m = np.where(ok, m, 0).astype(np.int64)
    whole, frac = np.divmod(m, _P10[9])
    if per_line:
        newline = (np.arange(1, n + 1) % per_line) == 0
    else:
        newline = np.zeros(n, bool)
    g = _n_groups(int(whole.max()))
    rows, (sign, head, point, tail) = _layout(n, (1, 4 * g, 1, 12), newline, indent)
    sign[np.signbit(x), 0] = 45
    _lead_digits(head.view(np.uint32), whole)
    point[frac != 0, 0] = 46
    _trail_digits(tail.view(np.uint32), frac)
    bad = np.flatnonzero(~ok)
    if len(bad):
        texts = [r[:-2] if r.endswith(".0") else r for r in map(repr, x[bad].tolist())]
        rows = _with_text(rows, bad, texts, 14 + 4 * g)
    return _text(rows)


def int_text(v: np.ndarray, indent: str, faces: bool) -> str:
    """Integers as ``str`` texts: with ``faces``, a line break after every -1 (but the
    last), else 16 to a line (lines joined by ``",\\n" + indent``)."""
    v = np.asarray(v, dtype=np.int64).reshape(-1)
    n = len(v)
    if n == 0:
        return ""
    a = np.abs(v)
    newline = (v == -1) if faces else (np.arange(1, n + 1) % 16) == 0
    g = min(_n_groups(int(a.max())), 4)
    rows, (sign, digits) = _layout(n, (1, 4 * g), newline, indent)
    sign[v < 0, 0] = 45
    _lead_digits(digits.view(np.uint32), a)
    big = np.flatnonzero(a >= _P10[3 * g])      # beyond 12 digits: not from a VRML file
    return _text(_with_text(rows, big, list(map(str, v[big].tolist())), 1 + 4 * g))
