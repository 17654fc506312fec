"""Give a face the feature points cloning needs: the ones it has, as given, and the
rest found on its geometry (:func:`~mpeg4fba.cloning.detect.find_feature_points`).

:func:`complete_points` is what ``mpeg4fba clone`` does with a target: a face with no
points gets every point the geometry has; a face with some keeps them and gets the
missing required ones; with ``snap=True`` its crisp given points (lip corners, eye
corners, nose tip, ...) are moved onto the geometry near them first.

:func:`matched_points` is what it then does when the target's points were all found:
it moves them into the source's convention (by how the source's given points differ
from what the detector finds on the source), so both faces' points agree; the source
keeps its points, and its FAT stays anchored on them.

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

import warnings
from dataclasses import dataclass, field
from typing import Iterable, Optional, Union

import numpy as np

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointSet, point_order
from .alignment import REQUIRED_POINTS
from .detect import PART_OF, PUPIL_OPENINGS, FaceNotFoundError, FoundPoints, find_feature_points
from .snapping import SNAP_POINTS, snap_points
from .surface import onto_same_sheet

__all__ = ["PointReport", "complete_points", "matched_points"]


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
                    snap: bool = False, source: Optional[FaceModel] = None,
                    source_found=None) -> PointReport:
    """Give ``face`` (in place) the points it lacks of ``required``, found on its
    geometry; a face with no points at all gets every point found.  Given points stay
    as given, unless ``snap`` moves them onto the geometry
    (:func:`~mpeg4fba.cloning.snapping.snap_points`: the crisp ones, and the inner lips'
    across the slit, in the convention of ``source``, the face the motion comes from,
    when given; ``source_found``: its found points, or a
    :class:`~mpeg4fba.cloning.detect.FaceNotFoundError`).  Raises
    :class:`~mpeg4fba.cloning.detect.FaceNotFoundError` when points are needed and the
    mesh does not look like a face."""
    given = face.points
    missing = given.missing(required)
    crisp = [k for k in SNAP_POINTS if k in given] if snap else []
    if not missing and not crisp:
        return PointReport(kept=tuple(given))
    found = find_feature_points(face)          # once, for the snapping and the filling
    snapped: dict = {}
    if crisp:
        if isinstance(source_found, FaceNotFoundError):
            source = source_found = None
        given, moved = snap_points(face, given, ids=crisp, found=found, source=source,
                                   source_found=source_found)
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



def matched_points(target: FaceModel, found: FoundPoints, source: FaceModel, *,
                   source_found: Union[FoundPoints, FaceNotFoundError, None] = None) -> FeaturePointSet:
    """The target's ``found`` points moved into the source's convention: each skin point
    by the difference, on the source, between its given point and the one
    :func:`~mpeg4fba.cloning.detect.find_feature_points` finds there (``source_found``,
    or found now; a :class:`~mpeg4fba.cloning.detect.FaceNotFoundError` there stands for
    a source the detector could not read), taken in the detector's frame of each face (eye separations, so it
    scales with the face), then put back on the target's mesh.

    A mapping is only as good as the agreement of its two faces' points: where the
    source's modeller put a lip corner a little further in than the detector's rules,
    the target's goes a little further in too.  The source keeps its points, so its FAT
    stays anchored on them.  Points of parts (eyes, teeth, tongue), points the source
    lacks, and all points when the detector cannot read the source as a face (with a
    warning) stay as found; but a pupil put at its eye opening's centre, the target
    having no eyeball, takes the source's pupil's offset from the source's opening.  The
    moved points are tied to a vertex of the sheet they lie on (for the mapping; a
    sidecar keeps the positions).

    >>> from mpeg4fba.models import reference_head
    >>> head = reference_head(resolution=0.5)
    >>> found = find_feature_points(head)
    >>> same = matched_points(head, found, head, source_found=found)   # onto itself
    >>> import numpy as np
    >>> # back to its own points (at the lip corner, where the lips' sheets meet, to 0.3 mm)
    >>> bool(np.allclose(same["2.4"], head.points["2.4"], atol=5e-3 * head.fapu.ES0))
    True
    """
    positions = {k: found.points[k] for k in found.points}
    ties: dict = {}
    if source_found is None:
        try:
            source_found = find_feature_points(source)
        except FaceNotFoundError as e:
            source_found = e
    if isinstance(source_found, FaceNotFoundError):
        warnings.warn(f"the found points are used as found (the source {source.name} "
                      f"is not read as a face: {source_found})", stacklevel=2)
        return FeaturePointSet(positions)
    ss, Rs = source_found.fit["s"], source_found.fit["R"]
    st, Rt = found.fit["s"], found.fit["R"]

    def moved(k: str, source_ref: np.ndarray) -> np.ndarray:
        # the target's found point moved by the source's given point's offset from
        # ``source_ref``, taken in the source's template frame (eye separations), then
        # put in the target's model frame
        d = ss * (np.asarray(source.points[k]) - source_ref) @ Rs.T
        return found.points[k] + d @ Rt / st

    # a pupil put at its eye opening's centre (no eyeball on the target) takes the
    # source's pupil's offset from the centre of the source's opening found by the same
    # rule: the canthi lie well behind the cornea, so the centre alone is 7 % of the eye
    # distance behind and 3 % below an eyeball's pupil (ICT heads without eyeballs)
    for k in found.fit.get("opening_pupils", ()):
        eye = PUPIL_OPENINGS[k]
        if k not in source.points or not all(e in source_found.points for e in eye):
            continue
        positions[k] = moved(k, np.mean([source_found.points[e] for e in eye], axis=0))
    by_mesh: dict = {}
    for k in found.points:
        if k in PART_OF or k not in source.points or k not in source_found.points:
            continue
        positions[k] = moved(k, source_found.points[k])
        tie = found.points.vertices.get(k)
        if tie is not None and tie[0] in target.meshes:
            by_mesh.setdefault(tie[0], []).append(k)
    for mesh, keys in by_mesh.items():
        V = target.world_vertices(mesh)
        T = target.meshes[mesh].triangles
        # back onto the sheet the point was found on (a surface facing away counts a
        # tenth of an eye separation further)
        tri, bary = onto_same_sheet(np.array([found.points[k] for k in keys]),
                                    np.array([positions[k] for k in keys]), V, T, 0.1 / st)
        on = np.einsum("nk,nkc->nc", bary, V[T[tri]])
        positions.update(zip(keys, on))
        # tied to a vertex of the sheet it lies on (the nearest vertex of all can be the
        # other lip's, a tenth of a millimetre away across a closed mouth)
        corner = T[tri, np.argmax(bary, axis=1)]
        ties.update({k: (mesh, int(v)) for k, v in zip(keys, corner)})
    return FeaturePointSet(positions, ties)
