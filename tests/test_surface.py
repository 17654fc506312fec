"""Closest points on meshes and the feature point warp (mpeg4fba.cloning.surface)."""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from mpeg4fba.cloning.surface import closest_points, feature_warp, point_triangle
from mpeg4fba.models import reference_head


def brute(p, V, T):
    """Closest point by sampling each triangle densely (reference, slow)."""
    g = np.linspace(0, 1, 41)
    u, v = np.meshgrid(g, g)
    keep = u + v <= 1
    bary = np.stack([1 - u[keep] - v[keep], u[keep], v[keep]], 1)
    pts = np.einsum("sk,tkc->tsc", bary, V[T])
    return np.linalg.norm(pts - p, axis=2).min()


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-2, 2), min_size=12, max_size=12))
def test_point_triangle_is_the_closest_point(xs):
    a = np.array(xs, dtype=float).reshape(4, 3)
    p, tri = a[:1], a[1:][None]
    if np.linalg.norm(np.cross(tri[0, 1] - tri[0, 0], tri[0, 2] - tri[0, 0])) < 1e-3:
        return
    b, d = point_triangle(p, tri)
    assert np.all(b >= -1e-9) and abs(b.sum() - 1) < 1e-9
    q = b[0] @ tri[0]
    assert abs(np.linalg.norm(p[0] - q) - d[0]) < 1e-9
    assert d[0] <= brute(p[0], tri[0][None].reshape(3, 3), np.array([[0, 1, 2]])) + 1e-9


def test_closest_points_on_a_real_mesh():
    skin = reference_head(resolution=0.5).meshes["Skin"]
    V, T = skin.vertices, skin.triangles
    rng = np.random.default_rng(0)
    P = V[rng.choice(len(V), 40)] + rng.normal(scale=0.002, size=(40, 3))
    t, b, d = closest_points(P, V, T)
    q = np.einsum("nk,nkc->nc", b, V[T[t]])
    assert np.allclose(np.linalg.norm(P - q, axis=1), d)
    # against every triangle
    for i in range(0, 40, 8):
        _, dd = point_triangle(np.repeat(P[i:i + 1], len(T), 0), V[T])
        assert d[i] <= dd.min() + 1e-12


def test_feature_warp_is_exact_at_the_points_and_smooth():
    rng = np.random.default_rng(1)
    moving = rng.normal(size=(30, 3))
    fixed = moving * 1.2 + [0.1, 0, 0] + 0.01 * rng.normal(size=(30, 3))
    # coincident points (a closed mouth's inner lip points) are fine
    moving = np.vstack([moving, moving[:1]])
    fixed = np.vstack([fixed, fixed[:1]])
    assert np.allclose(feature_warp(moving, fixed, moving[:30]), fixed[:30], atol=1e-8)
    # an affine map is reproduced everywhere
    A = np.array([[1.1, 0.1, 0], [0, 0.9, 0.05], [0, 0, 1.0]])
    pts = rng.normal(size=(5, 3))
    out = feature_warp(moving[:30], moving[:30] @ A.T + 0.3, pts)
    assert np.allclose(out, pts @ A.T + 0.3, atol=1e-8)
