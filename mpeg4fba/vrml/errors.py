"""The one error type of the VRML codec, and where in the text it points.

Example
-------
>>> from mpeg4fba import vrml
>>> try:
...     vrml.loads("#VRML V2.0 utf8\\nTransform { scael 1 1 1 }")
... except vrml.VRMLError as e:
...     print(e.line, e.column)
2 13
"""
from __future__ import annotations

import bisect
from typing import Iterable, Optional

from .._location import where_text


class LocatedError(ValueError):
    """An error in some text that says where: ``path``, ``line``, ``column`` (1-based;
    each None when unknown) and ``message``; ``str(error)`` reads
    ``path:line:column: message`` (``line 2, column 5: message`` for text from no file,
    just the message when nothing is known).  The base of the errors of every reader.
    """

    def __init__(self, message: str, path: Optional[str] = None, line: Optional[int] = None,
                 column: Optional[int] = None):
        self.message = message
        self.path = None if path is None else str(path)
        self.line = line
        self.column = column
        super().__init__(str(self))

    def where(self) -> str:
        return where_text(self.path, self.line, self.column)

    def __str__(self) -> str:
        where = self.where()
        return f"{where}: {self.message}" if where else self.message

    def __reduce__(self):
        return (type(self), (self.message, self.path, self.line, self.column))


class VRMLWarning(UserWarning):
    """Something the lenient reader kept although it is not VRML97."""


class VRMLError(LocatedError):
    """A syntax or meaning error in VRML text, or a value that can't be written.

    ``path``, ``line`` and ``column`` (1-based, in characters) say where; ``message``
    says what is wrong and ``expected`` (possibly empty) what would have been valid.
    ``str(error)`` reads ``file:line:column: message (expected ...)``.
    """

    def __init__(self, message: str, path: Optional[str] = None, line: Optional[int] = None,
                 column: Optional[int] = None, expected: Iterable[str] = ()):
        self.expected = tuple(expected)
        super().__init__(message, path, line, column)

    def __str__(self) -> str:
        text = super().__str__()
        if self.expected:
            text += " (expected " + _one_of(self.expected) + ")"
        return text

    def __reduce__(self):
        return (VRMLError, (self.message, self.path, self.line, self.column, self.expected))


def _one_of(items: tuple) -> str:
    if len(items) == 1:
        return items[0]
    return "one of " + ", ".join(items)


class Source:
    """Text of one file (or string) with lazy offset -> line/column mapping.

    Positions are kept as offsets while reading; lines are computed only when an
    error or a user asks, so reading pays nothing for them.
    """

    __slots__ = ("text", "path", "_line_starts")

    def __init__(self, text: str, path: Optional[str] = None):
        self.text = text
        self.path = path
        self._line_starts = None

    def compact(self) -> None:
        """Keep only the line starts, not the text (for large ASCII files).

        Nodes keep their Source for error locations; without this a loaded 50 MB file
        would hold its 50 MB of text for as long as the scene lives.
        """
        text = self.text
        if text is None or self._line_starts is not None or not text.isascii():
            return
        import numpy as np
        starts = [np.zeros(1, dtype=np.int64)]
        step = 1 << 22
        for i in range(0, len(text), step):
            chunk = np.frombuffer(text[i:i + step].encode("ascii"), dtype=np.uint8)
            starts.append(np.flatnonzero(chunk == 10) + (i + 1))
        self._line_starts = np.concatenate(starts)
        self.text = None

    def _starts(self):
        if self._line_starts is None:
            starts = [0]
            text = self.text
            find = text.find
            i = find("\n")
            while i >= 0:
                starts.append(i + 1)
                i = find("\n", i + 1)
            self._line_starts = starts
        return self._line_starts

    def line_column(self, offset: int) -> tuple[int, int]:
        starts = self._starts()
        offset = max(0, offset if self.text is None else min(offset, len(self.text)))
        i = bisect.bisect_right(starts, offset) - 1
        return i + 1, offset - int(starts[i]) + 1

    def error(self, message: str, offset: Optional[int], expected: Iterable[str] = ()) -> VRMLError:
        if offset is None:
            return VRMLError(message, self.path, expected=expected)
        line, column = self.line_column(offset)
        return VRMLError(message, self.path, line, column, expected)
