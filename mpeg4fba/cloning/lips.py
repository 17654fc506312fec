"""The lip regions of Facial Motion Cloning ("Treating the lip region").

Upper and lower lips lie close together in the alignment space but move in opposite
directions, so every vertex is put in one of three regions: :data:`UPPER` lip,
:data:`LOWER` lip or :data:`OUTSIDE`.  The upper-lip region is the polygon of the inner
upper lip contour closed by the sides of the nose (the nostrils 9.1, 9.2); the lower-lip
region the polygon of the inner lower lip contour closed by the sides of the chin (the
chin corners 2.11, 2.12).  Both are tested in the 2D alignment space.

On a closed mouth the two inner contours coincide, and vertices of the upper lip's
inner edge lie on (or, between feature points, a little past) the lower polygon's
border.  So vertices within ``band`` of the inner contours are classified again by the
mesh: each goes to the lip it is nearer to *along the surface* (edge-length-weighted
graph distance from the vertices of either polygon outside the band).  Where the
mouth slit is a real cut in the mesh this follows the slit exactly; where a vertex is
shared by both lips it keeps the polygon's answer.

>>> uv = np.array([[0.0, 0.1], [0.0, -0.1], [0.5, 0.0], [0.0, 0.0]])
>>> pts = {"2.4": (0.3, 0.0), "2.6": (0.15, 0.0), "2.2": (0, 0.0), "2.7": (-0.15, 0.0),
...        "2.5": (-0.3, 0.0), "2.8": (0.15, 0.0), "2.3": (0, 0.0), "2.9": (-0.15, 0.0),
...        "9.1": (0.2, 0.5), "9.2": (-0.2, 0.5), "2.11": (0.2, -0.5), "2.12": (-0.2, -0.5)}
>>> lip_regions(uv, {k: np.array(v) for k, v in pts.items()}).tolist()  # on the slit: upper
[1, 2, 0, 1]
"""
from __future__ import annotations

from typing import Mapping, Optional

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

__all__ = ["OUTSIDE", "UPPER", "LOWER", "UPPER_LIP_POLYGON", "LOWER_LIP_POLYGON",
           "lip_regions", "points_in_polygon", "LIP_POINTS"]

OUTSIDE, UPPER, LOWER = 0, 1, 2

#: Polygon of the upper-lip region: the inner upper contour from the left corner to the
#: right, then up to the right and left nostrils.
UPPER_LIP_POLYGON = ("2.4", "2.6", "2.2", "2.7", "2.5", "9.2", "9.1")
#: Polygon of the lower-lip region: the inner lower contour, then down to the chin corners.
LOWER_LIP_POLYGON = ("2.4", "2.8", "2.3", "2.9", "2.5", "2.12", "2.11")
#: The feature points the lip regions need.
LIP_POINTS = tuple(dict.fromkeys(UPPER_LIP_POLYGON + LOWER_LIP_POLYGON))
_INNER_UPPER = ("2.4", "2.6", "2.2", "2.7", "2.5")
_INNER_LOWER = ("2.4", "2.8", "2.3", "2.9", "2.5")


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


def lip_regions(uv: np.ndarray, points_uv: Mapping, *, triangles: Optional[np.ndarray] = None,
                vertices: Optional[np.ndarray] = None, band: float = 0.03) -> np.ndarray:
    """(n,) region of each 2D point: :data:`OUTSIDE`, :data:`UPPER` or :data:`LOWER`.

    ``points_uv`` maps the ids of :data:`LIP_POINTS` to their 2D positions.  With the
    mesh (``triangles`` over ``uv``'s rows and 3D ``vertices``) the vertices within
    ``band`` of the inner lip contours are settled by surface distance (see the module
    docstring).
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    upper = points_in_polygon(uv, np.array([points_uv[p] for p in UPPER_LIP_POLYGON]))
    lower = points_in_polygon(uv, np.array([points_uv[p] for p in LOWER_LIP_POLYGON])) & ~upper
    region = np.where(upper, UPPER, np.where(lower, LOWER, OUTSIDE)).astype(np.int8)
    if triangles is None or vertices is None or len(uv) == 0 or band <= 0:
        return region
    inner = np.array([points_uv[p] for p in _INNER_UPPER])
    inner_low = np.array([points_uv[p] for p in _INNER_LOWER])
    near = (np.minimum(_segment_distance(uv, inner), _segment_distance(uv, inner_low)) < band) \
        & (region != OUTSIDE)
    if not near.any():
        return region
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    v = np.asarray(vertices, dtype=np.float64)
    i = np.concatenate([tris[:, 0], tris[:, 1], tris[:, 2]])
    j = np.concatenate([tris[:, 1], tris[:, 2], tris[:, 0]])
    # only edges within the lip regions: a path round the mouth corner through the
    # outside region would make the far lip look near
    keep = (region[i] != OUTSIDE) & (region[j] != OUTSIDE)
    i, j = i[keep], j[keep]
    w = np.linalg.norm(v[i] - v[j], axis=1) + 1e-12
    n = len(uv)
    graph = sp.coo_matrix((np.concatenate([w, w]), (np.concatenate([i, j]), np.concatenate([j, i]))),
                          shape=(n, n)).tocsr()
    out = region.copy()
    dist = []
    for which in (UPPER, LOWER):
        seeds = np.flatnonzero((region == which) & ~near)
        if len(seeds) == 0:
            return region
        d = dijkstra(graph, directed=False, indices=seeds, min_only=True)
        dist.append(d)
    du, dl = dist
    settle = near & (np.isfinite(du) | np.isfinite(dl))
    out[settle & (du < dl)] = UPPER
    out[settle & (dl < du)] = LOWER
    return out
