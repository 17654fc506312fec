"""``path:line:column`` text, shared by every layer's errors and findings (knows nothing else)."""
from __future__ import annotations

from typing import Optional


def where_text(path: Optional[str], line: Optional[int], column: Optional[int],
               default: Optional[str] = None) -> str:
    """``path:line:column``, leaving out what is unknown.  Without a path: ``default``
    in its place when given, else ``line 3, column 5`` (text that came from no file has
    no name worth printing), else ``""``.

    >>> where_text("a.wrl", 3, None), where_text(None, None, None, "<face>")
    ('a.wrl:3', '<face>')
    >>> where_text(None, 2, 13), where_text(None, None, None)
    ('line 2, column 13', '')
    """
    if not path and default is None:
        if line is None:
            return ""
        return f"line {line}" + (f", column {column}" if column is not None else "")
    text = path or default
    if line is not None:
        text += f":{line}"
        if column is not None:
            text += f":{column}"
    return text
