"""Closest points on triangle meshes, and the 3D warp of one face onto another by its
feature points: the pieces of the cloner's surface alignment (:mod:`~mpeg4fba.cloning.fmc`).

>>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); T = np.array([[0, 1, 2]])
>>> t, b, d = closest_points(np.array([[0.2, 0.2, 1.0], [2.0, 0.0, 0.0]]), V, T)
>>> t.tolist(), np.round(b, 6).tolist(), np.round(d, 6).tolist()
([0, 0], [[0.6, 0.2, 0.2], [0.0, 1.0, 0.0]], [1.0, 1.0])
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["closest_points", "point_triangle", "feature_warp"]


def point_triangle(p: np.ndarray, tri: np.ndarray) -> tuple:
    """(barycentrics (n, 3), distances (n,)) of the closest point of triangle ``tri[i]``
    (n, 3, 3) to ``p[i]`` (n, 3): the Voronoi-region test of the vertices, edges and face,
    for all rows at once."""
    p = np.asarray(p, dtype=np.float64)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac = b - a, c - a
    ap, bp, cp = p - a, p - b, p - c
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    n = len(p)
    out = np.zeros((n, 3))
    done = np.zeros(n, dtype=bool)

    def take(mask, w0, w1, w2):
        m = mask & ~done
        out[m, 0], out[m, 1], out[m, 2] = w0[m], w1[m], w2[m]
        done[m] = True

    one, zero = np.ones(n), np.zeros(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        take((d1 <= 0) & (d2 <= 0), one, zero, zero)                       # vertex a
        take((d3 >= 0) & (d4 <= d3), zero, one, zero)                      # vertex b
        v = d1 / (d1 - d3)
        take((vc <= 0) & (d1 >= 0) & (d3 <= 0), 1 - v, v, zero)           # edge ab
        take((d6 >= 0) & (d5 <= d6), zero, zero, one)                      # vertex c
        w = d2 / (d2 - d6)
        take((vb <= 0) & (d2 >= 0) & (d6 <= 0), 1 - w, zero, w)           # edge ac
        e = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        take((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), zero, 1 - e, e)  # edge bc
        den = 1.0 / (va + vb + vc)
        take(np.ones(n, dtype=bool), 1 - (vb + vc) * den, vb * den, vc * den)  # face
    out = np.nan_to_num(out, nan=1.0 / 3.0)
    q = np.einsum("nk,nkc->nc", out, tri)
    return out, np.linalg.norm(p - q, axis=1)


def closest_points(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray,
                   k: int = 6) -> tuple:
    """(triangle index, barycentrics, distance) of the closest point of the mesh to each
    of ``points``, searched among the triangles around the ``k`` nearest vertices (exact
    unless the mesh is much coarser near a point than elsewhere)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    used = np.unique(T)
    k = max(1, min(int(k), len(used)))
    _, near = cKDTree(V[used]).query(P, k=k)
    near = used[np.asarray(near).reshape(len(P), k)]
    flat = T.ravel()
    order = np.argsort(flat, kind="stable")
    counts = np.bincount(flat, minlength=len(V))
    start = np.concatenate([[0], np.cumsum(counts)])
    tri_of = order // 3
    best_d = np.full(len(P), np.inf)
    best_t = np.zeros(len(P), dtype=np.int64)
    best_b = np.zeros((len(P), 3))
    for j in range(k):
        v = near[:, j]
        # every (point, incident triangle) pair of this neighbour at once
        cnt = counts[v]
        rows = np.repeat(np.arange(len(P)), cnt)
        pos = np.arange(rows.size) - np.repeat(np.cumsum(cnt) - cnt, cnt) + start[v][rows]
        t = tri_of[pos]
        b, d = point_triangle(P[rows], V[T[t]])
        # the best pair of each point
        o = np.lexsort((d, rows))
        rows, t, b, d = rows[o], t[o], b[o], d[o]
        first = np.ones(rows.size, dtype=bool)
        first[1:] = rows[1:] != rows[:-1]
        rows, t, b, d = rows[first], t[first], b[first], d[first]
        better = d < best_d[rows]
        r = rows[better]
        best_d[r], best_t[r], best_b[r] = d[better], t[better], b[better]
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
