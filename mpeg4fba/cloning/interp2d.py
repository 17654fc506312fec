"""Interpolation of function values from a 2D triangle mesh.

Implements the section "Interpolation from 2D triangle mesh" of Pandzic,
*Facial Motion Cloning*, as a sparse linear operator: for every query point a
row of weights over the ``N`` input points, so that ``weights @ values`` gives
the interpolated function value (scalar or vector valued).

For a query ``P`` and a triangle with vertices ``P1, P2, P3`` the barycentric
coordinates ``b`` solve eq. (1)::

    [x1 x2 x3] [b1]   [x]
    [y1 y2 y3] [b2] = [y]
    [ 1  1  1] [b3]   [1]

(solved here in closed form). ``P`` is inside when every ``b_k`` lies in
``[0, 1]`` (with a tolerance of ``1e-12`` so points on edges count as inside):

* inside one or more triangles: the triangle with the smallest interpolated
  ``depth`` is used (the first triangle, by index, when ``depth`` is None or on
  ties), with weights ``b`` (eq. (2));
* inside none: the triangle with the smallest "distance", the sum of the excess
  barycentric coordinates (amount below 0 or above 1), is used, with each
  ``b_k`` truncated to ``[0, 1]`` and divided by their sum.

Search.  Triangles are binned by their bounding boxes into a uniform grid and
each query is tested only against the triangles of its cell.  For queries inside
no triangle the closest triangle is searched exactly, without testing every
triangle: triangles are grouped by shape into buckets, each with a
``scipy.spatial.cKDTree`` over the centroids, and the ``k_nearest`` (default 16)
triangles with nearest centroids are tested, ``k`` doubling until a lower bound
proves that no untested triangle can be closer.  The bound: for ``P`` at
Euclidean distance ``d`` from triangle ``T``, the excess distance is at least
``d * sin(theta_min / 2) / h_max`` (smallest angle, largest altitude of ``T``),
and ``d >= |P - centroid| - R`` (``R`` the largest centroid-vertex distance).
Thin or large triangles have a weak bound, so they live in their own small
buckets which end up being searched in full.  ``k_nearest=None`` tests every
triangle of every bucket at once.  Ties go to the first triangle by index.
Cost: the bound is loose for queries far outside the mesh (several triangle
sizes away), which then test thousands of triangles each; ``exact=False`` tests
only the ``k_nearest`` triangles with nearest centroids, an approximation of
the paper's "closest triangle" (it can miss a thin or large triangle farther
away whose excess distance is smaller).
Degenerate (zero-area) triangles are skipped.

>>> pts = np.array([[0., 0.], [1., 0.], [0., 1.]])
>>> tri = np.array([[0, 1, 2]])
>>> w = interpolation_weights(pts, tri, np.array([[0.25, 0.25], [2., 0.]]))
>>> w.toarray().round(3)
array([[0.5 , 0.25, 0.25],
       [0.  , 1.  , 0.  ]])
>>> interpolate(w, np.array([0., 10., 20.])).round(6)
array([ 7.5, 10. ])
"""
from __future__ import annotations

from typing import Optional, Union

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

__all__ = ["interpolation_weights", "interpolate", "antialiased_weights"]

_INSIDE_TOL = 1e-12
_DEGENERATE_REL = 1e-12


class _Mesh:
    """Per-triangle precomputation: closed-form barycentric coefficients, grid."""

    def __init__(self, points: np.ndarray, triangles: np.ndarray, pad: float = 0.0) -> None:
        self.pad = float(pad)
        p = points[triangles]  # (M, 3, 2)
        x1, y1 = p[:, 0, 0], p[:, 0, 1]
        x2, y2 = p[:, 1, 0], p[:, 1, 1]
        x3, y3 = p[:, 2, 0], p[:, 2, 1]
        det = (y2 - y3) * (x1 - x3) + (x3 - x2) * (y1 - y3)  # twice the signed area
        edge2 = np.max(np.sum((p - np.roll(p, 1, axis=1)) ** 2, axis=2), axis=1)
        valid = np.abs(det) > _DEGENERATE_REL * edge2
        self.index = np.flatnonzero(valid)  # original triangle ids of kept triangles
        if self.index.size == 0:
            raise ValueError("no non-degenerate triangle")
        v = self.index
        d = det[v]
        self.tri = triangles[v]
        self.points = points
        self.x3, self.y3 = x3[v], y3[v]
        # b1 = a1*(x-x3) + c1*(y-y3); b2 = a2*(x-x3) + c2*(y-y3); b3 = 1-b1-b2
        self.a1 = (y2[v] - y3[v]) / d
        self.c1 = (x3[v] - x2[v]) / d
        self.a2 = (y3[v] - y1[v]) / d
        self.c2 = (x1[v] - x3[v]) / d
        pv = p[v]
        self.centroid = pv.mean(axis=1)
        self.lo = pv.min(axis=1)
        self.hi = pv.max(axis=1)
        # lower bound of the excess distance: s * max(0, |P - centroid| - R)
        self.radius = np.sqrt(np.max(np.sum((pv - self.centroid[:, None, :]) ** 2, axis=2), axis=1))
        e = np.roll(pv, -1, axis=1) - pv  # e[:, k] = vertex k -> vertex k+1
        elen = np.sqrt(np.sum(e**2, axis=2))
        cos = -np.sum(e * np.roll(e, 1, axis=1), axis=2) / (elen * np.roll(elen, 1, axis=1))
        sin_half = np.sqrt(np.clip((1.0 - cos.max(axis=1)) / 2.0, 0.0, 1.0))
        self.bound = sin_half * elen.min(axis=1) / np.abs(d)  # sin(theta_min/2) / h_max
        self._buckets: Optional[list] = None
        self._tree: Optional[cKDTree] = None
        self._build_grid()

    @property
    def m(self) -> int:
        return int(self.index.size)

    def bary(self, t: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Barycentric coordinates (..., 3) of points ``q`` (..., 2) in kept triangles ``t``."""
        dx = q[..., 0] - self.x3[t]
        dy = q[..., 1] - self.y3[t]
        b1 = self.a1[t] * dx + self.c1[t] * dy
        b2 = self.a2[t] * dx + self.c2[t] * dy
        return np.stack([b1, b2, 1.0 - b1 - b2], axis=-1)

    def _build_grid(self) -> None:
        lo, hi = self.lo.min(axis=0), self.hi.max(axis=0)
        ext = np.maximum(hi - lo, 1e-300)
        size = np.mean(np.max(self.hi - self.lo, axis=1))
        # keep the number of cells at most ~4 per triangle
        size = max(size, float(np.sqrt(ext[0] * ext[1] / (4.0 * self.m))), float(ext.max()) / 4096.0)
        n = np.floor(ext / size).astype(np.int64) + 1
        self.g_lo, self.g_size, self.g_n = lo, size, n
        c0 = self._cell_xy(self.lo - self.pad)
        c1 = self._cell_xy(self.hi + self.pad)
        w = c1[:, 0] - c0[:, 0] + 1
        counts = w * (c1[:, 1] - c0[:, 1] + 1)
        rep = np.repeat(np.arange(self.m), counts)
        off = np.arange(rep.size) - np.repeat(np.cumsum(counts) - counts, counts)
        cx = c0[rep, 0] + off % w[rep]
        cy = c0[rep, 1] + off // w[rep]
        cell = cy * n[0] + cx
        order = np.argsort(cell, kind="stable")  # keeps triangle order inside a cell
        self.g_tri = rep[order]
        self.g_ptr = np.zeros(int(n[0] * n[1]) + 1, dtype=np.int64)
        np.cumsum(np.bincount(cell, minlength=int(n[0] * n[1])), out=self.g_ptr[1:])

    def _cell_xy(self, xy: np.ndarray) -> np.ndarray:
        c = np.floor((xy - self.g_lo) / self.g_size).astype(np.int64)
        return np.clip(c, 0, self.g_n - 1)

    def cells(self, q: np.ndarray) -> np.ndarray:
        """Grid cell of each query, -1 when outside the grid."""
        inside = np.all((q >= self.g_lo) & (q <= self.g_lo + self.g_n * self.g_size), axis=1)
        c = self._cell_xy(q)
        return np.where(inside, c[:, 1] * self.g_n[0] + c[:, 0], -1)

    @property
    def tree(self) -> cKDTree:
        """kd-tree over all triangle centroids."""
        if self._tree is None:
            self._tree = cKDTree(self.centroid)
        return self._tree

    @property
    def buckets(self) -> list:
        """(kd-tree of centroids, kept triangle ids, min bound, max radius) per shape class."""
        if self._buckets is None:
            key = np.floor(np.log2(np.maximum(self.bound, 1e-300))).astype(np.int64)
            self._buckets = []
            for kv in np.unique(key):  # a few dozen classes at most
                ids = np.flatnonzero(key == kv)
                tree = cKDTree(self.centroid[ids])
                self._buckets.append((tree, ids, float(self.bound[ids].min()), float(self.radius[ids].max())))
        return self._buckets


def _triangle_distance(mesh: _Mesh, t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """2D distance from points ``q`` (k, 2) to kept triangles ``t`` (k,); 0 inside."""
    p = mesh.points[mesh.tri[t]]                      # (k, 3, 2)
    a, b = p, np.roll(p, -1, axis=1)
    ab = b - a
    ap = q[:, None, :] - a
    u = np.clip((ap * ab).sum(axis=2) / np.maximum((ab * ab).sum(axis=2), 1e-300), 0.0, 1.0)
    d = np.sqrt(((ap - u[..., None] * ab) ** 2).sum(axis=2)).min(axis=1)
    bc = mesh.bary(t, q)
    return np.where(np.all(bc >= -_INSIDE_TOL, axis=1), 0.0, d)


def _find_inside(mesh: _Mesh, q: np.ndarray, depth: Optional[np.ndarray],
                 query_depth: Optional[np.ndarray] = None, slack: float = 0.0):
    """For a chunk of queries: (found mask, kept triangle id, barycentrics)."""
    nq = q.shape[0]
    cell = mesh.cells(q)
    start = np.where(cell >= 0, mesh.g_ptr[np.maximum(cell, 0)], 0)
    cnt = np.where(cell >= 0, mesh.g_ptr[np.maximum(cell, 0) + 1] - start, 0)
    qi = np.repeat(np.arange(nq), cnt)
    pos = np.arange(qi.size) - np.repeat(np.cumsum(cnt) - cnt, cnt) + start[qi]
    t = mesh.g_tri[pos]
    b = mesh.bary(t, q[qi])
    ok = np.all((b >= -_INSIDE_TOL) & (b <= 1.0 + _INSIDE_TOL), axis=1)
    if slack > 0 and query_depth is not None:
        # triangles passing within ``slack``: surfaces seen edge-on (the inside of a lip)
        # are slivers in 2D that a query on them misses by a hair
        qq = q[qi]
        near = ~ok & np.all((qq >= mesh.lo[t] - slack) & (qq <= mesh.hi[t] + slack), axis=1)
        if near.any():
            near[near] = _triangle_distance(mesh, t[near], q[qi[near]]) <= slack
            bc = np.clip(b[near], 0.0, 1.0)
            b[near] = bc / bc.sum(axis=1, keepdims=True)
            ok |= near
    qi, t, b = qi[ok], t[ok], b[ok]
    if depth is not None:
        z = np.sum(b * depth[mesh.tri[t]], axis=1)
        if query_depth is not None:  # the surface nearest the query's own depth
            z = np.abs(z - query_depth[qi])
        order = np.lexsort((t, z, qi))  # per query: smallest depth, then first triangle
    else:
        order = np.lexsort((t, qi))
    qi, t, b = qi[order], t[order], b[order]
    first = np.ones(qi.size, dtype=bool)
    first[1:] = qi[1:] != qi[:-1]
    found = np.zeros(nq, dtype=bool)
    found[qi[first]] = True
    tt = np.zeros(nq, dtype=np.int64)
    bb = np.zeros((nq, 3))
    tt[qi[first]] = t[first]
    bb[qi[first]] = b[first]
    return found, tt, bb


def _outside(mesh: _Mesh, q: np.ndarray, k0: Optional[int], chunk: int, exact: bool = True):
    """Closest triangle (excess barycentric distance) and truncated barycentrics."""
    nq = q.shape[0]
    best_d = np.full(nq, np.inf)
    best_t = np.full(nq, np.iinfo(np.int64).max)
    best_b = np.zeros((nq, 3))
    budget = max(1, chunk) * 16

    def test(rows: np.ndarray, cand: np.ndarray) -> None:
        b = mesh.bary(cand, q[rows][:, None, :])
        ex = np.sum(np.maximum(-b, 0.0) + np.maximum(b - 1.0, 0.0), axis=2)
        d = ex.min(axis=1)
        tie = ex == d[:, None]
        j = np.argmin(np.where(tie, cand, np.iinfo(np.int64).max), axis=1)  # ties -> first triangle
        r = np.arange(rows.size)
        t = cand[r, j]
        better = (d < best_d[rows]) | ((d == best_d[rows]) & (t < best_t[rows]))
        upd = rows[better]
        best_d[upd], best_t[upd], best_b[upd] = d[better], t[better], b[r, j][better]

    if not exact:  # approximation: the k0 triangles with nearest centroids only
        buckets = [(mesh.tree, np.arange(mesh.m), 0.0, 0.0)]
    else:  # well-shaped (tight bound) buckets first, so that best_d shrinks early
        buckets = sorted(mesh.buckets, key=lambda x: -x[2])
    for tree, ids, s_min, r_max in buckets:
        m = ids.size
        k = m if k0 is None else min(max(1, int(k0)), m)
        done = 0  # candidates 0..done-1 (by centroid distance) already tested
        active = np.arange(nq)
        while active.size:
            if 4 * k >= m:  # cheaper to test the whole bucket
                step = max(1, budget // m)
                for s in range(0, active.size, step):
                    rows = active[s : s + step]
                    test(rows, np.broadcast_to(ids, (rows.size, m)))
                break
            rho = np.empty(active.size)
            step = max(1, budget // k)
            for s in range(0, active.size, step):
                rows = active[s : s + step]
                dist, idx = tree.query(q[rows], k=k)
                dist = np.asarray(dist).reshape(rows.size, -1)
                test(rows, ids[np.asarray(idx).reshape(rows.size, -1)[:, done:]])
                rho[s : s + step] = dist[:, -1]
            if not exact:
                break
            # untested triangles have centroid distance >= rho: certified when no bound can beat best
            active = active[best_d[active] >= s_min * (rho - r_max)]
            done, k = k, min(2 * k, m)
    bc = np.clip(best_b, 0.0, 1.0)
    return best_t, bc / bc.sum(axis=1, keepdims=True)


def interpolation_weights(
    points: np.ndarray,
    triangles: np.ndarray,
    queries: np.ndarray,
    depth: Optional[np.ndarray] = None,
    *,
    chunk: int = 4096,
    k_nearest: Optional[int] = 16,
    exact: bool = True,
    query_depth: Optional[np.ndarray] = None,
    slack: float = 0.0,
) -> sp.csr_matrix:
    """Sparse (Q, N) interpolation weights of ``queries`` from a 2D triangle mesh.

    ``points`` (N, 2), ``triangles`` (M, 3) indices into ``points``, ``queries``
    (Q, 2), ``depth`` (N,) optional, resolving overlaps to the nearer triangle.
    Each row holds at most 3 non-zero weights and sums to 1.  ``chunk`` bounds the
    number of queries processed at once; ``k_nearest`` is the initial number of
    candidate triangles (nearest centroids) for queries inside no triangle, None
    to test all at once (the result is the same; see the module docstring).
    ``exact=False`` only tests the ``k_nearest`` triangles with nearest centroids
    (fast approximation of the closest triangle for queries far outside).
    ``query_depth`` (Q,) changes the overlap rule: among the triangles holding a query,
    the one whose interpolated depth is nearest the query's own (not the smallest);
    with it, ``slack`` > 0 also counts triangles passing within that 2D distance of the
    query as holding it (truncated barycentrics), for surfaces seen edge-on.

    >>> pts = np.array([[0., 0.], [1., 0.], [1., 1.], [0., 1.]])
    >>> tri = np.array([[0, 1, 2], [0, 2, 3]])
    >>> interpolation_weights(pts, tri, np.array([[0.5, 0.5], [1., 1.]])).toarray()
    array([[0.5, 0. , 0.5, 0. ],
           [0. , 0. , 1. , 0. ]])
    """
    pts = np.asarray(points, dtype=float)
    tris = np.asarray(triangles, dtype=np.int64)
    q = np.asarray(queries, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError("points must have shape (N, 2)")
    if tris.ndim != 2 or tris.shape[1] != 3:
        raise ValueError("triangles must have shape (M, 3)")
    if q.ndim != 2 or q.shape[1] != 2:
        raise ValueError("queries must have shape (Q, 2)")
    n = pts.shape[0]
    if tris.size and (tris.min() < 0 or tris.max() >= n):
        raise ValueError("triangle index out of range")
    z = None
    if depth is not None:
        z = np.asarray(depth, dtype=float)
        if z.shape != (n,):
            raise ValueError("depth must have shape (N,)")
    zq = None
    if query_depth is not None:
        if z is None:
            raise ValueError("query_depth needs depth")
        zq = np.asarray(query_depth, dtype=float).reshape(-1)
        if zq.shape != (q.shape[0],):
            raise ValueError("query_depth must have shape (Q,)")
    chunk = max(1, int(chunk))
    slack = float(slack) if zq is not None else 0.0
    mesh = _Mesh(pts, tris, pad=slack)
    nq = q.shape[0]
    t_all = np.zeros(nq, dtype=np.int64)
    b_all = np.zeros((nq, 3))
    missing = []
    for s in range(0, nq, chunk):
        found, t, b = _find_inside(mesh, q[s : s + chunk], z,
                                   None if zq is None else zq[s : s + chunk], slack)
        t_all[s : s + chunk], b_all[s : s + chunk] = t, b
        missing.append(s + np.flatnonzero(~found))
    out = np.concatenate(missing) if missing else np.zeros(0, dtype=np.int64)
    if out.size:
        t_all[out], b_all[out] = _outside(mesh, q[out], k_nearest, chunk, exact)
    w = sp.csr_matrix(
        (b_all.ravel(), (np.repeat(np.arange(nq), 3), mesh.tri[t_all].ravel())),
        shape=(nq, n),
    )
    w.sum_duplicates()
    w.eliminate_zeros()
    return w


def interpolate(weights: sp.spmatrix, values: np.ndarray) -> np.ndarray:
    """Interpolated values ``weights @ values``; ``values`` is (N,) or (N, d).

    >>> interpolate(sp.csr_matrix(np.array([[0.5, 0.5]])), np.array([[0., 2.], [2., 4.]]))
    array([[1., 3.]])
    """
    return np.asarray(weights @ np.asarray(values, dtype=float))


def antialiased_weights(
    points: np.ndarray,
    triangles: np.ndarray,
    queries: np.ndarray,
    depth: Optional[np.ndarray] = None,
    *,
    support: Union[float, np.ndarray] = 0.02,
    samples: int = 8,
    chunk: int = 4096,
    k_nearest: Optional[int] = 16,
    exact: bool = True,
    query_depth: Optional[np.ndarray] = None,
    slack: float = 0.0,
) -> sp.csr_matrix:
    """Anti-aliased (low-pass filtered) interpolation weights, as in the paper.

    The weights are the average of the plain interpolation weights at the query
    itself and at ``samples`` points evenly spaced on the circle of radius
    ``support`` around it (angles ``2*pi*i/samples``), each of the ``samples+1``
    points with equal weight (``support`` may also be one radius per query).  Rows
    sum to 1; ``support=0`` gives the plain
    weights.

    >>> pts = np.array([[0., 0.], [1., 0.], [0., 1.]])
    >>> w = antialiased_weights(pts, np.array([[0, 1, 2]]), np.array([[0.2, 0.2]]), support=0.1)
    >>> w.toarray().round(6)
    array([[0.6, 0.2, 0.2]])
    """
    q = np.asarray(queries, dtype=float)
    nq = q.shape[0]
    samples = max(0, int(samples))
    ang = 2.0 * np.pi * np.arange(samples) / max(samples, 1)
    unit = np.vstack([np.zeros((1, 2)), np.column_stack([np.cos(ang), np.sin(ang)])])
    s = unit.shape[0]
    radius = np.broadcast_to(np.asarray(support, dtype=float).reshape(-1), (nq,))
    qq = (q[:, None, :] + radius[:, None, None] * unit[None, :, :]).reshape(-1, 2)
    zq = None if query_depth is None else np.repeat(np.asarray(query_depth, dtype=float), s)
    w = interpolation_weights(points, triangles, qq, depth, chunk=chunk, k_nearest=k_nearest,
                              exact=exact, query_depth=zq, slack=slack)
    avg = sp.csr_matrix(
        (np.full(nq * s, 1.0 / s), (np.repeat(np.arange(nq), s), np.arange(nq * s))),
        shape=(nq, nq * s),
    )
    out = (avg @ w).tocsr()
    out.sum_duplicates()
    out.eliminate_zeros()
    return out
