"""JSON text read the way every reader here needs it: bounded and precise.

``json.loads`` alone lets hostile text through in three ways: an integer of
thousands of digits (Python then refuses to convert it, or numpy later overflows),
nesting thousands deep (RecursionError), and bytes that are not UTF-8.  Here each is
a :class:`~mpeg4fba.formats.errors.FormatError` naming the file, and the line and
column where the text allows.

>>> loads_json('{"a": [1, 2.5]}', "x.json")
{'a': [1, 2.5]}
>>> loads_json('{"count": ' + "9" * 50 + '}', "x.json")
Traceback (most recent call last):
...
mpeg4fba.formats.errors.FormatError: x.json:1:11: a 50-digit integer: longer than any count, index or value of this file could be (at most 30 digits)
"""
from __future__ import annotations

import json
import re
from typing import Any, Optional, Union

from .errors import FormatError

__all__ = ["loads_json", "shown", "MAX_INT_DIGITS"]

MAX_INT_DIGITS = 30


class _LongInt(Exception):
    def __init__(self, text: str):
        self.text = text


def _parse_int(text: str) -> int:
    if len(text) - text.startswith("-") > MAX_INT_DIGITS:
        raise _LongInt(text)
    return int(text)


def _line_column(text: str, offset: int) -> tuple:
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def loads_json(text: Union[str, bytes], path: Optional[str] = None, **kw: Any) -> Any:
    """``json.loads(text, **kw)``, with FormatError for text that is not JSON or not
    UTF-8, integers of more than ``MAX_INT_DIGITS`` digits and nesting too deep to
    read."""
    if isinstance(text, (bytes, bytearray)):
        try:
            text = bytes(text).decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise FormatError(f"not UTF-8 text: {e.reason} at byte {e.start}", path) from None
    try:
        return json.loads(text, parse_int=_parse_int, **kw)
    except _LongInt as e:
        m = re.search(r"-?\d{%d,}" % (MAX_INT_DIGITS + 1), text)
        line, column = _line_column(text, m.start()) if m else (None, None)
        digits = len(e.text) - e.text.startswith("-")
        raise FormatError(f"a {digits}-digit integer: longer than any count, index or value "
                          f"of this file could be (at most {MAX_INT_DIGITS} digits)", path,
                          line, column) from None
    except json.JSONDecodeError as e:
        raise FormatError(f"not valid JSON: {e.msg}", path, e.lineno, e.colno) from None
    except RecursionError:
        raise FormatError("JSON nested too deeply to read (arrays or objects thousands of "
                          "levels deep)", path) from None


def shown(value: Any, limit: int = 60) -> str:
    """``value`` as JSON text for an error message, cut at ``limit`` characters.

    >>> shown([1, 2]), shown(None), shown("x" * 100, 10)
    ('[1, 2]', 'null', '"xxxxxxxx...')
    """
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):      # not JSON (a pygltflib object), or a huge int
        text = repr(value)
    return text if len(text) <= limit else text[:limit - 1] + "..."
