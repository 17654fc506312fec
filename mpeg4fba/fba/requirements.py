"""Which feature points a face needs, and why: the one list that cloning and validation
share.

A point is needed for one of four reasons, each a table here:

* a **FAP** moves it (:data:`FAP_POINTS`, from the standard's FAP table): a face whose
  FAT has a table for that FAP needs it (validation rule FBA002), and so does a face
  cloned onto, for every FAP it will get;
* the **FAPU** are measured between it and another (:data:`FAPU_POINTS`);
* it tells which meshes are a **part** (:data:`PART_POINTS`): the eyeballs by their
  pupils, upper and lower teeth by their points, the tongue by its points.  A part's
  points are needed only when the face has that part, and a part's own FAPs
  (:data:`PART_FAPS`) only then: a head without eyeballs gets no eyeball FAPs;
* a method needs it (``base``: Facial Motion Cloning's alignment triangulation and 7.1,
  :data:`mpeg4fba.cloning.REQUIRED_POINTS`).

:func:`required_points` puts them together; :data:`NOT_SURFACE` says which points lie
off the skin's surface (inside the mouth, the neck), where a check that points lie on
the mesh does not apply.

>>> required_points(faps=[3, 65])
['2.1', '10.1']
>>> required_points(faps=[23, 43], parts=["eye"])        # no tongue: no tongue FAP
['3.5', '3.6']
>>> required_points(faps=[43], parts=["tongue"], fapu=True)
['2.2', '2.3', '3.1', '3.3', '3.5', '3.6', '6.1', '6.2', '6.3', '6.4', '8.3', '8.4', '9.15']
"""
from __future__ import annotations

from typing import Iterable, Optional

from .featurepoints import point_order
from .tables import FAP

__all__ = ["FAPU_POINTS", "PART_POINTS", "PART_FAPS", "NOT_SURFACE", "fap_points",
           "required_points", "part_of_fap"]

#: The points each FAPU is measured between (ISO/IEC 14496-2, table C-1): IRISD0 3.1 to
#: 3.3 (left eye), ES0 3.5 to 3.6, ENS0 from the eyes' midpoint to 9.15, MNS0 9.15 to the
#: mouth (2.2 and 2.3), MW0 8.3 to 8.4.
FAPU_POINTS = ("3.1", "3.3", "3.5", "3.6", "9.15", "2.2", "2.3", "8.3", "8.4")

#: Part kind -> the points that identify its meshes (any one of each row does).
PART_POINTS = {
    "eye": ("3.5", "3.6"),
    "teeth": ("9.8", "9.9", "9.10", "9.11"),
    "tongue": ("6.1", "6.2", "6.3", "6.4"),
}

#: Part kind -> the FAPs that move that part alone (eyeball yaw, pitch, thrust and
#: pupil; the tongue's five).  A face without the part gets no table for them.
PART_FAPS = {
    "eye": tuple(range(23, 31)),
    "tongue": tuple(range(43, 48)),
}

#: Points that do not lie on the skin's surface: 7.1 (the centre of the head's rotation,
#: inside the neck), the tongue's and the teeth's (inside the mouth) and 11.5 (the top of
#: the skull under the hair).  Which points lie on *some* mesh depends on the parts
#: present (a pupil lies on its eyeball, floats in the eye opening without one).
NOT_SURFACE = frozenset({"7.1", "6.1", "6.2", "6.3", "6.4", "9.8", "9.9", "9.10", "9.11",
                         "11.5"})


def part_of_fap(fap: int) -> Optional[str]:
    """The part kind a FAP moves alone (``"eye"``, ``"tongue"``), else None.

    >>> part_of_fap(24), part_of_fap(3)
    ('eye', None)
    """
    for kind, faps in PART_FAPS.items():
        if fap in faps:
            return kind
    return None


def fap_points(faps: Iterable[int]) -> list:
    """The feature points the low-level FAPs ``faps`` move, in the standard's order
    (FAPs 1 and 2, visemes and expressions, move none of their own).

    >>> fap_points([1, 3, 47])
    ['2.1', '6.3', '6.4']
    """
    return point_order({fp for f in faps if 3 <= int(f) <= 68 for fp in FAP[int(f)].feature_points})


def required_points(faps: Iterable[int] = (), parts: Optional[Iterable[str]] = None, *,
                    fapu: bool = False, base: Iterable[str] = ()) -> list:
    """The feature points a face needs, in the standard's order.

    ``faps``: the FAPs its FAT has (or will have); ``parts``: the part kinds it has
    (:data:`PART_POINTS`; None: take every FAP as it comes, as validation does for a
    FAT that exists); with ``parts`` given, the FAPs of absent parts
    (:data:`PART_FAPS`) are left out and the points of present parts added (for teeth,
    the ones the face has are enough, so none is added); ``fapu``: add
    :data:`FAPU_POINTS`; ``base``: a method's own points.

    >>> required_points(faps=[29, 30], parts=[])
    []
    """
    faps = [int(f) for f in faps]
    ids = set(base)
    if parts is not None:
        present = set(parts)
        faps = [f for f in faps if part_of_fap(f) is None or part_of_fap(f) in present]
        for kind in present & {"eye", "tongue"}:
            ids |= set(PART_POINTS[kind])
    ids |= set(fap_points(faps))
    if fapu:
        ids |= set(FAPU_POINTS)
    return point_order(ids)
