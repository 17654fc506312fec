"""The normalised facial space and the cylindrical alignment space (mpeg4fba.cloning)."""
from __future__ import annotations

import numpy as np
import pytest

from mpeg4fba.cloning import (MOUTH_ANGLE, Normaliser, Projection, choose_axis,
                              cylindrical_projection, face_center, region_factors)
from mpeg4fba.fba.fapu import FAPU
from mpeg4fba.fba.featurepoints import FeaturePointSet
from mpeg4fba.fba.tables import FAP

# A generic face: x = its left, y = up, z = forward (model units, roughly cm).
FACE = {
    "2.1": (0, -8.0, 1.5), "2.2": (0, -4.0, 3.0), "2.3": (0, -4.2, 3.0),
    "2.4": (1.8, -4.1, 2.6), "2.5": (-1.8, -4.1, 2.6),
    "3.1": (3.0, 1.5, 1.5), "3.2": (-3.0, 1.5, 1.5), "3.3": (3.0, 0.5, 1.5),
    "3.4": (-3.0, 0.5, 1.5), "3.5": (3.0, 1.0, 1.4), "3.6": (-3.0, 1.0, 1.4),
    "4.1": (1.0, 3.0, 2.0), "4.2": (-1.0, 3.0, 2.0), "5.1": (4.0, -2.0, 1.0),
    "5.2": (-4.0, -2.0, 1.0), "8.1": (0, -3.6, 3.2), "8.2": (0, -4.8, 3.1),
    "8.3": (2.5, -4.1, 2.4), "8.4": (-2.5, -4.1, 2.4), "9.3": (0, -1.0, 4.5),
    "9.15": (0, -2.5, 3.4), "11.4": (0, 9.0, -3.0),
}


def face(scale=(1.0, 1.0, 1.0), shift=(0.0, 0.0, 0.0), points=FACE):
    s, t = np.asarray(scale, float), np.asarray(shift, float)
    return FeaturePointSet({k: np.asarray(v, float) * s + t for k, v in points.items()})


def fapu_of(points):
    return FAPU.from_feature_points(points)


def random_vertices(n=500, seed=0):
    return np.random.default_rng(seed).uniform([-6, -9, -3], [6, 9, 5], size=(n, 3))


def test_round_trip_exact():
    pts = face()
    norm = Normaliser(pts, fapu_of(pts))
    v = random_vertices()
    w = norm.normalise(v)
    assert np.allclose(norm.denormalise(w, v), v, rtol=0, atol=1e-12)
    f = norm.factors(v)
    assert np.allclose(norm.denormalise(norm.normalise(v, f), factors=f), v, rtol=0, atol=1e-12)
    d = np.random.default_rng(1).normal(size=v.shape)
    assert np.allclose(norm.denormalise_motion(norm.normalise_motion(d, v), v), d,
                       rtol=0, atol=1e-12)


def test_scaled_faces_share_normalised_motion():
    a = face()
    # a scaled, moved copy: the neutral faces coincide in the normalised space
    c = face(scale=(1.7,) * 3, shift=(5.0, -2.0, 0.5))
    va = random_vertices()
    na = Normaliser(a, fapu_of(a))
    vc = va * 1.7 + (5.0, -2.0, 0.5)
    assert np.allclose(na.normalise(va), Normaliser(c, fapu_of(c)).normalise(vc),
                       rtol=0, atol=1e-9)
    # FAP motion: also on a copy scaled differently along each axis (other proportions)
    for b in (c, face(scale=(1.7, 0.8, 1.3), shift=(5.0, -2.0, 0.5))):
        check_same_motion(a, b)


def check_same_motion(a, b):
    ua, ub = fapu_of(a), fapu_of(b)
    assert ua != ub
    na, nb = Normaliser(a, ua), Normaliser(b, ub)
    # a FAP motion of the same value on both faces becomes the same normalised motion
    for number, point in [(53, "8.3"), (51, "8.1"), (3, "2.1"), (19, "3.1"), (31, "4.1"),
                          (39, "5.1"), (17, "2.2")]:
        fap = FAP[number]
        value = 250.0
        ma = np.array([np.asarray(fap.axis) * value * ua.unit(fap)])
        mb = np.array([np.asarray(fap.axis) * value * ub.unit(fap)])
        ga = na.normalise_motion(ma, np.array([a[point]]))
        gb = nb.normalise_motion(mb, np.array([b[point]]))
        assert np.allclose(ga, gb, rtol=1e-12, atol=0)
        assert np.allclose(ga, np.asarray(fap.axis) * value)     # in FAP units
    # and back to each face's own model units
    m = np.array([[0.0, 100.0, 0.0]])
    assert np.allclose(nb.denormalise_motion(m, np.array([b["8.1"]])), [[0, 100 * ub.MNS, 0]])


def test_lip_region_uses_mw_mns():
    pts = face()
    u = fapu_of(pts)
    ids, f = region_factors(pts, u)
    for lip in ("2.2", "2.3", "2.4", "2.5", "8.1", "8.2", "8.3", "8.4"):
        assert f[ids.index(lip)].tolist() == [u.MW, u.MNS, u.MNS]
    assert f[ids.index("3.1")].tolist() == [u.ES, u.IRISD, u.ES]
    assert f[ids.index("11.4")].tolist() == [u.ES, u.ES, u.ES]
    norm = Normaliser(pts, u)
    near_lips = np.array([pts["8.3"], pts["2.2"], pts["8.2"]]) + 0.05
    assert np.array_equal(norm.factors(near_lips), np.tile([u.MW, u.MNS, u.MNS], (3, 1)))


def test_face_center_and_missing_points():
    pts = face()
    assert np.allclose(face_center(pts), [0, (1.0 - 4.1) / 2, (1.4 + 2.4) / 2])
    with pytest.raises(ValueError, match="8.4"):
        face_center(FeaturePointSet({k: v for k, v in FACE.items() if k != "8.4"}))


def test_nose_tip_projects_to_zero():
    pts = face()
    proj = Projection(pts)
    out = proj(np.array([pts["9.3"], pts["9.3"] + (0, 3.0, 0)]))
    assert np.allclose(out[:, 0], 0.0, atol=1e-15)
    assert np.allclose(out[:, 1], [pts["9.3"][1], pts["9.3"][1] + 3.0])


def test_angle_positive_to_the_left_and_monotonic():
    # positive angles toward the face's left (+x), increasing around the head up to +pi
    cx, cz = 0.5, -1.0
    theta = np.linspace(-np.pi + 0.01, np.pi, 41)
    ring = np.column_stack([cx + 3 * np.sin(theta), np.zeros_like(theta), cz + 3 * np.cos(theta)])
    out = cylindrical_projection(ring, center_x=cx, center_z=cz, nose_tip=(cx, 0, cz + 5))
    assert np.all(np.diff(out[:, 0]) > 0)
    assert np.allclose(out[:, 0], theta)
    assert out[-1, 0] == pytest.approx(np.pi)        # the back of the head: +pi, not -pi
    left = cylindrical_projection(np.array([[cx + 1, 0, cz + 2]]), center_x=cx, center_z=cz,
                                  nose_tip=(cx, 0, cz + 5))
    assert left[0, 0] > 0
    # angles are measured from a nose tip off the z axis too
    off = cylindrical_projection(ring, center_x=cx, center_z=cz,
                                 nose_tip=(cx + np.sin(0.3), 0, cz + np.cos(0.3)))
    assert np.allclose(off[:, 0], np.pi - np.mod(np.pi - (theta - 0.3), 2 * np.pi))
    assert np.all((off[:, 0] > -np.pi) & (off[:, 0] <= np.pi))


@pytest.mark.parametrize("mouth_angle", [MOUTH_ANGLE, 0.9, 2.0])
def test_mouth_angular_width_constant(mouth_angle):
    a = face()
    odd = dict(FACE, **{"8.3": (3.4, -4.0, 2.0), "8.4": (-2.9, -4.3, 2.6), "9.3": (0.3, -1, 6)})
    b = face(scale=(1.4, 0.9, 0.7), shift=(1.0, 2.0, -3.0), points=odd)
    for pts in (a, b):
        proj = Projection(pts, mouth_angle)
        ang = proj(np.array([pts["8.3"], pts["8.4"]]))[:, 0]
        assert ang[0] - ang[1] == pytest.approx(mouth_angle, abs=1e-12)
        cx, cz = choose_axis(pts, mouth_angle)
        assert cz < min(pts["8.3"][2], pts["8.4"][2])     # behind the mouth


def test_projection_of_normalised_faces_aligns():
    a, b = face(), face(scale=(1.5,) * 3, shift=(1.0, 2.0, 3.0))
    pa = Normaliser(a, fapu_of(a)).normalise_points()
    pb = Normaliser(b, fapu_of(b)).normalise_points()
    ids = ["8.3", "8.4", "9.3", "3.5", "2.2"]
    xa = Projection(pa)(np.array([pa[i] for i in ids]))
    xb = Projection(pb)(np.array([pb[i] for i in ids]))
    assert np.allclose(xa, xb, atol=1e-9)


def test_bad_input():
    pts = face()
    norm = Normaliser(pts, fapu_of(pts))
    with pytest.raises(ValueError):
        norm.normalise(np.zeros((4, 2)))
    with pytest.raises(TypeError):
        norm.denormalise(np.zeros((4, 3)))
    with pytest.raises(ValueError):
        choose_axis(pts, np.pi)
