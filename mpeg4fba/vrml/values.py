"""The VRML97 reader's field values: what the grammar gives for a field (a token of
numbers, a string, a node, a bracketed list) typed and checked against its declaration
(:class:`ValueReader`, the half of :class:`~mpeg4fba.vrml.builder.Builder` that reads
values; the other half builds the scene's structure).

>>> from mpeg4fba.vrml.fields import FIELD_TYPES
>>> kind_text(FIELD_TYPES["MFVec3f"]), kind_text(FIELD_TYPES["SFBool"])
('3 numbers per value', 'TRUE or FALSE')
"""
from __future__ import annotations

import re
from typing import Any

import numpy as np

from .fields import FieldType, NumberError, parse_numbers, unquote_string
from .lexer import Tok

__all__ = ["ValueReader", "MF", "kind_text", "NAN_WORD_RE"]

NAN_WORD_RE = re.compile(r"[nN][aA][nN]")
NEXT_WORD_RE = re.compile(r"[\s,]*([^\s,\[\]{}#]+)")

_FLOAT_MAX = float(np.finfo(np.float64).max)


class MF(list):
    """The items of a bracketed value, with the offset of its '['."""

    __slots__ = ("pos",)


def kind_text(ftype: FieldType) -> str:
    k = ftype.kind
    if k == "node":
        return "a node" if not ftype.mf else "nodes"
    if k == "string":
        return "a string" if not ftype.mf else "strings"
    if k == "bool":
        return "TRUE or FALSE"
    if k == "image":
        return "width, height, components and pixels"
    n = ftype.width
    what = ("integer" if k == "int" else "number") + ("s" if n > 1 else "")
    return (f"{n} {what}" if n > 1 else f"an {what}" if k == "int" else f"a {what}") + \
        (" per value" if ftype.mf else "")


class ValueReader:
    """Field values typed and checked (a mixin of the reader's transformer: it uses the
    transformer's ``text``, ``strict``, ``err``, ``warn``, ``pos_of``, ``Node`` and
    ``RawValue``)."""

    def numbers(self, tok: Tok, integer: bool) -> np.ndarray:
        try:
            out = parse_numbers(self.text, tok.start_pos, tok.end_pos, integer,
                                allow_nan=not self.strict)
        except NumberError as e:
            raise self.err(e.message, e.offset) from None
        if not integer and not self.strict and np.isnan(out).any():
            at = NAN_WORD_RE.search(self.text, tok.start_pos, tok.end_pos)
            self.warn("nan", "nan is not a VRML97 number; kept (written back as nan)",
                      at.start() if at else tok.start_pos)
        return out

    def check_class(self, node, d, where: str, pos: int) -> None:
        accepts = d.accepts
        if accepts is None or node.decl is None:
            return
        classes = node.classes
        if classes is None or classes & set(accepts):
            return
        raise self.err(f"a {node.type} node can't go in {where}",
                       pos, [f"a{'n' if accepts[0][0] in 'aeiou' else ''} {accepts[0]} node"
                             if len(accepts) == 1 else f"one of these node kinds: {', '.join(accepts)}"])

    def convert(self, d, value, owner: str, name: str = "", extra_ok: bool = False) -> Any:
        """The typed value of declaration ``d`` from what the grammar gave, for field
        ``name`` of ``owner`` (named in errors as "owner.name"; a field is read far more
        often than it is wrong, so the name is only put together for an error)."""
        ftype = d.type
        kind = ftype.kind
        if isinstance(value, Tok):
            t = value.type
            if t == "NUMBERS" and (kind in ("int", "float", "image")):
                text = self.text
                start, end = value.start_pos, value.end_pos
                if end - start < 96 and not ftype.mf and kind == "float":
                    # Small SF values (translation 1 2 3): plain Python beats a numpy call.
                    s = text[start:end]
                    # (comments, hexadecimal and the lenient reader's nan take the long way)
                    if not ("#" in s or "x" in s or "X" in s or "n" in s or "N" in s):
                        parts = s.replace(",", " ").split()
                        if len(parts) == ftype.width:
                            vals = tuple(map(float, parts))
                            # an overflow (1e309) goes on to be reported with its place;
                            # under 96 characters only an exponent can reach one
                            if not ("e" in s or "E" in s) or \
                                    all(-_FLOAT_MAX <= v <= _FLOAT_MAX for v in vals):
                                return vals[0] if ftype.width == 1 else vals
                nums = self.numbers(value, kind != "float")
                if extra_ok and not ftype.mf and kind != "image" and len(nums) > ftype.width:
                    # Seen in the wild: "field SFInt32 x 0 0 0".  The first value is
                    # unambiguous; the rest is dropped with a warning, not an error.
                    self.warn(f"extra:{self.where(owner, name)}", f"{self.where(owner, name)} is {ftype.name}: {len(nums)} numbers "
                              f"given, the first {ftype.width} kept", start)
                    nums = nums[:ftype.width]
                try:
                    return ftype.from_numbers(nums, False)
                except ValueError as e:
                    after = NEXT_WORD_RE.match(text, end)
                    if after and NAN_WORD_RE.fullmatch(after.group(1)):
                        raise self.err(f"{self.where(owner, name)}: {after.group(1)} is not a VRML97 number (the "
                                       "lenient reader, strict=False or --lenient, keeps it "
                                       "with a warning)", after.start(1)) from None
                    raise self.err(f"{self.where(owner, name)}: {e}", start) from None
            if t == "STRING" and kind == "string":
                s = unquote_string(value.value)
                return [s] if ftype.mf else s
            if (t == "TRUE" or t == "FALSE") and kind == "bool" and not ftype.mf:
                return t == "TRUE"
            if t == "NULL" and kind == "node" and not ftype.mf:
                return None
            found = {"NUMBERS": "numbers", "STRING": "a string", "TRUE": "TRUE",
                     "FALSE": "FALSE", "NULL": "NULL"}.get(t, repr(value.value))
            raise self.err(f"{self.where(owner, name)} is {ftype.name}: found {found}", value.start_pos,
                           [kind_text(ftype)])
        if isinstance(value, self.Node):
            if kind == "node":
                self.check_class(value, d, self.where(owner, name), value._pos)
                return [value] if ftype.mf else value
            raise self.err(f"{self.where(owner, name)} is {ftype.name}: found a {value.type} node", value._pos,
                           [kind_text(ftype)])
        # a bracketed list
        if not ftype.mf:
            raise self.err(f"{self.where(owner, name)} is {ftype.name}, a single value: brackets are for MF fields",
                           value.pos, [kind_text(ftype)])
        if not value:
            return ftype.empty()
        if kind == "node":
            for item in value:
                if not isinstance(item, self.Node):
                    raise self.err(f"{self.where(owner, name)} is MFNode: found {self.describe(item)}",
                                   self.pos_of(item), ["nodes"])
                self.check_class(item, d, self.where(owner, name), item._pos)
            return list(value)
        if kind == "string":
            out = []
            for item in value:
                if not (isinstance(item, Tok) and item.type == "STRING"):
                    raise self.err(f"{self.where(owner, name)} is MFString: found {self.describe(item)}",
                                   self.pos_of(item), ["strings"])
                out.append(unquote_string(item.value))
            return out
        arrays = []
        for item in value:
            if not (isinstance(item, Tok) and item.type == "NUMBERS"):
                raise self.err(f"{self.where(owner, name)} is {ftype.name}: found {self.describe(item)}",
                               self.pos_of(item), [kind_text(ftype)])
            arrays.append(self.numbers(item, kind == "int"))
        nums = arrays[0] if len(arrays) == 1 else np.concatenate(arrays)
        try:
            return ftype.from_numbers(nums, True)
        except ValueError as e:
            raise self.err(f"{self.where(owner, name)}: {e}", value.pos) from None

    @staticmethod
    def where(owner: str, name: str) -> str:
        return f"{owner}.{name}" if name else owner

    def describe(self, item) -> str:
        if isinstance(item, self.Node):
            return f"a {item.type} node"
        return {"NUMBERS": "numbers", "STRING": "a string", "TRUE": "TRUE",
                "FALSE": "FALSE"}.get(item.type, repr(item.value))

    def raw(self, value) -> Any:
        """A value kept as written, for fields the reader does not know."""
        def item(x):
            if isinstance(x, Tok):
                if x.type == "NUMBERS":
                    return self.text[x.start_pos:x.end_pos]
                return x.value
            return x
        if isinstance(value, MF):
            return self.RawValue([item(x) for x in value], True)
        return self.RawValue([item(value)], False)
