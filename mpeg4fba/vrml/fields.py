"""VRML97 field types: the Python value of each, parsing from text and formatting to text.

Values by type:

========================  ====================================================
SFBool                    ``bool``
SFInt32                   ``int``
SFFloat, SFTime           ``float``
SFString                  ``str``
SFVec2f/3f, SFColor,      ``tuple`` of floats (2, 3, 3, 4 long)
SFRotation
SFImage                   :class:`Image`
SFNode                    a ``Node`` or ``None``
MFInt32                   numpy ``int32`` array, shape (n,)
MFFloat, MFTime           numpy ``float64`` array, shape (n,)
MFVec2f/3f, MFColor,      numpy ``float64`` array, shape (n, 2/3/3/4)
MFRotation
MFString                  ``list`` of ``str``
MFNode                    ``list`` of ``Node``
========================  ====================================================

Example
-------
>>> FIELD_TYPES["MFVec3f"].coerce([[0, 1, 2], [3, 4, 5]]).shape
(2, 3)
>>> format_floats(np.array([1.0, 0.1, -2.5e-7]))
'1 0.1 -2.5e-07'
"""
from __future__ import annotations

import contextvars
import re
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from .._numbers import fromstring
from .numtext import VECTOR_MIN, float_text, int_text

__all__ = ["FieldType", "FIELD_TYPES", "Image", "NumberError", "parse_numbers",
           "format_floats", "format_float", "quote_string", "unquote_string"]

_NUM = r"[+-]?(?:0[xX][0-9a-fA-F]+|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
_NUMBER_RE = re.compile(_NUM)
_NAN_RE = re.compile(r"[+-]?[nN][aA][nN]")
# Possessive and anchored at token starts: a search through a 100,000-digit token once
# backtracked quadratically (minutes; found by the fuzzing run).
_SEPARATORS_RE = re.compile(r"(?:[\s,]++|#[^\n\r]*+)*+")
_COMMENT_RE = re.compile(r"#[^\n\r]*")
_NOT_INTEGER_RE = re.compile(r"(?<![^\s,])[^\s,.eE]*+[.eE][^\s,]*+")
#: Whether the writer writes NaN (as ``nan``): only for what the lenient reader read
#: (:func:`~mpeg4fba.vrml.writer.dumps` with ``strict=False``).
WRITE_NAN: contextvars.ContextVar = contextvars.ContextVar("vrml_write_nan", default=False)
_BLOCK = 1 << 16  # numbers formatted per step (a multiple of 16 and of 2, 3 and 4 wide)
_CHUNK = 1 << 22  # characters converted per numpy call; bounds the temporary copies
_INT32_MIN, _INT32_MAX = -(1 << 31), (1 << 31) - 1
_INT64_MIN, _INT64_MAX = -(1 << 63), (1 << 63) - 1


class NumberError(ValueError):
    """A bad number at ``offset`` in the text; the reader turns it into a VRMLError."""

    def __init__(self, message: str, offset: int):
        super().__init__(message)
        self.message = message
        self.offset = offset


def _locate_bad_number(text: str, start: int, end: int) -> int:
    """Offset of the first thing in text[start:end] that is not a number or separator."""
    pos = _SEPARATORS_RE.match(text, start, end).end()
    while pos < end:
        m = _NUMBER_RE.match(text, pos, end)
        if m is None:
            return pos
        nxt = _SEPARATORS_RE.match(text, m.end(), end).end()
        if nxt == m.end() and nxt < end:  # two numbers glued together, e.g. "1.2.3"
            return nxt
        pos = nxt
    return end


def _parse_slow(text: str, start: int, end: int, integer: bool,
                allow_nan: bool = False) -> np.ndarray:
    """Number by number: for hexadecimal values and for locating errors."""
    values = []
    pos = _SEPARATORS_RE.match(text, start, end).end()
    while pos < end:
        m = _NUMBER_RE.match(text, pos, end)
        if m is None and allow_nan and not integer:
            m = _NAN_RE.match(text, pos, end)
        if m is None:
            raise NumberError("not a number", pos)
        tok = m.group()
        if "x" in tok or "X" in tok:
            values.append(int(tok, 16))
        elif integer:
            if _NOT_INTEGER_RE.fullmatch(tok):
                raise NumberError(f"expected an integer, found {_cut(tok)!r}", pos)
            if len(tok) > 24:             # int() refuses 4,300 digits; none fits 64 bits
                raise NumberError(f"{_cut(tok)} is too large for an integer (VRML97 "
                                  "integers are 32-bit)", pos)
            values.append(int(tok))
        else:
            values.append(float(tok))
        if isinstance(values[-1], int) and not _INT64_MIN <= values[-1] <= _INT64_MAX:
            raise NumberError(f"{_cut(tok)} is too large for an integer (VRML97 integers are "
                              "32-bit)", pos)
        if not integer and np.isinf(float(values[-1])):
            raise NumberError(f"{_cut(tok)} is too large for a 64-bit float", pos)
        pos = _SEPARATORS_RE.match(text, m.end(), end).end()
    if integer:
        return np.array(values, dtype=np.int64)
    return np.array(values, dtype=np.float64)


def _cut(token: str, limit: int = 40) -> str:
    """A number's text for a message: a 400-digit one shown by its start and length."""
    return token if len(token) <= limit else f"{token[:limit]}... ({len(token)} characters)"


def _convert_chunk(chunk: str, base: int, text: str, start: int, end: int, integer: bool,
                   allow_nan: bool = False) -> np.ndarray:
    if "#" in chunk:
        chunk = _COMMENT_RE.sub(" ", chunk)
    if "x" in chunk or "X" in chunk:
        return _parse_slow(text, start, end, integer, allow_nan)
    if integer and ("." in chunk or "e" in chunk or "E" in chunk):
        bad = _NOT_INTEGER_RE.search(chunk)
        off = _locate_bad_number(text, start, end)
        if off < end:
            raise NumberError("not a number", off)
        # Offsets in the chunk are offsets in the text: comments were blanked in place.
        raise NumberError(f"expected an integer, found {bad.group()!r}", base + bad.start())
    if "," in chunk:
        chunk = chunk.replace(",", " ")
    if not chunk.strip():
        return np.empty(0, dtype=np.int64 if integer else np.float64)
    try:
        values = fromstring(chunk, np.int64 if integer else np.float64)
    except ValueError:
        raise NumberError("not a number", _locate_bad_number(text, start, end)) from None
    if not integer and not np.isfinite(values).all():
        if not allow_nan or np.isinf(values).any():
            _parse_slow(text, start, end, integer, allow_nan)   # raises, at the culprit
    return values


def parse_numbers(text: str, start: int = 0, end: Optional[int] = None,
                  integer: bool = False, allow_nan: bool = False) -> np.ndarray:
    """All numbers in ``text[start:end]`` (separated by white space, commas, comments).

    Converted by numpy in chunks of a few MB straight into one growing array, so a
    50 MB run costs about one copy of its values and no per-number Python work.
    Hexadecimal integers (``0xFF``) are accepted.  With ``integer=True`` the numbers
    must be written as integers and the result is int32 when every value fits (else
    int64); otherwise it is float64.  ``allow_nan``: a ``nan`` word (any case) reads as
    NaN (the lenient reader's).  Raises :class:`NumberError` with the offset of the
    culprit.

    >>> parse_numbers("1, 2.5 # comment\\n -3e2").tolist()
    [1.0, 2.5, -300.0]
    >>> parse_numbers("[ 1 -1 ]", 1, 7, integer=True).dtype
    dtype('int32')
    """
    if end is None:
        end = len(text)
    if end - start <= _CHUNK:
        return _narrow(_convert_chunk(text[start:end], start, text, start, end, integer, allow_nan))
    out = None
    n = 0
    pos = start
    while pos < end:
        cut = min(pos + _CHUNK, end)
        if cut < end:  # split at line ends only, so a chunk never cuts a comment in two
            nl = text.find("\n", cut, end)
            cut = end if nl < 0 else nl + 1
        part = _narrow(_convert_chunk(text[pos:cut], pos, text, pos, cut, integer, allow_nan))
        if out is None:
            # Size the array from the first chunk's density, with a little to spare.
            guess = int(len(part) * (end - start) / max(cut - pos, 1) * 1.02) + 16
            out = np.empty(guess, dtype=part.dtype)
        elif part.dtype != out.dtype:
            out = out.astype(np.result_type(out.dtype, part.dtype))
        if n + len(part) > len(out):
            out.resize(max(n + len(part), len(out) + len(out) // 4), refcheck=False)
        out[n:n + len(part)] = part
        n += len(part)
        pos = cut
    out.resize(n, refcheck=False)  # shrinks in place: no copy
    return out


def _narrow(values: np.ndarray) -> np.ndarray:
    """int64 values as int32 when they all fit (the common case for index lists)."""
    if values.dtype == np.int64 and values.size and \
            values.min() >= _INT32_MIN and values.max() <= _INT32_MAX:
        return values.astype(np.int32)
    return values


@dataclass(eq=False)
class Image:
    """An SFImage: ``width`` x ``height`` pixels of ``components`` bytes each (1-4).

    ``pixels`` is a uint32 array of ``width * height`` packed pixel values, first row
    at the bottom, as VRML97 stores them.
    """

    width: int
    height: int
    components: int
    pixels: np.ndarray

    def __post_init__(self):
        self.pixels = np.asarray(self.pixels, dtype=np.uint32).reshape(-1)

    def __eq__(self, other):
        return (isinstance(other, Image) and (self.width, self.height, self.components)
                == (other.width, other.height, other.components)
                and np.array_equal(self.pixels, other.pixels))

    def check(self) -> Optional[str]:
        """What is wrong with this image, or None."""
        if self.width < 0 or self.height < 0:
            return "SFImage width and height must not be negative"
        if not 0 <= self.components <= 4:
            return f"SFImage components must be 0 to 4, not {self.components}"
        if len(self.pixels) != self.width * self.height:
            return (f"SFImage of {self.width}x{self.height} needs {self.width * self.height} "
                    f"pixel values, found {len(self.pixels)}")
        if self.components < 4 and len(self.pixels) and int(self.pixels.max()) >> (8 * self.components):
            return f"SFImage pixel value too large for {self.components} component(s)"
        return None


# -- formatting -----------------------------------------------------------------------

_TRAILING_ZERO_RE = re.compile(r"\.0(?=[ ,\n]|$)")


def format_float(x: float) -> str:
    """Shortest text that reads back to the same float (``1.0`` -> ``1``)."""
    x = float(x)
    if x != x and WRITE_NAN.get():
        return "nan"
    if x != x or x in (float("inf"), float("-inf")):
        raise ValueError(f"{x} can't be written in VRML97")
    r = repr(x)
    return r[:-2] if r.endswith(".0") else r


def _check_finite(flat: np.ndarray) -> None:
    if not np.isfinite(flat).all() and (np.isinf(flat).any() or not WRITE_NAN.get()):
        raise ValueError("NaN or infinity can't be written in VRML97")


def format_floats(values: np.ndarray, per_line: int = 0, indent: str = "") -> str:
    """Numbers of a float array, shortest round-trip form, ``per_line`` to a line."""
    flat = np.asarray(values, dtype=np.float64).reshape(-1)
    _check_finite(flat)
    parts, sep = _float_parts(flat, per_line, indent)
    return sep.join(parts)


def _float_parts(flat: np.ndarray, per_line: int, indent: str) -> tuple:
    """(texts of blocks of ``flat``, the separator between them): a block at a time, as
    a list of Python floats and their strings costs ~100 bytes a number."""
    step = _BLOCK - _BLOCK % per_line if per_line else _BLOCK
    parts = [float_text(block, per_line, indent) if len(block) >= VECTOR_MIN else
             _join(list(map(repr, block.tolist())), per_line, indent, _TRAILING_ZERO_RE)
             for block in (flat[i:i + step] for i in range(0, len(flat), step))]
    return parts, ((",\n" + indent) if per_line else " ")


def _join(items: list, per_line: int, indent: str, strip=None) -> str:
    if per_line and len(items) > per_line:
        sep = ",\n" + indent
        text = sep.join(" ".join(items[i:i + per_line]) for i in range(0, len(items), per_line))
    elif per_line:
        text = " ".join(items)
    else:
        text = " ".join(items)
    return strip.sub("", text) if strip is not None else text


def quote_string(s: str) -> str:
    """``s`` as an SFString literal: quotes and backslashes escaped."""
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


_ESCAPE_RE = re.compile(r"\\(.)", re.S)


def unquote_string(literal: str) -> str:
    """The value of an SFString literal (with its quotes)."""
    body = literal[1:-1]
    if "\\" in body:
        body = _ESCAPE_RE.sub(r"\1", body)
    return body


# -- the types --------------------------------------------------------------------------

@dataclass(frozen=True)
class FieldType:
    """One VRML97 field type, e.g. ``FIELD_TYPES["SFVec3f"]``.

    ``kind`` is the value family (bool, int, float, string, node, image) and
    ``width`` the number of numbers per value for numeric types.
    """

    name: str
    kind: str
    width: int
    mf: bool

    @property
    def numeric(self) -> bool:
        return self.kind in ("int", "float")

    @property
    def single(self) -> "FieldType":
        """The SF type of the elements of an MF type (itself for SF types)."""
        return FIELD_TYPES["SF" + self.name[2:]]

    # -- Python values -> canonical values -----------------------------------------
    def coerce(self, value: Any) -> Any:
        """``value`` as this type's canonical Python value; ValueError if it can't be.

        >>> FIELD_TYPES["SFRotation"].coerce([0, 1, 0, 1.5])
        (0.0, 1.0, 0.0, 1.5)
        """
        k = self.kind
        if self.mf:
            if k == "node":
                items = list(value)
                for v in items:
                    _check_node(v, allow_none=False)
                return items
            if k == "string":
                if isinstance(value, str):
                    return [value]
                items = list(value)
                if not all(isinstance(v, str) for v in items):
                    raise ValueError(f"{self.name} takes strings")
                return items
            if k == "bool":
                return [bool(v) for v in value]
            arr = np.asarray(value, dtype=np.float64)
            if arr.size == 0:
                arr = arr.reshape((0, self.width) if self.width > 1 else (0,))
            if self.width > 1:
                if arr.ndim == 1 and arr.size % self.width == 0:
                    arr = arr.reshape(-1, self.width)
                if arr.ndim != 2 or arr.shape[1] != self.width:
                    raise ValueError(f"{self.name} takes an array of shape (n, {self.width}), "
                                     f"not {np.shape(value)}")
            elif arr.ndim != 1:
                arr = arr.reshape(-1)
            if not np.isfinite(arr).all():
                raise ValueError(f"{self.name} values must be finite")
            if k == "int":
                if not np.array_equal(arr, np.round(arr)) or (arr.size and (
                        arr.min() < _INT32_MIN or arr.max() > _INT32_MAX)):
                    raise ValueError(f"{self.name} takes 32-bit integers")
                return arr.astype(np.int32)
            return np.ascontiguousarray(arr)
        if k == "node":
            _check_node(value, allow_none=True)
            return value
        if k == "string":
            if not isinstance(value, str):
                raise ValueError(f"SFString takes a str, not {type(value).__name__}")
            return value
        if k == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"SFBool takes True or False, not {value!r}")
            return bool(value)
        if k == "image":
            if not isinstance(value, Image):
                raise ValueError("SFImage takes an Image")
            problem = value.check()
            if problem:
                raise ValueError(problem)
            return value
        if self.width > 1:
            vals = tuple(float(v) for v in value)
            if len(vals) != self.width:
                raise ValueError(f"{self.name} takes {self.width} numbers, not {len(vals)}")
            return vals
        if k == "int":
            if isinstance(value, (bool, np.bool_)) or int(value) != value:
                raise ValueError(f"SFInt32 takes an integer, not {value!r}")
            value = int(value)
            if not _INT32_MIN <= value <= _INT32_MAX:
                raise ValueError(f"{value} is outside the 32-bit range of SFInt32")
            return value
        return float(value)

    def empty(self) -> Any:
        """The empty MF value (or None for SFNode)."""
        if not self.mf:
            return None
        if self.kind in ("node", "string", "bool"):
            return []
        if self.kind == "int":
            return np.empty(0, dtype=np.int32)
        return np.empty((0, self.width) if self.width > 1 else 0)

    # -- numbers from text -> value -----------------------------------------------------
    def from_numbers(self, numbers: np.ndarray, bracketed: bool) -> Any:
        """The value of this (numeric or SFImage) type from a run of numbers.

        Raises ValueError with a message saying how many numbers were expected.
        """
        n = len(numbers)
        if self.kind == "image":
            if n < 3:
                raise ValueError("SFImage needs width, height and components first")
            w, h, c = (int(v) for v in numbers[:3])
            img = Image(w, h, c, np.zeros(0, np.uint32))
            if (numbers[3:] < 0).any() or (numbers[3:] > 0xFFFFFFFF).any():
                raise ValueError("SFImage pixel values must be 0 to 0xFFFFFFFF")
            img.pixels = numbers[3:].astype(np.uint32)
            problem = img.check()
            if problem:
                raise ValueError(problem)
            return img
        w = self.width
        if not self.mf:
            if n != w:
                raise ValueError(f"{self.name} takes {w} number{'s' if w > 1 else ''}, found {n}")
            if self.kind == "int":
                v = int(numbers[0])
                if not _INT32_MIN <= v <= _INT32_MAX:
                    if 0 <= v <= 0xFFFFFFFF:  # hexadecimal written unsigned, e.g. 0xFFFFFFFF
                        return v - (1 << 32)
                    raise ValueError(f"{v} is outside the 32-bit range of SFInt32")
                return v
            if w == 1:
                return float(numbers[0])
            return tuple(numbers.tolist())
        if not bracketed and n != w:
            raise ValueError(f"{self.name} without brackets takes one value ({w} number"
                             f"{'s' if w > 1 else ''}), found {n} numbers")
        if n % w:
            raise ValueError(f"{self.name} takes a multiple of {w} numbers, found {n}")
        if self.kind == "int":
            if n and (numbers.min() < _INT32_MIN or numbers.max() > 0xFFFFFFFF):
                raise ValueError(f"{self.name} value outside the 32-bit range")
            if n and numbers.max() > _INT32_MAX:  # hexadecimal written unsigned
                return numbers.astype(np.int64).astype(np.uint32).astype(np.int32)
            return numbers.astype(np.int32, copy=False)
        if w > 1:
            return numbers.reshape(-1, w)
        return numbers

    # -- value -> text ----------------------------------------------------------------------
    def format_parts(self, value: Any, indent: str = "") -> list:
        """:meth:`format` as a list of pieces: a long MF number list in blocks, so a
        writer can send a big mesh out without ever holding its whole text."""
        if not (self.mf and self.kind in ("int", "float")):
            return [self.format(value, indent)]
        if len(value) == 0:
            return ["[]"]
        inner = indent + "  "
        if self.kind == "int":
            parts, sep = _int_parts(np.asarray(value).reshape(-1), inner)
        else:
            flat = np.asarray(value, dtype=np.float64).reshape(-1)
            _check_finite(flat)
            parts, sep = _float_parts(flat, self.width if self.width > 1 else 10, inner)
        if len(value) == 1:
            return parts                                # one value: no brackets
        if len(parts) == 1:
            text = parts[0]
            if "\n" in text or len(text) > 60:
                return ["[\n" + inner + text + "\n" + indent + "]"]
            return ["[ " + text + " ]"]
        out = ["[\n" + inner]
        for i, part in enumerate(parts):
            if i:
                out.append(sep)
            out.append(part)
        out.append("\n" + indent + "]")
        return out

    def format(self, value: Any, indent: str = "") -> str:
        """Text of a non-node value.  ``indent`` is used for multi-line MF values."""
        k = self.kind
        if self.mf:
            if k == "string":
                if len(value) == 1:
                    return quote_string(value[0])
                return "[ " + " ".join(map(quote_string, value)) + " ]" if len(value) < 4 else \
                    "[\n" + indent + "  " + (",\n" + indent + "  ").join(map(quote_string, value)) \
                    + "\n" + indent + "]"
            return "".join(self.format_parts(value, indent))
        if k == "bool":
            return "TRUE" if value else "FALSE"
        if k == "string":
            return quote_string(value)
        if k == "int":
            return str(int(value))
        if k == "image":
            pixels = " ".join("0x%X" % p for p in value.pixels.tolist())
            head = f"{value.width} {value.height} {value.components}"
            return head + (" " + pixels if pixels else "")
        if self.width == 1:
            return format_float(value)
        return " ".join(map(format_float, value))


def _int_parts(values: np.ndarray, indent: str) -> tuple:
    """(texts of blocks of ``values``, the separator between them)."""
    n = len(values)
    faces = n > 8 and bool((values[:64] == -1).any())   # an index list: a face to a line
    if n <= _BLOCK:
        return [_int_block(values, indent, faces)], ""
    if faces:
        # cut just after a -1, so each block's last face ends where the block does
        ends = np.flatnonzero(values == -1) + 1
        cuts = np.unique(ends[np.searchsorted(ends, np.arange(_BLOCK, n, _BLOCK))
                              .clip(0, len(ends) - 1)])
        cuts = cuts[cuts < n]
    else:
        cuts = np.arange(_BLOCK, n, _BLOCK)         # multiples of 16: whole lines
    bounds = np.concatenate([[0], cuts, [n]])
    parts = [_int_block(values[a:b], indent, faces)
             for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist())]
    return parts, ",\n" + indent


def _int_block(values: np.ndarray, indent: str, faces: bool) -> str:
    """Integers: with ``faces``, a line break after each -1 but the last; else 16 to a
    line."""
    if len(values) >= VECTOR_MIN:
        return int_text(values, indent, faces)
    items = list(map(str, values.tolist()))
    if faces:
        nl = ",\n" + indent
        out = []
        for item in items:
            out.append(item)
            out.append(nl if item == "-1" else " ")
        out.pop()
        return "".join(out)
    if len(items) > 16:
        return (",\n" + indent).join(" ".join(items[i:i + 16]) for i in range(0, len(items), 16))
    return " ".join(items)


def _check_node(v: Any, allow_none: bool) -> None:
    from .scene import Node  # scene imports fields; import here to avoid the cycle
    if v is None and allow_none:
        return
    if not isinstance(v, Node):
        raise ValueError(f"expected a Node, not {type(v).__name__}")


def _make_types() -> dict:
    spec = {"Bool": ("bool", 1), "Int32": ("int", 1), "Float": ("float", 1), "Time": ("float", 1),
            "String": ("string", 0), "Vec2f": ("float", 2), "Vec3f": ("float", 3),
            "Color": ("float", 3), "Rotation": ("float", 4), "Node": ("node", 0),
            "Image": ("image", 0)}
    types = {}
    for base, (kind, width) in spec.items():
        types["SF" + base] = FieldType("SF" + base, kind, width, False)
        if base not in ("Bool", "Image"):  # VRML97 has neither MFBool nor MFImage
            types["MF" + base] = FieldType("MF" + base, kind, width, True)
    return types


FIELD_TYPES: dict[str, FieldType] = _make_types()
