"""The lip regions of Facial Motion Cloning ("Treating the lip region"), and the same
treatment for the eyelids.

Upper and lower lips lie close together in the alignment space but move in opposite
directions, so every vertex is put in the upper-lip region, the lower-lip region or
neither.  The upper-lip region is the polygon of the inner upper lip contour closed by
the sides of the nose (the nostrils 9.1, 9.2); the lower-lip region the polygon of the
inner lower lip contour closed by the sides of the chin (the chin corners 2.11, 2.12).
Both are tested in the 2D alignment space.  A target vertex of one lip then takes no
motion from the source's other lip (:mod:`~mpeg4fba.cloning.fmc`).

Eyelids have the same problem (a blink moves the upper lid down onto a lower lid that
stays), so each eye is treated the same way as an extension of the paper (on by
default, ``eyelids=False`` in the cloner turns it off): the upper lid is the polygon of
the upper lid margin (inner corner, 3.1 / 3.2, outer corner) closed by the eyebrow
(4.5 4.3 4.1 / 4.6 4.4 4.2), the lower lid the lower margin (3.3 / 3.4) closed by the
cheek bone and the nose bone (5.3 9.7 / 5.4 9.6).  Each such pair is a :class:`Slit`.

Two details the paper leaves open:

* The two polygons of a slit meet on the **mid line** of the slit (the midpoints of the
  upper and lower contour points) rather than on the two contours, so a closed mouth or
  eye leaves no gap between them (a vertex in such a gap would take the motion of both).
* A closed slit puts vertices of both sides on (or, between feature points, a little
  past) the mid line, and a lip's inner surface rolls into the mouth behind it, where the
  2D polygons cannot tell the lips apart.  So the vertices near the mid line (within
  ``band``), between its corners, are settled by the mesh: a harmonic field over the
  mesh's edges (conductance 1 / length) is +1 on the upper side's vertices outside that band,
  -1 on the lower side's, 0 at the vertex at each of the slit's two corners (if one lies
  within ``band`` of it), and free elsewhere; a vertex goes
  to the side its sign says.  A lip's inner surface hangs from the lip along its whole
  length and touches the other lip only round the corner, so the field follows the
  sheet a vertex belongs to (a nearest-seed rule did not: the other lip, through the
  corner, was often nearer than the vertex's own lip's outer surface).  Both sides meet
  at the corners, which is why they are held at 0: a sliver a decimated mesh hangs off
  a lip corner reaches neither side but through the corner, gets 0, and keeps the
  polygon's answer, as does any vertex the field leaves at 0 (no side reached).
  On random ICT pairs (``benchmarks/bench_clone_pairs.py``) this took the worst
  per-pair error from 24.3 to 12.5 % of the eye distance on full targets and the median
  from 11.3 to 9.1 on decimated ones, against the nearest-seed rule with a 0.01 corner
  disc, which it replaces.  Settling more by the mesh did not help: the whole lips (every
  vertex nearer the mid line than the outer contour's 8.1 / 8.2), or only those of them
  whose surface faces into the mouth, gave the same figures on the regression draw and
  worse ones on two fresh draws (decimated targets: median of the per-pair largest error
  7.19 -> 8.40 and worst 19.8 -> 22.1 on seed 2027, 9.06 -> 9.23 and 13.7 -> 26.0 on seed
  2028): a decimated lip corner joins the two lips by long edges, and the wider the
  field's reach, the more of a lip it can pull through one.
* Where the slit is a **hole in the mesh** (a mouth modelled open, as ICT-FaceKit's and
  most game heads' are; eyes cut out for eyeballs), its rim says which side a vertex
  hangs from better than any alignment: a boundary loop lying in the slit's region,
  spanning half its width or more and straddling its mid line is split at its two
  outermost vertices along the slit (the hole's own corners) into an upper and a lower
  rim.  A second field,
  over the pieces of mesh that hang from a rim, within :data:`RIM_REACH` bands of the
  mid line, holds the rims at +1 and -1 (stopping :data:`RIM_GUARD` bands short of
  their ends, which are held at 0); where it is past :data:`RIM_CONFIDENCE` it
  overrules the band's answer.  Only the rims' own ends are held at 0, not the
  vertices nearest the corner points as in the band's field: a corner point given a
  millimetre off puts that vertex on a lip, and held at 0 it weakens the field round
  it, where lower-lip vertices aligned above the mid line then kept the band's answer
  (ICT heads, four draws of 6 people, full and decimated, clean points and two 1 mm
  draws: of 144 clones four better, decimated ones, largest error 17.4 / 17.8 / 17.1 /
  16.8 -> 5.1 / 8.9 / 6.5 / 16.4 % of the eye distance, one worse, a full one already
  failing, 36.3 -> 41.1; the clean ones unchanged).  Misplaced points shift the
  alignment, not the rims: 1 mm of noise on an ICT head's points had put pieces of the
  lower lip (up to 1.4 bands from the mid line on a full head, 3 on a decimated one)
  above it, where they took the upper lip's motion (largest errors 40-58 % of the eye
  distance; 12 with the rims).  Round the corners the rims say little (both meet there,
  and the split can miss a decimated corner by a vertex): there the field is weak and
  the band's answer stands.  A welded slit has no such loop and is settled as before.
* Where the field that settled a vertex is weak (:func:`slit_sides`, :data:`SIDE_BLEND`),
  round the corners mostly, the cloner gives it both sides' motion, by how clearly the
  field said its side, rather than all of the side a corner point a millimetre off
  decided; a feature point's own vertex excepted (pinned onto the source's point, it
  takes its side's motion whole).

>>> uv = np.array([[0.0, 0.1], [0.0, -0.1], [0.5, 0.0]])
>>> pts = {"2.4": (0.3, 0.0), "2.6": (0.15, 0.01), "2.2": (0, 0.01), "2.7": (-0.15, 0.01),
...        "2.5": (-0.3, 0.0), "2.8": (0.15, -0.01), "2.3": (0, -0.01), "2.9": (-0.15, -0.01),
...        "9.1": (0.2, 0.5), "9.2": (-0.2, 0.5), "2.11": (0.2, -0.5), "2.12": (-0.2, -0.5)}
>>> lip_regions(uv, {k: np.array(v) for k, v in pts.items()}).tolist()
[1, 2, 0]
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Optional, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from .surface import boundary_loops, triangle_edges

__all__ = ["OUTSIDE", "UPPER", "LOWER", "Slit", "LIPS", "LEFT_EYELIDS", "RIGHT_EYELIDS",
           "SLITS", "UPPER_LIP_POLYGON", "LOWER_LIP_POLYGON", "LIP_POINTS", "lip_regions",
           "slit_regions", "slit_sides", "SIDE_BLEND", "points_in_polygon", "opposite"]

OUTSIDE, UPPER, LOWER = 0, 1, 2


@dataclass(frozen=True)
class Slit:
    """Two facing regions: ``upper`` / ``lower`` contours (same length, shared corners at
    both ends) and the points closing each polygon (``upper_close`` from the last corner
    back to the first, likewise ``lower_close``)."""

    name: str
    upper: tuple
    lower: tuple
    upper_close: tuple
    lower_close: tuple

    @property
    def points(self) -> tuple:
        return tuple(dict.fromkeys(self.upper + self.lower + self.upper_close + self.lower_close))


LIPS = Slit("lips", ("2.4", "2.6", "2.2", "2.7", "2.5"), ("2.4", "2.8", "2.3", "2.9", "2.5"),
            ("9.2", "9.1"), ("2.12", "2.11"))
LEFT_EYELIDS = Slit("left eyelids", ("3.11", "3.1", "3.7"), ("3.11", "3.3", "3.7"),
                    ("4.5", "4.3", "4.1"), ("5.3", "9.7"))
RIGHT_EYELIDS = Slit("right eyelids", ("3.8", "3.2", "3.12"), ("3.8", "3.4", "3.12"),
                     ("4.6", "4.4", "4.2"), ("5.4", "9.6"))
SLITS = (LIPS, LEFT_EYELIDS, RIGHT_EYELIDS)

#: The paper's polygons, as point ids (the mid line replaces the inner contours).
UPPER_LIP_POLYGON = LIPS.upper + LIPS.upper_close
LOWER_LIP_POLYGON = LIPS.lower + LIPS.lower_close
#: The feature points the lip regions need.
LIP_POINTS = LIPS.points


def opposite(label: int) -> int:
    """The label of the other side of the same slit (labels from :func:`slit_regions`)."""
    if label == OUTSIDE:
        return OUTSIDE
    return label + 1 if label % 2 == 1 else label - 1


def points_in_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """(n,) bool: which 2D points lie inside the polygon (even-odd rule, vectorised).

    >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    >>> points_in_polygon(np.array([[0.5, 0.5], [1.5, 0.5]]), square).tolist()
    [True, False]
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    poly = np.asarray(polygon, dtype=np.float64).reshape(-1, 2)
    x, y = p[:, 0:1], p[:, 1:2]
    a, b = poly, np.roll(poly, -1, axis=0)
    ay, by = a[:, 1][None], b[:, 1][None]
    crosses = (ay > y) != (by > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xcross = a[:, 0][None] + (y - ay) * (b[:, 0] - a[:, 0])[None] / (by - ay)
    return (crosses & (x < xcross)).sum(axis=1) % 2 == 1


def _segment_distance(points: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """(n,) distance of each point from a polyline."""
    a, b = chain[:-1], chain[1:]
    ab = b - a
    ll = np.maximum((ab * ab).sum(axis=1), 1e-300)
    t = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(axis=2) / ll[None], 0, 1)
    near = a[None] + t[..., None] * ab[None]
    return np.sqrt(((points[:, None, :] - near) ** 2).sum(axis=2)).min(axis=1)


def slit_regions(uv: np.ndarray, points_uv: Mapping, *, slits: Sequence[Slit] = SLITS,
                 triangles: Optional[np.ndarray] = None, vertices: Optional[np.ndarray] = None,
                 band: float = 0.03) -> np.ndarray:
    """(n,) int8 label of each 2D point: 0 outside every slit, ``2k + 1`` the upper side
    of ``slits[k]``, ``2k + 2`` its lower side.  Slits whose points ``points_uv`` lacks
    are skipped.  With the mesh (``triangles`` over ``uv``'s rows and 3D ``vertices``)
    the vertices near each mid line are settled by the harmonic field of the module's
    notes.
    """
    return slit_sides(uv, points_uv, slits=slits, triangles=triangles, vertices=vertices,
                      band=band)[0]


def slit_sides(uv: np.ndarray, points_uv: Mapping, *, slits: Sequence[Slit] = SLITS,
               triangles: Optional[np.ndarray] = None, vertices: Optional[np.ndarray] = None,
               band: float = 0.03) -> tuple:
    """(labels, side): :func:`slit_regions`'s labels, and (n,) the field that settled
    each vertex the mesh settled (+1 upper side, -1 lower; the band's field, or the
    rims' where that overrules it, 1 on a rim), NaN where the polygons alone said it.
    A weak field (:data:`SIDE_BLEND`) says the vertex lies where both sides meet.

    >>> uv = np.array([[0.0, 0.1], [0.0, -0.1], [0.5, 0.0]])
    >>> pts = {"2.4": (0.3, 0.0), "2.6": (0.15, 0.01), "2.2": (0, 0.01), "2.7": (-0.15, 0.01),
    ...        "2.5": (-0.3, 0.0), "2.8": (0.15, -0.01), "2.3": (0, -0.01), "2.9": (-0.15, -0.01),
    ...        "9.1": (0.2, 0.5), "9.2": (-0.2, 0.5), "2.11": (0.2, -0.5), "2.12": (-0.2, -0.5)}
    >>> labels, side = slit_sides(uv, {k: np.array(v) for k, v in pts.items()}, slits=(LIPS,))
    >>> labels.tolist(), bool(np.isnan(side).all())      # no mesh: the polygons alone
    ([1, 2, 0], True)
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    region = np.zeros(len(uv), dtype=np.int8)
    field = np.full(len(uv), np.nan)
    graph = loops = None
    for k, slit in enumerate(slits):
        if any(p not in points_uv for p in slit.points):
            continue
        up_label, low_label = 2 * k + 1, 2 * k + 2
        upper = np.array([points_uv[p] for p in slit.upper], dtype=np.float64)
        lower = np.array([points_uv[p] for p in slit.lower], dtype=np.float64)
        mid = (upper + lower) / 2
        up_poly = np.vstack([mid, [points_uv[p] for p in slit.upper_close]])
        low_poly = np.vstack([mid, [points_uv[p] for p in slit.lower_close]])
        free = region == OUTSIDE
        is_up = free & points_in_polygon(uv, up_poly)
        is_low = free & ~is_up & points_in_polygon(uv, low_poly)
        region[is_up] = up_label
        region[is_low] = low_label
        if triangles is None or vertices is None or band <= 0 or len(uv) == 0:
            continue
        tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        if loops is None:
            loops = boundary_loops(tris)
        lo, hi = np.sort([mid[0, 0], mid[-1, 0]])
        ours = (region == OUTSIDE) | (region == up_label) | (region == low_label)
        along = (uv[:, 0] >= lo) & (uv[:, 0] <= hi)
        dist = _segment_distance(uv, mid)
        # which way is up: from the lower closing points to the upper ones
        toward = (np.mean([points_uv[p] for p in slit.upper_close], axis=0)
                  - np.mean([points_uv[p] for p in slit.lower_close], axis=0))
        near = (dist < band) & along & ours
        if graph is None:
            graph = _edges(tris, np.asarray(vertices, dtype=np.float64))
        i, j, w = graph
        n = len(uv)

        def conductances(inside: np.ndarray) -> sp.csr_matrix:
            keep = inside[i] & inside[j]
            g = sp.coo_matrix((1.0 / w[keep], (i[keep], j[keep])), shape=(n, n)).tocsr()
            return g + g.T

        sides = (region == up_label) | (region == low_label)
        polygon = region.copy()
        # the vertex at each corner (if one lies within the band of it)
        cand = np.flatnonzero(sides | near)
        corners = []
        for end in (upper[0], upper[-1]):
            d = np.hypot(*(uv[cand] - end).T)
            if len(d) and d.min() < band:
                corners.append(cand[np.argmin(d)])
        corners = np.array(corners, dtype=np.int64)
        none = np.zeros(n, dtype=bool)
        if near.any():
            side = _harmonic_side(conductances(sides | near), polygon, near, up_label,
                                  low_label, corners, none, none)
            if side is not None:
                region[near & (side > _DECIDED)] = up_label
                region[near & (side < -_DECIDED)] = low_label
                field[near] = side[near]
        rims = _rims(uv, loops, ours & ((region == up_label) | (region == low_label)
                                        | (dist < RIM_REACH * band)), mid, toward,
                     RIM_GUARD * band)
        if rims is None:
            continue
        up_rim, low_rim, ends = rims
        # the rims' field, on the pieces of mesh that hang from a rim (an eyeball or the
        # gums in the slit's region have none to go by), decides where it is clearly
        # nearer one rim than the other; elsewhere (round the corners, mostly) the band's
        # answer stands
        wide = (dist < RIM_REACH * band) & along & ours
        _, piece = connected_components(conductances(sides | wide), directed=False)
        wide &= np.isin(piece, np.unique(piece[up_rim | low_rim]))
        side = _harmonic_side(conductances(sides | wide), polygon, wide, up_label, low_label,
                              ends, up_rim, low_rim)
        if side is not None:
            sure = wide & (np.abs(side) >= RIM_CONFIDENCE)
            region[sure & (side > 0)] = up_label
            region[sure & (side < 0)] = low_label
            field[sure] = side[sure]
        region[up_rim], region[low_rim] = up_label, low_label
        field[up_rim], field[low_rim] = 1.0, -1.0
    return region, field


#: |field| at or below which a vertex is undecided and keeps the polygon's answer
#: (numerical zero: the field is 0 exactly where only the corners are reached).
_DECIDED = 1e-9


def _harmonic_side(g: sp.csr_matrix, region: np.ndarray, near: np.ndarray, up_label: int,
                   low_label: int, ground: np.ndarray, up_rim: np.ndarray,
                   low_rim: np.ndarray) -> Optional[np.ndarray]:
    """(n,) the harmonic field over ``g`` (conductances): +1 on the upper side's vertices
    outside the band and on ``up_rim``, -1 on the lower's and on ``low_rim``, 0 at
    ``ground``, free elsewhere in the band (0 where nothing fixed is reached).  None when
    a side has no fixed vertex."""
    up = ((region == up_label) & ~near) | up_rim
    low = ((region == low_label) & ~near) | low_rim
    if not up.any() or not low.any():
        return None
    x = np.zeros(len(region))
    x[up], x[low] = 1.0, -1.0
    free = near & ~up & ~low
    free[ground] = False
    x[ground] = 0.0
    deg = np.asarray(g.sum(axis=1)).ravel()
    unknown = np.flatnonzero(free & (deg > 0))
    if not len(unknown):
        return x
    gu = g[unknown]
    A = sp.diags(deg[unknown]) - gu[:, unknown]
    # a whisper of pull towards 0 keeps pieces reaching nothing fixed solvable (at 0)
    A = A + 1e-12 * float(deg[unknown].mean()) * sp.eye(len(unknown))
    x[unknown] = spla.spsolve(A.tocsc(), gu @ x)
    return x


#: How far from the mid line (in bands) the mesh settles the sides when it has a rim
#: to go by: past the band, as far as misplaced feature points push a lip across the
#: mid line (1 mm of noise on the points of ICT heads put lower-lip vertices up to 1.4
#: bands above it on a full head and 3 on a decimated one).
RIM_REACH = 4.0
#: How clearly the rims' field must say a side (|field|, 1 on a rim) to overrule the
#: band's answer: more than half way to one rim.  Round the corners, where both rims
#: meet, the field is weak (0.03-0.2 at the lower-lip vertices it gave the upper lip's
#: motion on three noisy ICT clones), while the pieces of lip that noise had pushed
#: across the mid line sit at 0.999.
RIM_CONFIDENCE = 0.5
#: Below what |field| (of :func:`slit_sides`) a vertex is taken to lie where a slit's two
#: sides meet, and takes the motion of both, the upper side's weighted
#: ``(1 + field / SIDE_BLEND) / 2`` (:func:`~mpeg4fba.cloning.weights.mapping_weights`),
#: rather than all of one side's.  Round a mouth corner the field is weak (0.01-0.13 at
#: the lower-lip vertices a corner point found 0.9 % of the eye distance off gave the
#: upper lip's motion, 11.8 % off under jawOpen; 6.6 blended at 0.5), and there both
#: lips' motions meet anyway.  But a vertex whose side was right loses by the blend, so
#: the width is a trade, measured (largest error, % of the eye distance) on ICT heads
#: cloned with landmark, found and 1 mm noisy points (the first 3 people of a fresh draw,
#: seed 6161, and of the regression draw, full and decimated: 36 clones) and on the real
#: decimator's pairs with exact points (``benchmarks/bench_clone_pairs.py``, seeds 1919,
#: 2032, 2033: 120 clones).  0.5: 5 better and 1 worse of the 36 (17.3 -> 9.1, 9.4 ->
#: 7.2, 9.1 -> 6.7; 3.5 -> 4.8), but 7 better and 12 worse of the pairs on 1919 and 2032
#: alone (decimated 2032's median 5.71 -> 6.21).  0.1 and 0.25: 3 better, none worse of
#: the 36 (17.3 -> 9.1, 9.4 -> 7.2, 4.2 -> 3.6); of the pairs 0.1 7 better and 4 worse
#: (7.87 -> 5.51, 5.18 -> 4.62; 2.60 -> 5.05, the others by 0.1 or less; decimated 2032's
#: median 5.71 -> 5.37), 0.25 8 better and 4 worse on 1919 and 2032.
SIDE_BLEND = 0.1
#: How far short of its ends (in bands) a rim stops: where the loop turns at a corner,
#: which lip a vertex is on is the band's to say.
RIM_GUARD = 2.0


def _rims(uv: np.ndarray, loops: list, zone: np.ndarray, mid: np.ndarray,
          toward: np.ndarray, guard: float) -> Optional[tuple]:
    """(upper rim, lower rim, corners) of a slit that is a hole in the mesh: each
    boundary loop lying (by 80 % of its vertices) in ``zone``, spanning half the mid
    line's width or more, is split at its two ends along the slit (its outermost
    vertices); the half further along ``toward`` (by its median) is the upper
    rim, and it must lie on the far side of the mid line ``mid`` from the other (a hole
    within one lip does not).  The ends are the corners; the rims stop ``guard`` short
    of them.  None without such a loop.
    """
    n = len(uv)
    up, low = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    corners = []
    t = toward / max(float(np.linalg.norm(toward)), 1e-300)
    level = float((mid @ t).mean())
    width = float(np.ptp(mid[:, 0]))
    for loop in loops:
        if len(loop) < 4 or zone[loop].mean() < 0.8:
            continue
        u, h = uv[loop, 0], uv[loop] @ t
        span = float(np.ptp(u))
        if span < 0.5 * width:
            continue
        # each end: the loop's outermost vertex along the slit, where the hole itself
        # turns (on a rounded corner it may lie a little on either lip; the rims stop
        # ``guard`` short of it).  Not the vertex at the mid line's height near there:
        # the mid line is the feature points', and near a corner a lip's rim runs level
        # with it, so points a millimetre off put that end up to a tenth of the mouth
        # inside the corner, on one lip (ICT, fresh draw 4602, a decimated head with
        # found points: a lower-lip stretch cut off with the upper rim, largest error
        # 19.9 -> 6.9 % of the eye distance; of the draw's 80 clones one other better,
        # none worse)
        a, b = sorted((int(np.argmin(u)), int(np.argmax(u))))
        one, two = np.arange(a + 1, b), np.r_[np.arange(b + 1, len(loop)), np.arange(a)]
        if not len(one) or not len(two):
            continue
        # medians: a piece of a rim may be aligned across the mid line, as its lip is
        h1, h2 = float(np.median(h[one])), float(np.median(h[two]))
        if h1 < h2:
            one, two, h1, h2 = two, one, h2, h1
        if not h1 > level > h2:
            continue
        gap = np.min([np.hypot(*(uv[loop] - uv[loop[e]]).T) for e in (a, b)], axis=0)
        up[loop[one[gap[one] >= guard]]] = True
        low[loop[two[gap[two] >= guard]]] = True
        corners += [loop[a], loop[b]]
    if not corners:
        return None
    both = up & low
    return up & ~both, low & ~both, np.array(corners, dtype=np.int64)


def _edges(tris: np.ndarray, v: np.ndarray) -> tuple:
    i, j, length = triangle_edges(v, tris)
    return i, j, length + 1e-12           # a zero weight would be no edge to dijkstra


def lip_regions(uv: np.ndarray, points_uv: Mapping, *, triangles: Optional[np.ndarray] = None,
                vertices: Optional[np.ndarray] = None, band: float = 0.03) -> np.ndarray:
    """(n,) region of each 2D point for the lips alone: :data:`OUTSIDE`, :data:`UPPER` or
    :data:`LOWER` (see :func:`slit_regions`)."""
    return slit_regions(uv, points_uv, slits=(LIPS,), triangles=triangles, vertices=vertices,
                        band=band)
