"""The normalised facial space of Pandzic, *Facial Motion Cloning* ("Normalizing the face").

Every vertex ``V`` is mapped to ``(V - C) / N(FP)`` (component-wise), where ``C`` is the
centre of the face (:func:`face_center`) and ``N(FP)`` the normalisation factors of the
region of the feature point closest to ``V``.  The factors are FAPUs (``FAPU0 / 1024``),
so a motion of ``v`` FAP units along a FAP's axis becomes the number ``v`` on every face.

Factors of a feature point (:func:`point_factors`)
--------------------------------------------------
For each axis, the unit of the translational FAPs that move the point along that axis
(``FEATURE_POINTS[id].faps`` -> ``FAP[n].fapu`` and ``FAP[n].axis``; rotations, the
pupil scale and the tongue curl count in AU or are not translations and are ignored;
were two FAPs to disagree on one axis, the lower FAP number would win, but none do).
An axis no FAP moves the point along takes the typical unit of the point's group,
``_GROUP_UNITS`` below (the teeth 9.8-9.11 take the mouth's units instead of the nose's);
a group with no entry takes ES.  The resulting table, x / y / z:

=====================  ================================  =========================
points                 FAP-derived                        result
=====================  ================================  =========================
2.1 (chin)             x MW (15), y MNS (3), z MNS (14)   MW  MNS   MNS
2.2-2.10 (inner lip)   x MW (6, 7), y MNS, z MNS (16,17)  MW  MNS   MNS
2.11-2.14 (jaw)        none                               MW  MNS   MNS
3.1-3.4 (eyelids)      y IRISD (19-22)                    ES  IRISD ES
3.5, 3.6 (pupils)      z ES (27, 28)                      ES  IRISD ES
3.7-3.14 (eye)         none                               ES  IRISD ES
4.1, 4.2 (eyebrows)    x ES (37, 38), y ENS (31, 32)      ES  ENS   ENS
4.3-4.6 (eyebrows)     y ENS (33-36)                      ES  ENS   ENS
5.1, 5.2 (cheeks)      x ES (39, 40)                      ES  ENS   ES
5.3, 5.4 (cheek bone)  y ENS (41, 42)                     ES  ENS   ES
6.1 (tongue tip)       x MW (43), y MNS (44), z MW (45)   MW  MNS   MW
6.2-6.4 (tongue)       y MNS (46) / curl (47)             MW  MNS   MW
7.1 (spine)            rotations only                     ES  ES    ES
8.1-8.10 (outer lip)   x MW (53, 54), y MNS (51-60)       MW  MNS   MNS
9.1-9.3 (nose)         x ENS (61, 62, 64), y ENS (63)     ENS ENS   ENS
9.4-9.7, 9.12-9.15     none                               ENS ENS   ENS
9.8-9.11 (teeth)       none                               MW  MNS   MNS
10.1-10.10 (ears)      y ENS (65, 66), x ENS (67, 68)     ENS ENS   ENS
11.1-11.6 (head)       none                               ES  ES    ES
=====================  ================================  =========================

Example: a face and a copy twice its size map the same FAP motion to the same number.

>>> from mpeg4fba.fba.featurepoints import FeaturePointSet
>>> fp = FeaturePointSet({"3.5": (3, 4, 0), "3.6": (-3, 4, 0), "8.3": (2, -3, 1),
...                       "8.4": (-2, -3, 1), "9.3": (0, 0, 3)})
>>> u = FAPU(IRISD0=1.0, ES0=6.0, ENS0=4.0, MNS0=2.0, MW0=4.0)
>>> n = Normaliser(fp, u)
>>> n.center.tolist()
[0.0, 0.5, 0.5]
>>> corner = np.array([[2.0, -3.0, 1.0]])
>>> n.factors(corner) * 1024                           # MW0, MNS0, MNS0
array([[4., 2., 2.]])
>>> move = np.array([[100 * u.MW, 0.0, 0.0]])          # stretch_l_cornerlip_o = 100
>>> n.normalise_motion(move, corner).tolist()
[[100.0, 0.0, 0.0]]
>>> np.allclose(n.denormalise(n.normalise(corner), corner), corner, rtol=0, atol=1e-12)
True
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np
from scipy.spatial import cKDTree

from ..fba.fapu import FAPU
from ..fba.featurepoints import FeaturePointError, FeaturePointSet
from ..fba.tables import FAP, FEATURE_POINTS

__all__ = ["region_factors", "point_units", "face_center", "Normaliser", "CENTER_POINTS"]

#: Typical units (x, y, z) of each feature point group, for axes no FAP moves a point along.
_GROUP_UNITS = {
    2: ("MW", "MNS", "MNS"),      # inner lips, chin and jaw
    3: ("ES", "IRISD", "ES"),     # eyes
    4: ("ES", "ENS", "ENS"),      # eyebrows
    5: ("ES", "ENS", "ES"),       # cheeks
    6: ("MW", "MNS", "MW"),       # tongue
    8: ("MW", "MNS", "MNS"),      # outer lips
    9: ("ENS", "ENS", "ENS"),     # nose
    10: ("ENS", "ENS", "ENS"),    # ears
}
#: Points whose fallback is not their group's: the teeth move with the mouth.
_POINT_UNITS = {p: ("MW", "MNS", "MNS") for p in ("9.8", "9.9", "9.10", "9.11")}
_DEFAULT_UNIT = "ES"

#: The points :func:`face_center` is computed from.
CENTER_POINTS = ("3.5", "3.6", "8.3", "8.4")


def point_units(fp: str) -> tuple:
    """The FAPU names (x, y, z) normalising the region of feature point ``fp``.

    >>> point_units("8.3"), point_units("3.1"), point_units("11.4")
    (('MW', 'MNS', 'MNS'), ('ES', 'IRISD', 'ES'), ('ES', 'ES', 'ES'))
    """
    record = FEATURE_POINTS[fp]
    units: list = [None, None, None]
    for number in sorted(record.faps):
        fap = FAP[number]
        if fap.motion != "translation" or fap.axis is None or fap.fapu in (None, "AU"):
            continue
        for k in np.flatnonzero(np.asarray(fap.axis) != 0):
            if units[k] is None:
                units[k] = fap.fapu
    fallback = _POINT_UNITS.get(record.id) or _GROUP_UNITS.get(record.group) \
        or (_DEFAULT_UNIT,) * 3
    return tuple(u if u is not None else f for u, f in zip(units, fallback))


def region_factors(points: FeaturePointSet, fapu: FAPU) -> tuple:
    """(ids, (K, 3) factors): the normalisation factors of every positioned feature point.

    The factors are the FAPUs of :func:`point_units` in model units per FAP unit
    (``FAPU0 / 1024``); ids are in the standard's order, as ``points.positions``.

    >>> fp = FeaturePointSet({"2.2": (0, -1, 1), "3.5": (3, 4, 0)})
    >>> ids, f = region_factors(fp, FAPU(IRISD0=1, ES0=6, ENS0=4, MNS0=2, MW0=4))
    >>> ids, (f * 1024).tolist()
    (['2.2', '3.5'], [[4.0, 2.0, 2.0], [6.0, 1.0, 6.0]])
    """
    ids = list(points)
    factors = np.array([[fapu[u] for u in point_units(i)] for i in ids],
                       dtype=np.float64).reshape(len(ids), 3)
    if not (factors > 0).all():
        bad = [x for x in fapu.problems() if "not positive" in x] or [str(fapu.as_dict())]
        raise ValueError("normalisation needs positive FAPUs: " + "; ".join(bad))
    return ids, factors


def face_center(points: FeaturePointSet) -> np.ndarray:
    """The centre of the face: halfway between the pupils' midpoint and the mouth's.

    ``C = ((3.5 + 3.6) / 2 + (8.3 + 8.4) / 2) / 2``: the pupils' midpoint and the lip
    corners' midpoint lie on the face's mid line, are defined on every face the FAPU
    can be computed for, and scale with the face, so scaled copies of a face have
    scaled copies of the centre.

    >>> face_center(FeaturePointSet({"3.5": (3, 4, 0), "3.6": (-3, 4, 0),
    ...                              "8.3": (2, -2, 2), "8.4": (-2, -2, 2)})).tolist()
    [0.0, 1.0, 1.0]
    """
    points.require(CENTER_POINTS, "the centre of the face")
    p = np.array([points[i] for i in CENTER_POINTS])
    return p.mean(axis=0)


class Normaliser:
    """The map of one face into the normalised facial space and back.

    ``points`` are the face's neutral feature points (model units), ``fapu`` its FAPU,
    ``center`` the centre of scaling (default :func:`face_center`).  Vertices take the
    factors of their closest positioned feature point (:meth:`factors`, one KD-tree
    query per vertex array); pass ``factors=`` to reuse them across calls, and the
    neutral vertices (or their factors) to :meth:`denormalise`, since the regions are
    those of the original face.
    """

    def __init__(self, points: FeaturePointSet, fapu: FAPU,
                 center: Optional[Sequence[float]] = None):
        self.points = points
        self.fapu = fapu
        self.ids, self.point_factors = region_factors(points, fapu)
        if not self.ids:
            raise FeaturePointError("normalisation needs feature point positions")
        self.center = (face_center(points) if center is None
                       else np.asarray(center, dtype=np.float64).reshape(3))
        self._tree = cKDTree(points.positions)

    def regions(self, vertices: np.ndarray) -> np.ndarray:
        """(n,) index into ``ids`` of each vertex's closest feature point."""
        v = _as_vertices(vertices)
        if len(v) == 0:
            return np.zeros(0, dtype=np.intp)
        return np.asarray(self._tree.query(v)[1], dtype=np.intp)

    def factors(self, vertices: np.ndarray) -> np.ndarray:
        """(n, 3) normalisation factors of each vertex (those of its region)."""
        return self.point_factors[self.regions(vertices)]

    def _factors(self, vertices, factors, n: int) -> np.ndarray:
        if factors is None:
            if vertices is None:
                raise TypeError("give the face's vertices in model units or their factors")
            factors = self.factors(vertices)
        factors = np.asarray(factors, dtype=np.float64)
        if factors.shape != (n, 3):
            raise ValueError(f"factors have shape {factors.shape}, expected {(n, 3)}")
        return factors

    def normalise(self, vertices: np.ndarray, factors: Optional[np.ndarray] = None) -> np.ndarray:
        """``(V - C) / N`` for each vertex (model units -> normalised space)."""
        v = _as_vertices(vertices)
        return (v - self.center) / self._factors(v, factors, len(v))

    def denormalise(self, normalised: np.ndarray, vertices: Optional[np.ndarray] = None, *,
                    factors: Optional[np.ndarray] = None) -> np.ndarray:
        """The inverse of :meth:`normalise`: ``W * N + C``.

        ``vertices`` are the model-unit positions whose regions apply (usually the
        neutral face), or give their ``factors`` directly.
        """
        w = _as_vertices(normalised)
        return w * self._factors(vertices, factors, len(w)) + self.center

    def normalise_motion(self, deltas: np.ndarray, vertices: Optional[np.ndarray] = None, *,
                         factors: Optional[np.ndarray] = None) -> np.ndarray:
        """Motion vectors (model units) of ``vertices`` -> normalised motion (FAP units)."""
        d = _as_vertices(deltas)
        return d / self._factors(vertices, factors, len(d))

    def denormalise_motion(self, deltas: np.ndarray, vertices: Optional[np.ndarray] = None, *,
                           factors: Optional[np.ndarray] = None) -> np.ndarray:
        """Normalised motion of ``vertices`` -> motion vectors in model units."""
        d = _as_vertices(deltas)
        return d * self._factors(vertices, factors, len(d))

    def normalise_points(self, points: Optional[FeaturePointSet] = None) -> FeaturePointSet:
        """Feature points (default this face's) in the normalised space, each by its own
        region's factors (also for points another feature point happens to be closer to).
        """
        points = self.points if points is None else points
        ids, f = region_factors(points, self.fapu)
        if not ids:
            return FeaturePointSet({}, points.vertices)
        q = (points.positions - self.center) / f
        return FeaturePointSet(dict(zip(ids, q)), points.vertices)

    def __repr__(self) -> str:
        return f"<Normaliser {len(self.ids)} regions, centre {self.center.tolist()}>"


def _as_vertices(vertices) -> np.ndarray:
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"expected an (n, 3) array, got shape {v.shape}")
    return v
