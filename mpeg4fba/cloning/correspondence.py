"""Where each target skin vertex is on the source: the alignment, and the registration
that goes beyond it.

Pandzic's Facial Motion Cloning, "Aligning source and target face": both faces,
normalised and cylindrically projected (:class:`~mpeg4fba.cloning.skin.Skin`), are
aligned in 2D by moving the target's feature points onto the source's, the other
vertices pulled by interpolation over a triangulation of the feature points
(:func:`paper_alignment`, :func:`~mpeg4fba.cloning.alignment.align`).  That is
``alignment="paper"``.

The default, ``alignment="surface"`` (:data:`ALIGNMENTS`), departs from the paper: the
2D interpolation between feature points can't see how a surface seen edge-on by the
projection (under the chin, the neck) differs between two faces, so the target is then
placed on the source's surface in 3D (:func:`surface_alignment`): warped by its
feature points (:func:`warp_skin`), its neck cut pinned onto the source's
(:func:`pin_neck`), fitted onto the source's skin by a non-rigid ICP
(:func:`register_skin`), and each vertex's aligned 2D position taken from its closest
point on the source's surface (:func:`onto_surface`).  The result is one record,
:class:`Correspondence`; :func:`correspond` is the whole step, and the cloner accepts a
record (or a function of the two skins and the :class:`AlignOptions` returning one) in
its place (``FacialMotionCloner(..., correspondence=...)``).

:func:`derive_points` uses the correspondence the other way round: the target vertex
the mapping places on a source feature point the target lacks.

References: I. S. Pandzic, "Facial Motion Cloning", Graphical Models 65(6), 2003,
section "Aligning source and target face"; B. Amberg, S. Romdhani, T. Vetter, "Optimal
Step Nonrigid ICP Algorithms for Surface Registration", CVPR 2007 (the fit of
:func:`~mpeg4fba.cloning.registration.register_surface`).

>>> AlignOptions().alignment, AlignOptions(alignment="paper").register
('surface', True)
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import Callable, Optional, Sequence, Union

import numpy as np

from ..fba.featurepoints import point_order
from ..fba.requirements import NOT_SURFACE
from .alignment import align
from .errors import CloneWarning
from .skin import Skin, mesh_groups
from .registration import (REGISTRATION_FINE_SCALES, REGISTRATION_MEMBRANE, SPDFactoriser,
                           register_surface, surface_biharmonic)
from .surface import closest_points, feature_warp, loop_correspondence, neck_cut

__all__ = ["ALIGNMENTS", "NECK_RATIO", "DERIVE_DISTANCE",
           "AlignOptions", "Correspondence", "correspond", "paper_alignment",
           "surface_alignment", "warp_skin", "pin_neck", "register_skin", "onto_surface",
           "derive_points"]


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
#:    (:func:`~mpeg4fba.cloning.registration.register_surface`).  The warp is exact only
#:    at the feature points; between them a surface can end up at the right place but
#:    slid along itself (a throat displaced down the neck, the underside of the chin
#:    shifted back), which a closest point can't see and the fit corrects, since a
#:    slid surface no longer matches the source's where it bends;
#: 4. each vertex goes to its closest point on the source's surface (of its mesh
#:    group), whose 2D position is its aligned position for the lip and eyelid regions;
#: 5. with ``register=True`` and ``refine=True``, the fit goes on to a sixty-fourth of
#:    the face (:data:`~mpeg4fba.cloning.registration.REGISTRATION_FINE_SCALES`), feature
#:    points held, and its result is the surface points the surface weights are taken
#:    at; the regions stay with step 4, since a vertex following the source's facets
#:    can cross the mouth's mid line.
#:
#: 2D interpolation between feature points can't see how a surface seen edge-on by the
#: projection (under the chin, the neck) differs between two faces; the 3D steps can.
#: On six pairs of ICT identities onto decimated skins (``benchmarks/bench_clone_ict.py
#: --pairs``), the median of the largest errors falls from 17 % of the eye distance
#: (paper) to 12 (steps 1 and 4 with 2D weights) and 2.7 (all five steps, surface
#: weights), the mean error from 0.21 to 0.13 and 0.060 %.
ALIGNMENTS = ("surface", "paper")

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

# The finer fit (step 5) holds every feature point fast, also where the target's mesh
# is much coarser than the source's.  Holding such points loosely (pulled to their
# place like any vertex to the surface, put back at the end; an option, ``loose_pins``,
# once chosen on ICT 1 -> 2) did not earn its place on random ICT pairs
# (``benchmarks/bench_clone_pairs.py``, four draws of 20 pairs: seeds 1919, 2027, 2028,
# 2029): onto the full targets it changed nothing; onto the decimated ones, held fast,
# the median of the per-pair largest errors is 6.20 -> 5.84, 7.19 -> 8.44, 9.06 -> 7.77
# and 11.4 -> 7.72 % of the eye distance, the worst pair's 13.4 -> 11.8, 19.8 -> 18.3,
# 13.7 -> 15.2 and 15.7 -> 16.3, the worst mean lower on all four (0.079 -> 0.078,
# 0.086 -> 0.084, 0.081 -> 0.076, 0.095 -> 0.089), flipped triangles (median) no more.

#: How near (normalised space, eye separation 1) the mapping must place some target skin
#: vertex to a source feature point for that vertex to become the target's point when
#: the target lacks it (:func:`derive_points`): 0.05 is 3 mm on a
#: human face, a few of the target's edges.  Too small: a coarse target gets no ear
#: points and loses the ear FAPs (with a warning); too large: a head without ears gets
#: ear points on its cheek, and ear FAPs that move the cheek.
DERIVE_DISTANCE = 0.05


@dataclasses.dataclass(frozen=True)
class AlignOptions:
    """The options of the correspondence step, as the cloner takes them (checked there).

    Parameters
    ----------
    triangulation : "fixed", "delaunay" or id triples
        The feature point triangulation of the paper's alignment
        (:func:`~mpeg4fba.cloning.alignment.align`).
    alignment : str
        :data:`ALIGNMENTS`.
    neck : bool
        Pin the neck cuts onto each other (:data:`NECK_RATIO`).
    register : bool
        Fit the target's main skin onto the source's (step 3 of :data:`ALIGNMENTS`).
    refine : bool
        Go on to :data:`~mpeg4fba.cloning.registration.REGISTRATION_FINE_SCALES` for the
        surface points (step 5).
    membrane : float
        The fit's membrane term against its thin plate
        (:data:`~mpeg4fba.cloning.registration.REGISTRATION_MEMBRANE`).
    by_mesh : bool
        Closest points on the source mesh that is each target mesh's counterpart
        (:func:`~mpeg4fba.cloning.skin.mesh_groups`).
    """

    triangulation: Union[str, Sequence] = "fixed"
    alignment: str = "surface"
    neck: bool = True
    register: bool = True
    refine: bool = True
    membrane: float = REGISTRATION_MEMBRANE
    by_mesh: bool = True


@dataclasses.dataclass(frozen=True)
class Correspondence:
    """Where the target's skin vertices are on the source (rows of the target's
    :class:`~mpeg4fba.cloning.skin.Skin`).

    Attributes
    ----------
    aligned : (Nt, 2) array
        Aligned positions in the source's 2D alignment space (the surface alignment's
        closest points where it ran).
    aligned_depth : (Nt,) array
        Their depth, to compare with the source surfaces lying over them in 2D.
    alignment_ids, alignment_triangles
        The feature point triangulation of the paper's alignment.
    surface_points : (Nt, 3) array or None
        With ``alignment="surface"``: the target's skin placed on the source's surface,
        in the source's normalised space (None with the paper's alignment).
    neck_pinned : bool
        Whether the neck cuts were pinned onto each other (:data:`NECK_RATIO`).
    """

    aligned: np.ndarray
    aligned_depth: np.ndarray
    alignment_ids: list
    alignment_triangles: np.ndarray
    surface_points: Optional[np.ndarray] = None
    neck_pinned: bool = False


#: What stands in for :func:`register_skin` in :func:`surface_alignment`.
Registration = Callable[..., np.ndarray]


def paper_alignment(source: Skin, target: Skin,
                    triangulation: Union[str, Sequence] = "fixed") -> Correspondence:
    """The paper's alignment: the target's projected skin pulled by its feature points
    onto the source's (:func:`~mpeg4fba.cloning.alignment.align`)."""
    aligned, depth, ids, tris = align(target.space, source.space, triangulation)
    return Correspondence(aligned, depth, ids, tris)


def warp_skin(source: Skin, target: Skin) -> np.ndarray:
    """(Nt, 3) the target's normalised skin warped by the thin-plate spline that takes
    its feature points (those on the surface, and 7.1) onto the source's, in the
    source's normalised space (step 1 of :data:`ALIGNMENTS`)."""
    src, tgt = source.space, target.space
    common = [i for i in point_order(set(tgt.ids) & set(src.ids))
              if i not in NOT_SURFACE or i == "7.1"]
    moving = tgt.normalise(np.array([target.face.points[i] for i in common]))
    fixed = src.normalise(np.array([source.face.points[i] for i in common]))
    return feature_warp(moving, fixed, target.normalised)


def pin_neck(source: Skin, target: Skin, warped: np.ndarray) -> tuple:
    """(``warped`` corrected so the target's neck cut lies on the source's, whether it
    was): see :data:`NECK_RATIO`.  ``warped`` is the target's skin in the source's
    normalised space; a :class:`CloneWarning` when the cuts are too far apart."""
    cuts = []
    for skin in (source, target):
        face = skin.face
        if skin.main is None:
            return warped, False
        first, n = skin.offsets[skin.main]
        v = skin.normalised[first:first + n]
        chin, axis = skin.space.normalise(np.array([face.points["2.1"], face.points["7.1"]]))
        loop = neck_cut(v, face.meshes[skin.main].triangles, chin, axis)
        if loop is None:
            return warped, False
        cuts.append((first, n, v, loop, chin[1] - v[loop, 1].mean()))
    (_, _, vs, ls, drop_s), (ft, nt, vt, lt, drop_t) = cuts
    if not 1 / NECK_RATIO <= drop_t / drop_s <= NECK_RATIO:
        warnings.warn(f"the neck cuts of {source.face.name} and {target.face.name} lie "
                      f"{drop_s:.2f} and {drop_t:.2f} (normalised) below the chin: too "
                      "far apart to be the same place, the necks are left unpinned",
                      CloneWarning, stacklevel=2)
        return warped, False
    residual = loop_correspondence(vt[lt], vs[ls]) - warped[ft + lt]
    points = target.main_point_rows()
    keep = ~np.isin(lt, points)
    rows = np.concatenate([points, lt[keep]])
    values = np.vstack([np.zeros((len(points), 3)), residual[keep]])
    out = warped.copy()
    out[ft:ft + nt] += surface_biharmonic(vt, target.face.meshes[target.main].triangles,
                                          rows, values)
    return out, True


def register_skin(source: Skin, target: Skin, warped: np.ndarray, *,
                  membrane: float = REGISTRATION_MEMBRANE, scales: Optional[tuple] = None,
                  factorise: Optional[SPDFactoriser] = None) -> np.ndarray:
    """``warped`` with the target's main skin fitted onto the source's main skin
    (:func:`~mpeg4fba.cloning.registration.register_surface`, over ``scales``, by default
    its own), its feature points held."""
    if source.main is None or target.main is None:
        return warped
    ft, nt = target.offsets[target.main]
    fs, ns = source.offsets[source.main]
    tris = target.face.meshes[target.main].triangles
    pins = target.main_point_rows()
    out = warped.copy()
    out[ft:ft + nt] = register_surface(
        target.normalised[ft:ft + nt], tris, warped[ft:ft + nt], pins,
        source.normalised[fs:fs + ns], source.face.meshes[source.main].triangles,
        membrane=membrane, factorise=factorise,
        **({} if scales is None else {"scales": scales}))
    return out


def onto_surface(source: Skin, target: Skin, placed: np.ndarray, aligned: np.ndarray,
                 aligned_depth: np.ndarray, by_mesh: bool = True) -> tuple:
    """(aligned, aligned_depth) with each target vertex at the 2D position and depth of
    its closest point (``placed``: the target's skin in the source's normalised space)
    on the source's surface of its mesh group (step 4 of :data:`ALIGNMENTS`); vertices
    whose closest triangle spans the back of the head keep their positions."""
    aligned, aligned_depth = aligned.copy(), aligned_depth.copy()
    uv_s, depth_s = source.space.uv, source.space.depth
    tris = source.triangles
    tri_mesh = source.mesh_index[tris[:, 0]]
    for rows, meshes in mesh_groups(source, target, by_mesh):
        sub = np.flatnonzero(np.isin(tri_mesh, meshes))
        if not len(sub) or not len(rows):
            continue
        t, b, _ = closest_points(placed[rows], source.normalised, tris[sub])
        corners = tris[sub][t]
        uv = np.einsum("nk,nkc->nc", b, uv_s[corners])
        depth = np.einsum("nk,nk->n", b, depth_s[corners])
        # a triangle across the back of the head (angle +-pi) has no usable mean
        fine = np.ptp(uv_s[corners][:, :, 0], axis=1) < np.pi
        aligned[rows[fine]] = uv[fine]
        aligned_depth[rows[fine]] = depth[fine]
    return aligned, aligned_depth


def surface_alignment(source: Skin, target: Skin, paper: Correspondence,
                      options: AlignOptions = AlignOptions(), *,
                      register: Registration = register_skin) -> Correspondence:
    """The "surface" refinement of the paper's alignment ``paper`` (see
    :data:`ALIGNMENTS`); ``register`` stands in for :func:`register_skin` (a benchmark's
    ground truth)."""
    warped = warp_skin(source, target)
    pinned = False
    if options.neck:
        warped, pinned = pin_neck(source, target, warped)
    factorise = SPDFactoriser()          # both fits solve on the same mesh
    if options.register:
        warped = register(source, target, warped, membrane=options.membrane,
                          factorise=factorise)
    # the 2D positions (for the regions) from the stiffer fit, the surface points
    # from the finer one (see REGISTRATION_FINE_SCALES)
    surface_points = register(source, target, warped, membrane=options.membrane,
                              scales=REGISTRATION_FINE_SCALES, factorise=factorise) \
        if options.register and options.refine else warped
    aligned, depth = onto_surface(source, target, warped, paper.aligned, paper.aligned_depth,
                                  options.by_mesh)
    return dataclasses.replace(paper, aligned=aligned, aligned_depth=depth,
                               surface_points=surface_points, neck_pinned=pinned)


def correspond(source: Skin, target: Skin,
               options: AlignOptions = AlignOptions()) -> Correspondence:
    """The correspondence step: :func:`paper_alignment`, then with
    ``alignment="surface"`` :func:`surface_alignment`.

    >>> from mpeg4fba.models import reference_head
    >>> from mpeg4fba.cloning.parts import find_parts
    >>> from mpeg4fba.cloning.projection import MOUTH_ANGLE
    >>> face = reference_head(resolution=0.5)
    >>> skin = Skin(face, find_parts(face), "global", MOUTH_ANGLE)
    >>> corr = correspond(skin, skin, AlignOptions(register=False))
    >>> float(abs(corr.aligned - skin.space.uv).max()) < 1e-9, corr.neck_pinned
    (True, False)
    """
    corr = paper_alignment(source, target, options.triangulation)
    if options.alignment == "surface":
        corr = surface_alignment(source, target, corr, options)
    return corr


def derive_points(source: Skin, target: Skin, placed: np.ndarray, ids: Sequence[str],
                  distance: float = DERIVE_DISTANCE) -> dict:
    """Point id -> (target skin mesh, vertex) for those of ``ids`` the source has on its
    skin: the target vertex placed (``placed``: the target's skin in the source's
    normalised space, by the correspondence or the mapping) nearest the source's point,
    when it is within ``distance`` of it (:data:`DERIVE_DISTANCE`; else the target has no
    such place, a face without ears, and the point stays missing)."""
    wanted = [k for k in ids if k in source.face.points and k not in NOT_SURFACE]
    if not wanted or not len(target.vertices):
        return {}
    at = source.space.normalise(np.array([source.face.points[k] for k in wanted]))
    # the nearest point of the target's skin as the mapping placed it, and of its
    # triangle the corner nearest to it
    tri, bary, dist = closest_points(at, placed, target.triangles, k=16)
    row = target.triangles[tri, np.argmax(bary, axis=1)]
    names = list(target.offsets)
    out = {}
    for k, d, r in zip(wanted, dist, row):
        if d > distance:
            continue
        mesh = names[int(target.mesh_index[r])]
        out[k] = (mesh, int(r - target.offsets[mesh][0]))
    return out
