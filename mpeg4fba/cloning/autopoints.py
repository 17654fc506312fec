"""Give a face the feature points cloning needs: the ones it has, as given, and the
rest found on its geometry (:func:`~mpeg4fba.cloning.detect.find_feature_points`).

:func:`complete_points` is what ``mpeg4fba clone`` does with a target: a face with no
points gets every point the geometry has; a face with some keeps them and gets the
missing required ones; with ``snap=True`` its crisp given points (lip corners, eye
corners, nose tip, ...) are moved onto the geometry near them first.

:func:`matched_source` is what it then does with the source when the target's points
were all found: the source's skin points are found the same way, so both faces' points
follow one convention and share the detector's habits (a mapping is only as good as
the agreement of its two sets of points; the source keeps its own FAPU, FAT and part
points).

>>> from mpeg4fba.models import reference_head
>>> from mpeg4fba.fba import FeaturePointSet
>>> face = reference_head(resolution=0.5)
>>> given = {k: face.points[k] for k in list(face.points)[:10]}
>>> face.points = FeaturePointSet(given)
>>> report = complete_points(face)
>>> report.kept == tuple(given), set(REQUIRED_POINTS) <= set(face.points), len(report.added)
(True, True, 42)
"""
from __future__ import annotations

import copy
import warnings
from dataclasses import dataclass, field
from typing import Iterable, Optional

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointSet, point_order
from .alignment import REQUIRED_POINTS
from .detect import (_PART_OF, CRISP_POINTS, FaceNotFoundError, FoundPoints,
                     find_feature_points, snap_points)

__all__ = ["PointReport", "complete_points", "matched_source"]


@dataclass(frozen=True)
class PointReport:
    """What :func:`complete_points` did: ``kept`` the given points used as given,
    ``added`` the ones found on the geometry, ``snapped`` given point -> distance moved
    (model units), ``found`` the detector's result (None when nothing was needed)."""

    kept: tuple = ()
    added: tuple = ()
    snapped: dict = field(default_factory=dict)
    found: Optional[FoundPoints] = None

    def lowest(self) -> Optional[tuple]:
        """(id, confidence) of the least confident added point, or None."""
        if self.found is None or not self.added:
            return None
        conf = self.found.confidence
        worst = min(self.added, key=lambda k: conf.get(k, 0.0))
        return worst, float(conf.get(worst, 0.0))


def complete_points(face: FaceModel, *, required: Iterable[str] = REQUIRED_POINTS,
                    snap: bool = False) -> PointReport:
    """Give ``face`` (in place) the points it lacks of ``required``, found on its
    geometry; a face with no points at all gets every point found.  Given points stay
    as given, unless ``snap`` moves the crisp ones onto the geometry.  Raises
    :class:`~mpeg4fba.cloning.detect.FaceNotFoundError` when points are needed and the
    mesh does not look like a face."""
    given = face.points
    missing = given.missing(required)
    crisp = [k for k in CRISP_POINTS if k in given] if snap else []
    if not missing and not crisp:
        return PointReport(kept=tuple(given))
    found = find_feature_points(face)          # once, for the snapping and the filling
    snapped: dict = {}
    if crisp:
        given, moved = snap_points(face, given, ids=crisp, found=found)
        snapped = {k: float(d) for k, d in moved.items()}
    take = set(found.points) if not len(given) else set(missing) & set(found.points)
    positions = {k: given[k] for k in given}
    positions.update({k: found.points[k] for k in take})
    # the found points' vertex ties only name the nearest vertex (a reader would move the
    # point onto it): they are left out, the given points keep theirs
    face.points = FeaturePointSet(positions, {k: v for k, v in given.vertices.items() if k in positions})
    if not take:
        return PointReport(kept=tuple(given), snapped=snapped)
    return PointReport(kept=tuple(given), added=tuple(point_order(take)), snapped=snapped,
                       found=found)


def matched_source(source: FaceModel, *, found: Optional[FoundPoints] = None) -> FaceModel:
    """A copy of ``source`` whose skin points are the ones
    :func:`~mpeg4fba.cloning.detect.find_feature_points` finds on it (``found``, or found
    now), for mapping it onto a target whose points were all found: the same rules and
    the same convention on both sides.  Its FAPU (from its own points), FAT, meshes and
    the points of its eyes, teeth and tongue stay its own.  A source the detector
    cannot read as a face is returned as it is, with a warning.

    >>> from mpeg4fba.models import reference_head
    >>> head = reference_head(resolution=0.5)
    >>> twin = matched_source(head)
    >>> import numpy as np
    >>> twin.fat is head.fat, twin.fapu == head.fapu
    (True, True)
    >>> bool(np.all(twin.points["3.5"] == head.points["3.5"]))      # a part's point: kept
    True
    """
    if found is None:
        try:
            found = find_feature_points(source)
        except FaceNotFoundError as e:
            warnings.warn(f"the source's points are used as given (the target's were found): {e}",
                          stacklevel=2)
            return source
    fapu = source.fapu
    positions = {k: source.points[k] for k in source.points}
    ties = dict(source.points.vertices)
    for k in found.points:
        if k in _PART_OF:
            continue
        positions[k] = found.points[k]
        ties.pop(k, None)
    out = copy.copy(source)
    out.points = FeaturePointSet(positions, ties)
    out.fapu = fapu
    return out
