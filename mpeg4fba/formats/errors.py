"""The error type of the file readers in :mod:`mpeg4fba.formats`.

Example
-------
>>> e = FormatError("<fapu> attribute ES0: 'abc' is not a number", "alice.fdp", 12)
>>> str(e)
"alice.fdp:12: <fapu> attribute ES0: 'abc' is not a number"
>>> isinstance(e, ValueError), e.line, e.message
(True, 12, "<fapu> attribute ES0: 'abc' is not a number")
>>> str(FormatError("not a feature point file"))
'<string>: not a feature point file'
"""
from __future__ import annotations

from typing import Optional

__all__ = ["FormatError"]


class FormatError(ValueError):
    """A file that does not follow its format.

    ``path`` is the file (None for text given directly), ``line`` (1-based) where the
    problem is when that is known, ``column`` likewise (rarely known), and
    ``message`` what is wrong.  ``str(error)`` reads ``path:line: message``
    (``path:line:column: message`` when the column is known).
    """

    def __init__(self, message: str, path: Optional[str] = None, line: Optional[int] = None,
                 column: Optional[int] = None):
        self.message = message
        self.path = None if path is None else str(path)
        self.line = line
        self.column = column
        super().__init__(str(self))

    def __str__(self) -> str:
        where = self.path or "<string>"
        if self.line is not None:
            where += f":{self.line}"
            if self.column is not None:
                where += f":{self.column}"
        return f"{where}: {self.message}"

    def __reduce__(self):
        return (FormatError, (self.message, self.path, self.line, self.column))
