"""The mapping, built once: for every target skin vertex, weights over the source skin
vertices, one sparse matrix ``W`` (target motion = ``W @`` source motion).

Pandzic's Facial Motion Cloning, "Mapping facial motion", "Antialiasing" and "Treating
the lip region": each target vertex takes the interpolation of the source's motion at
its aligned position in the 2D alignment space
(:func:`~mpeg4fba.cloning.interp2d.antialiased_weights`: the paper's 2D triangle-mesh
interpolation, overlapping triangles resolved by depth, points outside every triangle
by the excess-barycentric distance), averaged over a circle of radius ``support``
round it (the anti-aliasing filter, 0.02 as in the paper); a target upper-lip vertex
sees no source lower-lip vertex and vice versa (the regions of
:func:`~mpeg4fba.cloning.lips.slit_regions`, :func:`slit_labels`).

Where we depart from it (each an option, the paper's rule one argument away):

* ``interpolation="surface"`` (:data:`INTERPOLATIONS`, the default with the surface
  alignment): the barycentric weights of the target vertex's place on the source's
  surface, with the filter carried over the surface
  (:func:`~mpeg4fba.cloning.surface.surface_weights`), and the sheet facing the
  target vertex preferred (:data:`FACING`, :func:`facing_normals`);
* overlaps resolved by the nearest depth (:data:`OVERLAP_RULES`), the outside search
  kept to nearby triangles (:data:`OUTSIDE_RULES`);
* the eyelids are treated like the lips (:data:`~mpeg4fba.cloning.lips.SLITS`), a
  triangle with one corner on the other side stays visible (:func:`visible_triangles`),
  and the filter shrinks to nothing at the corners of the mouth and eyes
  (:func:`support_radius`);
* a target vertex whose side of a slit its mesh says only weakly (round a mouth or eye
  corner) takes both sides' motion, weighted by how clearly it was said
  (:data:`~mpeg4fba.cloning.lips.SIDE_BLEND`, ``side_blend=0`` for the paper's rule);
* the target's feature point vertices take the unfiltered interpolation, so each FAP
  moves a feature point by exactly what it moves the source's;
* each target mesh maps from its counterpart (:func:`~mpeg4fba.cloning.skin.mesh_groups`).

References: I. S. Pandzic, "Facial Motion Cloning", Graphical Models 65(6), 2003,
sections "Interpolation from 2D triangle mesh" to "Treating the lip region".

>>> WeightOptions().interpolation, WeightOptions().support
('surface', 0.02)
"""
from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np
import scipy.sparse as sp

from .correspondence import Correspondence
from .interp2d import antialiased_weights
from .lips import OUTSIDE, SIDE_BLEND, opposite, slit_regions, slit_sides
from .skin import Skin, coarseness, mean_edge, mesh_groups
from .surface import surface_weights, triangle_normals, vertex_normals

__all__ = ["OVERLAP_RULES", "OUTSIDE_RULES", "INTERPOLATIONS", "FACING", "FACING_RESOLUTION",
           "WeightOptions", "mapping_weights", "slit_labels", "visible_triangles",
           "facing_normals", "support_radius"]


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
#: source (most normals against the source's) has its normals reversed first.  On random
#: ICT pairs onto the full targets (``benchmarks/bench_clone_pairs.py``, 20 pairs a draw,
#: median / worst of the per-pair largest error, % of the eye distance) it is what keeps
#: the inner lips apart: off, 10.7 / 14.6 on the regression draw 1919 and 10.4 / 13.9 on
#: draw 2029.  Of 0.005, 0.01, 0.02 and 0.04, the largest wins on every draw tried:
#: 0.01 -> 0.04 is 5.72 / 12.2 -> 5.03 / 12.2 (1919), 5.11 / 8.98 -> 4.52 / 8.98 (2028),
#: 5.37 / 13.0 -> 4.87 / 9.47 (2029) and, judged on a fresh draw, 5.21 / 17.2 -> 4.90 /
#: 12.3 (2031, worst flips 75 -> 38), the mean no worse anywhere; 0.005 is worse (6.71 on
#: 2029).  0.04 is 2.5 mm on a human face: sheets further apart than that are told
#: apart by distance alone.  The decimated targets' figures do not change: their
#: normals are too coarse to count.
FACING = 0.04
#: The coarsest a target's mesh may be against the source's (mean edge length round a
#: target vertex over that round the source vertex nearest its surface point) for its
#: normal to count with :data:`FACING`.  A coarse mesh's normal at a lip or eyelid rim
#: averages both sides, and a decimated mesh has folded patches whose normals agree
#: with each other but not with the surface: on the ICT skins decimated to a quarter,
#: the mouth's vertices are 2 to 4 times as coarse as the source's, the full meshes'
#: within 1.8 times.  Without this rule a vertex of such a patch at a mouth corner
#: (ICT 2 -> 1, decimated) went from 0.2 to 6.5 % of the eye distance.
FACING_RESOLUTION = 2.0


@dataclasses.dataclass(frozen=True)
class WeightOptions:
    """The options of the weights step, as the cloner takes them (checked there).

    Parameters
    ----------
    support : float
        Radius of the anti-aliasing filter (alignment space, or normalised space with
        the surface interpolation; 0 turns it off).
    samples : int
        Points on the filter's circle.
    interpolation : str
        :data:`INTERPOLATIONS`.
    overlap, outside : str
        :data:`OVERLAP_RULES`, :data:`OUTSIDE_RULES` (2D interpolation).
    facing : float
        :data:`FACING` (surface interpolation).
    slits : tuple
        The :class:`~mpeg4fba.cloning.lips.Slit` s treated (lips, eyelids).
    by_mesh : bool
        Each target mesh from its counterpart (:func:`~mpeg4fba.cloning.skin.mesh_groups`).
    blend : float
        :data:`~mpeg4fba.cloning.lips.SIDE_BLEND`: target vertices whose side of a slit the
        mesh says more weakly than this take both sides' motion; 0: each takes its side's.
    """

    support: float = 0.02
    samples: int = 8
    interpolation: str = "surface"
    overlap: str = "nearest"
    outside: str = "nearby"
    facing: float = FACING
    slits: tuple = ()
    by_mesh: bool = True
    blend: float = SIDE_BLEND


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


def slit_labels(source: Skin, target: Skin, aligned: np.ndarray, slits: tuple) -> tuple:
    """(source regions, target regions, target sides): each skin vertex's side of the lips
    and eyelids (:func:`~mpeg4fba.cloning.lips.slit_regions`, by the source's feature
    points; the target at its ``aligned`` positions), and the field that settled the
    target's by its mesh (:func:`~mpeg4fba.cloning.lips.slit_sides`); (None, None, None)
    without ``slits``."""
    if not slits:
        return None, None, None
    uv = source.space.uv
    pts = {k: source.space.point_uv(k) for k in source.space.ids}
    return (slit_regions(uv, pts, slits=slits, triangles=source.triangles,
                         vertices=source.vertices),
            *slit_sides(aligned, pts, slits=slits, triangles=target.triangles,
                        vertices=target.vertices))


def facing_normals(source: Skin, target: Skin, surface_points: np.ndarray, facing: float,
                   resolution: float = FACING_RESOLUTION) -> Optional[np.ndarray]:
    """(Nt, 3) unit normals of the target's skin vertices in the normalised space for
    :data:`FACING`, zero where they don't count (where the target is more than
    ``resolution`` times as coarse as the source round its ``surface_points``, see
    :data:`FACING_RESOLUTION`, or disagrees with its own triangles); None with
    ``facing=0``."""
    if facing <= 0:
        return None
    out = np.zeros((len(target.normalised), 3))
    src_n = vertex_normals(source.normalised, source.triangles)
    for name, (first, n) in target.offsets.items():
        v = target.normalised[first:first + n]
        tris = target.face.meshes[name].triangles
        if not len(tris):
            continue
        normal = vertex_normals(v, tris)
        face = triangle_normals(v, tris)
        # the least agreement of a vertex's normal with its own triangles'
        agree = np.ones(n)
        for k in range(3):
            np.minimum.at(agree, tris[:, k], (face * normal[tris[:, k]]).sum(axis=1))
        ratio, near = coarseness(source, mean_edge(v, tris), surface_points[first:first + n])
        if np.median((normal * src_n[near]).sum(axis=1)) < 0:
            normal = -normal          # wound the other way round from the source
        coarse = ratio > resolution
        normal[(agree <= 0.5) | coarse] = 0.0
        out[first:first + n] = normal
    return out


def support_radius(source: Skin, aligned: np.ndarray, support: float,
                   slits: tuple) -> np.ndarray:
    """Per target vertex radius of the anti-aliasing filter: ``support``, shrinking
    to 0 at the corners of the ``slits`` (mouth and eye corners, the source's points
    in its alignment space; ``aligned``: the target's positions there), where both
    sides of a slit meet and a filter of full size would average the two."""
    radius = np.full(len(aligned), float(support))
    if support <= 0 or not slits:
        return radius
    for slit in slits:
        for corner in (slit.upper[0], slit.upper[-1]):
            if corner not in source.space.ids:
                continue
            d = np.hypot(*(aligned - source.space.point_uv(corner)).T)
            radius = np.minimum(radius, np.maximum(d - support, 0.0))
    return radius


def mapping_weights(source: Skin, target: Skin, correspondence: Correspondence,
                    source_regions: Optional[np.ndarray], target_regions: Optional[np.ndarray],
                    options: WeightOptions = WeightOptions(),
                    target_sides: Optional[np.ndarray] = None) -> sp.csr_matrix:
    """The weights step: sparse (Nt, Ns) ``W``, rows the target's skin vertices, columns
    the source's, each row summing to 1; regions and sides from :func:`slit_labels`.  A
    target vertex whose side the mesh says weakly (``|side| < options.blend``) takes
    both sides' weights, the upper side's by ``(1 + side / blend) / 2``, unless it is a
    feature point's."""
    src_uv, depth = source.space.uv, source.space.depth
    aligned = correspondence.aligned
    nt = len(aligned)
    support, samples = options.support, options.samples
    exact = options.outside == "global"
    surface = options.interpolation == "surface"
    tris = source.triangles
    if not surface:
        # a triangle wrapping round the back of the head (across angle +-pi) would
        # cover the whole face in 2D
        spread = np.ptp(src_uv[tris][:, :, 0], axis=1)
        tris = tris[spread < np.pi]

    # the target's feature point vertices take the unfiltered interpolation, so each
    # FAP moves its feature point by exactly what it moves the source's (the filter
    # would shave the peak of a motion centred on the point)
    points = target.point_vertices()
    filtered = np.ones(nt, dtype=bool)
    filtered[points] = False

    zq = correspondence.aligned_depth if options.overlap == "nearest" else None
    radius = support_radius(source, aligned, support, options.slits)

    normals = facing_normals(source, target, correspondence.surface_points,
                             options.facing) if surface else None

    def weights(rows: np.ndarray, triangles: np.ndarray) -> sp.csr_matrix:
        if surface:
            r = np.where(filtered[rows], radius[rows], 0.0)
            return surface_weights(correspondence.surface_points[rows], source.normalised,
                                   triangles, r, samples,
                                   normals=None if normals is None else normals[rows],
                                   facing=options.facing)
        out = antialiased_weights(src_uv, triangles, aligned[rows], depth,
                                  support=radius[rows], samples=samples, exact=exact,
                                  query_depth=None if zq is None else zq[rows],
                                  slack=_NEAREST_SLACK)
        plain = np.flatnonzero(~filtered[rows])
        if len(plain) and support > 0:
            lil = out.tolil()
            lil[plain] = antialiased_weights(
                src_uv, triangles, aligned[rows[plain]], depth, support=0, exact=exact,
                query_depth=None if zq is None else zq[rows[plain]], slack=_NEAREST_SLACK)
            out = lil.tocsr()
        return out

    treg = target_regions
    if treg is None:
        treg = np.full(nt, OUTSIDE, dtype=np.int8)
    sreg = source_regions
    tri_mesh = source.mesh_index[tris[:, 0]]
    def sided(rows: np.ndarray, in_group: np.ndarray, label: int) -> sp.csr_matrix:
        # the weights of ``rows`` taken as on the side ``label``
        hide = opposite(int(label))
        keep = in_group if hide == OUTSIDE else in_group & visible_triangles(sreg[tris], hide)
        return weights(rows, tris[keep])

    blend = float(options.blend)
    mixed = np.zeros(nt, dtype=bool)
    if target_sides is not None and blend > 0:
        with np.errstate(invalid="ignore"):
            mixed = (treg != OUTSIDE) & (np.abs(target_sides) < blend)
        # a feature point's vertex (a mouth corner's is where the field is held at 0) takes
        # its side's motion whole: it is pinned onto the source's point, whose motion the
        # FAPs define (blended, a snapped inner corner of an ICT head was 10.5 % of the eye
        # distance off under jawOpen, 3.9 alone)
        mixed[points] = False
    blocks, order = [], []
    for group_rows, source_meshes in mesh_groups(source, target, options.by_mesh):
        in_group = np.isin(tri_mesh, source_meshes)
        plain, rows = group_rows[~mixed[group_rows]], group_rows[mixed[group_rows]]
        for which in np.unique(treg[plain]):
            r = plain[treg[plain] == which]
            blocks.append(sided(r, in_group, which))
            order.append(r)
        # where a slit's sides meet: both sides' weights, by how clearly the mesh said it
        for up in np.unique(treg[rows] - 1 + treg[rows] % 2):
            r = rows[(treg[rows] == up) | (treg[rows] == up + 1)]
            a = np.clip(0.5 + 0.5 * target_sides[r] / blend, 0.0, 1.0)
            blocks.append(sp.diags(a) @ sided(r, in_group, up)
                          + sp.diags(1 - a) @ sided(r, in_group, up + 1))
            order.append(r)
    w = sp.vstack(blocks).tocsr()
    perm = np.empty(nt, dtype=np.int64)
    perm[np.concatenate(order)] = np.arange(nt)
    return w[perm]
