"""The 2D alignment space of Facial Motion Cloning and the alignment of a target face on a source.

A face (its neutral vertices in the face frame) is taken into the alignment space in
two steps:

1. **Position normalisation** about the face centre ``C`` (:func:`face_center`).
   ``positions="global"`` (the default) divides by one set of FAPU for the whole face,
   ``(ES0, ENS0, ES0)``; ``positions="regional"`` uses the paper's regional factors
   (:class:`~mpeg4fba.cloning.normalise.Normaliser`, in FAPU0 rather than FAPU0 / 1024).
   Why the default departs from the paper: regional factors are discontinuous where
   regions meet, and on a real face the jump is large (the eyes' height unit IRISD is
   about a quarter of the brows' ENS, which throws the eyes above the eyebrows), so the
   projected surface tears and folds and the mapping picks up motion from the wrong
   part of the face.  Positions only need to bring two faces roughly together (the
   feature-point alignment does the rest); the *motion* is normalised regionally, as the
   paper does, whatever ``positions`` says (see :mod:`mpeg4fba.cloning.transfer`).
2. **Cylindrical projection** (:class:`~mpeg4fba.cloning.projection.Projection`) to
   ``(angle, height)``: angle 0 at the nose tip, the axis placed so the mouth always
   subtends :data:`~mpeg4fba.cloning.projection.MOUTH_ANGLE`.  The depth of a point is
   minus its distance from the axis, so "smallest depth" is the outermost surface.

Alignment (:func:`align`): the target's feature points are moved onto the source's, and
every other target vertex is pulled by the same displacement interpolated from a fixed
triangulation of the feature points (:func:`alignment_triangles`, package data
``data/alignment_triangles.csv``, designed on the reference head; ``"delaunay"`` builds
one instead from whichever feature points both faces share).

>>> ids, tris = alignment_triangles()
>>> len(tris), "2.1" in ids, "7.1" in REQUIRED_POINTS
(88, True, True)
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Optional, Sequence, Union

import numpy as np
import scipy.sparse as sp

from ..fba.fapu import FAPU
from ..fba.featurepoints import FeaturePointSet, point_order
# feature points inside the mouth or the neck, useless for aligning the surface
from ..fba.requirements import NOT_SURFACE
from .interp2d import interpolation_weights
from .normalise import Normaliser, face_center
from .projection import MOUTH_ANGLE, Projection

__all__ = ["REQUIRED_POINTS", "alignment_triangles", "FaceSpace", "align", "alignment_weights",
           "delaunay_triangles", "POSITION_MODES"]

_DATA = Path(__file__).with_name("data") / "alignment_triangles.csv"

#: How positions are normalised before the projection (see the module docstring).
POSITION_MODES = ("global", "regional")


@lru_cache(maxsize=None)
def alignment_triangles() -> tuple:
    """(ids, (M, 3) int array): the fixed feature point triangulation, as indices into ids."""
    rows = []
    for number, line in enumerate(_DATA.read_text(encoding="utf-8").splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        row = [p.strip() for p in line.split(",")]
        if len(row) != 3:
            raise ValueError(f"{_DATA}:{number}: expected three feature point ids, got {line!r}")
        rows.append(row)
    ids = point_order({p for row in rows for p in row})
    index = {p: k for k, p in enumerate(ids)}
    tris = np.array([[index[p] for p in row] for row in rows], dtype=np.int64)
    tris.setflags(write=False)
    return tuple(ids), tris


#: Feature points every face must have to be cloned from or to: the vertices of the
#: alignment triangulation (which include the pupils 3.5 and 3.6, the lip contours the
#: lip regions are made of, the nostrils and the chin corners) and 7.1, the top of the
#: spine, as the centre of the head's rotation.  (The paper names "7.2 (neck base)"; the
#: standard's group 7 has one point, 7.1, which it describes as the centre of head
#: rotation, so that is the point we require.)
REQUIRED_POINTS = tuple(point_order(set(alignment_triangles()[0]) | {"7.1"}))


def delaunay_triangles(uv: np.ndarray) -> np.ndarray:
    """Delaunay triangles of 2D points, coincident points (e.g. the inner lip
    contours of a closed mouth) collapsed onto their first occurrence."""
    from scipy.spatial import Delaunay

    uv = np.asarray(uv, dtype=np.float64)
    scale = max(float(np.ptp(uv, axis=0).max()), 1e-300)
    key = np.round(uv / (scale * 1e-9)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    tri = Delaunay(uv[first]).simplices
    return first[tri]


class FaceSpace:
    """One face's vertices in the alignment space.

    ``vertices`` (N, 3) are in the face frame (the frame of the feature points);
    ``points`` the neutral feature points; ``fapu`` the face's FAPU.  Attributes: ``uv``
    (N, 2) = (angle in radians, height in FAPU0), ``depth`` (N,), ``normaliser`` (the
    regional one, used for motion), ``motion_factors`` (N, 3) and ``point_uv(id)``.
    """

    def __init__(self, vertices: np.ndarray, points: FeaturePointSet, fapu: FAPU, *,
                 positions: str = "global", mouth_angle: float = MOUTH_ANGLE):
        if positions not in POSITION_MODES:
            raise ValueError(f"positions must be one of {POSITION_MODES}, not {positions!r}")
        self.positions = positions
        self.points = points
        self.fapu = fapu
        self.vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        self.normaliser = Normaliser(points, fapu)
        self.center = face_center(points)
        self.motion_factors = self.normaliser.factors(self.vertices)
        self._global = np.array([fapu.ES0, fapu.ENS0, fapu.ES0])
        pts = self.normalised_points()
        self.projection = Projection(pts, mouth_angle)
        self.uv = self.project(self.normalise(self.vertices))
        self.depth = self._depth(self.normalise(self.vertices))
        self.ids = list(pts)
        self._point_uv = dict(zip(self.ids, self.project(pts.positions))) if len(pts) else {}
        self._point_depth = dict(zip(self.ids, self._depth(pts.positions))) if len(pts) else {}

    def normalise(self, vertices: np.ndarray, factors: Optional[np.ndarray] = None) -> np.ndarray:
        """Positions in the normalised space this face space projects (FAPU0 units)."""
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        if self.positions == "global":
            return (v - self.center) / self._global
        return self.normaliser.normalise(v, factors) / 1024.0

    def normalised_points(self) -> FeaturePointSet:
        if self.positions == "global":
            ids = list(self.points)
            if not ids:
                return FeaturePointSet({})
            q = (self.points.positions - self.center) / self._global
            return FeaturePointSet(dict(zip(ids, q)), self.points.vertices)
        p = self.normaliser.normalise_points()
        return FeaturePointSet({k: p[k] / 1024.0 for k in p}, p.vertices)

    def project(self, normalised: np.ndarray) -> np.ndarray:
        return self.projection(np.asarray(normalised, dtype=np.float64).reshape(-1, 3))

    def _depth(self, normalised: np.ndarray) -> np.ndarray:
        dx = normalised[:, 0] - self.projection.center_x
        dz = normalised[:, 2] - self.projection.center_z
        return -np.hypot(dx, dz)

    def point_uv(self, fp: str) -> np.ndarray:
        return self._point_uv[fp]

    def points_depth(self, ids: Sequence[str]) -> np.ndarray:
        return np.array([self._point_depth[i] for i in ids], dtype=np.float64)

    def points_uv(self, ids: Sequence[str]) -> np.ndarray:
        return np.array([self._point_uv[i] for i in ids], dtype=np.float64).reshape(-1, 2)

    def map_point_array(self, points: np.ndarray, other: "FaceSpace") -> np.ndarray:
        """:meth:`map_point` for an (n, 3) array."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return (p - self.center) / self._global * other._global + other.center

    def map_point(self, point: np.ndarray, other: "FaceSpace") -> np.ndarray:
        """A 3D point of this face carried to ``other`` through the global normalisation
        (used for centres of rotation with no feature point of their own)."""
        p = np.asarray(point, dtype=np.float64).reshape(3)
        return (p - self.center) / self._global * other._global + other.center


def alignment_weights(target: FaceSpace, ids: Sequence[str], triangles: np.ndarray,
                      queries: Optional[np.ndarray] = None) -> sp.csr_matrix:
    """Sparse (Q, K) weights interpolating a function of the K feature points ``ids`` at
    the target's vertices (or ``queries``) from the feature point triangulation."""
    q = target.uv if queries is None else queries
    return interpolation_weights(target.points_uv(ids), triangles, q)


def align(target: FaceSpace, source: FaceSpace,
          triangulation: Union[str, np.ndarray, Sequence] = "fixed", *,
          refine: bool = True) -> tuple:
    """(aligned (N, 2) target uv, aligned (N,) depth, ids, triangles): the target's vertices
    pulled so that its feature points land on the source's.  The depth is carried along the
    same way (the feature points' depth differences interpolated), so that a target
    vertex can be compared with the source surfaces lying over it in 2D.

    ``triangulation`` is ``"fixed"`` (package data, all its points required), ``"delaunay"``
    (of every feature point both faces have, except 7.1 and the points inside the mouth;
    laid out on the source's projection) or a sequence of id triples.  With ``refine``
    the other feature points both faces have (ears, outer eyelids, Cupid's bow...) are
    then moved onto the source's as well, by a second interpolation over a Delaunay
    triangulation of all the points in which the first ones do not move.
    """
    ids, tris = _triangulation(target, source, triangulation)
    moved = source.points_uv(ids) - target.points_uv(ids)
    w = alignment_weights(target, ids, tris)
    aligned = target.uv + np.asarray(w @ moved)
    depth = target.depth + np.asarray(w @ (source.points_depth(ids) - target.points_depth(ids)))
    if refine:
        extra = [i for i in point_order(set(target.ids) & set(source.ids))
                 if i not in ids and i not in NOT_SURFACE
                 and abs(source.point_uv(i)[0]) < _REFINE_ANGLE
                 and abs(target.point_uv(i)[0]) < _REFINE_ANGLE]
        if extra:
            # second pass: the feature points outside the triangulation (ears, outer
            # eyelids, ...) go onto the source's too, the triangulation's ones stay put
            first = target.points_uv(extra)
            first = first + np.asarray(alignment_weights(target, ids, tris, first) @ moved)
            at = np.vstack([source.points_uv(ids), first])
            residual = np.vstack([np.zeros((len(ids), 2)), source.points_uv(extra) - first])
            second = delaunay_triangles(at)
            w2 = interpolation_weights(at, second, aligned)
            aligned = aligned + np.asarray(w2 @ residual)
    return aligned, depth, ids, tris


#: Feature points further round the head than this (radians) are left out of the second
#: alignment pass: the back of the skull wraps round to -pi.
_REFINE_ANGLE = 2.5


def _triangulation(target: FaceSpace, source: FaceSpace, triangulation) -> tuple:
    if isinstance(triangulation, str):
        if triangulation == "fixed":
            ids, tris = alignment_triangles()
            for face, which in ((target, "target"), (source, "source")):
                face.points.require(ids, f"the alignment triangulation ({which} face)")
            return list(ids), np.asarray(tris)
        if triangulation == "delaunay":
            ids = [i for i in point_order(set(target.ids) & set(source.ids))
                   if i not in NOT_SURFACE]
            if len(ids) < 3:
                raise ValueError("a Delaunay alignment needs at least three feature points "
                                 "on both faces")
            return ids, delaunay_triangles(source.points_uv(ids))
        raise ValueError(f"triangulation must be 'fixed', 'delaunay' or id triples, "
                         f"not {triangulation!r}")
    rows = [tuple(str(p) for p in row) for row in triangulation]
    if any(len(r) != 3 for r in rows):
        raise ValueError("each triangle of a triangulation is three feature point ids")
    ids = point_order({p for r in rows for p in r})
    for face, which in ((target, "target"), (source, "source")):
        face.points.require(ids, f"the alignment triangulation ({which} face)")
    index = {p: k for k, p in enumerate(ids)}
    return ids, np.array([[index[p] for p in r] for r in rows], dtype=np.int64)
