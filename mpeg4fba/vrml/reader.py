"""VRML97 text -> Scene: ``load(path)`` and ``loads(text)``.

The syntax is ``grammars/vrml97.lark``; lark's LALR parser drives it with the
builder (:mod:`~mpeg4fba.vrml.builder`) passed in as its transformer, so no parse tree
is ever built: each rule's callback types and checks what it reduces, knowing (through
the ``*_head`` rules) which node or PROTO it is in.  The lexer
(:mod:`~mpeg4fba.vrml.lexer`) is ours but its terminals are the grammar's: it compiles
them into one regular expression, adds nothing to them, and hands a bracketed run of
numbers to numpy as one token.  Here: the parser's loop, the entry points and the
syntax errors' wording.

Example
-------
>>> scene = loads('#VRML V2.0 utf8\\nDEF T Transform { translation 0 1 0 }')
>>> scene.find("T")["translation"]
(0.0, 1.0, 0.0)
"""
from __future__ import annotations

import gc
import os
import re
import sys
import threading
import warnings
from importlib import resources
from pathlib import Path
from typing import Any, Optional, Union

from lark import Lark
from lark.exceptions import UnexpectedInput, UnexpectedToken, VisitError

from .builder import MF, NAN_WORD_RE, X3D_WORDS, Builder, kind_text
from .errors import Source, VRMLError, VRMLWarning
from .fields import FieldType
from .inflate import read_maybe_gzipped
from .lexer import FastLexer, Tok

__all__ = ["load", "loads", "parse_value", "VRMLWarning"]


_COMPACT_ABOVE = 8 << 20  # chars: above this a Source keeps line starts, not the text
_HEADER_RE = re.compile(r"#VRML[ \t]+V2\.0[ \t]+utf8")
_LATE_HEADER_RE = re.compile(r"^[ \t]*#VRML[ \t]+V2\.0[ \t]+utf8", re.M)

# Where a token may name its kind in an error message.
_TOKEN_NAMES = {"ID": "a name", "NUMBERS": "a number", "STRING": "a string",
                "TRUE": "TRUE", "FALSE": "FALSE", "NULL": "NULL",
                "EVENT_KIND": "eventIn or eventOut", "FIELD_KIND": "field or exposedField",
                "$END": "the end of the file"}


def _grammar_text() -> str:
    """The grammar, from the package (wheel) or from the source tree's grammars/."""
    try:
        return resources.files("mpeg4fba.grammars").joinpath("vrml97.lark").read_text("utf-8")
    except (ModuleNotFoundError, FileNotFoundError, OSError):
        here = Path(__file__).resolve().parents[2] / "grammars" / "vrml97.lark"
        return here.read_text("utf-8")


# -- the parser -------------------------------------------------------------------------

_lock = threading.RLock()
_parser: Optional[Lark] = None
_builder: Optional[Builder] = None


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
        builder = Builder()
        parser = Lark(_grammar_text(), parser="lalr", lexer=FastLexer, transformer=builder,
                      maybe_placeholders=False, cache=_cache_file() or False)
        _direct_callbacks(parser, builder)
        _parser, _builder = parser, builder
    return _parser, _builder


_driver: Optional[tuple] = None
_lexer: Optional[FastLexer] = None


def _shared_lexer(parser: Lark) -> FastLexer:
    """One lexer for :func:`_parse` and :func:`parse_value` (its regexes compiled once)."""
    global _lexer
    if _lexer is None:
        _lexer = FastLexer(parser.lexer_conf)
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
    return feed(Tok("$END", "", len(text), len(text)), True)


class _Splice(list):
    """Children of an inlined repetition (lark's ``x*``), spliced into the parent."""

    __slots__ = ()


def _direct_callbacks(parser: Lark, builder: Builder) -> None:
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


def _make_callback(name: str, expansion, plan: list, builder: Builder):
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
    if prev and prev[-1] in X3D_WORDS:
        return src.error(f"{prev[-1]} is X3D, not VRML97", pos - len(prev[-1]) - 1)
    if prev and NAN_WORD_RE.fullmatch(prev[-1].lstrip("+-")):
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
        FastLexer.current_source = src
        FastLexer.current_source_strict = bool(strict)
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
            FastLexer.current_source = None
            FastLexer.current_source_strict = True
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

    >>> from mpeg4fba.vrml.fields import FIELD_TYPES
    >>> parse_value(FIELD_TYPES["MFString"], '[ "WALK" "ANY" ]')
    ['WALK', 'ANY']
    """
    from .catalogue import FieldDecl
    parser, builder = _get_parser()
    lexer = _shared_lexer(parser)
    src = Source(text, where)
    with _lock:
        FastLexer.current_source = src
        try:
            toks = list(lexer.lex(text))
        finally:
            FastLexer.current_source = None
        if not toks:
            raise src.error("empty value", 0, [kind_text(ftype)])
        if toks[0].type == "LSQB":
            if toks[-1].type != "RSQB":
                raise src.error("'[' not closed", len(text), ["']'"])
            value = MF(toks[1:-1])
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
