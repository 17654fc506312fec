"""eSpeak NG phonemes as MPEG-4 visemes: the table (package data,
``data/phonemes_en.csv``) and the rule for phonemes it does not list.

Each phoneme has a viseme and a jaw opening at its start, optionally a second viseme
and opening its glide reaches by its end (diphthongs), and a kind: ``vowel``,
``closure`` (p, b, m: the lips shut fully), ``consonant``, ``carry`` (h and the glottal
stop have no mouth shape of their own and take the next phoneme's) or ``pause`` (the
mouth returns to neutral).

The table covers eSpeak's English phonemes.  Any other phoneme (another language's
voice) is read by :func:`phoneme_shape`'s fallback: stress and length marks dropped
(``'``, ``,``, ``:``, a trailing digit or ``#``) and the table tried again, else the
first character decides by its class: vowel letters by their openness (a A V -> aa;
e E @ 3 -> E; i I y Y -> ih; o O 0 Q -> oh; u U -> ou), consonants by where they
are made (p b m B -> PP; f v F -> FF; T D -> TH; t d c -> DD; k g q x G N -> kk;
S Z J C -> CH; s z -> SS; n l L -> nn; r R -> RR; j -> ih; w W -> ou; h ? -> carry), and anything
else is a plain consonant with the DD shape.

>>> phoneme_shape("'A:").viseme, phoneme_shape("p").kind, phoneme_shape("aI").viseme2
(10, 'closure', 12)
>>> phoneme_shape("y:").viseme                 # French/German y: not in the English table
12
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Optional

__all__ = ["PhonemeShape", "phoneme_shape", "phoneme_table", "KINDS"]

KINDS = ("vowel", "closure", "consonant", "carry", "pause")


@dataclass(frozen=True)
class PhonemeShape:
    """The mouth for one phoneme: ``viseme`` (0-14) and ``jaw`` (0-1) at its start,
    ``viseme2``/``jaw2`` at its end (None: no glide), ``kind`` (:data:`KINDS`) and
    ``listed`` (False when the fallback rule made it)."""

    phoneme: str
    viseme: int
    jaw: float
    viseme2: Optional[int]
    jaw2: Optional[float]
    kind: str
    listed: bool = True


@lru_cache(maxsize=None)
def phoneme_table() -> dict:
    """eSpeak mnemonic -> :class:`PhonemeShape`, from the package data."""
    text = resources.files(__package__).joinpath("data/phonemes_en.csv").read_text(encoding="utf-8")
    rows = csv.DictReader(line for line in text.splitlines() if not line.startswith("#"))
    out = {}
    for r in rows:
        v2 = r["viseme2"].strip()
        out[r["phoneme"]] = PhonemeShape(r["phoneme"], int(r["viseme"]), float(r["jaw"]),
                                         int(v2) if v2 else None,
                                         float(r["jaw2"]) if v2 else None, r["kind"])
    return out


# first character -> (viseme, jaw, kind) of the fallback
_VOWELS = {**dict.fromkeys("aAV", (10, 0.8)), **dict.fromkeys("eE@3", (11, 0.5)),
           **dict.fromkeys("iIyY", (12, 0.3)), **dict.fromkeys("oO0Q", (13, 0.65)),
           **dict.fromkeys("uU", (14, 0.3))}
_CONSONANTS = {**dict.fromkeys("pbmB", (1, 0.0, "closure")), **dict.fromkeys("fvF", (2, 0.08, "consonant")),
               **dict.fromkeys("TD", (3, 0.15, "consonant")), **dict.fromkeys("tdc", (4, 0.12, "consonant")),
               **dict.fromkeys("kgqxGN", (5, 0.22, "consonant")),
               **dict.fromkeys("SZJC", (6, 0.12, "consonant")), **dict.fromkeys("sz", (7, 0.08, "consonant")),
               **dict.fromkeys("nlL", (8, 0.18, "consonant")), **dict.fromkeys("rR", (9, 0.2, "consonant")),
               "j": (12, 0.15, "consonant"), "w": (14, 0.12, "consonant"), "W": (14, 0.12, "consonant"),
               "h": (0, 0.3, "carry"), "?": (0, 0.1, "carry")}


def _bare(name: str) -> str:
    return name.lstrip("',%=")


@lru_cache(maxsize=4096)
def phoneme_shape(name: str) -> PhonemeShape:
    """The :class:`PhonemeShape` of an eSpeak phoneme (stress marks allowed)."""
    table = phoneme_table()
    bare = _bare(name)
    if bare in table:
        return table[bare]
    if not bare or bare.startswith("_"):
        return PhonemeShape(bare, 0, 0.0, None, None, "pause", False)
    short = bare.rstrip(":#0123456789") or bare
    if short in table:
        s = table[short]
        return PhonemeShape(bare, s.viseme, s.jaw, s.viseme2, s.jaw2, s.kind, False)
    first = short[0]
    if first in _VOWELS:
        v, jaw = _VOWELS[first]
        return PhonemeShape(bare, v, jaw, None, None, "vowel", False)
    v, jaw, kind = _CONSONANTS.get(first, (4, 0.12, "consonant"))
    return PhonemeShape(bare, v, jaw, None, None, kind, False)
