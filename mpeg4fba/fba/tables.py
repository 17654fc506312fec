"""The standard's tables as typed records: FAPs, feature points, visemes, expressions.

The facts live in ``data/*.csv`` (our own clean tables, written from the facts in
ISO/IEC 14496-2 Annex C as reconstructed from public implementations); this module
reads them once and offers lookups.  Code asks ``FAP[3].fapu``; it never hard-codes a
table.

Example
-------
>>> FAP[3].name, FAP["open_jaw"].number, FAP[3].fapu
('open_jaw', 3, 'MNS')
>>> FAP["stretch_l_cornerlip"].number          # the Visual (14496-2) naming
6
>>> FAP.bifs("stretch_l_cornerlip").number     # the BIFS FAP-node naming
53
>>> FEATURE_POINTS["3.5"].description
'center of the pupil of left eye'
>>> VISEMES["PP"].phonemes, EXPRESSIONS[1].name
(('p', 'b', 'm'), 'joy')
"""
from __future__ import annotations

import csv
import difflib
import io
from dataclasses import dataclass
from importlib import resources
from typing import Iterator, Optional, Union

__all__ = ["FapRecord", "FeaturePoint", "Viseme", "Expression", "FAP", "FEATURE_POINTS",
           "VISEMES", "EXPRESSIONS", "N_FAPS", "LOW_LEVEL", "FAPU_NAMES"]

N_FAPS = 68
#: The low-level FAP numbers, 3 to 68.
LOW_LEVEL = tuple(range(3, N_FAPS + 1))
#: The distance units (FAPU) by name; AU (1e-5 rad) is the angle unit.
FAPU_NAMES = ("IRISD", "ES", "ENS", "MNS", "MW", "AU")


@dataclass(frozen=True)
class FapRecord:
    """One Facial Animation Parameter.

    ``fapu`` is the unit name (MNS, MW, ES, ENS, IRISD, AU; None for FAPs 1 and 2);
    ``motion`` is translation, rotation, scale (pupil dilation) or curl (tongue roll);
    ``axis`` is the unit direction of positive motion for a translation, or the
    right-handed rotation axis for a rotation, in the face frame (x = the face's left,
    y = up, z = forward); ``feature_points`` the points it moves (for eyeball and head
    rotations, the centre they turn about: 3.5/3.6 and 7.1, as the implementations
    attach them; the recalled ISO column says "na" there).

    ``range`` is the I-frame quantised min/max times the quantiser step: the range of
    the dequantised value in FAP units.  This reading makes the eyeball bounds +-88
    degrees (1200 x 128 AU) and the head's +-181 degrees, where the raw quantised
    numbers would give well under one degree; for FAPs beyond 11 the quantiser
    figures are recalled, not sourced twice, so range checks only warn.
    """

    number: int
    name: str
    bifs_name: str
    description: str
    fapu: Optional[str]
    unidirectional: bool
    positive_motion: str
    motion: Optional[str]
    axis: Optional[tuple]
    feature_points: tuple
    quant_step: int
    range: Optional[tuple]

    @property
    def high_level(self) -> bool:
        """FAP 1 (viseme) and FAP 2 (expression) select shapes; the rest move points."""
        return self.number <= 2

    @property
    def feature_point(self) -> Optional[str]:
        """The first (usually only) feature point of the FAP, or None."""
        return self.feature_points[0] if self.feature_points else None

    def __int__(self) -> int:
        return self.number

    def __repr__(self) -> str:
        return f"<FAP {self.number} {self.name}>"


@dataclass(frozen=True)
class FeaturePoint:
    """One of the 84 feature points: ``id`` is "group.index" (e.g. "3.5")."""

    id: str
    group: int
    index: int
    description: str
    faps: tuple
    defines_fapu: tuple

    def __repr__(self) -> str:
        return f"<FeaturePoint {self.id} {self.description}>"


@dataclass(frozen=True)
class Viseme:
    """Viseme 0-14 (0 is none): short name, phonemes, example words."""

    number: int
    name: str
    phonemes: tuple
    examples: tuple


@dataclass(frozen=True)
class Expression:
    """Expression 0-6 (0 is neutral): name and the look of the face."""

    number: int
    name: str
    description: str


def _rows(name: str) -> list:
    text = resources.files(__package__).joinpath("data", name).read_text("utf-8")
    return list(csv.DictReader(io.StringIO(text)))


class _Table:
    """Lookup by number (or id) and by name, with a did-you-mean on a miss."""

    def __init__(self, what: str, records: list, key: str):
        self.what = what
        self._records = records
        self._by_key = {getattr(r, key): r for r in records}
        self._by_name: dict = {}
        for r in records:
            name = getattr(r, "name", None)
            if name:
                self._by_name.setdefault(name.lower(), r)

    def _miss(self, item) -> KeyError:
        """KeyError with the nearest names: the same words in another order first
        (``jaw_open`` -> ``open_jaw``, which difflib alone ranks too far), then difflib's.

        >>> try:
        ...     FAP["jaw_open"]
        ... except KeyError as e:
        ...     print(e.args[0])
        no FAP 'jaw_open'; did you mean open_jaw?
        """
        word = str(item).strip().lower()
        names = [str(k) for k in self._by_key] + list(self._by_name)
        words = sorted(word.replace("-", "_").split("_"))
        close = [n for n in self._by_name if sorted(n.split("_")) == words]
        close += [n for n in difflib.get_close_matches(word, names, n=3) if n not in close]
        hint = f"; did you mean {', '.join(close[:3])}?" if close else ""
        return KeyError(f"no {self.what} {item!r}{hint}")

    def __getitem__(self, item):
        if isinstance(item, str):
            key = item.strip()
            r = self._by_name.get(key.lower().replace(" ", ""))
            if r is None:
                r = self._by_key.get(key)
            if r is None and key.isdigit():
                r = self._by_key.get(int(key))
        else:
            r = self._by_key.get(item)
        if r is None:
            raise self._miss(item)
        return r

    def get(self, item, default=None):
        try:
            return self[item]
        except KeyError:
            return default

    def __contains__(self, item) -> bool:
        return self.get(item) is not None

    def __iter__(self) -> Iterator:
        return iter(self._records)

    def __len__(self) -> int:
        return len(self._records)

    def __repr__(self) -> str:
        return f"<{len(self)} {self.what}s>"


class _FapTable(_Table):
    """``FAP[n]`` by number, ``FAP["name"]`` by the Visual (ISO/IEC 14496-2) name or,
    where it names no other FAP, the BIFS FAP-node field name.

    The two namings collide on one word: "stretch_l_cornerlip" is FAP 6 in the Visual
    naming and FAP 53 in the BIFS naming (likewise "stretch_r_cornerlip": 7 and 54).
    ``FAP[...]`` resolves by the Visual naming, which is what FAP streams and papers
    use; ``FAP.bifs(...)`` resolves by the BIFS naming, which is what the VRML/BIFS
    FAP node uses (the FAT codec reads FAP nodes with it).
    """

    def __init__(self, records: list):
        super().__init__("FAP", records, "number")
        for r in records:  # BIFS names that are no Visual name of another FAP
            if r.bifs_name and r.bifs_name.lower() not in self._by_name:
                self._by_name[r.bifs_name.lower()] = r
        self._by_bifs = {r.bifs_name: r for r in records if r.bifs_name}

    def bifs(self, name: str) -> FapRecord:
        """The FAP whose BIFS FAP-node field is ``name``."""
        r = self._by_bifs.get(name)
        if r is None:
            raise self._miss(name)
        return r

    @property
    def low_level(self) -> list:
        """FAPs 3-68."""
        return [r for r in self._records if not r.high_level]

    def number(self, fap: Union[int, str, FapRecord]) -> int:
        """The number of a FAP given by number, name or record."""
        if isinstance(fap, FapRecord):
            return fap.number
        return self[fap].number


def _vec(text: str) -> Optional[tuple]:
    return tuple(float(v) for v in text.split()) if text else None


def _load_faps() -> list:
    out = []
    for r in _rows("faps.csv"):
        lo, hi = r["min"], r["max"]
        out.append(FapRecord(
            number=int(r["number"]), name=r["name"], bifs_name=r["bifs_name"],
            description=r["description"], fapu=r["fapu"] or None,
            unidirectional=r["direction"] == "unidirectional",
            positive_motion=r["positive_motion"], motion=r["motion"] or None,
            axis=_vec(r["axis"]), feature_points=tuple(r["feature_point"].split()),
            quant_step=int(r["quant_step"]),
            range=(float(lo), float(hi)) if lo != "" else None))
    return out


def _load_points() -> list:
    return [FeaturePoint(r["id"], int(r["group"]), int(r["index"]), r["description"],
                         tuple(int(v) for v in r["faps"].split()), tuple(r["defines_fapu"].split()))
            for r in _rows("feature_points.csv")]


FAP = _FapTable(_load_faps())
FEATURE_POINTS = _Table("feature point", _load_points(), "id")
VISEMES = _Table("viseme", [Viseme(int(r["number"]), r["name"], tuple(r["phonemes"].split()),
                                   tuple(r["examples"].split())) for r in _rows("visemes.csv")],
                 "number")
EXPRESSIONS = _Table("expression", [Expression(int(r["number"]), r["name"], r["description"])
                                    for r in _rows("expressions.csv")], "number")
