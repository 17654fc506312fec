"""Closest points on triangle meshes, the 3D warp of one face onto another by its
feature points, and the pinning of one neck cut onto another: the pieces of the cloner's
surface alignment (:mod:`~mpeg4fba.cloning.fmc`).

>>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); T = np.array([[0, 1, 2]])
>>> t, b, d = closest_points(np.array([[0.2, 0.2, 1.0], [2.0, 0.0, 0.0]]), V, T)
>>> t.tolist(), np.round(b, 6).tolist(), np.round(d, 6).tolist()
([0, 0], [[0.6, 0.2, 0.2], [0.0, 1.0, 0.0]], [1.0, 1.0])
"""
from __future__ import annotations

from collections import defaultdict
from typing import Optional, Union

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

__all__ = ["closest_points", "point_triangle", "feature_warp", "boundary_loops",
           "boundary_vertices", "neck_cut", "loop_correspondence", "vertex_normals", "triangle_normals", "triangle_edges",
           "surface_weights", "triangle_neighbours", "onto_same_sheet"]

def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of two (n, 3) arrays (einsum: twice as fast as a product's
    ``sum(1)``)."""
    return np.einsum("ij,ij->i", a, b)


def point_triangle(p: np.ndarray, tri: np.ndarray) -> tuple:
    """(barycentrics (n, 3), distances (n,)) of the closest point of triangle ``tri[i]``
    (n, 3, 3) to ``p[i]`` (n, 3), for all rows at once: the projection on the plane where
    it falls inside (most rows, when the triangles were chosen near the points), else the
    nearest of the closest points on the three edges (degenerate triangles too)."""
    p = np.asarray(p, dtype=np.float64)
    out, sliver = _plane_coordinates(p, tri)
    # a sliver's plane is ill-defined: its rows go the edges' way
    inside = (out >= 0).all(axis=1) & ~sliver
    rest = np.flatnonzero(~inside)
    if len(rest):
        q, corner = p[rest], tri[rest]
        best = np.full(len(rest), np.inf)
        bary = np.zeros((len(rest), 3))
        for i, j in ((0, 1), (1, 2), (2, 0)):
            e = corner[:, j] - corner[:, i]
            ee = _dot(e, e)
            s = np.clip(_dot(q - corner[:, i], e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
            gap = corner[:, i] + s[:, None] * e - q
            d = _dot(gap, gap)
            better = d < best
            best[better] = d[better]
            bary[better] = 0.0
            bary[better, i] = 1 - s[better]
            bary[better, j] = s[better]
        out[rest] = bary
    gap = np.einsum("nk,nkc->nc", out, tri) - p
    return out, np.sqrt(_dot(gap, gap))


def closest_points(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray,
                   k: int = 6, *, normals: Optional[np.ndarray] = None,
                   facing: float = 0.0) -> tuple:
    """(triangle index, barycentrics, distance) of the closest point of the mesh to each
    of ``points``, searched among the triangles around the ``k`` nearest vertices (exact
    unless the mesh is much coarser near a point than elsewhere).

    With ``normals`` (n, 3, unit or zero) and ``facing`` > 0 a triangle is chosen by its
    distance plus ``facing * (1 - cos) / 2``, cos between its normal and the point's: a
    triangle facing the other way counts ``facing`` further away, so of two sheets that
    touch (closed lips, eyelids) the point takes the one it faces like.  A zero normal
    adds the same to every triangle (plain closest point).  The distance returned is the
    true one.  The work is in proportion to the points, not the mesh, beyond one k-d tree
    of its vertices and one sort of its triangles' corners.

    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0.01], [0, 1, 0.01], [1, 0, 0.01]])
    >>> T = np.array([[0, 1, 2], [3, 4, 5]])   # a sheet facing +z under one facing -z
    >>> P, up = np.array([[0.2, 0.2, 0.006]]), np.array([[0.0, 0, 1]])
    >>> [int(closest_points(P, V, T, normals=up, facing=f)[0][0]) for f in (0.0, 0.01)]
    [1, 0]
    """
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    cost_of_facing = normals is not None and facing > 0
    if cost_of_facing:
        N = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        # the sheet a point faces like may lie a little beyond the nearest vertices
        k = max(int(k), 12)
    flat = T.ravel()
    counts = np.bincount(flat, minlength=len(V))
    used = np.flatnonzero(counts)
    k = max(1, min(int(k), len(used)))
    gap, near = cKDTree(V[used]).query(P, k=k)
    gap = np.asarray(gap).reshape(len(P), k)
    near = used[np.asarray(near).reshape(len(P), k)]
    order = np.argsort(flat, kind="stable")
    start = np.concatenate([[0], np.cumsum(counts)])
    tri_of = order // 3
    # the triangles round the vertices any point may look at, and their bounds: a
    # triangle round vertex v lies within its longest edge of v, so it is no nearer to a
    # point than |point - v| - that edge; likewise no nearer than |point - centroid| -
    # its farthest corner.  Neighbours and triangles beyond the best found are skipped.
    seen = np.unique(near)
    cnt = counts[seen]
    pos = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt) + np.repeat(start[seen], cnt)
    cand = np.unique(tri_of[pos])
    corners = V[T[cand]]
    centre = np.zeros((len(T), 3))
    radius = np.zeros(len(T))
    longest = np.zeros(len(T))
    centre[cand] = corners.mean(axis=1)
    radius[cand] = np.linalg.norm(corners - centre[cand][:, None], axis=2).max(axis=1)
    longest[cand] = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    reach = np.zeros(len(V))
    reach[seen] = np.maximum.reduceat(longest[tri_of[pos]], np.cumsum(cnt) - cnt)
    if cost_of_facing:
        tn = np.zeros((len(T), 3))
        tn[cand] = triangle_normals(V, T[cand])
    best_d = np.full(len(P), np.inf)
    best_c = np.full(len(P), np.inf)
    best_t = np.zeros(len(P), dtype=np.int64)
    best_b = np.zeros((len(P), 3))
    for j in range(k):
        active = np.flatnonzero(gap[:, j] - reach[near[:, j]] <= best_c)
        if not len(active):
            continue
        v = near[active, j]
        # every (point, incident triangle) pair of this neighbour at once
        cnt = counts[v]
        rows = np.repeat(active, cnt)
        pos = np.arange(rows.size) - np.repeat(np.cumsum(cnt) - cnt, cnt) + np.repeat(start[v], cnt)
        t = tri_of[pos]
        off = P[rows] - centre[t]
        hope = np.sqrt(_dot(off, off)) - radius[t] <= best_c[rows]
        rows, t = rows[hope], t[hope]
        if not rows.size:
            continue
        b, d = point_triangle(P[rows], V[T[t]])
        cost = d + facing * (1 - _dot(N[rows], tn[t])) / 2 if cost_of_facing else d
        # the best pair of each point (rows come grouped; the first of equal costs wins)
        new = np.r_[True, rows[1:] != rows[:-1]]
        group = np.cumsum(new) - 1
        low = np.minimum.reduceat(cost, np.flatnonzero(new))
        hit = np.flatnonzero(cost == low[group])
        first = hit[np.r_[True, group[hit][1:] != group[hit][:-1]]]
        rows, t, b, d, cost = rows[first], t[first], b[first], d[first], cost[first]
        better = cost < best_c[rows]
        r = rows[better]
        best_c[r], best_d[r], best_t[r], best_b[r] = cost[better], d[better], t[better], b[better]
    return best_t, best_b, best_d


def feature_warp(moving: np.ndarray, fixed: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points`` moved by the thin-plate spline taking the 3D points ``moving`` (k, 3)
    onto ``fixed`` exactly (points closer than 1e-9 of the spread to an earlier one are
    left out, so coincident feature points - a closed mouth's - do no harm)."""
    from scipy.interpolate import RBFInterpolator

    m = np.asarray(moving, dtype=np.float64)
    f = np.asarray(fixed, dtype=np.float64)
    scale = max(float(np.ptp(m, axis=0).max()), 1e-300)
    _, keep = np.unique(np.round(m / (scale * 1e-9)).astype(np.int64), axis=0, return_index=True)
    keep = np.sort(keep)
    if len(keep) < 5:
        return np.asarray(points, dtype=np.float64) + (f[keep] - m[keep]).mean(axis=0)
    warp = RBFInterpolator(m[keep], f[keep] - m[keep], kernel="thin_plate_spline")
    p = np.asarray(points, dtype=np.float64)
    return p + warp(p)


def boundary_vertices(T: np.ndarray, n: int) -> np.ndarray:
    """(n,) True at the vertices on a boundary edge (an edge of one triangle)."""
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    key = e[:, 0] * n + e[:, 1]
    u, cnt = np.unique(key, return_counts=True)
    once = u[cnt == 1]
    out = np.zeros(n, dtype=bool)
    out[once // n] = True
    out[once % n] = True
    return out


def boundary_loops(triangles: np.ndarray) -> list:
    """The closed chains of boundary edges (edges of a single triangle) of a mesh, each an
    array of vertex indices in order; open chains (at non-manifold vertices) are dropped.

    >>> [l.tolist() for l in boundary_loops(np.array([[0, 1, 2], [0, 2, 3]]))]
    [[0, 1, 2, 3]]
    """
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    e = T[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    if not len(e):
        return []
    _, inverse, count = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True,
                                  return_counts=True)
    b = e[count[inverse.ravel()] == 1]
    starting = defaultdict(list)
    for k, a in enumerate(b[:, 0].tolist()):
        starting[a].append(k)
    used = np.zeros(len(b), dtype=bool)
    loops = []
    # a walk per loop: boundary edges are few (the rims of the holes), not per vertex
    for first in range(len(b)):
        if used[first]:
            continue
        chain, k = [], first
        while True:
            used[k] = True
            chain.append(int(b[k, 0]))
            nxt = [j for j in starting[int(b[k, 1])] if not used[j]]
            if int(b[k, 1]) == chain[0] or not nxt:
                break
            k = nxt[0]
        if int(b[k, 1]) == chain[0] and len(chain) >= 3:
            loops.append(np.array(chain, dtype=np.int64))
    return loops


def neck_cut(vertices: np.ndarray, triangles: np.ndarray, chin: np.ndarray,
             axis: np.ndarray) -> Optional[np.ndarray]:
    """The boundary loop where a head mesh is cut off at the neck, or None.

    ``vertices`` in the face frame (y up); the cut is the lowest boundary loop that winds
    once round the vertical line through ``axis`` (the top of the spine, 7.1) and lies,
    on average, below ``chin`` (2.1): a hole of the face (a mouth, an eye) winds round
    no such line, and a face mask's rim is not below its chin.
    """
    V = np.asarray(vertices, dtype=np.float64)
    best, best_y = None, np.inf
    for loop in boundary_loops(triangles):
        p = V[loop]
        y = float(p[:, 1].mean())
        if y >= float(chin[1]) or y >= best_y:
            continue
        a = np.arctan2(p[:, 0] - axis[0], p[:, 2] - axis[2])
        turns = np.diff(np.append(a, a[0]))
        turns = (turns + np.pi) % (2 * np.pi) - np.pi
        if abs(round(float(turns.sum()) / (2 * np.pi))) == 1:
            best, best_y = loop, y
    return best


def loop_correspondence(moving: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """For each point of the closed loop ``moving`` (n, 3), the point of the closed loop
    ``fixed`` (m, 3) at the same angle round the vertical line through each loop's
    centroid (the loops of two neck cuts: star-shaped about that line), interpolated
    along ``fixed``'s vertices."""
    def angles(p):
        c = p.mean(axis=0)
        return np.arctan2(p[:, 0] - c[0], p[:, 2] - c[2])

    f = np.asarray(fixed, dtype=np.float64)
    a = angles(f)
    order = np.argsort(a)
    a, f = a[order], f[order]
    a3 = np.concatenate([a - 2 * np.pi, a, a + 2 * np.pi])
    f3 = np.vstack([f, f, f])
    want = angles(np.asarray(moving, dtype=np.float64))
    return np.stack([np.interp(want, a3, f3[:, j]) for j in range(3)], axis=1)


def triangle_edges(vertices: np.ndarray, triangles: np.ndarray) -> tuple:
    """(i, j, length): the three edges of every triangle, corner 0 -> 1, 1 -> 2, 2 -> 0
    (3m each, a shared edge once per triangle), and their lengths.

    >>> i, j, d = triangle_edges(np.array([[0.0, 0, 0], [3, 0, 0], [0, 4, 0]]), np.array([[0, 1, 2]]))
    >>> i.tolist(), j.tolist(), d.tolist()
    ([0, 1, 2], [1, 2, 0], [3.0, 5.0, 4.0])
    """
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    i = np.concatenate([T[:, 0], T[:, 1], T[:, 2]])
    j = np.concatenate([T[:, 1], T[:, 2], T[:, 0]])
    return i, j, np.linalg.norm(V[i] - V[j], axis=1)


def triangle_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(m, 3) unit normals of the triangles (by their winding; 0 for a degenerate one)."""
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    n = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def onto_same_sheet(before: np.ndarray, after: np.ndarray, vertices: np.ndarray,
                    triangles: np.ndarray, facing: float) -> tuple:
    """(triangle index, barycentrics) of each point of ``after`` dropped onto the mesh,
    on the sheet its point of ``before`` lies on: a triangle facing away from the one
    under ``before`` counts ``facing`` further (closed lips and lids are two sheets that
    a move of a millimetre can cross; :func:`closest_points`).

    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, .01], [0, 1, .01], [1, 0, .01]], float)
    >>> T = np.array([[0, 1, 2], [3, 4, 5]])          # two sheets 0.01 apart, facing apart
    >>> p = np.array([[0.2, 0.2, 0.0]])
    >>> int(onto_same_sheet(p, p + [0, 0, 0.009], V, T, facing=1.0)[0][0])
    0
    """
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    here, _, _ = closest_points(np.asarray(before, dtype=np.float64), V, T)
    tri, bary, _ = closest_points(np.asarray(after, dtype=np.float64), V, T,
                                  normals=triangle_normals(V, T[here]), facing=facing)
    return tri, bary


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(n, 3) unit normals, the area-weighted mean of the incident triangles' (0 for a
    vertex in no triangle)."""
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    face = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    corners = T.ravel()
    # bincount sums per vertex many times faster than np.add.at
    n = np.stack([np.bincount(corners, np.repeat(face[:, c], 3), minlength=len(V))
                  for c in range(3)], axis=1)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def triangle_neighbours(triangles: np.ndarray) -> np.ndarray:
    """(m, 3) index of the triangle across the edge opposite each corner (-1 on a
    boundary, or where more than two triangles share the edge).

    >>> triangle_neighbours(np.array([[0, 1, 2], [2, 1, 3]])).tolist()
    [[1, -1, -1], [-1, -1, 0]]
    """
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    m = len(T)
    out = np.full((m, 3), -1, dtype=np.int64)
    if not m:
        return out
    # the edge opposite corner k joins corners k+1 and k+2
    a = np.concatenate([T[:, 1], T[:, 2], T[:, 0]])
    b = np.concatenate([T[:, 2], T[:, 0], T[:, 1]])
    tri = np.tile(np.arange(m), 3)
    corner = np.repeat(np.arange(3), m)
    key = np.minimum(a, b) * (int(T.max()) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    k = key[order]
    first = np.ones(len(k), dtype=bool)
    first[1:] = k[1:] != k[:-1]
    group = np.cumsum(first) - 1
    size = np.bincount(group)
    pair = size[group] == 2
    # in a group of two, each member's neighbour is the other
    start = np.flatnonzero(first)
    other = np.where(np.arange(len(k)) == start[group], start[group] + 1, start[group])
    sel = order[pair]
    out[tri[sel], corner[sel]] = tri[order[other[pair]]]
    return out


def _plane_coordinates(P: np.ndarray, tri: np.ndarray) -> tuple:
    """(barycentric coordinates of the projections of ``P`` (n, 3) on the planes of
    ``tri`` (n, 3, 3), negative outside the triangle; whether each triangle is a sliver,
    its squared area under 1e-12 of the product of its two edges' squared lengths)."""
    a = tri[:, 0]
    e1, e2, d = tri[:, 1] - a, tri[:, 2] - a, P - a
    d00, d01, d11 = _dot(e1, e1), _dot(e1, e2), _dot(e2, e2)
    d20, d21 = _dot(d, e1), _dot(d, e2)
    den = d00 * d11 - d01 * d01
    sliver = den <= 1e-12 * d00 * d11
    den = np.where(np.abs(den) > 0, den, np.inf)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.stack([1 - v - w, v, w], axis=1), sliver


def _plane_barycentric(P: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of the projections of ``P`` (n, 3) on the planes of
    ``tri`` (n, 3, 3); negative outside the triangle."""
    return _plane_coordinates(P, tri)[0]


def surface_weights(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray,
                    radius: Union[float, np.ndarray] = 0.0, samples: int = 8,
                    steps: int = 8, *, normals: Optional[np.ndarray] = None,
                    facing: float = 0.0) -> sp.csr_matrix:
    """(len(points), len(vertices)) interpolation weights over a mesh at the closest
    point of each of ``points``, anti-aliased: the average with ``samples`` points on
    the circle of ``radius`` (one per point, or one for all) round it in the plane of
    its triangle, each carried over the mesh by walking across edges (up to ``steps``
    triangles; past a boundary it stops at the rim).  The paper's filter, on the surface
    rather than in the 2D projection.  Rows sum to 1.  ``normals`` and ``facing``: the
    closest point is chosen as :func:`closest_points` says.

    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]); T = np.array([[0, 1, 2], [2, 1, 3]])
    >>> surface_weights(np.array([[0.2, 0.2, 0.3]]), V, T).toarray().round(6).tolist()
    [[0.6, 0.2, 0.2, 0.0]]
    >>> w = surface_weights(np.array([[0.45, 0.45, 0.0]]), V, T, radius=0.2, samples=4)
    >>> w.toarray().round(6).tolist()   # two samples cross into the second triangle
    [[0.14, 0.41, 0.41, 0.04]]
    """
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    n = len(P)
    t, b, _ = closest_points(P, V, T, normals=normals, facing=facing)
    rows, cols, vals = [np.repeat(np.arange(n), 3)], [T[t].ravel()], [b.ravel()]
    r = np.broadcast_to(np.asarray(radius, dtype=np.float64).reshape(-1), (n,))
    filtered = np.flatnonzero(r > 0) if samples > 0 else np.zeros(0, dtype=np.int64)
    share = np.ones(n)
    if len(filtered):
        share[filtered] = 1.0 / (samples + 1)
        corners = V[T[t[filtered]]]
        q = np.einsum("nk,nkc->nc", b[filtered], corners)
        normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        e1 = corners[:, 1] - corners[:, 0]
        e1 -= (e1 * normal).sum(1, keepdims=True) * normal
        e1 /= np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), 1e-300)
        e2 = np.cross(normal, e1)
        angle = 2 * np.pi * np.arange(samples) / samples
        offset = (np.cos(angle)[None, :, None] * e1[:, None] + np.sin(angle)[None, :, None] * e2[:, None])
        S = (q[:, None] + r[filtered, None, None] * offset).reshape(-1, 3)
        cur = np.repeat(t[filtered], samples)
        near = triangle_neighbours(T)
        walking = np.arange(len(S))           # samples still crossing edges
        for _ in range(int(steps)):
            c = cur[walking]
            bary = _plane_barycentric(S[walking], V[T[c]])
            worst = bary.argmin(axis=1)
            nxt = near[c, worst]
            move = (bary[np.arange(len(walking)), worst] < -1e-12) & (nxt >= 0)
            if not move.any():
                break
            walking = walking[move]
            cur[walking] = nxt[move]
        bary = np.clip(_plane_barycentric(S, V[T[cur]]), 0.0, None)
        total = bary.sum(axis=1, keepdims=True)
        bary = np.where(total > 0, bary / np.where(total > 0, total, 1), 1.0 / 3.0)
        rows.append(np.repeat(np.repeat(filtered, samples), 3))
        cols.append(T[cur].ravel())
        vals.append(bary.ravel() / (samples + 1))
    vals[0] = vals[0] * np.repeat(share, 3)
    out = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                        shape=(n, len(V)))
    out.sum_duplicates()
    return out
