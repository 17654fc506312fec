"""Facial Motion Cloning (Pandzic, "Facial Motion Cloning"): copy the motion of one face
onto another as a FAT.

>>> from mpeg4fba.cloning import clone, REQUIRED_POINTS
>>> len(REQUIRED_POINTS)
52

Modules: :mod:`~mpeg4fba.cloning.interp2d` (interpolation from a 2D triangle mesh, with
anti-aliasing), :mod:`~mpeg4fba.cloning.normalise` (the normalised facial space),
:mod:`~mpeg4fba.cloning.projection` and :mod:`~mpeg4fba.cloning.alignment` (the 2D
alignment space), :mod:`~mpeg4fba.cloning.lips` (lip regions), :mod:`~mpeg4fba.cloning.parts`
and :mod:`~mpeg4fba.cloning.rigid` (eyes, teeth, tongue, head), :mod:`~mpeg4fba.cloning.checks`
(feature points on the mesh, in its units), :mod:`~mpeg4fba.cloning.detect` (feature
points found on a head that has none; :mod:`~mpeg4fba.cloning.autopoints` gives a face
the ones it lacks), :mod:`~mpeg4fba.cloning.points` (the points the method needs),
:mod:`~mpeg4fba.cloning.surface` (closest points, warp, normals on meshes),
:mod:`~mpeg4fba.cloning.registration` (the non-rigid ICP and its sparse solves).

The steps of the method, one module each, in the order
:class:`~mpeg4fba.cloning.fmc.FacialMotionCloner` (:mod:`~mpeg4fba.cloning.fmc`) runs
them: :mod:`~mpeg4fba.cloning.skin` (both faces' skin in the normalised and alignment
spaces), :mod:`~mpeg4fba.cloning.correspondence` (alignment and registration),
:mod:`~mpeg4fba.cloning.weights` (the mapping, lip and eyelid rule included),
:mod:`~mpeg4fba.cloning.transfer` (the motion of every table through the mapping) and
:mod:`~mpeg4fba.cloning.part_motion` (eyes, teeth, tongue, head).
:mod:`~mpeg4fba.cloning.local_frames`: Kong et al.'s local-frame cloning for faces that
share a mesh; :mod:`~mpeg4fba.cloning.errors`: what both cloners raise and warn.
"""
from __future__ import annotations

from .alignment import REQUIRED_POINTS, FaceSpace, align, alignment_triangles
from .checks import PlacementError, check_placement
from .autopoints import PointReport, complete_points
from .detect import CRISP_POINTS, FaceNotFoundError, FoundPoints, find_feature_points
from .snapping import LIP_EDGE_POINTS, SNAP_POINTS, snap_points
from .fmc import CloneWarning, FacialMotionCloner, PreparedSource, required_points_missing
from .api import METHODS, clone
from .job import CloneJob
from .local_frames import (LocalFrameCloner, LocalFrameWarning, TopologyError,
                           local_frame_clone)
from .interp2d import antialiased_weights, interpolate, interpolation_weights
from .lips import LOWER, OUTSIDE, SLITS, UPPER, lip_regions, slit_regions
from .normalise import Normaliser, face_center, point_units, region_factors
from .parts import PARTS, carry_part_points, find_parts, separate_parts
from .projection import MOUTH_ANGLE, Projection, choose_axis, cylindrical_projection

__all__ = ["clone", "FacialMotionCloner", "PreparedSource", "CloneJob", "LocalFrameCloner", "LocalFrameWarning",
           "TopologyError", "local_frame_clone", "CloneWarning", "required_points_missing",
           "REQUIRED_POINTS", "FaceSpace", "align", "alignment_triangles",
           "interpolation_weights", "interpolate", "antialiased_weights",
           "lip_regions", "slit_regions", "SLITS", "UPPER", "LOWER", "OUTSIDE", "PARTS", "find_parts",
           "Normaliser", "face_center", "point_units", "region_factors",
           "Projection", "choose_axis", "cylindrical_projection", "MOUTH_ANGLE",
           "PlacementError", "check_placement", "separate_parts", "carry_part_points",
           "find_feature_points", "FoundPoints", "FaceNotFoundError", "snap_points",
           "CRISP_POINTS", "LIP_EDGE_POINTS", "SNAP_POINTS", "complete_points", "PointReport"]
