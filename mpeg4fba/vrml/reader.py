"""VRML97 text -> Scene: ``load(path)`` and ``loads(text)``.

The syntax is ``grammars/vrml97.lark``; lark's LALR parser drives it with the
builder below passed in as its transformer, so no parse tree is ever built: each
rule's callback types and checks what it reduces, knowing (through the ``*_head``
rules) which node or PROTO it is in.  The lexer is ours but its terminals are the
grammar's: it compiles them into one regular expression, adds nothing to them, and
hands a bracketed run of numbers to numpy as one token.

Example
-------
>>> scene = loads('#VRML V2.0 utf8\\nDEF T Transform { translation 0 1 0 }')
>>> scene.find("T")["translation"]
(0.0, 1.0, 0.0)
"""
from __future__ import annotations

import difflib
import gc
import os
import re
import sys
import threading
import warnings
from importlib import resources
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np
from lark import Lark
from lark.lexer import Lexer
from lark.exceptions import UnexpectedInput, UnexpectedToken, VisitError

from .errors import Source, VRMLError
from .fields import FIELD_TYPES, FieldType, NumberError, parse_numbers, unquote_string
from .inflate import read_maybe_gzipped

__all__ = ["load", "loads", "parse_value", "VRMLWarning"]


class VRMLWarning(UserWarning):
    """Something the lenient reader kept although it is not VRML97."""


_COMPACT_ABOVE = 8 << 20  # chars: above this a Source keeps line starts, not the text
_HEADER_RE = re.compile(r"#VRML[ \t]+V2\.0[ \t]+utf8")
_NAN_WORD_RE = re.compile(r"[nN][aA][nN]")
_NEXT_WORD_RE = re.compile(r"[\s,]*([^\s,\[\]{}#]+)")
_NAME_BEFORE = frozenset({"DEF", "USE", "ROUTE", "TO", "IS", "PROTO", "EXTERNPROTO"})
_LATE_HEADER_RE = re.compile(r"^[ \t]*#VRML[ \t]+V2\.0[ \t]+utf8", re.M)

# Where a token may name its kind in an error message.
_TOKEN_NAMES = {"ID": "a name", "NUMBERS": "a number", "STRING": "a string",
                "TRUE": "TRUE", "FALSE": "FALSE", "NULL": "NULL",
                "EVENT_KIND": "eventIn or eventOut", "FIELD_KIND": "field or exposedField",
                "$END": "the end of the file"}
_X3D_WORDS = {"IMPORT", "EXPORT", "COMPONENT", "PROFILE", "META", "UNIT", "AS",
              "inputOnly", "outputOnly", "initializeOnly", "inputOutput"}


def _grammar_text() -> str:
    """The grammar, from the package (wheel) or from the source tree's grammars/."""
    try:
        return resources.files("mpeg4fba.grammars").joinpath("vrml97.lark").read_text("utf-8")
    except (ModuleNotFoundError, FileNotFoundError, OSError):
        here = Path(__file__).resolve().parents[2] / "grammars" / "vrml97.lark"
        return here.read_text("utf-8")


# -- the lexer ------------------------------------------------------------------------

class _Tok:
    """A token: far cheaper to make than lark's Token, and all the parser reads."""

    __slots__ = ("type", "value", "start_pos", "end_pos")
    line = column = end_line = end_column = None

    def __init__(self, type: str, value: str, start_pos: int, end_pos: int):
        self.type = type
        self.value = value
        self.start_pos = start_pos
        self.end_pos = end_pos

    def __str__(self) -> str:
        return self.value

    def __repr__(self) -> str:
        return f"_Tok({self.type}, {self.value!r})"


_SURROGATE_RE = re.compile("[\udc80-\udcff]")  # bytes that were not UTF-8, kept by _decode


class _FastLexer(Lexer):
    """Lexer built from the grammar's own terminals (lark custom-lexer interface 0)."""

    __future_interface__ = 0
    current_source: Optional[Source] = None
    current_source_strict = True

    def __init__(self, lexer_conf):
        terms = {t.name: t for t in lexer_conf.terminals}
        rx = {name: t.pattern.to_regexp() for name, t in terms.items()}
        id_re = re.compile(rx["ID"])
        self.punct = {}
        self.word_terminals = []
        for t in lexer_conf.terminals:
            if t.name in ("ID", "NUMBERS", "STRING") or t.name in lexer_conf.ignore:
                continue
            name = sys.intern(str(t.name))  # identical objects make the table lookups cheap
            if t.pattern.type == "str" and not id_re.fullmatch(t.pattern.value):
                self.punct[t.pattern.value] = name
            else:
                self.word_terminals.append((name, re.compile(rx[t.name])))
        # Blanks and comments in a form with exactly one way to split any run of them:
        # "(?:SEPARATOR|COMMENT)*" lets the regex engine re-split a run of n blanks in
        # 2**n ways when what follows fails to match, so a file ending in 40 blanks
        # took days.  Here each comment takes the separators after it, and a
        # separator run cannot follow a separator run.
        sep, comment = rx["SEPARATOR"], rx["COMMENT"]
        if set(lexer_conf.ignore) != {"SEPARATOR", "COMMENT"}:
            raise AssertionError("the VRML grammar ignores SEPARATOR and COMMENT only")
        # Atomic groups and possessive repeats besides: no backtracking entry is kept per
        # comment line (100,000 comment lines cost 130 MB before).
        skip = f"(?:(?>{sep}))?+(?:(?>{comment})(?:(?>{sep}))?+)*+"
        punct = "|".join(re.escape(p) for p in sorted(self.punct, key=len, reverse=True))
        self.skip_re = re.compile(skip)
        self.master = re.compile(
            f"{skip}(?:(?P<ID>{rx['ID']})|(?P<NUMBERS>{rx['NUMBERS']})|(?P<STRING>{rx['STRING']})"
            f"|(?P<P>{punct}))", re.S)
        gi = self.master.groupindex
        self.groups = (gi["ID"], gi["NUMBERS"], gi["STRING"], gi["P"])
        # The lenient reader's numbers also take a "nan" word (any case, not followed by
        # more of a name), tried before names: only a run starting with nan can be both.
        core = r"(?:0[xX][0-9a-fA-F]+|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
        if rx["NUMBERS"].count(core) != 2:
            raise AssertionError("the grammar's NUMBERS changed: update the lenient nan")
        word_end = r"(?![^\x00-\x20\x22\x23\x27\x2c\x2e\x5b\x5c\x5d\x7b\x7d\x7f])"
        loose = rx["NUMBERS"].replace(core, core[:-1] + f"|[nN][aA][nN]{word_end})")
        self.master_lenient = re.compile(
            f"{skip}(?:(?P<NUMBERS>{loose})|(?P<ID>{rx['ID']})|(?P<STRING>{rx['STRING']})"
            f"|(?P<P>{punct}))", re.S)
        gl = self.master_lenient.groupindex
        self.groups_lenient = (gl["ID"], gl["NUMBERS"], gl["STRING"], gl["P"])
        # A bracketed run of plain numbers: checked with one character class, the
        # cheapest scan there is, then given to numpy whole.
        self.run_re = re.compile(r"[0-9eE+\-.,\s]*")
        self.words: dict = {}

    def word_type(self, word: str) -> str:
        if not word.isascii() and _SURROGATE_RE.search(word):
            return "ID"  # not cached: the lexer reports it
        for name, rx in self.word_terminals:
            if rx.fullmatch(word):
                break
        else:
            name = sys.intern("ID")
        if len(self.words) < 100_000:
            self.words[word] = name
        return name

    @staticmethod
    def named_nan(text: str, m, prev: str) -> bool:
        """Whether a "nan" the lenient lexer took for a number is a name: after DEF, USE,
        ROUTE, TO, IS, (EXTERN)PROTO or a field type, or before "{" or "."."""
        if prev in _NAME_BEFORE or prev[:2] in ("SF", "MF"):
            return True
        after = m.start(m.lastindex) + 3
        while after < len(text) and text[after] in " \t\r\n,":
            after += 1
        return text[after:after + 1] in ("{", ".")

    def lex(self, text: str):
        lenient = not self.current_source_strict
        match = (self.master_lenient if lenient else self.master).match
        run_match = self.run_re.match
        words = self.words
        punct = self.punct
        tok = _Tok
        g_id, g_num, g_str, g_p = self.groups_lenient if lenient else self.groups
        pos = 0
        prev = ""
        while True:
            m = match(text, pos)
            if m is None:
                break
            i = m.lastindex
            is_id = i == g_id
            if lenient:
                if i == g_num and text[m.start(i)] in "nN" and self.named_nan(text, m, prev):
                    m = self.master.match(text, pos)   # a name after all: DEF nan, USE nan
                    i, is_id = self.groups[0], True
                prev = m.group(i) if is_id else ""
            start = m.start(i)
            pos = m.end()
            if is_id:
                v = m.group(i)
                kind = words.get(v)
                if kind is None:
                    kind = self.word_type(v)
                    if not v.isascii() and _SURROGATE_RE.search(v):
                        bad = start + _SURROGATE_RE.search(v).start()
                        raise self.current_source.error(
                            f"invalid UTF-8 (byte 0x{ord(text[bad]) - 0xDC00:02X}) in a name; "
                            "VRML97 files are UTF-8", bad)
                yield tok(kind, v, start, pos)
            elif i == g_num:
                yield tok("NUMBERS", "", start, pos)
            elif i == g_str:
                yield tok("STRING", m.group(i), start, pos)
            else:
                v = m.group(i)
                yield tok(punct[v], v, start, pos)
                if v == "[":
                    r = run_match(text, pos)
                    end = r.end()
                    if end - pos > 16 and text[end:end + 1] == "]":
                        stripped = self.skip_re.match(text, pos).end()
                        last = end
                        while last > stripped and text[last - 1] in " \t\r\n,":
                            last -= 1
                        if stripped < last:
                            yield tok("NUMBERS", "", stripped, last)
                        pos = end
        end = self.skip_re.match(text, pos).end()
        if end < len(text):
            src = self.current_source
            c = text[end]
            if "\udc80" <= c <= "\udcff":
                raise src.error(f"invalid UTF-8 (byte 0x{ord(c) - 0xDC00:02X}); VRML97 files "
                                "are UTF-8", end)
            if c == '"':
                raise src.error("string not closed: a '\"' has no closing quote", end)
            raise src.error(f"unexpected character {c!r}", end)


# -- building the scene -----------------------------------------------------------------

class _MF(list):
    """The items of a bracketed value, with the offset of its '['."""

    __slots__ = ("pos",)


class _Scope:
    """File or PROTO-body scope: its PROTO types and DEF names."""

    __slots__ = ("parent", "proto", "protos", "defs", "defaults")

    def __init__(self, parent: Optional["_Scope"], proto, defaults: bool = False):
        self.parent = parent
        self.proto = proto
        self.protos: dict = {}
        self.defs: dict = {}
        #: a PROTO interface: each field's default value is a DEF/USE scope of its own
        self.defaults = defaults

    def lookup_type(self, name: str):
        s = self
        while s is not None:
            t = s.protos.get(name)
            if t is not None:
                return t
            s = s.parent
        return None


_IS_RULES = {  # node side kind -> PROTO interface kinds it may be bound to (VRML97 4.8.3)
    "inout": ("exposedField", "field", "eventIn", "eventOut"),
    "field": ("field",),
    "in": ("eventIn",),
    "out": ("eventOut",),
}


_FLOAT_MAX = float(np.finfo(np.float64).max)


def _lenient_is(node_kind: str, proto_kind: str) -> bool:
    """Whether the lenient reader keeps an IS that VRML97's table (4.8.3) forbids: a
    field or an event bound to an exposedField, which X3D allows (its table is VRML97's
    with these added; an exposedField carries a value and both events); any other
    mismatch means nothing and stays an error."""
    return proto_kind == "exposedField" and node_kind != "exposedField"


def _implicit_clash(d, declared: dict) -> Optional[str]:
    """Why ``d`` may not join the interface ``declared`` (name -> declaration), or None:
    ``exposedField foo`` declares ``eventIn set_foo`` and ``eventOut foo_changed`` as well
    (VRML97 4.7), and a node type's interface names are unique.

    >>> from types import SimpleNamespace as D
    >>> _implicit_clash(D(kind="eventIn", name="set_size"), {"size": D(kind="exposedField")})
    'its exposedField size already declares eventIn set_size'
    """
    if d.kind == "exposedField":
        for kind, name in (("eventIn", f"set_{d.name}"), ("eventOut", f"{d.name}_changed")):
            if name in declared:
                return f"that declares {kind} {name}, which is already declared"
        return None
    for base in ((d.name[4:],) if d.name.startswith("set_") else ()) + \
            ((d.name[:-8],) if d.name.endswith("_changed") else ()):
        other = declared.get(base)
        if other is not None and other.kind == "exposedField":
            return f"its exposedField {base} already declares {d.kind} {d.name}"
    return None


def _kind_text(ftype: FieldType) -> str:
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


class _Builder:
    """The transformer: one method per grammar rule, called as lark reduces it."""

    Node = Proto = ExternProto = Route = Scene = RawValue = type("_Unbound", (), {})

    def __init__(self):
        self.bound = False
        self.reset(Source(""), True)

    def bind(self) -> None:
        """Import the scene graph and catalogue (not at import: they need parse_value)."""
        from .catalogue import NODE_TYPES
        from .scene import ExternProto, Node, Proto, RawValue, Route, Scene
        self.NODE_TYPES = NODE_TYPES
        self.SCRIPT = NODE_TYPES["Script"]
        self.Node, self.Proto, self.ExternProto = Node, Proto, ExternProto
        self.Route, self.Scene, self.RawValue = Route, Scene, RawValue
        self.bound = True

    def reset(self, source: Source, strict: bool) -> None:
        self.src = source
        self.text = source.text
        self.strict = strict
        self.scope = _Scope(None, None)
        self.frames: list = []
        self.warned: set = set()
        self.pending_def = None
        self.open_defs: set = set()   # ids of DEF'd nodes whose bodies are being read

    # -- helpers --------------------------------------------------------------------------
    def err(self, message: str, pos: Optional[int], expected=()) -> VRMLError:
        return self.src.error(message, pos, expected)

    def warn(self, key: str, message: str, pos: int) -> None:
        if key in self.warned:
            return
        self.warned.add(key)
        e = self.src.error(message, pos)
        warnings.warn(str(e), VRMLWarning, stacklevel=2)

    def pos_of(self, value) -> Optional[int]:
        if isinstance(value, _Tok):
            return value.start_pos
        if isinstance(value, self.Node):
            return value._pos
        return getattr(value, "pos", None)

    def numbers(self, tok: _Tok, integer: bool) -> np.ndarray:
        try:
            out = parse_numbers(self.text, tok.start_pos, tok.end_pos, integer,
                                allow_nan=not self.strict)
        except NumberError as e:
            raise self.err(e.message, e.offset) from None
        if not integer and not self.strict and np.isnan(out).any():
            at = _NAN_WORD_RE.search(self.text, tok.start_pos, tok.end_pos)
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
        if isinstance(value, _Tok):
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
                    after = _NEXT_WORD_RE.match(text, end)
                    if after and _NAN_WORD_RE.fullmatch(after.group(1)):
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
                           [_kind_text(ftype)])
        if isinstance(value, self.Node):
            if kind == "node":
                self.check_class(value, d, self.where(owner, name), value._pos)
                return [value] if ftype.mf else value
            raise self.err(f"{self.where(owner, name)} is {ftype.name}: found a {value.type} node", value._pos,
                           [_kind_text(ftype)])
        # a bracketed list
        if not ftype.mf:
            raise self.err(f"{self.where(owner, name)} is {ftype.name}, a single value: brackets are for MF fields",
                           value.pos, [_kind_text(ftype)])
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
                if not (isinstance(item, _Tok) and item.type == "STRING"):
                    raise self.err(f"{self.where(owner, name)} is MFString: found {self.describe(item)}",
                                   self.pos_of(item), ["strings"])
                out.append(unquote_string(item.value))
            return out
        arrays = []
        for item in value:
            if not (isinstance(item, _Tok) and item.type == "NUMBERS"):
                raise self.err(f"{self.where(owner, name)} is {ftype.name}: found {self.describe(item)}",
                               self.pos_of(item), [_kind_text(ftype)])
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
            if isinstance(x, _Tok):
                if x.type == "NUMBERS":
                    return self.text[x.start_pos:x.end_pos]
                return x.value
            return x
        if isinstance(value, _MF):
            return self.RawValue([item(x) for x in value], True)
        return self.RawValue([item(value)], False)

    def unknown_field(self, node, name: str, pos: int) -> VRMLError:
        names = list(node.decl.fields) + [d.name for d in node.interface]
        close = difflib.get_close_matches(name, names, n=3)
        return self.err(f"{node.type} has no field {name!r}", pos,
                        [repr(c) for c in close] if close else ())

    def node_event(self, node, name: str):
        for d in node._interface or ():
            if d.name == name:
                return d, {"eventIn": "in", "eventOut": "out", "field": "field",
                           "exposedField": "inout"}[d.kind]
        return node.decl.event(name)

    # -- rules ----------------------------------------------------------------------------
    def start(self, items):
        statements = [s for s in items if s is not None]
        for s in statements:
            if isinstance(s, self.Node) and s.decl is not None:
                classes = s.classes
                if classes is not None and "child" not in classes:
                    message = f"a {s.type} node can't be a root node of a file"
                    if self.strict:
                        raise self.err(message, s._pos, [
                            "a grouping, shape, sensor, light, interpolator, bindable or "
                            "Script node"])
                    self.warn("root:" + s.type, message + "; kept", s._pos)
        return self.Scene(statements)

    def node_head(self, items):
        tok = items[0]
        name = tok.value
        decl = self.scope.lookup_type(name) or self.NODE_TYPES.get(name)
        if decl is None:
            if name in _X3D_WORDS:
                raise self.err(f"{name} is X3D, not VRML97", tok.start_pos)
            if self.strict:
                close = difflib.get_close_matches(
                    name, list(self.NODE_TYPES) + self.visible_protos(), n=3)
                raise self.err(f"unknown node type {name!r}", tok.start_pos,
                               [repr(c) for c in close] if close else ())
            self.warn("node:" + name, f"{name} is not a VRML97 node type; kept as a generic node",
                      tok.start_pos)
        if decl is not None and decl.name == name:
            name = decl.name            # one string for all nodes of a type, not one each
        node = self.Node._raw(name, decl, self.src, tok.start_pos)
        if self.pending_def is not None:
            node.name = self.pending_def.value
            self.scope.defs[node.name] = node
            self.open_defs.add(id(node))
            self.pending_def = None
        self.frames.append(node)
        return node

    def visible_protos(self) -> list:
        out, s = [], self.scope
        while s is not None:
            out.extend(s.protos)
            s = s.parent
        return out

    def node(self, items):
        node = items[0]
        self.frames.pop()
        for s in items[1:]:
            if s is not None:
                node.statements.append(s)
        return node

    def field(self, items):
        tok, value = items
        node = self.frames[-1]
        name = tok.value
        if node.decl is None:
            node.fields[name] = self.raw(value)
            return None
        d = node.decl.fields.get(name) if not node._interface else None
        if d is None:
            d = node.field_decl(name)          # an alias, or a Script's own field
        if d is None:
            if self.strict:
                raise self.unknown_field(node, name, tok.start_pos)
            self.warn(f"field:{node.type}.{name}",
                      f"{node.type} has no field {name!r}; kept as written", tok.start_pos)
            node.fields[name] = self.raw(value)
            return None
        if d.kind != "field" and d.kind != "exposedField":
            raise self.err(f"{node.type}.{name} is an {d.kind}: it can't be given a value",
                           tok.start_pos, ["a field or exposedField"])
        if d.origin is not None or (d.name != name and name in node.decl.alias_origin):
            self.warn(f"x3d:{node.type}.{name}", f"{node.type}.{name} is an X3D field, not "
                      "VRML97; accepted" + (f" as {d.name}" if d.name != name else ""),
                      tok.start_pos)
        node.fields[d.name] = self.convert(d, value, node.type, name)
        return None

    def is_field(self, items):
        tok, _, ptok = items
        node = self.frames[-1]
        proto = self.scope.proto
        if proto is None:
            raise self.err("IS is only allowed inside a PROTO body", tok.start_pos)
        pd = proto.fields.get(ptok.value)
        if pd is None:
            close = difflib.get_close_matches(ptok.value, list(proto.fields), n=3)
            raise self.err(f"PROTO {proto.name} has no field {ptok.value!r} to bind with IS",
                           ptok.start_pos, [repr(c) for c in close])
        if node.decl is not None:
            ev = self.node_event(node, tok.value)
            if ev is None:
                raise self.unknown_field(node, tok.value, tok.start_pos)
            self.check_is(node, tok, ev, pd, ptok)
        node.is_map[tok.value] = ptok.value
        return None

    def check_is(self, node, tok, ev, pd, ptok) -> None:
        d, direction = ev
        if d.type is not pd.type:
            raise self.err(f"{node.type}.{tok.value} is {d.type.name} but PROTO field "
                           f"{pd.name} is {pd.type.name}", ptok.start_pos, [d.type.name])
        if pd.kind not in _IS_RULES[direction]:
            message = (f"{node.type}.{tok.value} ({d.kind}) can't be bound with IS to "
                       f"{pd.kind} {pd.name}")
            if self.strict or not _lenient_is(d.kind, pd.kind):
                raise self.err(message, ptok.start_pos, [" or ".join(_IS_RULES[direction])])
            # seen in robot worlds: Box { size IS size } with an exposedField size
            self.warn(f"is:{node.type}.{tok.value}:{pd.name}", message + " in VRML97; kept",
                      ptok.start_pos)

    def decl_common(self, kind_tok, type_tok, name_tok):
        ftype = FIELD_TYPES.get(type_tok.value)
        if ftype is None:
            close = difflib.get_close_matches(type_tok.value, list(FIELD_TYPES), n=3)
            raise self.err(f"unknown field type {type_tok.value!r}", type_tok.start_pos,
                           [repr(c) for c in close] or ["a VRML97 field type"])
        from .catalogue import FieldDecl
        target = self.frames[-1]
        d = FieldDecl(kind_tok.value, ftype, name_tok.value, ftype.empty(), None,
                      kind_tok.start_pos)
        if isinstance(target, self.Node):
            if target.decl is not self.SCRIPT and target.decl is not None:
                raise self.err(f"interface declarations are only allowed in Script nodes, "
                               f"not in {target.type}", kind_tok.start_pos)
            if d.kind == "exposedField":
                raise self.err("a Script can't have an exposedField in VRML97",
                               kind_tok.start_pos, ["eventIn, eventOut or field"])
            old = target.field_decl(d.name)
            if old is not None:
                if old in target.interface and (old.kind, old.type) == (d.kind, d.type) \
                        and not d.has_value:
                    # Seen in the wild: the same event declared twice.  Harmless; keep one.
                    self.warn(f"dup:{d.name}", f"Script declares {d.kind} {d.name} twice; "
                              "the repeat is ignored", name_tok.start_pos)
                    return old, None
                raise self.err(f"Script already has a field or event named {d.name!r}",
                               name_tok.start_pos)
            target.interface.append(d)
        else:
            if d.name in target.fields:
                raise self.err(f"{target.name} already declares {d.name!r}", name_tok.start_pos)
            clash = _implicit_clash(d, target.fields)
            if clash is not None:
                raise self.err(f"{target.name} declares {d.kind} {d.name}, but {clash}",
                               name_tok.start_pos, ["an interface name of its own"])
            target.fields[d.name] = d
        return d, target

    def event_decl(self, items):
        self.decl_common(*items)
        return None

    def field_decl(self, items):
        kind_tok, type_tok, name_tok, value = items
        d, target = self.decl_common(kind_tok, type_tok, name_tok)
        owner = target.type if isinstance(target, self.Node) else target.name
        d.default = self.convert(d, value, owner, d.name, extra_ok=True)
        if self.scope.defaults:
            self.scope.defs = {}
        return None

    def is_decl(self, items):
        kind_tok, type_tok, name_tok, _, ptok = items
        d, node = self.decl_common(kind_tok, type_tok, name_tok)
        if node is None:
            raise self.err(f"Script already has a field or event named {d.name!r}",
                           name_tok.start_pos)
        proto = self.scope.proto
        if proto is None:
            raise self.err("IS is only allowed inside a PROTO body", name_tok.start_pos)
        pd = proto.fields.get(ptok.value)
        if pd is None:
            raise self.err(f"PROTO {proto.name} has no field {ptok.value!r} to bind with IS",
                           ptok.start_pos, [repr(c) for c in proto.fields])
        direction = {"eventIn": "in", "eventOut": "out", "field": "field"}[d.kind]
        self.check_is(node, name_tok, (d, direction), pd, ptok)
        node.is_map[d.name] = pd.name
        return None

    def extern_decl(self, items):
        kind_tok, type_tok, name_tok = items
        self.decl_common(kind_tok, type_tok, name_tok)
        return None

    def mfvalue(self, items):
        out = _MF(items[1:])
        out.pos = items[0].start_pos
        return out

    def def_head(self, items):
        # Reduced before the node's type is read: node_head binds the name at once, so
        # that a USE inside the node's own body is recognised as a cycle.
        self.pending_def = items[0]
        return items[0]

    def def_node(self, items):
        tok, node = items
        self.open_defs.discard(id(node))
        return node

    def use_node(self, items):
        tok = items[0]
        node = self.scope.defs.get(tok.value)
        if node is None:
            close = difflib.get_close_matches(tok.value, list(self.scope.defs), n=3)
            where = " in this PROTO body" if self.scope.proto is not None else ""
            if self.scope.defaults:
                where = (" in this field's default value (each PROTO field's default is a "
                         "DEF/USE scope of its own)")
            raise self.err(f"USE {tok.value}: no node was DEF'd as {tok.value!r} before{where}",
                           tok.start_pos, [repr(c) for c in close])
        if id(node) in self.open_defs and not self.through_script(node):
            message = f"USE {tok.value} inside the node DEF'd as {tok.value} makes it its own ancestor"
            if self.strict:
                raise self.err(message, tok.start_pos)
            self.warn("cycle:" + tok.value, message + "; kept", tok.start_pos)
        return node

    def through_script(self, node) -> bool:
        """Whether a USE of the open ``node`` here reaches it through a Script's field: a
        Script's SFNode and MFNode fields are references, not the transformation
        hierarchy that may have no cycles (VRML97 4.4.2, 6.40), so the Script itself or
        a node holding it may be named there."""
        frames = self.frames
        for i in range(len(frames) - 1, -1, -1):
            f = frames[i]
            if getattr(f, "decl", None) is self.SCRIPT:
                return any(g is node for g in frames[:i + 1])
            if f is node:
                return False
        return False

    def route(self, items):
        fn, ff, _, tn, tf = items
        ends = []
        for ntok, ftok, want in ((fn, ff, "out"), (tn, tf, "in")):
            node = self.scope.defs.get(ntok.value)
            if node is None:
                raise self.err(f"ROUTE names {ntok.value!r}, which no DEF before it defines",
                               ntok.start_pos, [repr(c) for c in difflib.get_close_matches(
                                   ntok.value, list(self.scope.defs), n=3)])
            ev = None
            if node.decl is not None:
                ev = self.node_event(node, ftok.value)
                if ev is None:
                    raise self.err(f"{node.type} {ntok.value} has no event {ftok.value!r}",
                                   ftok.start_pos)
                d, direction = ev
                if direction != want and direction != "inout":
                    word = "eventOut" if want == "out" else "eventIn"
                    what = {"in": "eventIn", "out": "eventOut", "field": "field"}[direction]
                    what += "" if d.kind != "exposedField" else " of an exposedField"
                    raise self.err(f"ROUTE {'from' if want == 'out' else 'to'} "
                                   f"{ntok.value}.{ftok.value}, which is an {what}",
                                   ftok.start_pos, [f"an {word} or exposedField"])
            ends.append((node, ev))
        (a, ea), (b, eb) = ends
        if ea is not None and eb is not None and ea[0].type is not eb[0].type:
            raise self.err(f"ROUTE from {ea[0].type.name} {fn.value}.{ff.value} to "
                           f"{eb[0].type.name} {tn.value}.{tf.value}: the types differ",
                           tf.start_pos, [ea[0].type.name])
        r = self.Route(a, ff.value, b, tf.value)
        r._source, r._pos = self.src, fn.start_pos
        return r

    def proto_head(self, items):
        proto = self.open_declaration(self.Proto, items[0])
        self.scope = _Scope(self.scope, None, defaults=True)
        return proto

    def open_declaration(self, cls, tok):
        """A PROTO or EXTERNPROTO whose interface is about to be read."""
        p = cls(tok.value)
        p._source, p._pos = self.src, tok.start_pos
        self.frames.append(p)
        return p

    def proto_body_start(self, items):
        proto = self.frames.pop()
        self.scope = _Scope(self.scope.parent, proto)       # the interface's scope ends
        return None

    def proto(self, items):
        proto = items[0]
        proto.body = [s for s in items[1:] if s is not None]
        self.scope = self.scope.parent
        if not any(isinstance(s, self.Node) for s in proto.body):
            raise self.err(f"PROTO {proto.name} has no node in its body", proto._pos,
                           ["at least one node"])
        self.scope.protos[proto.name] = proto
        return proto

    def externproto_head(self, items):
        return self.open_declaration(self.ExternProto, items[0])

    def externproto(self, items):
        proto = items[0]
        urls = items[-1]
        self.frames.pop()
        if isinstance(urls, _Tok):
            proto.urls = [unquote_string(urls.value)]
        else:
            bad = [u for u in urls if not (isinstance(u, _Tok) and u.type == "STRING")]
            if bad:
                raise self.err("EXTERNPROTO URLs must be strings", self.pos_of(bad[0]),
                               ["a string"])
            proto.urls = [unquote_string(u.value) for u in urls]
        self.scope.protos[proto.name] = proto
        return proto


# -- the parser -------------------------------------------------------------------------

_lock = threading.RLock()
_parser: Optional[Lark] = None
_builder: Optional[_Builder] = None


def _cache_file() -> Optional[str]:
    """Where lark keeps the parser's tables between processes (building them costs a
    fresh process ~0.05 s; loading them ~0.01 s): ``$MPEG4FBA_CACHE`` (a folder; empty,
    ``0`` or ``off``: no cache), else ``$XDG_CACHE_HOME/mpeg4fba``, else
    ``~/.cache/mpeg4fba``.  lark checks the file against the grammar, lark's and
    Python's versions, and rebuilds (and rewrites) it on any mismatch or damage; a
    folder that can't be made or written means no cache, never an error."""
    where = os.environ.get("MPEG4FBA_CACHE")
    if where is not None and where.strip().lower() in ("", "0", "off", "no", "false"):
        return None
    try:
        if where:
            base = Path(where)
        else:
            base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mpeg4fba"
        base.mkdir(mode=0o700, parents=True, exist_ok=True)
    except (OSError, RuntimeError):           # RuntimeError: no home folder
        return None
    import lark
    return str(base / f"vrml97-tables-lark{lark.__version__}.cache")


def _get_parser():
    global _parser, _builder
    if _parser is None:
        builder = _Builder()
        parser = Lark(_grammar_text(), parser="lalr", lexer=_FastLexer, transformer=builder,
                      maybe_placeholders=False, cache=_cache_file() or False)
        _direct_callbacks(parser, builder)
        _parser, _builder = parser, builder
    return _parser, _builder


_driver: Optional[tuple] = None
_lexer: Optional[_FastLexer] = None


def _shared_lexer(parser: Lark) -> _FastLexer:
    """One lexer for :func:`_parse` and :func:`parse_value` (its regexes compiled once)."""
    global _lexer
    if _lexer is None:
        _lexer = _FastLexer(parser.lexer_conf)
    return _lexer


def _parse(parser: Lark, text: str):
    """``parser.parse(text)`` by a loop of our own over lark's LALR table (built from
    the grammar, as ever): lark's generic loop re-reads its configuration, compares
    symbols through ``__eq__`` and asserts on every token.  Same results, same errors
    (``tests/test_vrml_reader.py`` compares the two on generated scenes); if lark's
    internals ever differ, lark's own loop runs."""
    global _driver
    if _driver is None:
        try:
            inner = parser.parser.parser.parser
            table = inner.parse_table
            start, end = table.start_states["start"], table.end_states["start"]
            callbacks = inner.callbacks
            from lark.parsers.lalr_analysis import Shift
        except (AttributeError, KeyError, ImportError):
            _driver = ()
        else:
            steps = {}
            for state, actions in table.states.items():
                row = {}
                for term, (action, arg) in actions.items():
                    if action is Shift:
                        row[term] = (True, arg)
                    else:
                        row[term] = (False, (len(arg.expansion), sys.intern(str(arg.origin.name)),
                                             callbacks[arg]))
                steps[state] = row
            _driver = (steps, start, end, _shared_lexer(parser))
    if not _driver:
        return parser.parse(text)
    steps, start, end, lexer = _driver
    state_stack = [start]
    value_stack: list = []
    push_state, push_value = state_stack.append, value_stack.append

    def feed(token, last: bool):
        while True:
            try:
                shift, arg = steps[state_stack[-1]][token.type]
            except KeyError:
                expected = {t for t in steps[state_stack[-1]] if t.isupper()}
                raise UnexpectedToken(token, expected) from None
            if shift:
                push_state(arg)
                push_value(token)
                return None
            size, name, callback = arg
            if size:
                children = value_stack[-size:]
                del state_stack[-size:]
                del value_stack[-size:]
            else:
                children = []
            value = callback(children)
            push_state(steps[state_stack[-1]][name][1])
            push_value(value)
            if last and state_stack[-1] == end:
                return value_stack[-1]

    # feed()'s loop again, inlined: a call per token costs more than the loop itself
    for token in lexer.lex(text):
        ttype = token.type
        while True:
            step = steps[state_stack[-1]].get(ttype)
            if step is None:
                feed(token, False)                  # raises UnexpectedToken
            if step[0]:
                push_state(step[1])
                push_value(token)
                break
            size, name, callback = step[1]
            if size:
                children = value_stack[-size:]
                del state_stack[-size:]
                del value_stack[-size:]
            else:
                children = []
            push_value(callback(children))
            push_state(steps[state_stack[-1]][name][1])
    return feed(_Tok("$END", "", len(text), len(text)), True)


class _Splice(list):
    """Children of an inlined repetition (lark's ``x*``), spliced into the parent."""

    __slots__ = ()


def _direct_callbacks(parser: Lark, builder: _Builder) -> None:
    """Give lark's LALR loop plain callbacks, precomputed per rule.

    lark wraps each rule's callback in generic child filters and builds a Tree for
    every inlined rule; here each rule gets a closure that picks its children by
    precomputed positions, and the parse table is keyed by interned strings so that
    its lookups never fall back to Python-level ``__eq__``.  Same results, about half
    the time per token.  If lark's internals ever differ, lark's own callbacks stay.
    """
    try:
        inner = parser.parser.parser.parser
        table = inner.parse_table
        rules = list(inner.callbacks)
    except AttributeError:
        return
    intern = sys.intern
    table.states = {state: {intern(str(k)): v for k, v in actions.items()}
                    for state, actions in table.states.items()}
    callbacks = {}
    for rule in rules:
        if not hasattr(rule, "origin"):
            continue
        rule.origin.name = name = intern(str(rule.origin.name))
        expansion = rule.expansion
        plan = []
        for i, sym in enumerate(expansion):
            if sym.is_term:
                if not getattr(sym, "filter_out", False):
                    plan.append((i, False))
            else:
                plan.append((i, str(sym.name).startswith("__")))
        callbacks[rule] = _make_callback(name, expansion, plan, builder)
    inner.callbacks = callbacks


def _make_callback(name: str, expansion, plan: list, builder: _Builder):
    if name.startswith("__"):  # a repetition: x | self x
        if expansion and expansion[0].name == name:
            def grow(children):
                acc = children[0]
                acc.extend(children[1:])
                return acc
            return grow
        return _Splice
    if name.startswith("_"):  # an inlined alternative: pass its one child through
        index = plan[0][0] if plan else 0
        return lambda children: children[index]
    method = getattr(builder, name)
    if all(not splice for _, splice in plan):
        indices = [i for i, _ in plan]
        if indices == list(range(len(expansion))):
            return method
        return lambda children: method([children[i] for i in indices])

    def call(children):
        items = []
        for i, splice in plan:
            if splice:
                items.extend(children[i])
            else:
                items.append(children[i])
        return method(items)
    return call


def is_name(text: str) -> bool:
    """Whether ``text`` is a VRML97 name (the grammar's ID, and not a keyword).

    >>> is_name("Head_1"), is_name("1st"), is_name("a.b"), is_name("PROTO")
    (True, False, False, False)
    """
    parser, _ = _get_parser()
    lexer = parser.parser.lexer
    lexer = getattr(lexer, "lexer", lexer)  # lark wraps interface-0 lexers
    m = lexer.master.fullmatch(text)
    return (m is not None and m.lastgroup == "ID" and m.start("ID") == 0
            and lexer.word_type(text) in _NAME_TERMINALS)


# What the grammar takes as a DEF/USE name (rule def_head): ID, and two keywords.
_NAME_TERMINALS = ("ID", "IS", "TO")


def _syntax_error(src: Source, e: UnexpectedInput) -> VRMLError:
    tok = getattr(e, "token", None)
    expected = sorted(getattr(e, "expected", ()) or ())
    names = []
    for t in expected:
        n = _TOKEN_NAMES.get(t)
        if n is None:
            lit = _literal_of(t)
            n = repr(lit) if lit else t
        if n not in names:
            names.append(n)
    if tok is None or tok.type == "$END":
        return src.error("unexpected end of file", len(src.text), names)
    pos = tok.start_pos
    if tok.type == "NUMBERS":
        what = "number " + repr(src.text[pos:tok.end_pos][:20])
    elif tok.type == "ID":
        what = f"name {tok.value!r}"
    else:
        what = repr(tok.value)
    prev = re.findall(r"[^\s\[\]{}.,#\"']+", src.text[max(0, pos - 64):pos])
    if prev and prev[-1] in _X3D_WORDS:
        return src.error(f"{prev[-1]} is X3D, not VRML97", pos - len(prev[-1]) - 1)
    if prev and _NAN_WORD_RE.fullmatch(prev[-1].lstrip("+-")):
        at = src.text.rfind(prev[-1], 0, pos)
        return src.error(f"{prev[-1]} is not a VRML97 number (the lenient reader, "
                         "strict=False or --lenient, keeps it with a warning)", at)
    return src.error(f"unexpected {what}", pos, names)


def _literal_of(terminal: str) -> Optional[str]:
    parser, _ = _get_parser()
    for t in parser.terminals:
        if t.name == terminal and t.pattern.type == "str":
            return t.pattern.value
    return None


def loads(text: str, strict: bool = True, path: Optional[str] = None,
          require_header: bool = True):
    """Read VRML97 text into a :class:`Scene`.

    ``strict=False`` keeps nodes and fields that are not VRML97 as generic ones (with a
    :class:`VRMLWarning` once per kind) instead of rejecting them.  Raises
    :class:`VRMLError` with the line and column of the first problem.

    >>> len(loads("#VRML V2.0 utf8\\nGroup { children [ Shape {} Shape {} ] }").nodes)
    1
    """
    if text.startswith("\ufeff"):
        text = text[1:]
    src = Source(text, str(path) if path is not None else None)
    if require_header:
        if not _HEADER_RE.match(text):
            first = text.split("\n", 1)[0][:40].rstrip("\r")
            if first.startswith("#VRML V1.0"):
                raise src.error("VRML 1.0 is not supported; this reader reads VRML97 (V2.0)", 0)
            if first.startswith("#X3D"):
                raise src.error("this is X3D classic encoding, not VRML97", 0)
            if strict:
                raise src.error(f"missing VRML97 header, found {first!r}", 0,
                                ["'#VRML V2.0 utf8'"])
            # Inline fragments and hand-edited files: read as VRML97 all the same
            late = _LATE_HEADER_RE.search(text)
            message = ("the VRML97 header is not on the first line but here; read as VRML97"
                       if late else "no VRML97 header ('#VRML V2.0 utf8'); read as VRML97")
            warnings.warn(str(src.error(message, late.start() if late else 0)), VRMLWarning,
                          stacklevel=2)
    with _lock:
        parser, builder = _get_parser()
        if not builder.bound:
            builder.bind()
        builder.reset(src, strict)
        _FastLexer.current_source = src
        _FastLexer.current_source_strict = bool(strict)
        # A parse makes a few objects per token and frees almost none, so the cyclic
        # collector would run often and walk everything the program holds, for
        # nothing: the scene graph has no cycles to collect until the parse is over.
        collecting = gc.isenabled()
        gc.disable()
        try:
            scene = _parse(parser, text)
        except VRMLError:
            raise
        except VisitError as e:  # lark wraps errors raised in callbacks on some paths
            if isinstance(e.orig_exc, VRMLError):
                raise e.orig_exc from None
            raise
        except UnexpectedInput as e:
            raise _syntax_error(src, e) from None
        finally:
            if collecting:
                gc.enable()
            builder.reset(Source(""), True)
            _FastLexer.current_source = None
            _FastLexer.current_source_strict = True
    scene.path = src.path
    if len(text) > _COMPACT_ABOVE:
        src.compact()
    return scene


def _decode(data: bytes, path: Optional[str]) -> str:
    """UTF-8 text of a file.  Invalid bytes inside strings and comments are kept
    byte-exactly (as surrogate escapes, written back unchanged) with a warning, since
    files in the wild put Latin-1 or Shift-JIS there; anywhere else they are an error.
    """
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        first = e.start
    text = data.decode("utf-8", "surrogateescape")
    line = data.count(b"\n", 0, first) + 1
    line_start = data.rfind(b"\n", 0, first) + 1
    column = len(data[line_start:first].decode("utf-8", "replace")) + 1
    warnings.warn(str(VRMLError(f"invalid UTF-8 (byte 0x{data[first]:02X}); bytes that are not "
                                "UTF-8 are kept as they are", path, line, column)),
                  VRMLWarning, stacklevel=3)
    return text


def read_bytes(path: Union[str, os.PathLike], max_inflated: Optional[int] = None,
               max_ratio: Optional[float] = None) -> Union[bytes, bytearray]:
    """The bytes of a VRML file, gunzipped (under bounds, see
    :mod:`mpeg4fba.vrml.inflate`) when they start with gzip's magic bytes."""
    return read_maybe_gzipped(path, max_inflated, max_ratio)


def load(path: Union[str, os.PathLike], strict: bool = True, *,
         max_inflated: Optional[int] = None, max_ratio: Optional[float] = None):
    """Read a VRML97 file (plain or gzip-compressed, by its magic bytes) into a Scene.

    Gzip data may inflate to at most ``max_inflated`` bytes and ``max_ratio`` times its
    compressed size (None: the limits in force, by default 2 GiB and 1000 above 16 MiB;
    see :mod:`mpeg4fba.vrml.inflate`); past them reading stops with a VRMLError.

    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "a.wrl")
    >>> _ = open(p, "w").write("#VRML V2.0 utf8\\nShape { geometry Box {} }")
    >>> load(p).nodes[0].type
    'Shape'
    """
    data = read_bytes(path, max_inflated, max_ratio)
    head = data[3:80] if data.startswith(b"\xef\xbb\xbf") else data[:80]
    if not head.startswith(b"#"):
        # Say so before decoding: a binary or foreign file gets one clear line.
        shown = "".join(chr(b) if 32 <= b < 127 else f"\\x{b:02x}" for b in head[:24])
        raise VRMLError(f"not a VRML97 file: it starts with '{shown}', not '#VRML V2.0 utf8'",
                        str(path), 1, 1)
    text = _decode(data, str(path))
    del data  # the text is all we need from here: halves peak memory on big files
    return loads(text, strict=strict, path=str(path))


def parse_value(ftype: FieldType, text: str, where: str = "value") -> Any:
    """One field value of type ``ftype`` from its VRML text (no nodes), e.g. defaults.

    >>> parse_value(FIELD_TYPES["MFString"], '[ "WALK" "ANY" ]')
    ['WALK', 'ANY']
    """
    from .catalogue import FieldDecl
    parser, builder = _get_parser()
    lexer = _shared_lexer(parser)
    src = Source(text, where)
    with _lock:
        _FastLexer.current_source = src
        try:
            toks = list(lexer.lex(text))
        finally:
            _FastLexer.current_source = None
        if not toks:
            raise src.error("empty value", 0, [_kind_text(ftype)])
        if toks[0].type == "LSQB":
            if toks[-1].type != "RSQB":
                raise src.error("'[' not closed", len(text), ["']'"])
            value = _MF(toks[1:-1])
            value.pos = 0
        else:
            if len(toks) != 1:
                raise src.error("one value expected", toks[1].start_pos)
            value = toks[0]
        old = builder.src, builder.text
        builder.src, builder.text = src, text
        try:
            return builder.convert(FieldDecl("field", ftype, where), value, where)
        finally:
            builder.src, builder.text = old
