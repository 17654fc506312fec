"""The feature points Facial Motion Cloning needs, checked before any work.

Pandzic's Facial Motion Cloning requires the feature points of its alignment
triangulation (the paper's Figure 7) plus the neck base and the iris centres.  Ours are
:data:`~mpeg4fba.cloning.alignment.REQUIRED_POINTS`: those of our triangulation
(package data, designed on the reference head) and 7.1, the head's centre of rotation
(where the paper names 7.2, the neck base); a FAPU must follow from them.  The rest of
what :func:`mpeg4fba.fba.requirements.required_points` asks for is put by the cloning
(:func:`~mpeg4fba.cloning.correspondence.derive_points`), and the teeth and tongue
points by :func:`~mpeg4fba.cloning.parts.match_parts`.

>>> from mpeg4fba.models import reference_head
>>> required_points_missing(reference_head(resolution=0.5))
[]
"""
from __future__ import annotations

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointError, point_order
from .alignment import REQUIRED_POINTS

__all__ = ["REQUIRED_POINTS", "required_points_missing", "check_faces"]


def required_points_missing(face: FaceModel) -> list:
    """The required feature points (:data:`REQUIRED_POINTS`) ``face`` lacks, in order."""
    return face.points.missing(REQUIRED_POINTS)


def check_faces(source: FaceModel, target: FaceModel) -> None:
    """FeaturePointError listing, for both faces, the required points they lack;
    ValueError for a face with no usable FAPU."""
    problems, ids = [], set()
    for face, which in ((source, "source"), (target, "target")):
        missing = required_points_missing(face)
        if missing:
            ids |= set(missing)
            problems.append(f"the {which} face ({face.name}) lacks feature point"
                            f"{'s' if len(missing) > 1 else ''} {', '.join(missing)}")
    if problems:
        raise FeaturePointError("facial motion cloning needs the feature points of the "
                                "alignment triangulation and 7.1 (REQUIRED_POINTS, listed in "
                                "the README's 'The feature points a face needs'): "
                                + "; ".join(problems) + " (complete_points(face) finds the "
                                "missing ones on its geometry)", point_order(ids))
    for face, which in ((source, "source"), (target, "target")):
        if face.fapu is None:
            raise ValueError(f"the {which} face ({face.name}) has no usable FAPU")
