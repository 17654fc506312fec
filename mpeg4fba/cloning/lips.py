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

from .surface import triangle_edges

__all__ = ["OUTSIDE", "UPPER", "LOWER", "Slit", "LIPS", "LEFT_EYELIDS", "RIGHT_EYELIDS",
           "SLITS", "UPPER_LIP_POLYGON", "LOWER_LIP_POLYGON", "LIP_POINTS", "lip_regions",
           "slit_regions", "points_in_polygon", "opposite"]

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
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    region = np.zeros(len(uv), dtype=np.int8)
    graph = None
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
        lo, hi = np.sort([mid[0, 0], mid[-1, 0]])
        near = (_segment_distance(uv, mid) < band) & (uv[:, 0] >= lo) & (uv[:, 0] <= hi) \
            & ((region == OUTSIDE) | (region == up_label) | (region == low_label))
        if not near.any():
            continue
        if graph is None:
            graph = _edges(np.asarray(triangles, dtype=np.int64).reshape(-1, 3),
                           np.asarray(vertices, dtype=np.float64))
        i, j, w = graph
        inside = (region == up_label) | (region == low_label) | near
        keep = inside[i] & inside[j]
        n = len(uv)
        g = sp.coo_matrix((1.0 / w[keep], (i[keep], j[keep])), shape=(n, n)).tocsr()
        g = g + g.T
        # the vertex at each corner (if one lies within the band of it)
        cand = np.flatnonzero(inside)
        corners = []
        for end in (upper[0], upper[-1]):
            d = np.hypot(*(uv[cand] - end).T)
            if len(d) and d.min() < band:
                corners.append(cand[np.argmin(d)])
        side = _harmonic_side(g, region, near, up_label, low_label,
                              np.array(corners, dtype=np.int64))
        if side is None:
            continue
        region[near & (side > _DECIDED)] = up_label
        region[near & (side < -_DECIDED)] = low_label
    return region


#: |field| at or below which a vertex is undecided and keeps the polygon's answer
#: (numerical zero: the field is 0 exactly where only the corners are reached).
_DECIDED = 1e-9


def _harmonic_side(g: sp.csr_matrix, region: np.ndarray, near: np.ndarray, up_label: int,
                   low_label: int, ground: np.ndarray) -> Optional[np.ndarray]:
    """(n,) the harmonic field over ``g`` (conductances): +1 on the upper side's vertices
    outside the band, -1 on the lower's, 0 at ``ground``, free in the band (0 where
    nothing fixed is reached).  None when a side has no vertex outside the band."""
    up = (region == up_label) & ~near
    low = (region == low_label) & ~near
    if not up.any() or not low.any():
        return None
    x = np.zeros(len(region))
    x[up], x[low] = 1.0, -1.0
    free = near.copy()
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


def _edges(tris: np.ndarray, v: np.ndarray) -> tuple:
    i, j, length = triangle_edges(v, tris)
    return i, j, length + 1e-12           # a zero weight would be no edge to dijkstra


def lip_regions(uv: np.ndarray, points_uv: Mapping, *, triangles: Optional[np.ndarray] = None,
                vertices: Optional[np.ndarray] = None, band: float = 0.03) -> np.ndarray:
    """(n,) region of each 2D point for the lips alone: :data:`OUTSIDE`, :data:`UPPER` or
    :data:`LOWER` (see :func:`slit_regions`)."""
    return slit_regions(uv, points_uv, slits=(LIPS,), triangles=triangles, vertices=vertices,
                        band=band)
