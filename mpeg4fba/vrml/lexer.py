"""The VRML97 reader's lexer: the grammar's own terminals (``grammars/vrml97.lark``)
compiled into one regular expression, nothing added to them, and a bracketed run of
numbers handed on as one token for numpy (:mod:`mpeg4fba.vrml.reader` drives it).

>>> from mpeg4fba.vrml.reader import loads
>>> scene = loads('#VRML V2.0 utf8\\nShape { geometry PointSet { coord DEF C Coordinate {'
...               ' point [ 0 0 0, 1 0 0 ] } } }')
>>> scene.find("C")["point"].shape          # the bracketed run: one token, one array
(2, 3)
"""
from __future__ import annotations

import re
import sys
from typing import Optional

from lark.lexer import Lexer

from .errors import Source

__all__ = ["FastLexer", "Tok", "SURROGATE_RE", "NAME_BEFORE"]

#: Words after which a lenient reader's "nan" is a name (DEF nan, USE nan, ...).
NAME_BEFORE = frozenset({"DEF", "USE", "ROUTE", "TO", "IS", "PROTO", "EXTERNPROTO"})

class Tok:
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
        return f"Tok({self.type}, {self.value!r})"


SURROGATE_RE = re.compile("[\udc80-\udcff]")  # bytes that were not UTF-8, kept by _decode


class FastLexer(Lexer):
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
        if not word.isascii() and SURROGATE_RE.search(word):
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
        if prev in NAME_BEFORE or prev[:2] in ("SF", "MF"):
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
        tok = Tok
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
                    if not v.isascii() and SURROGATE_RE.search(v):
                        bad = start + SURROGATE_RE.search(v).start()
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
