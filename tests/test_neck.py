"""Neck cuts pinned onto each other in the surface alignment (mpeg4fba.cloning.surface
boundary_loops / neck_cut / loop_correspondence / surface_biharmonic, and the cloner's
``neck`` option)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpeg4fba.cloning import CloneWarning, FacialMotionCloner
from mpeg4fba.cloning.registration import surface_biharmonic
from mpeg4fba.cloning.surface import boundary_loops, loop_correspondence, neck_cut
from mpeg4fba.fba.fat import FAT
from mpeg4fba.fba.featurepoints import FeaturePointSet
from mpeg4fba.models import reference_head

from _meshes import grid, tube


# -- boundary loops -------------------------------------------------------------------------
def test_boundary_loop_of_a_square_runs_round_its_rim():
    V, T = grid(5)
    loops = boundary_loops(T)
    assert len(loops) == 1
    loop = loops[0]
    assert len(loop) == 16 and len(set(loop.tolist())) == 16
    rim = (V[:, 0] == 0) | (V[:, 0] == 4) | (V[:, 1] == 0) | (V[:, 1] == 4)
    assert set(loop.tolist()) == set(np.flatnonzero(rim).tolist())
    # consecutive vertices are neighbours on the rim
    steps = np.linalg.norm(np.diff(V[np.append(loop, loop[0])], axis=0), axis=1)
    assert np.allclose(steps, 1.0)


def test_a_tube_has_two_loops_and_a_closed_mesh_none():
    V, T = tube()
    assert sorted(len(l) for l in boundary_loops(T)) == [24, 24]
    skin = reference_head(resolution=0.5).meshes["LeftEyeball"]
    assert boundary_loops(skin.triangles) == []
    assert boundary_loops(np.zeros((0, 3), dtype=int)) == []


# -- the neck cut ---------------------------------------------------------------------------
def test_neck_cut_is_the_low_loop_round_the_spine():
    V, T = tube(top=0.0, bottom=-2.0)
    bottom = set(range(len(V) - 24, len(V)))
    loop = neck_cut(V, T, chin=np.array([0, -0.5, 1.0]), axis=np.array([0, 0.0, 0]))
    assert set(loop.tolist()) == bottom
    # below the chin is required: a chin under the bottom ring leaves no cut
    assert neck_cut(V, T, chin=np.array([0, -3.0, 1.0]), axis=np.zeros(3)) is None
    # a hole that does not wind round the spine (a mouth) is no cut
    Vg, Tg = grid(5)
    Vg = Vg[:, [0, 2, 1]] - [2, 3, -1]               # a flat patch in front, below the chin
    assert neck_cut(Vg, Tg, chin=np.array([0, 0.0, 1.0]), axis=np.zeros(3)) is None


def test_the_reference_head_is_closed_at_the_neck():
    head = reference_head(resolution=0.5)
    skin = head.meshes["Skin"]
    assert neck_cut(skin.vertices, skin.triangles, head.points["2.1"], head.points["7.1"]) is None


# -- pairing two cuts -----------------------------------------------------------------------
@settings(max_examples=40, deadline=None)
@given(st.floats(0.5, 2.0), st.floats(-3.0, 3.0), st.floats(-1.0, 1.0), st.integers(8, 40))
def test_loop_correspondence_pairs_by_angle(scale, spin, shift, n):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False) + spin
    moving = np.stack([np.sin(a), np.zeros(n), np.cos(a)], 1) + [shift, 0.3, 0]
    b = np.linspace(0, 2 * np.pi, 97, endpoint=False)
    fixed = scale * np.stack([np.sin(b), np.zeros(97), np.cos(b)], 1) + [0, -1.0, shift]
    got = loop_correspondence(moving, fixed)
    centre = fixed.mean(axis=0)
    angle = np.arctan2(got[:, 0] - centre[0], got[:, 2] - centre[2])
    want = np.arctan2(np.sin(a), np.cos(a))
    assert np.allclose(np.angle(np.exp(1j * (angle - want))), 0, atol=0.04)
    assert np.allclose(got[:, 1], -1.0)


# -- the smoothest field --------------------------------------------------------------------
def test_surface_biharmonic_holds_its_values_and_is_smooth():
    V, T = grid(9)
    fixed = np.flatnonzero((V[:, 1] == 0) | (V[:, 1] == 8))
    values = np.where(V[fixed, 1:2] == 0, 0.0, 1.0)
    f = surface_biharmonic(V, T, fixed, values)
    assert np.allclose(f[fixed], values)
    # between two held rows the field climbs monotonically from one to the other
    column = f[V[:, 0] == 4][:, 0]
    assert np.all(np.diff(column) > 0) and 0 < column[1:-1].min() and column[1:-1].max() < 1


def test_surface_biharmonic_follows_the_surface_not_the_air():
    # a tube held at 0 along one side of its top ring and 1 on its bottom ring: points
    # close in space across the tube but far along its surface keep their own values
    V, T = tube(rings=10, around=32)
    top = np.arange(32)
    bottom = np.arange(len(V) - 32, len(V))
    f = surface_biharmonic(V, T, np.concatenate([top, bottom]),
                           np.concatenate([np.zeros(32), np.ones(32)])[:, None])[:, 0]
    rings = f.reshape(10, 32)
    assert np.allclose(rings.std(axis=1), 0, atol=1e-9)            # symmetric round the tube
    assert np.all(np.diff(rings[:, 0]) > 0)


# -- the cloner -----------------------------------------------------------------------------
def _cut(face, below: float):
    """``face`` with its skin open below height ``below`` (triangles with a vertex lower
    are dropped; the vertices stay, so feature point ties hold)."""
    skin = face.meshes["Skin"]
    keep = (skin.vertices[skin.triangles][:, :, 1] >= below).all(axis=1)
    skin.triangles = skin.triangles[keep]
    face.invalidate()
    return face


def _long_necked(stretch: float, below: float):
    """A reference head whose skin under the chin is stretched down by ``stretch``, cut
    at the image of ``below``: the same mesh, so vertex i corresponds to vertex i."""
    face = reference_head(resolution=0.5)
    face.fat = FAT()
    chin = float(face.points["2.1"][1])
    skin = face.meshes["Skin"]
    v = skin.vertices.copy()
    low = v[:, 1] < chin
    v[low, 1] = chin + (v[low, 1] - chin) * stretch
    skin.vertices = v
    points = {k: face.points[k] for k in face.points}
    face.points = FeaturePointSet(points, face.points.vertices)
    face.invalidate()
    return _cut(face, chin + (below - chin) * stretch)


@pytest.fixture(scope="module")
def necks():
    source = _cut(reference_head(resolution=0.5), below=-0.15)
    target = _long_necked(1.4, below=-0.15)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the pin alone, on the warp (the registration would then fit the neck freely)
        pinned = FacialMotionCloner(source, target, scale_motion=False, register=False)
        free = FacialMotionCloner(source, target, scale_motion=False, neck=False,
                                  register=False)
    return source, target, pinned, free


def _neck_error(cloner, target):
    """3D distance (in the source's normalised space) between where each target neck
    vertex is aligned and where its counterpart (same index) is on the source."""
    first, n = cloner.target_skin["Skin"]
    s_first, _ = cloner.source_skin["Skin"]
    v = target.meshes["Skin"].vertices
    chin = float(target.points["2.1"][1])
    used = np.unique(target.meshes["Skin"].triangles)
    neck = used[(v[used, 1] < chin - 0.01)]
    uv = cloner.aligned[first + neck]
    true = cloner.src.space.uv[s_first + neck]
    return np.hypot(*(uv - true).T)


def test_pinned_necks_line_up(necks):
    source, target, pinned, free = necks
    assert pinned.neck_pinned and not free.neck_pinned
    e_pinned, e_free = _neck_error(pinned, target), _neck_error(free, target)
    # the warp alone lets the longer neck slide down the shorter one
    assert np.median(e_pinned) < 0.5 * np.median(e_free)
    assert np.percentile(e_pinned, 95) < 0.5 * np.percentile(e_free, 95)


def test_pinning_leaves_the_feature_points_exact(necks):
    _, target, pinned, free = necks
    rows = pinned.tgt.point_vertices()
    assert np.allclose(pinned.aligned[rows], free.aligned[rows], atol=1e-9)


def test_necks_cut_at_different_places_are_left_alone():
    source = _cut(reference_head(resolution=0.5), below=-0.16)
    target = _cut(reference_head(resolution=0.5), below=-0.14)
    target.fat = FAT()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cloner = FacialMotionCloner(source, target)
    assert not cloner.neck_pinned
    messages = [str(w.message) for w in caught if issubclass(w.category, CloneWarning)]
    assert any("neck cuts" in m and "unpinned" in m for m in messages)


def test_closed_heads_clone_as_before():
    source = reference_head(resolution=0.5)
    target = reference_head(resolution=0.5, face_width=1.1, seed=3)
    target.fat = FAT()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = FacialMotionCloner(source, target)
        b = FacialMotionCloner(source, target, neck=False)
    assert not a.neck_pinned
    assert np.array_equal(a.aligned, b.aligned)
