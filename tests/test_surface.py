"""Closest points on meshes and the feature point warp (mpeg4fba.cloning.surface)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpeg4fba.cloning.registration import register_surface
from mpeg4fba.cloning.surface import (boundary_loops, closest_points, feature_warp, point_triangle,
                                      surface_weights, triangle_neighbours)
from mpeg4fba.models import reference_head

from _meshes import grid, tube


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


# -- neighbours, weights on the surface, registration ----------------------------------------
def bumpy_tube(centre: float):
    """A tube with a ring-shaped bulge (a crease to slide on) at y = -centre."""
    return tube(rings=41, around=32, bottom=-4.0,
                profile=lambda y: 1 + 0.3 * np.exp(-((y + centre) / 0.3) ** 2))


def test_triangle_neighbours_are_mutual():
    skin = reference_head(resolution=0.5).meshes["Skin"]
    T = skin.triangles
    near = triangle_neighbours(T)
    has = near >= 0
    t, k = np.nonzero(has)
    n = near[t, k]
    # the neighbour lists this triangle back, and they share the edge opposite corner k
    assert (near[n] == t[:, None]).any(axis=1).all()
    edge = np.sort(np.stack([T[t, (k + 1) % 3], T[t, (k + 2) % 3]], 1), axis=1)
    shared = np.array([np.intersect1d(T[a], T[b]) for a, b in zip(t[:200], n[:200])])
    assert np.array_equal(np.sort(shared, axis=1), edge[:200])
    # boundary edges (the mouth and eye openings) have none
    assert (~has).sum() == sum(len(l) for l in boundary_loops(T))


@settings(max_examples=30, deadline=None)
@given(st.floats(0.0, 0.15), st.integers(3, 12), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_surface_weights_keep_a_linear_field_on_a_plane(radius, samples, a, b):
    # rows sum to 1, and on a plane the filter's circle averages a linear field to its
    # centre value, however many triangles the circle crosses
    x, y = np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 1, 9))
    V = np.stack([x.ravel(), y.ravel(), np.zeros(81)], 1)
    k = np.arange(81).reshape(9, 9)[:-1, :-1].ravel()
    T = np.concatenate([np.stack([k, k + 1, k + 10], 1), np.stack([k, k + 10, k + 9], 1)])
    rng = np.random.default_rng(samples)
    P = np.column_stack([rng.uniform(0.2, 0.8, (20, 2)), rng.normal(scale=0.1, size=20)])
    W = surface_weights(P, V, T, radius, samples)
    assert np.allclose(np.asarray(W.sum(axis=1)).ravel(), 1)
    field = a * V[:, 0] + b * V[:, 1]
    assert np.allclose(W @ field, a * P[:, 0] + b * P[:, 1], atol=1e-9)


def test_surface_weights_stop_at_the_rim():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    W = surface_weights(np.array([[0.05, 0.05, 0]]), V, np.array([[0, 1, 2]]), radius=0.5)
    assert np.allclose(W.sum(), 1) and (W.data >= 0).all()


def _closed_lips(gap: float = 0.002):
    """Two 5 x 5 unit grids a ``gap`` apart: the lower lip at z=0 facing +z, the upper
    at z=gap facing -z (its triangles wound the other way)."""
    x, y = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
    grid = np.stack([x.ravel(), y.ravel(), np.zeros(25)], 1)
    k = np.arange(25).reshape(5, 5)[:-1, :-1].ravel()
    T = np.concatenate([np.stack([k, k + 1, k + 6], 1), np.stack([k, k + 6, k + 5], 1)])
    V = np.vstack([grid, grid + [0, 0, gap]])
    return V, np.vstack([T, T[:, ::-1] + 25])


def test_facing_keeps_a_point_on_the_sheet_it_faces_like():
    V, T = _closed_lips()
    # lower-lip points placed a little too high, nearer the upper lip
    P = np.column_stack([np.linspace(0.1, 0.9, 7), np.full(7, 0.4), np.full(7, 0.0015)])
    up = np.tile([0.0, 0.0, 1.0], (7, 1))
    lip = np.r_[np.zeros(25), np.ones(25)]          # 0 on the lower lip, 1 on the upper
    plain = surface_weights(P, V, T, radius=0.05)
    faced = surface_weights(P, V, T, radius=0.05, normals=up, facing=0.01)
    assert np.allclose(plain @ lip, 1) and np.allclose(faced @ lip, 0)
    assert np.allclose(np.asarray(faced.sum(axis=1)).ravel(), 1)
    # a zero normal (one that doesn't count) and facing=0 are the plain closest point
    for normals, facing in ((np.zeros((7, 3)), 0.01), (up, 0.0)):
        t, _, _ = closest_points(P, V, T, normals=normals, facing=facing)
        assert (t >= len(T) // 2).all()
    # the distance returned is the true one, not the cost
    assert np.allclose(closest_points(P, V, T, normals=up, facing=0.01)[2], 0.0015)
    # a sheet facing the right way but further off than ``facing`` is not worth the trip
    V, T = _closed_lips(gap=0.02)
    t, _, d = closest_points(P + [0, 0, 0.0175], V, T, normals=up, facing=0.01)
    assert (t >= len(T) // 2).all() and np.allclose(d, 0.001)


def test_registration_slides_a_surface_along_itself():
    # source: a bulge at depth 2; target: the same tube with its bulge at 2.3, held at
    # both rims.  Closest points leave the target's bulge where it is (they only move a
    # vertex across the surface); the fit slides it onto the source's
    src, T = bumpy_tube(2.0)
    tgt, _ = bumpy_tube(2.3)
    rims = np.concatenate([np.arange(32), np.arange(len(tgt) - 32, len(tgt))])
    peak = np.flatnonzero(np.isclose(tgt[:, 1], -2.3, atol=0.06))
    out = register_surface(tgt, T, tgt, rims, src, T)
    t, b, _ = closest_points(tgt[peak], src, T)
    projected = np.einsum("nk,nkc->nc", b, src[T[t]])
    assert np.abs(projected[:, 1] + 2.3).max() < 0.1                  # did not move
    assert np.abs(out[peak, 1] + 2.0).max() < 0.1                       # slid to the bulge
    assert np.allclose(out[rims], tgt[rims])
    # and the result lies on the source surface
    _, _, d = closest_points(out, src, T)
    assert d.max() < 0.02


def test_registration_membrane_keeps_the_slide_between_held_points():
    # a strip on its own plane, held at x = 0.5 (moved +0.1 along x) and at x = 1.5
    # (not moved): the thin plate alone extends that slide linearly past the held rows
    # (more than 0.1 at the left end, backwards at the right), the membrane term holds
    # the overshoot back, the more the stronger it is; the held rows stay put either way
    V, T = grid(41, 9, spacing=0.05)
    idx = np.arange(len(V)).reshape(9, 41)
    held = np.concatenate([idx[:, 10], idx[:, 30]])
    start = V.copy()
    start[idx[:, 10], 0] += 0.1
    left, right = idx[4, 0], idx[4, 40]
    over = []
    for membrane in (0.0, 0.5, 2.0):
        out = register_surface(V, T, start, held, V, T, membrane=membrane)
        d = out[:, 0] - V[:, 0]
        assert np.allclose(out[held], start[held]) and np.allclose(out[:, 2], 0, atol=1e-9)
        assert np.isclose(d[idx[4, 20]], 0.05, atol=1e-3)         # halfway: half the slide
        over.append((d[left] - 0.1, -d[right]))
    assert over[0][0] > 0.015 and over[0][1] > 0.015                # the thin plate overshoots
    assert over[0][0] > over[1][0] > over[2][0] > 0
    assert over[0][1] > over[1][1] > over[2][1] > 0


def _grid(n: int, z: float, up: bool, lo: float = 0.0, hi: float = 1.0):
    """An n x n grid over [lo, hi]^2 at height ``z``, wound to face +z (``up``) or -z."""
    x, y = np.meshgrid(np.linspace(lo, hi, n), np.linspace(lo, hi, n))
    V = np.c_[x.ravel(), y.ravel(), np.full(n * n, z)]
    i = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
    T = np.r_[np.c_[i, i + 1, i + n + 1], np.c_[i, i + n + 1, i + n]]
    return V, (T if up else T[:, ::-1])


@pytest.mark.parametrize("wound", ["same", "reversed"])
def test_registration_keeps_to_the_sheet_that_faces_the_same_way(wound):
    # closed lips: over the middle, a sheet facing down (the upper lip's underside) lies
    # 0.02 above the one facing up (the lower lip's top); the moving sheet faces up and
    # starts 0.013 up, nearer the wrong sheet there (the plain nearest vertex took it to
    # 0.02).  One supple scale, so no stiffer fit settles it first.  A surface wound the
    # other way round throughout works the same.
    low, T_low = _grid(101, 0.0, up=wound == "same")
    high, T_high = _grid(41, 0.02, up=wound != "same", lo=0.3, hi=0.7)
    SV = np.r_[low, high]
    ST = np.r_[T_low, T_high + len(low)]
    rest, T = _grid(41, 0.0, up=True)
    out = register_surface(rest, T, rest + [0, 0, 0.013], np.array([], dtype=int), SV, ST,
                           scales=(0.02,))
    assert np.abs(out[:, 2]).max() < 1e-3
