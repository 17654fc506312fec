"""Facial Motion Cloning (Pandzic): copy every FAP, viseme and expression of a source
face onto a target face, as a FAT.

The steps, each in its own module:

0. Before any work: the required points (:data:`REQUIRED_POINTS`; the rest of what
   :func:`mpeg4fba.fba.requirements.required_points` asks for is put by the cloning),
   the points on the meshes in the meshes' units (:mod:`~mpeg4fba.cloning.checks`);
   teeth and tongue points the target lacks carried over from the source, and parts
   welded into another mesh split off (:mod:`~mpeg4fba.cloning.parts`).
1. Both faces' skin (every mesh that is not an eye, teeth or tongue,
   :mod:`~mpeg4fba.cloning.parts`) go to the 2D alignment space
   (:class:`~mpeg4fba.cloning.alignment.FaceSpace`: normalised, then cylindrically
   projected), and the target is aligned on the source by its feature points
   (:func:`~mpeg4fba.cloning.alignment.align`), then, by default, on the source's
   surface (:data:`ALIGNMENTS`).
2. The lip (and eyelid) regions of both are found (:mod:`~mpeg4fba.cloning.lips`).
3. The mapping is built once: for every target skin vertex, anti-aliased weights over
   the source skin vertices (:func:`~mpeg4fba.cloning.interp2d.antialiased_weights`,
   overlaps resolved by the outermost surface; target upper-lip vertices see no source
   lower-lip vertex and vice versa), one sparse matrix ``W``.
4. Every motion of the source (each table at each of its interval borders) is taken in
   the normalised facial space (divided by the regional FAPU factors of its vertex) and
   back in the target's units (multiplied by the target's factors for the same region),
   all at once as one sparse matrix ``S``; the target's motions are ``W @ S``
   (``scale_motion=False`` skips the scaling, a pure mapping; see :meth:`_scale` for why
   the region is the source vertex's).
5. The eyes, teeth, tongue and head: motion of the Transform that carries them in the
   source is carried over to the target's Transform for the same part (found, or
   installed when the target has none or its centre of rotation is wrong); motion of
   their meshes is fitted with a rigid motion and carried over the same way, or, when
   it is not rigid (a pupil dilating, a tongue curling), mapped vertex to vertex in 3D.
6. Each target table gets the source's interval borders: the target's displacement at
   each border, differenced, gives the per-interval displacements of FaceDefMesh.
   Tables that move nothing on the target (the eyeball FAPs of a head without
   eyeballs) are left out, with one warning per missing part; skin points the
   target lacks and its FAPs need (the ears') are put where the mapping places the
   source's (:meth:`FacialMotionCloner.derive_points`).

Example
-------
>>> from mpeg4fba.models import reference_head
>>> source = reference_head(resolution=0.5)
>>> target = reference_head(resolution=0.5, face_width=1.1, jaw=0.9, seed=3)
>>> target.fat = FAT()
>>> cloned = clone(source, target)
>>> len(cloned.fat.faps), len(cloned.fat.visemes), len(cloned.fat.expressions)
(66, 14, 6)
"""
from __future__ import annotations

import dataclasses
import warnings
from functools import cached_property
from typing import Optional, Sequence, Union

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..fba.face import FaceModel, FaceTransform
from ..fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform, interval_weights
from ..fba.featurepoints import FeaturePointError, FeaturePointSet, point_order
from ..fba.requirements import NOT_SURFACE, fap_points, required_points
from ..fba.stream import FapStream
from .alignment import REQUIRED_POINTS, FaceSpace, align
from .interp2d import antialiased_weights
from .lips import LIPS, OUTSIDE, SLITS, opposite, slit_regions
from .checks import check_placement
from .parts import (HEAD, PARTS, find_parts, lowest_common_transform, match_parts,
                    separate_parts, source_transform, target_transform)
from .projection import MOUTH_ANGLE
from .rigid import axis_angle, fit_rigid, rotation_centre, sphere_centre
from .surface import (REGISTRATION_FINE_SCALES, REGISTRATION_MEMBRANE, closest_points,
                      feature_warp, loop_correspondence, neck_cut, register_surface,
                      surface_biharmonic, surface_weights, triangle_edges, triangle_normals,
                      vertex_normals)

__all__ = ["clone", "FacialMotionCloner", "CloneWarning", "required_points_missing",
           "OVERLAP_RULES", "OUTSIDE_RULES", "METHODS", "ALIGNMENTS", "NECK_RATIO",
           "INTERPOLATIONS", "FACING", "FACING_RESOLUTION", "LOOSE_PIN_RESOLUTION",
           "visible_triangles"]

_SPEC = {p.name: p for p in PARTS}


#: (This and :data:`OUTSIDE_RULES` are rules of the 2D interpolation,
#: ``interpolation="2d"``.)  How overlapping source triangles are chosen between:
#: "front", the smallest depth (the outermost surface, the paper's rule), or "nearest"
#: (the default), the surface whose depth is nearest the target vertex's own aligned
#: depth, so hidden surfaces - the scalp under hair, the inside of the lips, under the
#: chin - map to hidden surfaces.  On ICT
#: identities (benchmarks/bench_clone_ict.py) "nearest" halves the mean error of "front"
#: (0.117 against 0.220 % of the eye distance, same mesh, paper's alignment, motion
#: copied as is).
OVERLAP_RULES = ("front", "nearest")
#: With overlap="nearest", triangles passing this close (alignment-space units, about
#: 0.6 mm on a human face) to a target point count among those holding it: a surface
#: seen edge-on by the projection (the inside of the lips) is a row of slivers in 2D.
_NEAREST_SLACK = 0.01


#: How a target point that falls outside every source triangle (in an eye opening, the
#: mouth slit, past the edge of the mesh) picks the triangle it takes its motion from, by
#: the paper's excess-barycentric distance: among the 16 triangles with the nearest
#: centroids ("nearby", the default), or among all triangles ("global", the letter of the
#: paper).  The measure is in units of each triangle's own size, so over a mesh whose
#: triangles vary in size "global" often prefers a large triangle far away to the small
#: ones at the edge of the hole: on the 30,000-vertex reference heads 18 % of such points
#: took their motion from more than 3 times the distance of the nearest triangle, up to
#: the width of the face (and the search is some 300 times slower).
OUTSIDE_RULES = ("nearby", "global")


#: How the target is aligned on the source.  "paper": the paper's alignment alone (feature
#: points onto the source's, the rest pulled by interpolation over the feature point
#: triangulation, in 2D).  "surface" (the default) then places the target on the
#: source's surface in 3D, in the normalised space, in five steps:
#:
#: 1. the thin-plate spline that takes the target's feature points onto the source's
#:    warps all its skin vertices (:func:`~mpeg4fba.cloning.surface.feature_warp`);
#: 2. with ``neck=True``, the neck cuts are pinned onto each other (:data:`NECK_RATIO`);
#: 3. with ``register=True``, the target's main skin is fitted onto the source's by a
#:    non-rigid ICP whose stiffness (thin plate and membrane, ``membrane``) relaxes
#:    from the size of the face to a sixteenth of it, feature points held
#:    (:func:`~mpeg4fba.cloning.surface.register_surface`).  The warp is exact only
#:    at the feature points; between them a surface can end up at the right place but
#:    slid along itself (a throat displaced down the neck, the underside of the chin
#:    shifted back), which a closest point can't see and the fit corrects, since a
#:    slid surface no longer matches the source's where it bends;
#: 4. each vertex goes to its closest point on the source's surface (of its mesh
#:    group), whose 2D position is its aligned position for the lip and eyelid regions;
#: 5. with ``register=True`` and ``refine=True``, the fit goes on to a sixty-fourth of
#:    the face (:data:`~mpeg4fba.cloning.surface.REGISTRATION_FINE_SCALES`), feature
#:    points where the target is much coarser than the source held loosely
#:    (:data:`LOOSE_PIN_RESOLUTION`), and its result is the surface points the surface
#:    weights are taken at; the regions stay with step 4, since a vertex following the
#:    source's facets can cross the mouth's mid line.
#:
#: 2D interpolation between feature points can't see how a surface seen edge-on by the
#: projection (under the chin, the neck) differs between two faces; the 3D steps can.
#: On six pairs of ICT identities onto decimated skins (``benchmarks/bench_clone_ict.py
#: --pairs``), the median of the largest errors falls from 17 % of the eye distance
#: (paper) to 12 (steps 1 and 4 with 2D weights) and 2.7 (all five steps, surface
#: weights), the mean error from 0.21 to 0.13 and 0.060 %.
ALIGNMENTS = ("surface", "paper")

#: Where the target's weights over the source's vertices come from.  "2d": the paper's
#: interpolation in the 2D projection at the aligned position (overlaps resolved by
#: :data:`OVERLAP_RULES`, points outside all triangles by :data:`OUTSIDE_RULES`), with
#: the anti-aliasing filter around it in 2D.  "surface" (the default with the surface
#: alignment): the barycentric weights of the closest point on the source's surface
#: itself, and the filter on the surface (points on a circle of radius ``support`` round
#: it, in the normalised space where the eye separation is 1, carried over the mesh:
#: :func:`~mpeg4fba.cloning.surface.surface_weights`).  The cylindrical projection
#: squeezes the neck and the underside of the chin near its axis, where a small error in
#: 2D is a large one on the surface and depth no longer tells surfaces apart; the
#: surface weights take the motion from where the alignment put the vertex.  The lip and
#: eyelid rule holds in both: a vertex of one side takes nothing from source triangles
#: wholly on the other side.
INTERPOLATIONS = ("surface", "2d")

#: Neck cuts: no feature point lies below the chin, so the warp guesses how the target's
#: neck lies along the source's, and a longer neck slides down the shorter one (on ICT,
#: 1 to 2 cm at the bottom, and the steep fall-off of jawOpen's motion down the throat
#: lands 5 mm too low).  When both main skins are open at the neck (a boundary loop
#: below the chin winding round the spine, :func:`~mpeg4fba.cloning.surface.neck_cut`),
#: the target's cut is pinned onto the source's (point for point by the angle round the
#: neck), and the difference spreads over the target's surface as the smoothest
#: (bilaplacian) field that is 0 at every feature point: the neck stretches evenly
#: between the jaw and the cut.  Two cuts whose distances below the chin differ by more
#: than this factor (in the normalised space) are not taken to be the same place (a
#: bust against a head), and the neck is left to the warp, with a :class:`CloneWarning`.
#: ICT identities' cuts, the same place on the same mesh, differ by up to 1.5 there.
#: The pinned cut is where the registration (step 3) starts, not a constraint on it: two
#: cuts do not correspond point for point as well as their angles round the neck say
#: (on ICT, where both are the same vertices, pairing by angle is 4 to 14 % of the eye
#: distance off on average), and holding them made the fit worse on four of six ICT
#: pairs.  With the registration on, pinning changes ICT's figures little (six pairs:
#: mean 0.0665 against 0.0673 % of the eye distance, 97 against 95 errors over 2 %);
#: without it, it cuts the throat's errors (ICT 1 -> 2: largest 4.8 -> 2.9 %).
NECK_RATIO = 2.0

#: Which way a surface faces, with the surface interpolation: where two sheets of the
#: source touch (the closed lips, whose inner faces meet along the mouth line; the
#: eyelids) a target vertex placed a fraction of a millimetre off lands on the wrong
#: one, and the lip regions don't always prevent it (inside the mouth the upper and
#: lower regions of a uv polygon mean little).  So the surface point is chosen by
#: distance plus ``facing * (1 - cos) / 2``, cos between the source triangle's normal
#: and the target vertex's (:func:`~mpeg4fba.cloning.surface.closest_points`): a sheet
#: facing the other way counts as ``facing`` further off (normalised space, eye
#: separation 1; 0 turns it off).  A target normal counts only where the target's mesh
#: is about as fine as the source's there (:data:`FACING_RESOLUTION`) and agrees with
#: its own triangles (a fold, a sliver); a target wound the other way round from the
#: source (most normals against the source's) has its normals reversed first.  On six
#: ICT identity pairs onto the full mesh (``benchmarks/bench_clone_ict.py --pairs
#: --same-mesh``) 0.01 takes the median of the largest errors from 14.6 to 3.1 % of the
#: eye distance, flipped triangles from 102 to 20 and the mean error from 0.070 to
#: 0.065 %; with 0.005 the median of the largest errors stays at 8.3 %, 0.02 changes
#: little more.  The default's figures on the decimated skins do not change: their
#: normals are too coarse to count.
FACING = 0.01
#: The coarsest a target's mesh may be against the source's (mean edge length round a
#: target vertex over that round the source vertex nearest its surface point) for its
#: normal to count with :data:`FACING`.  A coarse mesh's normal at a lip or eyelid rim
#: averages both sides, and a decimated mesh has folded patches whose normals agree
#: with each other but not with the surface: on the ICT skins decimated to a quarter,
#: the mouth's vertices are 2 to 4 times as coarse as the source's, the full meshes'
#: within 1.8 times.  Without this rule a vertex of such a patch at a mouth corner
#: (ICT 2 -> 1, decimated) went from 0.2 to 6.5 % of the eye distance.
FACING_RESOLUTION = 2.0
#: How much coarser than the source (as for :data:`FACING_RESOLUTION`) the target's mesh
#: must be round a feature point for the point to be held loosely in the finer fit
#: (``refine=True``): pulled to its place on the source like any vertex to the surface,
#: then put back there exactly.  A held point ties its neighbours to it over an edge of
#: the target, and on a coarse mesh that edge is longer than the scales the finer fit
#: works at: on ICT 1 -> 2 decimated, a vertex 4 % of the eye distance behind the left
#: lip corner (2.4), joined to it by one sliver, was dragged along with it, 1.2 % IOD
#: from its true place (1.0 loosely, 0.75 on the full mesh) and 2.36 % IOD off under
#: jawOpen (1.91 loosely).  On a mesh as fine as the source's, holding the points is
#: right: loosened there, the lip corners' neighbours slide 0.7 % IOD along the lips
#: (1 -> 2 onto the full mesh: largest error 2.56 -> 7.25).  On six ICT pairs
#: (``benchmarks/bench_clone_ict.py --pairs``) the decimated targets' points are 1.2 to
#: 24 times as coarse as the source's (medians 3.1 to 3.7 on 1 -> 2, 3 -> 4, 5 -> 6),
#: the full meshes' 0.6 to 1.5 times.  Loosening above 2 takes the decimated targets'
#: median of the largest errors from 2.71 to 2.49 % IOD, errors over 2 % from 76 to 74
#: and flips from 3 to 2, and leaves the full meshes as they were (above 1.5: the same;
#: above 3: a median of 2.63).
LOOSE_PIN_RESOLUTION = 2.0


#: How near (normalised space, eye separation 1) the mapping must place some target skin
#: vertex to a source feature point for that vertex to become the target's point when
#: the target lacks it (:meth:`FacialMotionCloner.derive_points`): 0.05 is 3 mm on a
#: human face, a few of the target's edges.  Too small: a coarse target gets no ear
#: points and loses the ear FAPs (with a warning); too large: a head without ears gets
#: ear points on its cheek, and ear FAPs that move the cheek.
DERIVE_DISTANCE = 0.05


def _runs(numbers) -> str:
    """Sorted integers as runs: ``_runs([23, 24, 25, 43]) == "23-25, 43"``."""
    out, run = [], []
    for n in sorted(set(numbers)):
        if run and n != run[-1] + 1:
            out.append(f"{run[0]}-{run[-1]}" if len(run) > 2 else ", ".join(map(str, run)))
            run = []
        run.append(n)
    if run:
        out.append(f"{run[0]}-{run[-1]}" if len(run) > 2 else ", ".join(map(str, run)))
    return ", ".join(out)


def _no_point(part: str, face: FaceModel) -> str:
    """Why ``face`` has no ``part`` when no component was refused."""
    ids = _SPEC[part].points
    if any(fp in face.points for fp in ids):
        return f"no mesh of its own at its point {' or '.join(ids)}"
    return (f"no point {' or '.join(ids)} given, and no mesh shaped like the source's "
            "where it would be")


class CloneWarning(UserWarning):
    """Something of the source's motion could not be carried to the target."""


def required_points_missing(face: FaceModel) -> list:
    """The required feature points (:data:`REQUIRED_POINTS`) ``face`` lacks, in order."""
    return face.points.missing(REQUIRED_POINTS)


def _check_faces(source: FaceModel, target: FaceModel) -> None:
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


def visible_triangles(corner_regions: np.ndarray, hide: int) -> np.ndarray:
    """(m,) bool: which source triangles, by the regions of their corners (m, 3), a
    target vertex of the side opposite ``hide`` may take motion from: those with at most
    one corner on the ``hide`` side.  One is allowed because where the mesh joins the
    two sides (the corners of the mouth and eyes) both move the skin; two make the
    triangle the other side's: a lower-lip vertex at the mouth corner of ICT 3 -> 4 (full
    mesh) took the upper lip's motion from such a triangle, 11 % of the eye distance off
    under jawOpen.

    >>> visible_triangles(np.array([[1, 1, 1], [1, 1, 0], [1, 2, 0], [0, 0, 0]]), 1).tolist()
    [False, False, True, True]
    """
    return (np.asarray(corner_regions) == hide).sum(axis=1) < 2


def _linear(face: FaceModel, transform: Optional[str]) -> np.ndarray:
    return face.world_matrix(transform)[0][:3, :3]


class FacialMotionCloner:
    """The target-to-source mapping of two faces, built once; :meth:`clone` then makes
    the target's FAT and :meth:`map_skin` maps any set of source skin motions.

    Parameters: ``support`` (radius of the anti-aliasing filter in the alignment space,
    0 to turn it off) and ``samples`` (points on its circle); ``scale_motion`` (normalise
    motion by the regional FAPU factors, the paper's method; False copies it as is);
    ``positions`` ("global" or "regional", see :mod:`~mpeg4fba.cloning.alignment`);
    ``triangulation`` ("fixed", "delaunay" or id triples); ``lips`` (treat the lip
    regions) and ``eyelids`` (the same for the eyelids, :mod:`~mpeg4fba.cloning.lips`); ``by_mesh`` (map meshes to their counterparts, :meth:`_mesh_groups`; False:
    every target skin mesh from all the source's, the paper's single face mesh);
    ``alignment`` (:data:`ALIGNMENTS`); ``neck`` (pin the neck cuts onto each other,
    :data:`NECK_RATIO`); ``register`` (fit the target's skin onto the source's, step 3 of
    :data:`ALIGNMENTS`; ``membrane`` weighs its membrane term against its thin plate,
    :data:`~mpeg4fba.cloning.surface.REGISTRATION_MEMBRANE`, 0 for the thin plate
    alone; ``refine``: go on to
    :data:`~mpeg4fba.cloning.surface.REGISTRATION_FINE_SCALES` for the surface points,
    the regions staying with the stiffer fit; ``loose_pins``: how much coarser than the
    source the target must be round a feature point for it to be held loosely there,
    :data:`LOOSE_PIN_RESOLUTION`, ``inf`` to hold them all fast); ``interpolation``
    (:data:`INTERPOLATIONS`; by default "surface" with the surface alignment, "2d" with the paper's); ``facing`` (with the surface
    interpolation, how much a source sheet facing against the target vertex counts
    against it, :data:`FACING`, 0 to turn it off); ``overlap`` (:data:`OVERLAP_RULES`); ``outside`` (:data:`OUTSIDE_RULES`); ``rigid_tolerance`` (how far a part's mesh motion may be from rigid, as a
    fraction of its size, to become a Transform motion); ``min_motion`` (target vertices
    moving less than this fraction of a table's largest motion are left out of it).
    """

    def __init__(self, source: FaceModel, target: FaceModel, *, support: float = 0.02,
                 samples: int = 8, scale_motion: bool = True, positions: str = "global",
                 triangulation: Union[str, Sequence] = "fixed", lips: bool = True,
                 eyelids: bool = True,
                 mouth_angle: float = MOUTH_ANGLE, rigid_tolerance: float = 0.05,
                 min_motion: float = 1e-3, outside: str = "nearby", overlap: str = "nearest",
                 by_mesh: bool = True, alignment: str = "surface", neck: bool = True,
                 register: bool = True, interpolation: Optional[str] = None,
                 membrane: float = REGISTRATION_MEMBRANE, facing: float = FACING,
                 refine: bool = True, loose_pins: float = LOOSE_PIN_RESOLUTION):
        _check_faces(source, target)
        if outside not in OUTSIDE_RULES:
            raise ValueError(f"outside must be one of {OUTSIDE_RULES}, not {outside!r}")
        exact = outside == "global"
        self.outside = outside
        if overlap not in OVERLAP_RULES:
            raise ValueError(f"overlap must be one of {OVERLAP_RULES}, not {overlap!r}")
        self.overlap = overlap
        for face, which in ((source, "source"), (target, "target")):
            check_placement(face, which)
        #: the target's part points carried over from the source (teeth and tongue given
        #: without points), id -> (mesh, vertex)
        matched, self.carried_points = match_parts(source, target)
        if self.carried_points:
            target = _with_points(target, self.carried_points)
            ids = point_order(self.carried_points)
            warnings.warn(f"the target's feature point{'s' if len(ids) > 1 else ''} "
                          f"{', '.join(ids)} (its teeth, tongue) were carried over from the "
                          "source's by its other points; give them to place them yourself",
                          CloneWarning, stacklevel=2)
        # eyes, teeth, tongue welded into another mesh become meshes of their own (the
        # cloned face is the target so split)
        source, target = separate_parts(source), separate_parts(target, matched)
        self.source, self.target = source, target
        self.scale_motion = bool(scale_motion)
        self.by_mesh = bool(by_mesh)
        self.rigid_tolerance = float(rigid_tolerance)
        self.min_motion = float(min_motion)
        self.source_parts = find_parts(source)
        # the Transform carrying each source part's motion (None: its meshes move alone)
        self.source_transforms = {p: source_transform(source, m) for p, m in self.source_parts.items()}
        #: part name -> why the target has no such part (for the warning)
        self.target_missing_parts: dict = {}
        self.target_parts = find_parts(target, self.target_missing_parts)
        self.src = _Skin(source, self.source_parts, positions, mouth_angle)
        self.tgt = _Skin(target, self.target_parts, positions, mouth_angle)
        for skin, face, which in ((self.src, source, "source"), (self.tgt, target, "target")):
            if not len(skin.vertices):
                raise ValueError(f"the {which} face ({face.name}) has no skin: all its meshes "
                                 "were taken for eyes, teeth or tongue, by the feature points "
                                 "3.5, 3.6, 9.8-9.11 and 6.1-6.4 they hold")
        if alignment not in ALIGNMENTS:
            raise ValueError(f"alignment must be one of {ALIGNMENTS}, not {alignment!r}")
        self.alignment = alignment
        if interpolation is None:
            interpolation = "surface" if alignment == "surface" else "2d"
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"interpolation must be one of {INTERPOLATIONS}, not {interpolation!r}")
        if interpolation == "surface" and alignment != "surface":
            raise ValueError('interpolation="surface" needs alignment="surface" (the target '
                             "placed on the source's surface in 3D)")
        self.interpolation = interpolation
        self.neck = bool(neck)
        self.register = bool(register)
        self.refine = bool(refine)
        self.membrane = float(membrane)
        if not np.isfinite(self.membrane) or self.membrane < 0:
            raise ValueError(f"membrane must be a finite number >= 0, not {membrane!r}")
        self.facing = float(facing)
        if not np.isfinite(self.facing) or self.facing < 0:
            raise ValueError(f"facing must be a finite number >= 0, not {facing!r}")
        self.loose_pins = float(loose_pins)
        if np.isnan(self.loose_pins) or self.loose_pins < 0:
            raise ValueError(f"loose_pins must be a number >= 0 (inf: never), not {loose_pins!r}")
        #: whether the neck cuts were pinned onto each other (:data:`NECK_RATIO`)
        self.neck_pinned = False
        #: with alignment="surface": the target's skin vertices placed on the source's
        #: surface, in the source's normalised space (None with the paper's alignment)
        self.surface_points: Optional[np.ndarray] = None
        self.aligned, self.aligned_depth, self.alignment_ids, self.alignment_triangles = align(
            self.tgt.space, self.src.space, triangulation)
        if alignment == "surface":
            self._surface_align()
        self.source_regions = self.target_regions = None
        tris = self.src.triangles
        uv = self.src.space.uv
        if interpolation == "2d":
            # a triangle wrapping round the back of the head (across angle +-pi) would
            # cover the whole face in 2D
            spread = np.ptp(uv[tris][:, :, 0], axis=1)
            tris = tris[spread < np.pi]
        self.slits = (LIPS,) * bool(lips) + SLITS[1:] * bool(eyelids)
        if self.slits:
            pts = {k: self.src.space.point_uv(k) for k in self.src.space.ids}
            self.source_regions = slit_regions(uv, pts, slits=self.slits,
                                               triangles=self.src.triangles,
                                               vertices=self.src.vertices)
            self.target_regions = slit_regions(self.aligned, pts, slits=self.slits,
                                               triangles=self.tgt.triangles,
                                               vertices=self.tgt.vertices)
        self.weights = self._weights(tris, support, samples, exact)
        self._part_maps: dict = {}

    # -- the skin ---------------------------------------------------------------------------
    def _weights(self, tris, support, samples, exact) -> sp.csr_matrix:
        src_uv, depth = self.src.space.uv, self.src.space.depth
        nt = len(self.aligned)

        # the target's feature point vertices take the unfiltered interpolation, so each
        # FAP moves its feature point by exactly what it moves the source's (the filter
        # would shave the peak of a motion centred on the point)
        points = self.tgt.point_vertices()
        filtered = np.ones(nt, dtype=bool)
        filtered[points] = False

        zq = self.aligned_depth if self.overlap == "nearest" else None
        radius = self._support(support)

        normals = self._facing_normals() if self.interpolation == "surface" else None

        def weights(rows: np.ndarray, triangles: np.ndarray) -> sp.csr_matrix:
            if self.interpolation == "surface":
                r = np.where(filtered[rows], radius[rows], 0.0)
                return surface_weights(self.surface_points[rows], self.src.normalised,
                                       triangles, r, samples,
                                       normals=None if normals is None else normals[rows],
                                       facing=self.facing)
            out = antialiased_weights(src_uv, triangles, self.aligned[rows], depth,
                                      support=radius[rows], samples=samples, exact=exact,
                                      query_depth=None if zq is None else zq[rows],
                                      slack=_NEAREST_SLACK)
            plain = np.flatnonzero(~filtered[rows])
            if len(plain) and support > 0:
                lil = out.tolil()
                lil[plain] = antialiased_weights(
                    src_uv, triangles, self.aligned[rows[plain]], depth, support=0, exact=exact,
                    query_depth=None if zq is None else zq[rows[plain]], slack=_NEAREST_SLACK)
                out = lil.tocsr()
            return out

        treg = self.target_regions
        if treg is None:
            treg = np.full(nt, OUTSIDE, dtype=np.int8)
        sreg = self.source_regions
        tri_mesh = self.src.mesh_index[tris[:, 0]]
        blocks, order = [], []
        for group_rows, source_meshes in self._mesh_groups():
            in_group = np.isin(tri_mesh, source_meshes)
            for which in np.unique(treg[group_rows]):
                rows = group_rows[treg[group_rows] == which]
                hide = opposite(int(which))
                keep = in_group if hide == OUTSIDE else in_group & visible_triangles(sreg[tris], hide)
                blocks.append(weights(rows, tris[keep]))
                order.append(rows)
        w = sp.vstack(blocks).tocsr()
        perm = np.empty(nt, dtype=np.int64)
        perm[np.concatenate(order)] = np.arange(nt)
        return w[perm]

    def _facing_normals(self) -> Optional[np.ndarray]:
        """(Nt, 3) unit normals of the target's skin vertices in the normalised space for
        :data:`FACING`, zero where they don't count (see :data:`FACING_RESOLUTION`);
        None with ``facing=0``."""
        if self.facing <= 0:
            return None
        out = np.zeros((len(self.tgt.normalised), 3))
        src_n = vertex_normals(self.src.normalised, self.src.triangles)
        for name, (first, n) in self.tgt.offsets.items():
            v = self.tgt.normalised[first:first + n]
            tris = self.target.meshes[name].triangles
            if not len(tris):
                continue
            normal = vertex_normals(v, tris)
            face = triangle_normals(v, tris)
            # the least agreement of a vertex's normal with its own triangles'
            agree = np.ones(n)
            for k in range(3):
                np.minimum.at(agree, tris[:, k], (face * normal[tris[:, k]]).sum(axis=1))
            ratio, near = self._coarseness(_mean_edge(v, tris),
                                           self.surface_points[first:first + n])
            if np.median((normal * src_n[near]).sum(axis=1)) < 0:
                normal = -normal          # wound the other way round from the source
            coarse = ratio > FACING_RESOLUTION
            normal[(agree <= 0.5) | coarse] = 0.0
            out[first:first + n] = normal
        return out

    @cached_property
    def _source_edges(self) -> tuple:
        """(mean edge length round each source skin vertex, rows in triangles, their
        k-d tree) in the normalised space."""
        on = np.unique(self.src.triangles)
        return _mean_edge(self.src.normalised, self.src.triangles), on, \
            cKDTree(self.src.normalised[on])

    def _coarseness(self, edges: np.ndarray, places: np.ndarray) -> tuple:
        """(ratio, near): for target vertices whose edges have the mean lengths ``edges``
        (normalised space, :func:`_mean_edge`), those over the mean edge round ``near``,
        the source skin vertex nearest each one's place on the source (``places``)."""
        edge, on, tree = self._source_edges
        _, k = tree.query(places)
        near = on[k]
        return edges / np.maximum(edge[near], 1e-300), near

    def _surface_align(self) -> None:
        """The "surface" refinement of the alignment (see :data:`ALIGNMENTS`)."""
        src, tgt = self.src.space, self.tgt.space
        common = [i for i in point_order(set(tgt.ids) & set(src.ids))
                  if i not in NOT_SURFACE or i == "7.1"]
        moving = tgt.normalise(np.array([self.target.points[i] for i in common]))
        fixed = src.normalise(np.array([self.source.points[i] for i in common]))
        warped = feature_warp(moving, fixed, self.tgt.normalised)
        if self.neck:
            warped = self._pin_neck(warped)
        if self.register:
            warped = self._register(warped)
        # the 2D positions (for the regions) from the stiffer fit, the surface points
        # from the finer one (see REGISTRATION_FINE_SCALES)
        self.surface_points = self._register(warped, REGISTRATION_FINE_SCALES, loosen=True) \
            if self.register and self.refine else warped
        source_3d = self.src.normalised
        tris = self.src.triangles
        tri_mesh = self.src.mesh_index[tris[:, 0]]
        for rows, meshes in self._mesh_groups():
            sub = np.flatnonzero(np.isin(tri_mesh, meshes))
            if not len(sub) or not len(rows):
                continue
            t, b, _ = closest_points(warped[rows], source_3d, tris[sub])
            corners = tris[sub][t]
            uv = np.einsum("nk,nkc->nc", b, src.uv[corners])
            depth = np.einsum("nk,nk->n", b, src.depth[corners])
            # a triangle across the back of the head (angle +-pi) has no usable mean
            fine = np.ptp(src.uv[corners][:, :, 0], axis=1) < np.pi
            self.aligned[rows[fine]] = uv[fine]
            self.aligned_depth[rows[fine]] = depth[fine]

    def _pin_neck(self, warped: np.ndarray) -> np.ndarray:
        """``warped`` (the target's skin in the source's normalised space) corrected so
        the target's neck cut lies on the source's (see :data:`NECK_RATIO`)."""
        cuts = []
        for skin, face in ((self.src, self.source), (self.tgt, self.target)):
            if skin.main is None:
                return warped
            first, n = skin.offsets[skin.main]
            v = skin.normalised[first:first + n]
            chin, axis = skin.space.normalise(np.array([face.points["2.1"], face.points["7.1"]]))
            loop = neck_cut(v, face.meshes[skin.main].triangles, chin, axis)
            if loop is None:
                return warped
            cuts.append((first, n, v, loop, chin[1] - v[loop, 1].mean()))
        (_, _, vs, ls, drop_s), (ft, nt, vt, lt, drop_t) = cuts
        if not 1 / NECK_RATIO <= drop_t / drop_s <= NECK_RATIO:
            warnings.warn(f"the neck cuts of {self.source.name} and {self.target.name} lie "
                          f"{drop_s:.2f} and {drop_t:.2f} (normalised) below the chin: too "
                          "far apart to be the same place, the necks are left unpinned",
                          CloneWarning, stacklevel=3)
            return warped
        residual = loop_correspondence(vt[lt], vs[ls]) - warped[ft + lt]
        points = self.tgt.main_point_rows()
        keep = ~np.isin(lt, points)
        rows = np.concatenate([points, lt[keep]])
        values = np.vstack([np.zeros((len(points), 3)), residual[keep]])
        out = warped.copy()
        out[ft:ft + nt] += surface_biharmonic(vt, self.target.meshes[self.tgt.main].triangles,
                                              rows, values)
        self.neck_pinned = True
        return out

    def _register(self, warped: np.ndarray, scales: Optional[tuple] = None,
                  loosen: bool = False) -> np.ndarray:
        """``warped`` with the target's main skin fitted onto the source's main skin
        (:func:`~mpeg4fba.cloning.surface.register_surface`, over ``scales``, by default
        its own), its feature points held; with ``loosen``, those where the target is
        coarser than the source (``loose_pins``, :data:`LOOSE_PIN_RESOLUTION`) are held
        loosely during the fit and put back at the end."""
        if self.src.main is None or self.tgt.main is None:
            return warped
        ft, nt = self.tgt.offsets[self.tgt.main]
        fs, ns = self.src.offsets[self.src.main]
        tris = self.target.meshes[self.tgt.main].triangles
        pins = self.tgt.main_point_rows()
        loose = None
        if loosen and len(pins):
            edges = _mean_edge(self.tgt.normalised[ft:ft + nt], tris)[pins]
            ratio, _ = self._coarseness(edges, warped[ft + pins])
            loose = pins[ratio > self.loose_pins]
        out = warped.copy()
        out[ft:ft + nt] = register_surface(
            self.tgt.normalised[ft:ft + nt], tris, warped[ft:ft + nt], pins,
            self.src.normalised[fs:fs + ns], self.source.meshes[self.src.main].triangles,
            membrane=self.membrane, loose=loose,
            **({} if scales is None else {"scales": scales}))
        if loose is not None:
            out[ft + loose] = warped[ft + loose]
        return out

    def _support(self, support: float) -> np.ndarray:
        """Per target vertex radius of the anti-aliasing filter: ``support``, shrinking
        to 0 at the corners of the slits (mouth and eye corners), where both sides of a
        slit meet and a filter of full size would average the two."""
        radius = np.full(len(self.aligned), float(support))
        if support <= 0 or not self.slits:
            return radius
        for slit in self.slits:
            for corner in (slit.upper[0], slit.upper[-1]):
                if corner not in self.src.space.ids:
                    continue
                d = np.hypot(*(self.aligned - self.src.space.point_uv(corner)).T)
                radius = np.minimum(radius, np.maximum(d - support, 0.0))
        return radius

    def _mesh_groups(self) -> list:
        """(target skin rows, source skin mesh indices they take motion from) per target mesh.

        A target mesh takes its motion from the source mesh of the same name when there
        is one; the target's main skin (the mesh holding most feature points) from the
        source's main skin; any other mesh from all the source's skin meshes.  So the
        face is not moved by what lies over it in 2D (eyelashes, hair, a beard mesh) and
        vice versa.
        """
        src_names = list(self.src.offsets)
        out = []
        for k, (name, (first, n)) in enumerate(self.tgt.offsets.items()):
            if not self.by_mesh:
                meshes = list(range(len(src_names)))
            elif name in self.src.offsets:
                meshes = [src_names.index(name)]
            elif name == self.tgt.main and self.src.main is not None:
                meshes = [src_names.index(self.src.main)]
            else:
                meshes = list(range(len(src_names)))
            out.append((np.arange(first, first + n), meshes))
        return out

    def map_skin(self, motion: Union[np.ndarray, sp.spmatrix]) -> Union[np.ndarray, sp.csr_matrix]:
        """Target skin motions from source skin motions.

        ``motion`` is (Ns, 3) or (Ns, 3K) (K motions side by side, x y z each) in the
        face frame, rows in the order of :attr:`source_skin`; the answer has the
        target's rows (:attr:`target_skin`), sparse for a sparse ``motion``.
        """
        scale = self._scale()
        if sp.issparse(motion):
            s = motion.tocoo(copy=True)
            if scale is not None:
                s.data = s.data * scale[s.row, s.col % 3]
            return (self.weights @ s.tocsr()).tocsr()
        s = np.asarray(motion, dtype=np.float64)
        if scale is not None:
            k = s.shape[1] // 3
            s = (s.reshape(len(s), k, 3) * scale[:, None, :]).reshape(s.shape)
        return np.asarray(self.weights @ s)

    def _scale(self) -> Optional[np.ndarray]:
        """(Ns, 3) factor taking each source vertex's motion to the target's units.

        A source vertex's motion is normalised by the FAPU of its region (its closest
        feature point) and denormalised by the target's FAPU *for the same region*, so
        the FAP units carry over exactly (a FAP moving a feature point by v x FAPU on the
        source does so on the target) and a target vertex between regions does not get
        its neighbours' motion in another region's unit (which, where the eyes' IRISD
        meets the brows' ENS, is four times off).  The target's own region is used only
        for a point the target lacks.
        """
        if not self.scale_motion:
            return None
        if getattr(self, "_scale_cache", None) is None:
            src = self.src.space.normaliser
            tgt = self.tgt.space.normaliser
            regions = src.regions(self.src.vertices)
            index = {fp: k for k, fp in enumerate(tgt.ids)}
            to_t = np.array([index.get(fp, -1) for fp in src.ids])
            t = to_t[regions]
            target_units = np.where((t >= 0)[:, None], tgt.point_factors[np.maximum(t, 0)],
                                    np.nan)
            missing = t < 0
            if missing.any():
                # a region the target has no point for: the target's nearest region there
                near = tgt.factors(self.src.space.map_point_array(self.src.vertices[missing],
                                                                  self.tgt.space))
                target_units[missing] = near
            self._scale_cache = target_units / self.src.space.motion_factors
        return self._scale_cache

    @property
    def source_skin(self) -> dict:
        """Source skin mesh name -> (first row, vertex count) in the stacked skin arrays."""
        return dict(self.src.offsets)

    @property
    def target_skin(self) -> dict:
        return dict(self.tgt.offsets)

    # -- the whole FAT ------------------------------------------------------------------------
    def clone(self) -> FaceModel:
        """The target with a FAT holding every table of the source's."""
        out = _copy_face(self.target)
        out.fat = FAT()
        tables = sorted(self.source.fat, key=lambda t: t.key)
        borders = [_borders(t) for t in tables]
        columns = self._skin_columns(tables, borders)
        mapped = self.map_skin(columns).tocsc()
        installer = _Installer(out, self)
        new_tables = []
        col = 0
        for table, b in zip(tables, borders):
            nz = b[b != 0]
            block = mapped[:, col:col + 3 * len(nz)].toarray().reshape(mapped.shape[0], len(nz), 3)
            col += 3 * len(nz)
            meshes = self._skin_table(out, b, block)
            meshes += self._part_meshes(table, b, out, installer)
            transforms = self._part_transforms(table, b, installer) + installer.extra
            installer.extra = []
            new_tables.append(FaceDefTable(table.fap, meshes, transforms, table.select))
        out.points = self.output_points
        dropped = {}
        for t in new_tables:
            lacking = out.points.missing(fap_points([t.fap]))
            if not t.meshes and not t.transforms:
                # moves nothing (the target lacks what it moved, said by the part notes):
                # it would only ask for its feature point
                continue
            if lacking:
                dropped.setdefault(tuple(lacking), []).append(t.fap)
            else:
                out.fat.add(t)
        out.invalidate()
        for message in installer.notes + self._skip_notes(installer.skipped, out.fat):
            warnings.warn(message, CloneWarning, stacklevel=2)
        for lacking, faps in dropped.items():
            warnings.warn(f"the target lacks feature point{'s' if len(lacking) > 1 else ''} "
                          f"{', '.join(lacking)} and the mapping can't put "
                          f"{'them' if len(lacking) > 1 else 'it'} (the source has "
                          f"{'them' if len(lacking) > 1 else 'it'} nowhere the target's skin "
                          f"maps to, or not at all): FAP{'s' if len(faps) > 1 else ''} "
                          f"{_runs(faps)} not cloned", CloneWarning, stacklevel=2)
        return out

    def _skip_notes(self, skipped: dict, fat: FAT) -> list:
        """One message per kind of part the target lacks (eyeballs, teeth, tongue): why,
        and which of the source's tables lost that motion or were left out."""
        out = []
        kinds = {"eye": "eyeballs", "teeth": "teeth", "tongue": "tongue"}
        for kind, label in kinds.items():
            parts = [p for p in skipped if p in _SPEC and _SPEC[p].kind == kind]
            if not parts:
                continue
            keys = set().union(*(skipped[p] for p in parts))
            gone = sorted(f for f, sel in keys if f > 2 and f not in fat.faps)
            kept = sorted(f for f, sel in keys if f > 2 and f in fat.faps)
            high = sorted({"visemes" if f == 1 else "expressions" for f, _ in keys if f <= 2})
            why = "; ".join((f"{p}: " if len(parts) > 1 else "")
                            + self.target_missing_parts.get(p, _no_point(p, self.target)) for p in parts)
            text = f"the target has no {' or '.join(parts) if kind == 'teeth' else label} ({why})"
            if gone:
                text += f"; FAP{'s' if len(gone) > 1 else ''} {_runs(gone)} not cloned"
            if kept or high:
                text += "; cloned without its motion: " + ", ".join(
                    ([f"FAP{'s' if len(kept) > 1 else ''} {_runs(kept)}"] if kept else []) + high)
            out.append(text)
        return out

    @cached_property
    def output_points(self) -> FeaturePointSet:
        """The target's feature points plus those the source's FAPs need that the target
        lacks and the mapping can put (:meth:`derive_points`)."""
        need = required_points(self.source.fat.faps, parts=self._target_kinds(), fapu=True,
                               base=REQUIRED_POINTS)
        missing = self.target.points.missing(need)
        if not missing:
            return self.target.points
        found = self.derive_points(missing)
        if not found:
            return self.target.points
        positions = {k: self.target.points[k] for k in self.target.points}
        ties = dict(self.target.points.vertices)
        for k, (mesh, vertex) in found.items():
            positions[k] = self.target.world_vertices(mesh)[vertex]
            ties[k] = (mesh, vertex)
        return FeaturePointSet(positions, ties)

    def _target_kinds(self) -> list:
        return sorted({_SPEC[p].kind for p in self.target_parts if p in _SPEC})

    def derive_points(self, ids: Sequence[str]) -> dict:
        """Point id -> (target skin mesh, vertex) for those of ``ids`` the source has on
        its skin: the target vertex the mapping places nearest the source's point, when
        it is placed within :data:`DERIVE_DISTANCE` of it (else the target has no such
        place, a face without ears, and the point stays missing)."""
        src = self.src
        wanted = [k for k in ids if k in self.source.points and k not in NOT_SURFACE]
        if not wanted or not len(self.tgt.vertices):
            return {}
        placed = self.surface_points if self.surface_points is not None else \
            np.asarray(self.weights @ src.normalised)
        at = src.space.normalise(np.array([self.source.points[k] for k in wanted]))
        # the nearest point of the target's skin as the mapping placed it, and of its
        # triangle the corner nearest to it
        tri, bary, dist = closest_points(at, placed, self.tgt.triangles, k=16)
        row = self.tgt.triangles[tri, np.argmax(bary, axis=1)]
        names = list(self.tgt.offsets)
        out = {}
        for k, d, r in zip(wanted, dist, row):
            if d > DERIVE_DISTANCE:
                continue
            mesh = names[int(self.tgt.mesh_index[r])]
            out[k] = (mesh, int(r - self.tgt.offsets[mesh][0]))
        return out

    def _skin_columns(self, tables: list, borders: list) -> sp.csr_matrix:
        """Source skin motion of every table at every non-zero border: (Ns, 3K) sparse."""
        rows, cols, vals = [], [], []
        col = 0
        for table, b in zip(tables, borders):
            nz = b[b != 0]
            for m in table.meshes:
                if m.mesh not in self.src.offsets:
                    continue
                first, _ = self.src.offsets[m.mesh]
                R = self.src.linear[m.mesh]
                w = interval_weights(m.borders, nz)                       # (nb, intervals)
                d = np.einsum("bj,kjc->kbc", w, m.displacements) @ R.T    # (k, nb, 3)
                k = len(m.indices)
                rows.append(np.repeat(first + m.indices, 3 * len(nz)))
                cols.append(np.tile(col + np.arange(3 * len(nz)), k))
                vals.append(d.reshape(-1))
            extra = self._transform_skin_motion(table, nz)
            if extra is not None:
                r, c, v = extra
                rows.append(r)
                cols.append(col + c)
                vals.append(v)
            col += 3 * len(nz)
        n = len(self.src.vertices)
        if not rows:
            return sp.csr_matrix((n, col))
        s = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(n, col)).tocsr()
        s.sum_duplicates()
        return s

    def _transform_skin_motion(self, table: FaceDefTable, nz: np.ndarray):
        """Skin motion from a Transform that is not a part's (a jaw carrying a chin mesh)."""
        part_transforms = set(self.source_transforms.values())
        movers = [t.transform for t in table.transforms if t.transform not in part_transforms]
        if not movers:
            return None
        affected = [m for m in self.src.offsets
                    if set(movers) & set(self.source.chain(self.source.meshes[m].parent))]
        if not affected:
            return None
        rows, cols, vals = [], [], []
        for j, value in enumerate(nz):
            play = _play_table(self.source, table, value)
            for m in affected:
                first, n = self.src.offsets[m]
                moved = play.world_vertices(m)[0] - self.source.world_vertices(m)
                rows.append(np.repeat(first + np.arange(n), 3))
                cols.append(np.tile(3 * j + np.arange(3), n))
                vals.append(moved.reshape(-1))
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)

    def _skin_table(self, out: FaceModel, borders: np.ndarray, block: np.ndarray) -> list:
        """FaceDefMesh entries of the target skin from its motion at the non-zero borders."""
        return self._entries(out, self.tgt.offsets, borders, block)

    def _entries(self, out: FaceModel, offsets: dict, borders: np.ndarray,
                 motion: np.ndarray) -> list:
        """FaceDefMesh entries, one per mesh of ``offsets`` (name -> (first row, count)),
        from world motion [rows, non-zero borders, 3]; vertices moving less than
        ``min_motion`` of the largest motion are left out."""
        if motion.shape[1] == 0 or not len(motion):
            return []
        norm = np.linalg.norm(motion, axis=2).max(axis=1)
        top = norm.max()
        if top <= 0:
            return []
        keep = norm > self.min_motion * top
        entries = []
        for name, (first, n) in offsets.items():
            sel = np.flatnonzero(keep[first:first + n])
            if not len(sel):
                continue
            R = _linear(out, out.meshes[name].parent)
            local = motion[first + sel] @ np.linalg.inv(R).T
            entries.append(FaceDefMesh(name, borders, sel, _intervals(borders, local)))
        return entries

    # -- eyes, teeth, tongue, head ------------------------------------------------------------
    def _part_transforms(self, table: FaceDefTable, borders: np.ndarray, inst: "_Installer") -> list:
        """Target FaceDefTransforms for the source's part Transforms this table drives."""
        out, seen = [], set()
        for part, meshes in self.source_parts.items():
            ts = self.source_transforms[part]
            entries = [e for e in table.transforms if e.transform == ts]
            if ts is None or not entries:
                continue
            if part != HEAD and ts == self.source_transforms[HEAD]:
                continue  # the head's transform moves this part; it is mapped as the head's
            if part not in self.target_parts:
                inst.skip(part, table)
                continue
            pivot = self._source_pivot(part, ts)
            tt = inst.transform(part, self._target_centre(part, pivot))
            R_s = _linear(self.source, self.source.transforms[ts].parent)
            R_t = _linear(inst.face, inst.face.transforms[tt].parent)
            for e in entries:
                if e.field == "rotation":
                    axis = R_t.T @ (R_s @ np.asarray(e.rotation[:3], float))
                    new = FaceDefTransform(tt, "rotation", rotation=(*axis, e.rotation[3]))
                elif e.field == "translation":
                    t = self._map_translation(part, R_s @ np.asarray(e.translation, float))
                    new = FaceDefTransform(tt, "translation", translation=tuple(R_t.T @ t))
                else:
                    new = FaceDefTransform(tt, "scale", scale=e.scale)
                key = (tt, new.field, new.rotation, new.translation, new.scale)
                if key not in seen:
                    seen.add(key)
                    out.append(new)
        return out

    def _source_pivot(self, part: str, transform: str) -> np.ndarray:
        t = self.source.transforms[transform]
        M = self.source.world_matrix(t.parent)[0]
        return M[:3, :3] @ (np.asarray(t.translation, float) + np.asarray(t.center, float)) + M[:3, 3]

    def _target_centre(self, part: str, source_pivot: np.ndarray) -> np.ndarray:
        """Where the target's part must turn about: an eye's centre, 7.1 for the head,
        the source's pivot carried over for teeth and tongue."""
        if part == HEAD:
            return np.asarray(self.target.points["7.1"], float)
        if _SPEC[part].kind == "eye":
            return sphere_centre(np.vstack([self.target.world_vertices(m)
                                            for m in self.target_parts[part]]))
        return self.src.space.map_point(source_pivot, self.tgt.space)

    def _anchor(self, part: str) -> Optional[str]:
        pts = _SPEC[part].points if part in _SPEC else ("7.1",)
        for fp in pts:
            if fp in self.source.points and fp in self.target.points:
                return fp
        return None

    def _map_translation(self, part: str, t_world: np.ndarray) -> np.ndarray:
        if not self.scale_motion:
            return t_world
        fp = self._anchor(part)
        if fp is None:
            return t_world
        fs = self.src.space.normaliser.factors(self.source.points[fp][None])[0]
        ft = self.tgt.space.normaliser.factors(self.target.points[fp][None])[0]
        return t_world / fs * ft

    def _part_meshes(self, table: FaceDefTable, borders: np.ndarray, out: FaceModel,
                     inst: "_Installer") -> list:
        """Targets of the motion of part meshes: a rigid motion becomes Transform entries
        (returned through ``inst.extra``), anything else is mapped vertex to vertex."""
        result = []
        nz = borders[borders != 0]
        for part, meshes in self.source_parts.items():
            if part == HEAD:
                continue
            entries = [m for m in table.meshes if m.mesh in meshes]
            if not entries:
                continue
            if part not in self.target_parts:
                inst.skip(part, table)
                continue
            x, offsets = _stack(self.source, meshes)
            motion = np.zeros((len(x), len(nz), 3))
            for m in entries:
                first, _ = offsets[m.mesh]
                R = _linear(self.source, self.source.meshes[m.mesh].parent)
                w = interval_weights(m.borders, nz)
                motion[first + m.indices] += np.einsum("bj,kjc->kbc", w, m.displacements) @ R.T
            size = float(np.ptp(x, axis=0).max()) or 1.0
            fits = [fit_rigid(x, x + motion[:, j]) for j in range(len(nz))]
            rigid = all(f.is_rigid(self.rigid_tolerance, 1e-9 * size) for f in fits) and \
                all(f.residual <= self.rigid_tolerance * size for f in fits)
            if rigid and len(nz):
                inst.extra.extend(self._rigid_entries(part, x, nz, fits, inst))
            else:
                result += self._deformation(part, borders, motion, out)
        return result

    def _rigid_entries(self, part, x, nz, fits, inst) -> list:
        j = int(np.argmax(np.abs(nz)))
        value, fit = float(nz[j]), fits[j]
        axis, angle = axis_angle(fit.rotation)
        if _SPEC[part].kind == "eye":
            pivot = sphere_centre(x)
        else:
            pivot = rotation_centre(fit, x.mean(axis=0))
        slide = fit.translation - (np.eye(3) - fit.rotation) @ pivot
        tt = inst.transform(part, self._target_centre(part, pivot) if angle > 1e-9 else None)
        R_t = _linear(inst.face, inst.face.transforms[tt].parent)
        entries = []
        if angle > 1e-9:
            entries.append(FaceDefTransform(tt, "rotation",
                                            rotation=(*(R_t.T @ axis), angle / value)))
        if np.linalg.norm(slide) > 1e-9 * (np.ptp(x, axis=0).max() or 1.0):
            t = self._map_translation(part, slide) / value
            entries.append(FaceDefTransform(tt, "translation", translation=tuple(R_t.T @ t)))
        return entries

    def _deformation(self, part: str, borders: np.ndarray, motion: np.ndarray,
                     out: FaceModel) -> list:
        """Non-rigid motion of a part mapped to the target's part meshes by 3D proximity."""
        w, t_offsets = self._part_map(part)
        k = motion.shape[1]
        s = motion.reshape(len(motion), 3 * k)
        xs, _ = _stack(self.source, self.source_parts[part])
        xt, _ = _stack(self.target, self.target_parts[part])
        if self.scale_motion:
            s = s / np.tile(self.src.space.normaliser.factors(xs), (1, k))
        d = np.asarray(w @ s)
        if self.scale_motion:
            d = d * np.tile(self.tgt.space.normaliser.factors(xt), (1, k))
        return self._entries(out, t_offsets, borders, d.reshape(len(d), k, 3))

    def _part_map(self, part: str) -> tuple:
        if part not in self._part_maps:
            xs, _ = _stack(self.source, self.source_parts[part])
            xt, offsets = _stack(self.target, self.target_parts[part])
            ps = self.src.space.normalise(xs)
            pt = self.tgt.space.normalise(xt)
            fp = self._anchor(part)
            if fp is not None:
                pt = pt + (self.src.space.normalise(self.source.points[fp][None])
                           - self.tgt.space.normalise(self.target.points[fp][None]))
            k = min(4, len(ps))
            dist, idx = cKDTree(ps).query(pt, k=k)
            dist, idx = dist.reshape(len(pt), k), idx.reshape(len(pt), k)
            inv = 1.0 / np.maximum(dist, 1e-12)
            inv[dist <= 1e-12] = 1e12
            inv /= inv.sum(axis=1, keepdims=True)
            w = sp.csr_matrix((inv.ravel(), (np.repeat(np.arange(len(pt)), k), idx.ravel())),
                              shape=(len(pt), len(ps)))
            self._part_maps[part] = (w, offsets)
        return self._part_maps[part]


class _Skin:
    """A face's skin meshes stacked: world vertices, triangles, alignment space."""

    def __init__(self, face: FaceModel, parts: dict, positions: str, mouth_angle: float):
        rigid = {m for p, ms in parts.items() if p != HEAD for m in ms}
        names = [n for n, m in face.meshes.items() if n not in rigid and len(m.vertices)]
        self.offsets: dict = {}
        self.linear: dict = {}
        verts, tris = [], []
        first = 0
        for n in names:
            m = face.meshes[n]
            self.offsets[n] = (first, len(m.vertices))
            self.linear[n] = _linear(face, m.parent)
            verts.append(face.world_vertices(n))
            tris.append(m.triangles + first)
            first += len(m.vertices)
        self.mesh_index = np.repeat(np.arange(len(names)),
                                    [len(face.meshes[n].vertices) for n in names])
        counts = {}
        for fp in face.points:
            tie = face.points.vertex(fp)
            if tie is not None and tie[0] in self.offsets:
                counts[tie[0]] = counts.get(tie[0], 0) + 1
        self.main = max(counts, key=counts.get) if counts else (names[0] if names else None)
        self.vertices = np.vstack(verts) if verts else np.zeros((0, 3))
        self.triangles = np.vstack(tris) if tris else np.zeros((0, 3), dtype=np.int64)
        self.space = FaceSpace(self.vertices, face.points, face.fapu, positions=positions,
                               mouth_angle=mouth_angle)
        self.face = face
        self._point_rows: Optional[np.ndarray] = None

    @cached_property
    def normalised(self) -> np.ndarray:
        """The skin vertices in this face's normalised space (FAPU0 units)."""
        return self.space.normalise(self.vertices)

    def main_point_rows(self) -> np.ndarray:
        """:meth:`point_vertices` of the main skin mesh, as rows of that mesh."""
        first, n = self.offsets[self.main]
        rows = self.point_vertices()
        return rows[(rows >= first) & (rows < first + n)] - first

    def point_vertices(self) -> np.ndarray:
        """Rows of the skin vertices that are feature points: a point's vertex tie, else
        the skin vertex nearest to it when that is within 1 % of ES0."""
        if self._point_rows is None:
            self._point_rows = self._find_point_vertices()
        return self._point_rows

    def _find_point_vertices(self) -> np.ndarray:
        rows = set()
        if not len(self.vertices):
            return np.zeros(0, dtype=np.int64)
        tree = cKDTree(self.vertices)
        tol = 0.01 * float(self.face.fapu.ES0)
        for fp in self.face.points:
            tie = self.face.points.vertex(fp)
            if tie is not None and tie[0] in self.offsets:
                rows.add(self.offsets[tie[0]][0] + int(tie[1]))
                continue
            d, i = tree.query(self.face.points[fp])
            if d <= tol:
                rows.add(int(i))
        return np.array(sorted(rows), dtype=np.int64)


class _Installer:
    """The target's part Transforms: found, or installed on first use, centres checked."""

    def __init__(self, face: FaceModel, cloner: FacialMotionCloner):
        self.face = face
        self.cloner = cloner
        self.parts = {p: list(m) for p, m in cloner.target_parts.items()}
        self.chosen: dict = {}
        self.notes: list = []
        self.extra: list = []
        #: part name -> tables (fap, select) whose motion of it the target can't take
        self.skipped: dict = {}
        self._tol = 0.02 * float(cloner.target.fapu.ES0)

    def note(self, message: str) -> None:
        if message not in self.notes:
            self.notes.append(message)

    def skip(self, part: str, table: FaceDefTable) -> None:
        """Record that ``table`` moves ``part``, which the target lacks (one warning per
        kind of part at the end, :meth:`FacialMotionCloner.clone`)."""
        self.skipped.setdefault(part, set()).add((table.fap, table.select))

    def transform(self, part: str, centre: Optional[np.ndarray]) -> str:
        if part in self.chosen:
            return self.chosen[part]
        if part != HEAD and HEAD not in self.chosen and self._head_moves():
            self.transform(HEAD, np.asarray(self.cloner.target.points["7.1"], float))
        face = self.face
        name = target_transform(face, part, self.parts)
        if name is None:
            name = self._install(part, centre)
        elif centre is not None:
            # eyes and head must turn about their centres; a jaw's pivot is the
            # modeller's choice unless it is far off (e.g. left at the origin)
            rigid = part == HEAD or _SPEC[part].kind == "eye"
            name = self._check_centre(part, name, centre, self._tol if rigid else 25 * self._tol)
        self.chosen[part] = name
        for rider in (_SPEC[part].riders if part in _SPEC else ()):
            if rider in self.parts and target_transform(face, rider, self.parts) == name:
                self.chosen.setdefault(rider, name)
        return name

    def _head_moves(self) -> bool:
        src = self.cloner.source
        ts = self.cloner.source_transforms[HEAD]
        return ts is not None and any(e.transform == ts for t in src.fat for e in t.transforms)

    def _unique(self, base: str) -> str:
        taken = set(self.face.transforms) | set(self.face.meshes)
        name, k = base, 2
        while name in taken:
            name, k = f"{base}_{k}", k + 1
        return name

    def _install(self, part: str, centre: Optional[np.ndarray]) -> str:
        face = self.face
        meshes = self.parts[part]
        parent = lowest_common_transform(face, meshes)
        label = "".join(w.capitalize() for w in part.split())
        name = self._unique(label if part == HEAD else f"{label}Motion")
        M = face.world_matrix(parent)[0]
        c = np.zeros(3) if centre is None else np.linalg.inv(M) @ np.append(centre, 1.0)
        face.transforms[name] = FaceTransform(name, parent=parent, center=tuple(c[:3]))
        if part == HEAD:
            for t in list(face.transforms.values()):
                if t.name != name and t.parent is None:
                    t.parent = name
            for m in face.meshes.values():
                if m.parent is None:
                    m.parent = name
        else:
            for mname in meshes:
                self._reparent(mname, name, parent)
        self.note(f"installed Transform {name} for the {part} of the target"
                  + (f", turning about {np.round(centre, 6).tolist()}" if centre is not None else ""))
        return name

    def _reparent(self, mesh: str, new_parent: str, common: Optional[str]) -> None:
        face = self.face
        m = face.meshes[mesh]
        if m.parent != common:
            # bake the transforms between the common ancestor and the mesh into its vertices
            A = np.linalg.inv(face.world_matrix(common)[0]) @ face.world_matrix(m.parent)[0]
            m.vertices = m.vertices @ A[:3, :3].T + A[:3, 3]
        m.parent = new_parent
        face.invalidate()

    def _check_centre(self, part: str, name: str, centre: np.ndarray, tol: float) -> str:
        face = self.face
        t = face.transforms[name]
        M = face.world_matrix(t.parent)[0]
        pivot = M[:3, :3] @ (np.asarray(t.translation, float) + np.asarray(t.center, float)) + M[:3, 3]
        if np.linalg.norm(pivot - centre) <= tol:
            return name
        local = np.linalg.inv(M) @ np.append(centre, 1.0)
        still = np.allclose(t.rotation[3] % (2 * np.pi), 0) and np.allclose(t.scale, 1)
        if still:
            t.center = tuple(local[:3] - np.asarray(t.translation, float))
            self.note(f"moved the centre of Transform {name} ({part}) to "
                      f"{np.round(centre, 6).tolist()}")
            return name
        # a turned or scaled Transform: a new pivot Transform under it takes its children
        W = face.world_matrix(name)[0]
        c = np.linalg.inv(W) @ np.append(centre, 1.0)
        pivot_name = self._unique(f"{name}Pivot")
        face.transforms[pivot_name] = FaceTransform(pivot_name, parent=name, center=tuple(c[:3]))
        for other in face.transforms.values():
            if other.parent == name and other.name != pivot_name:
                other.parent = pivot_name
        for m in face.meshes.values():
            if m.parent == name:
                m.parent = pivot_name
        face.invalidate()
        self.note(f"installed Transform {pivot_name} under {name} ({part}) to turn about "
                  f"{np.round(centre, 6).tolist()}")
        return pivot_name


def _mean_edge(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(n,) mean length of the edges at each vertex (0 for a vertex in no triangle)."""
    i, j, length = triangle_edges(vertices, triangles)
    n = len(vertices)
    total = np.bincount(i, length, n) + np.bincount(j, length, n)
    count = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    return total / np.maximum(count, 1)


def _stack(face: FaceModel, meshes: Sequence[str]) -> tuple:
    offsets, verts, first = {}, [], 0
    for n in meshes:
        v = face.world_vertices(n)
        offsets[n] = (first, len(v))
        verts.append(v)
        first += len(v)
    return (np.vstack(verts) if verts else np.zeros((0, 3))), offsets


def _borders(table: FaceDefTable) -> np.ndarray:
    """The union of a table's interval borders (0 included; [0, 1] when it has none)."""
    b = [m.borders for m in table.meshes]
    if not b:
        return np.array([0.0, 1.0])
    return np.union1d(np.concatenate(b), [0.0])


def _intervals(borders: np.ndarray, at_borders: np.ndarray) -> np.ndarray:
    """Per-interval displacements [k, intervals, 3] from displacements at the non-zero
    borders [k, nb, 3] (the displacement at 0 is 0)."""
    zero = int(np.flatnonzero(borders == 0)[0])
    full = np.insert(at_borders, zero, 0.0, axis=1)
    width = np.diff(borders)
    return np.diff(full, axis=1) / width[None, :, None]


def _play_table(face: FaceModel, table: FaceDefTable, value: float):
    solo = _copy_face(face, share=True)
    solo.fat = FAT([table])
    if table.fap == 1:
        s = FapStream.from_values({}, fps=1, n_frames=1,
                                  visemes=[(table.select, 0, int(value), 0)])
    elif table.fap == 2:
        s = FapStream.from_values({}, fps=1, n_frames=1,
                                  expressions=[(table.select, int(value), 0, 0, 0, 0)])
    else:
        s = FapStream.from_values({table.fap: [value]}, fps=1, n_frames=1)
    return solo.play(s)


def _with_points(face: FaceModel, ties: dict) -> FaceModel:
    """A copy of ``face`` sharing its meshes, with the points ``ties`` (id -> (mesh,
    vertex)) added."""
    out = _copy_face(face, share=True)
    positions = {k: face.points[k] for k in face.points}
    vertices = dict(face.points.vertices)
    for k, (mesh, vertex) in ties.items():
        positions[k] = face.world_vertices(mesh)[vertex]
        vertices[k] = (mesh, vertex)
    out.points = FeaturePointSet(positions, vertices)
    return out


def _copy_face(face: FaceModel, share: bool = False) -> FaceModel:
    """A copy of a face whose meshes and transforms can be re-parented without touching
    the original (vertex arrays are shared until replaced)."""
    meshes = face.meshes.values() if share else \
        [dataclasses.replace(m) for m in face.meshes.values()]
    transforms = face.transforms.values() if share else \
        [dataclasses.replace(t) for t in face.transforms.values()]
    out = FaceModel(meshes, transforms, points=face.points, fapu=face.fapu, fat=face.fat,
                    name=face.name)
    out.colors = dict(face.colors)
    out.regions = dict(face.regions)
    for attr in ("source", "initial_faps", "initial_viseme", "initial_expression"):
        if hasattr(face, attr):
            setattr(out, attr, getattr(face, attr))
    return out


#: The cloning methods :func:`clone` knows.
METHODS = ("fmc", "local-frames")


def clone(source: FaceModel, target: FaceModel, method: str = "fmc", **options) -> FaceModel:
    """The target face with a FAT for every FAP, viseme and expression of the source's.

    ``method="fmc"`` (default): Facial Motion Cloning, any two faces with the required
    feature points (``options`` go to :class:`FacialMotionCloner`); FeaturePointError
    listing the ids when either face lacks some, :class:`CloneWarning` for anything left
    out or installed.  ``method="local-frames"``: Kong et al.'s local-frame cloning for
    faces that share a mesh (:class:`~mpeg4fba.cloning.local_frames.LocalFrameCloner`).
    """
    if method == "fmc":
        return FacialMotionCloner(source, target, **options).clone()
    if method == "local-frames":
        from .local_frames import LocalFrameCloner
        return LocalFrameCloner(source, target, **options).clone()
    raise ValueError(f"method must be one of {', '.join(METHODS)}, not {method!r}")
