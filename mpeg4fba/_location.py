"""``path:line:column`` text, shared by every layer's errors and findings (knows nothing else)."""
from __future__ import annotations

from typing import Optional


def where_text(path: Optional[str], line: Optional[int], column: Optional[int],
               default: str = "<string>") -> str:
    """``path:line:column``, leaving out what is unknown.

    >>> where_text("a.wrl", 3, None), where_text(None, None, None, "<face>")
    ('a.wrl:3', '<face>')
    """
    text = path or default
    if line is not None:
        text += f":{line}"
        if column is not None:
            text += f":{column}"
    return text
