"""Given feature points moved onto the geometry the detector finds
(:func:`snap_points`, ``mpeg4fba clone --snap`` and ``mpeg4fba points --snap``): the crisp
points onto the points found, the inner lips' across the mouth's slit only.

>>> SNAP_POINTS[:5], LIP_EDGE_POINTS["2.3"]
(('2.1', '2.2', '2.3', '2.4', '2.5'), 'lower lip')
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointSet, normalise_id
from .detect import (CRISP_POINTS, TEMPLATE_ES_MM, FaceNotFoundError, FoundPoints,
                     find_feature_points)
from .surface import onto_same_sheet

__all__ = ["snap_points", "LIP_EDGE_POINTS", "SNAP_POINTS"]


#: The inner lips' points and the lip whose edge each lies on.  The geometry pins them
#: across the mouth's slit but not along it, so :func:`snap_points` moves each across
#: onto its lip's edge (``FoundPoints.curves``), keeping where along the lip it was
#: given.  Across is where a misplaced point does harm: on ICT heads, 1 mm of noise
#: across the slit on these points raised the largest cloning error up to 13 times, the
#: same noise along it up to 2 times (a point a millimetre above the slit drags the
#: lips' regions across it).
LIP_EDGE_POINTS = {"2.2": "upper lip", "2.6": "upper lip", "2.7": "upper lip",
                   "2.3": "lower lip", "2.8": "lower lip", "2.9": "lower lip"}

#: What :func:`snap_points` moves by default: the crisp points, the inner lips' among
#: them across the slit only (:data:`LIP_EDGE_POINTS`).
SNAP_POINTS = CRISP_POINTS + tuple(k for k in LIP_EDGE_POINTS if k not in CRISP_POINTS)


def snap_points(face: FaceModel, points: FeaturePointSet, ids=SNAP_POINTS, *,
                found: Optional[FoundPoints] = None, source: Optional[FaceModel] = None,
                source_found: Optional[FoundPoints] = None) -> tuple:
    """(snapped FeaturePointSet, id -> distance moved in model units): the given points
    among ``ids`` moved onto the geometry found near them (within a quarter of the eye
    separation; further, the given point is kept: the user knows better).

    Crisp points (:data:`CRISP_POINTS`) go to the points found.  The inner lips' points
    (:data:`LIP_EDGE_POINTS`) go across the slit only: to the nearest point of their
    lip's edge, keeping where along the lip they were given, then by as much as the
    ``source`` face's own point of that id lies off its lip's edge (measured in each
    face's head frame, in eye separations, then dropped onto the lip's sheet), so that
    the target's points agree with the source's as cloning needs.  Without a source
    they stay on the edge, which is where the reference head has them.
    ``found`` / ``source_found``: :func:`find_feature_points` of ``face`` / ``source``
    when the caller has it already.

    >>> from mpeg4fba.models import reference_head
    >>> head = reference_head(resolution=0.5)
    >>> off = dict(head.points.items()); off["2.6"] = off["2.6"] + [0, 0.003, 0]  # 3 mm up
    >>> snapped, moved = snap_points(head, FeaturePointSet(off), ids=["2.6"])
    >>> 2.5e-3 < moved["2.6"] < 3.5e-3, bool(abs(snapped["2.6"][1] - head.points["2.6"][1]) < 1e-3)
    (True, True)
    """
    found = find_feature_points(face) if found is None else found
    pos = {k: points[k] for k in points}
    ties = dict(points.vertices)
    es = None
    if "3.5" in points and "3.6" in points:
        es = float(np.linalg.norm(points["3.5"] - points["3.6"]))
    if not es:
        es = TEMPLATE_ES_MM * found.scale
    if source is not None and source_found is None:
        try:
            source_found = find_feature_points(source)
        except FaceNotFoundError:
            source = None
    moved = {}
    for k in ids:
        k = normalise_id(k)
        if k not in pos:
            continue
        if k in LIP_EDGE_POINTS:
            to, tie = _across_the_slit(face, found, k, pos[k], source, source_found)
            if to is None:
                continue
        elif k in found.points:
            to, tie = found.points[k], found.points.vertex(k)
        else:
            continue
        d = float(np.linalg.norm(to - pos[k]))
        if d <= 0.25 * es:
            pos[k] = to
            if tie is not None:
                ties[k] = tie
            moved[k] = d
    return FeaturePointSet(pos, ties), moved


#: Each lip's inner contour through the found points, right corner to left: its edge
#: where the geometry shows no contact groove (a coarse or smooth mouth).
_LIP_CHAINS = {"upper lip": ("2.5", "2.7", "2.2", "2.6", "2.4"),
               "lower lip": ("2.5", "2.9", "2.3", "2.8", "2.4")}


def _lip_edge(found: FoundPoints, name: str) -> Optional[np.ndarray]:
    """The lip's edge found (``found.curves``), else its contour through the found
    points, else None."""
    if name in found.curves:
        return found.curves[name]
    chain = _LIP_CHAINS[name]
    if all(k in found.points for k in chain):
        return np.array([found.points[k] for k in chain])
    return None


def _across_the_slit(face: FaceModel, found: FoundPoints, k: str, p: np.ndarray,
                     source: Optional[FaceModel], source_found: Optional[FoundPoints]) -> tuple:
    """(where :func:`snap_points` puts the inner lip point ``k`` given at ``p``, its
    (mesh, vertex) tie), or (None, None) without the lip's edge or its mesh."""
    edge = _lip_edge(found, LIP_EDGE_POINTS[k])
    mesh = (found.points.vertices.get("2.2") or (None,))[0]
    if edge is None or mesh not in face.meshes:
        return None, None
    on = _nearest_on_polyline(p, edge)
    to = on
    if source is not None and source_found is not None and k in source.points:
        src_edge = _lip_edge(source_found, LIP_EDGE_POINTS[k])
        if src_edge is not None:
            q = np.asarray(source.points[k])
            # the source's offset in its head frame (eye separations), then in the face's
            off = source_found.fit["s"] * (q - _nearest_on_polyline(q, src_edge)) @ source_found.fit["R"].T
            to = on + off @ found.fit["R"] / found.fit["s"]
    V = face.world_vertices(mesh)
    T = face.meshes[mesh].triangles
    # onto the sheet of the lip whose edge it is (a surface facing away counts a tenth
    # of an eye separation further)
    tri, bary = onto_same_sheet(on[None], to[None], V, T, 0.1 / found.fit["s"])
    return bary[0] @ V[T[tri[0]]], (mesh, int(T[tri[0], np.argmax(bary[0])]))


def _nearest_on_polyline(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """The point of the polyline ``line`` (k, 3) nearest ``p``."""
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0, 1)
    near = a + t[:, None] * ab
    return near[np.argmin(np.linalg.norm(near - p, axis=1))]
