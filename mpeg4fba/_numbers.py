"""Whole runs of numbers from text, one numpy call, the same on every numpy we allow.

``np.fromstring(text, sep=" ")`` stops at the first token that is not a number.  NumPy
2.3 and later raise ``ValueError`` there; earlier versions return the numbers before it
with a ``DeprecationWarning``.  The readers rely on the error, so on an older numpy the
warning is turned into it.
"""
from __future__ import annotations

import warnings
from typing import Union

import numpy as np

__all__ = ["fromstring", "ranges", "number_text", "EXACT_INT"]

#: Integers below this in size are exact in a float64.
EXACT_INT = 2.0 ** 53


def _raises_on_unmatched() -> bool:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        try:
            np.fromstring("1 x", dtype=np.float64, sep=" ")
        except ValueError:
            return True
    return False


_RAISES = _raises_on_unmatched()


def fromstring(text: Union[str, bytes, np.ndarray], dtype=np.float64) -> np.ndarray:
    """The numbers of ``text`` (separated by blanks) as one array; ``ValueError`` at
    anything that is not a number.

    >>> fromstring("1 2.5 -3").tolist()
    [1.0, 2.5, -3.0]
    >>> fromstring("1 x")
    Traceback (most recent call last):
    ValueError: string or file could not be read to its end due to unmatched data
    """
    if _RAISES:
        return np.fromstring(text, dtype=dtype, sep=" ")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        try:
            return np.fromstring(text, dtype=dtype, sep=" ")
        except DeprecationWarning:
            raise ValueError("string or file could not be read to its end due to "
                             "unmatched data") from None


def ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Concatenated ``arange(s, s + l)`` for each start and length, without a loop.

    >>> ranges(np.array([10, 20]), np.array([3, 2])).tolist()
    [10, 11, 12, 20, 21]
    """
    lengths = np.asarray(lengths, dtype=np.int64)
    total = int(lengths.sum())
    if not total:
        return np.zeros(0, dtype=np.int64)
    before = np.cumsum(lengths) - lengths
    return np.arange(total, dtype=np.int64) + np.repeat(np.asarray(starts, np.int64) - before,
                                                        lengths)


def number_text(x: float) -> str:
    """Shortest text: 25 for 25.0, else repr.

    >>> number_text(25.0), number_text(0.1)
    ('25', '0.1')
    """
    return str(int(x)) if float(x).is_integer() and abs(x) < EXACT_INT else repr(float(x))
