"""Tests of mpeg4fba.cloning.interp2d (Pandzic, Facial Motion Cloning: 2D mesh interpolation)."""
from __future__ import annotations

import time
from typing import Optional

import numpy as np
import pytest
from scipy.spatial import Delaunay

from mpeg4fba.cloning import antialiased_weights, interpolate, interpolation_weights


def brute_force(points, triangles, queries, depth: Optional[np.ndarray] = None):
    """Reference: the paper's algorithm, looping over every query and every triangle."""
    n = len(points)
    out = np.zeros((len(queries), n))
    for qi, p in enumerate(queries):
        best_in, best_in_key = None, None
        best_out, best_out_d = None, np.inf
        for ti, (a, b, c) in enumerate(triangles):
            m = np.array([[*points[a], *points[b], *points[c]][0::2],
                          [*points[a], *points[b], *points[c]][1::2],
                          [1.0, 1.0, 1.0]])
            if abs(np.linalg.det(m)) < 1e-12:
                continue
            bc = np.linalg.solve(m, [p[0], p[1], 1.0])
            if np.all(bc >= -1e-12) and np.all(bc <= 1 + 1e-12):
                key = 0.0 if depth is None else float(bc @ depth[[a, b, c]])
                if best_in is None or key < best_in_key:
                    best_in, best_in_key = (ti, bc), key
            d = float(np.sum(np.maximum(-bc, 0) + np.maximum(bc - 1, 0)))
            if d < best_out_d:
                best_out, best_out_d = (ti, bc), d
        if best_in is not None:
            ti, bc = best_in
        else:
            ti, bc = best_out
            bc = np.clip(bc, 0, 1)
            bc = bc / bc.sum()
        np.add.at(out[qi], triangles[ti], bc)
    return out


def random_overlapping_mesh(rng, n=30, m=25):
    pts = rng.uniform(0, 1, (n, 2))
    tris = np.array([rng.choice(n, 3, replace=False) for _ in range(m)])
    return pts, tris


def delaunay_mesh(rng, n=200):
    pts = rng.uniform(0, 1, (n, 2))
    return pts, Delaunay(pts).simplices.astype(np.int64)


def test_linear_function_reproduced_inside():
    rng = np.random.default_rng(0)
    pts, tris = delaunay_mesh(rng)
    q = rng.uniform(0.2, 0.8, (500, 2))
    w = interpolation_weights(pts, tris, q)
    f = lambda xy: 3.0 * xy[:, 0] - 2.0 * xy[:, 1] + 0.5
    np.testing.assert_allclose(interpolate(w, f(pts)), f(q), atol=1e-12)
    vec = np.column_stack([f(pts), pts])
    np.testing.assert_allclose(interpolate(w, vec), np.column_stack([f(q), q]), atol=1e-12)
    assert w.getnnz(axis=1).max() <= 3


def test_vertices_map_to_themselves():
    rng = np.random.default_rng(1)
    pts, tris = delaunay_mesh(rng, 100)
    w = interpolation_weights(pts, tris, pts).toarray()
    np.testing.assert_allclose(w, np.eye(len(pts)), atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("use_depth", [False, True])
def test_matches_brute_force_overlapping(seed, use_depth):
    rng = np.random.default_rng(seed)
    pts, tris = random_overlapping_mesh(rng)
    depth = rng.uniform(0, 1, len(pts)) if use_depth else None
    q = rng.uniform(-0.5, 1.5, (300, 2))
    ref = brute_force(pts, tris, q, depth)
    for k in (None, 16, 1):  # all at once, default, and the smallest start
        w = interpolation_weights(pts, tris, q, depth, chunk=37, k_nearest=k).toarray()
        np.testing.assert_allclose(w, ref, atol=1e-9)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_knn_outside_matches_brute_force(seed):
    """Outside the hull (thin hull triangles): the pruned search equals the exhaustive one."""
    rng = np.random.default_rng(100 + seed)
    pts, tris = delaunay_mesh(rng, 60)
    assert len(tris) > 16
    ang = rng.uniform(0, 2 * np.pi, 200)
    r = rng.uniform(0.75, 1.5, 200)
    q = 0.5 + np.column_stack([np.cos(ang), np.sin(ang)]) * r[:, None]  # outside the hull
    ref = brute_force(pts, tris, q)
    w = interpolation_weights(pts, tris, q).toarray()
    np.testing.assert_allclose(w, ref, atol=1e-9)


def test_depth_resolves_overlap_to_nearer_triangle():
    pts = np.array([[0, 0], [2, 0], [0, 2], [0, 0], [2, 0], [0, 2]], dtype=float)
    tris = np.array([[0, 1, 2], [3, 4, 5]])
    q = np.array([[0.5, 0.5]])
    far_first = np.array([5, 5, 5, 1, 1, 1], dtype=float)
    w = interpolation_weights(pts, tris, q, far_first).toarray()
    assert w[0, :3].sum() == 0 and np.isclose(w[0, 3:].sum(), 1)
    w = interpolation_weights(pts, tris, q).toarray()  # no depth: first triangle
    assert w[0, 3:].sum() == 0 and np.isclose(w[0, :3].sum(), 1)


def test_degenerate_triangles_skipped_and_outside_truncated():
    pts = np.array([[0, 0], [1, 0], [0, 1], [2, 2]], dtype=float)
    tris = np.array([[0, 0, 1], [0, 1, 2], [1, 1, 1]])
    w = interpolation_weights(pts, tris, np.array([[2.0, -1.0], [0.5, 0.5]])).toarray()
    np.testing.assert_allclose(w, [[0, 1, 0, 0], [0, 0.5, 0.5, 0]], atol=1e-12)
    with pytest.raises(ValueError):
        interpolation_weights(pts, np.array([[0, 0, 1]]), pts)


def test_scaling_50k():
    rng = np.random.default_rng(7)
    pts = rng.uniform(0, 1, (25_500, 2))
    tris = Delaunay(pts).simplices.astype(np.int64)[:50_000]  # ~1000 holes inside too
    depth = rng.uniform(0, 1, len(pts))
    for pad, exact in ((0.01, True), (0.05, False)):
        q = rng.uniform(-pad, 1 + pad, (50_000, 2))
        t0 = time.perf_counter()
        w = interpolation_weights(pts, tris, q, depth, exact=exact)
        dt = time.perf_counter() - t0
        print(f"50k queries (pad {pad}, exact={exact}) / {len(tris)} triangles: {dt:.2f} s")
        assert w.shape == (50_000, len(pts))
        np.testing.assert_allclose(np.asarray(w.sum(axis=1)).ravel(), 1.0, atol=1e-9)


def test_approximate_outside_search_is_close_on_well_shaped_mesh():
    rng = np.random.default_rng(11)
    g = np.stack(np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 1, 12)), -1).reshape(-1, 2)
    pts = g + rng.uniform(-0.01, 0.01, g.shape)
    tris = Delaunay(pts).simplices.astype(np.int64)
    q = rng.uniform(-0.3, 1.3, (400, 2))
    a = interpolation_weights(pts, tris, q, exact=False)
    e = interpolation_weights(pts, tris, q)
    np.testing.assert_allclose(np.asarray(a.sum(axis=1)).ravel(), 1.0, atol=1e-12)
    inside = (q.min(axis=1) > 0.02) & (q.max(axis=1) < 0.98)
    np.testing.assert_allclose(a.toarray()[inside], e.toarray()[inside], atol=1e-12)


def test_antialiasing():
    rng = np.random.default_rng(3)
    pts, tris = random_overlapping_mesh(rng, 40, 30)
    depth = rng.uniform(0, 1, len(pts))
    q = rng.uniform(-0.2, 1.2, (200, 2))
    a = antialiased_weights(pts, tris, q, depth)
    np.testing.assert_allclose(np.asarray(a.sum(axis=1)).ravel(), 1.0, atol=1e-12)
    a0 = antialiased_weights(pts, tris, q, depth, support=0.0)
    w = interpolation_weights(pts, tris, q, depth)
    np.testing.assert_allclose(a0.toarray(), w.toarray(), atol=1e-12)
    # the filter is an average of plain weights at the documented sample points
    ang = 2 * np.pi * np.arange(8) / 8
    off = np.vstack([[0, 0], 0.02 * np.column_stack([np.cos(ang), np.sin(ang)])])
    manual = np.mean([interpolation_weights(pts, tris, q + o, depth).toarray() for o in off], axis=0)
    np.testing.assert_allclose(a.toarray(), manual, atol=1e-12)


def test_nearest_depth_with_slack_takes_an_edge_on_sliver():
    """Two layers over one spot: a wide front triangle (depth 0) and, behind it, a sliver
    (depth 1) that the query misses by 0.001 in 2D.  Smallest depth takes the front; the
    query's own depth (1) with slack takes the sliver."""
    from mpeg4fba.cloning.interp2d import interpolation_weights
    pts = np.array([[-1.0, -1.0], [1.0, -1.0], [0.0, 1.0],       # front, wide
                    [-0.5, 0.001], [0.5, 0.001], [0.0, 0.002]])  # behind, a sliver
    tris = np.array([[0, 1, 2], [3, 4, 5]])
    depth = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    q = np.array([[0.0, 0.0]])
    front = interpolation_weights(pts, tris, q, depth).toarray()[0]
    assert front[:3].sum() == pytest.approx(1.0)
    own = interpolation_weights(pts, tris, q, depth, query_depth=np.array([1.0])).toarray()[0]
    assert own[:3].sum() == pytest.approx(1.0)            # no slack: the sliver misses
    slack = interpolation_weights(pts, tris, q, depth, query_depth=np.array([1.0]),
                                  slack=0.01).toarray()[0]
    assert slack[3:].sum() == pytest.approx(1.0)
