"""The error type of the file readers in :mod:`mpeg4fba.formats`.

Example
-------
>>> e = FormatError("<fapu> attribute ES0: 'abc' is not a number", "alice.fdp", 12)
>>> str(e)
"alice.fdp:12: <fapu> attribute ES0: 'abc' is not a number"
>>> isinstance(e, ValueError), e.line, e.message
(True, 12, "<fapu> attribute ES0: 'abc' is not a number")
>>> str(FormatError("not a feature point file"))
'not a feature point file'
"""
from __future__ import annotations

from ..vrml.errors import LocatedError

__all__ = ["FormatError"]


class FormatError(LocatedError):
    """A file that does not follow its format.

    ``path`` is the file (None for text given directly), ``line`` (1-based) where the
    problem is when that is known, ``column`` likewise (rarely known), and
    ``message`` what is wrong.  ``str(error)`` reads ``path:line: message``
    (``path:line:column: message`` when the column is known; without a path, just
    ``line 3: message`` or the message).
    """
