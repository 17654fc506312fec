"""The procedural reference head: a complete, compliant MPEG-4 face made in code."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from mpeg4fba.fba import FAP, FAPU, FEATURE_POINTS, FapStream
from mpeg4fba.fba.compliance import check_fat, fap_ratios
from mpeg4fba.formats.validate import validate
from mpeg4fba.formats.wrl_face import load_face, save_face
from mpeg4fba.models import EXPRESSION_FAPS, MESHES, TRANSFORMS, VISEME_FAPS, reference_head
from mpeg4fba.testing import assert_fap_compliant

OTHER = dict(face_width=1.15, jaw=0.9, nose=1.2, eye_spacing=0.92, mouth_width=1.1,
             resolution=0.7, seed=3)


@pytest.fixture(scope="module")
def face():
    return reference_head()


@pytest.fixture(scope="module")
def other():
    return reference_head(**OTHER)


def _all_faps_stream() -> FapStream:
    """Every low-level FAP, each alone over a few frames, both signs where it has two."""
    values = {}
    for r in FAP.low_level:
        lo, hi = r.range
        top = min(hi, 900.0)
        low = 0.25 * top if r.unidirectional else max(lo, -900.0) / 2
        values[r.number] = [0.0, top / 2, top, low, 0.0]
    return FapStream.from_values(values)


def test_structure(face):
    assert set(face.meshes) == set(MESHES)
    assert {n: m.parent for n, m in face.meshes.items()} == MESHES
    assert {n: t.parent for n, t in face.transforms.items()} == TRANSFORMS
    # the head turns about the top of the spine, the jaw about its hinge, the eyes
    # about their centres (their Transforms' translations)
    assert np.allclose(face.transforms["Head"].center, face.points["7.1"])
    for side, fp in (("LeftEye", "3.5"), ("RightEye", "3.6")):
        centre = np.array(face.transforms[side].translation)
        radius = np.linalg.norm(face.points[fp] - centre)
        assert np.allclose(face.points[fp] - centre, [0, 0, radius])     # gaze along +z
    assert face.points["3.5"][0] > 0 > face.points["3.6"][0]             # x: the face's left


def test_triangle_counts(face):
    skin = len(face.meshes["Skin"].triangles)
    total = sum(len(m.triangles) for m in face.meshes.values())
    assert 5000 <= skin <= total <= 20000
    small = reference_head(resolution=0.5)
    assert 5000 <= sum(len(m.triangles) for m in small.meshes.values()) < total


def test_all_84_feature_points_are_vertices_of_their_meshes(face):
    assert len(face.points) == 84 == len(FEATURE_POINTS)
    ties = face.points.vertices
    assert set(ties) == {fp.id for fp in FEATURE_POINTS}
    for fp, (mesh, index) in ties.items():
        assert np.allclose(face.world_vertices(mesh)[index], face.points[fp]), fp
    where = {fp: mesh for fp, (mesh, _) in ties.items()}
    assert where["3.5"] == "LeftEyeball" and where["3.6"] == "RightEyeball"
    assert {where[k] for k in ("9.8", "9.10")} == {"UpperTeeth"}
    assert {where[k] for k in ("9.9", "9.11")} == {"LowerTeeth"}
    assert {where[k] for k in ("6.1", "6.2", "6.3", "6.4")} == {"Tongue"}
    assert where["11.5"] == "Hair" and where["7.1"] == "Spine"
    assert all(where[fp.id] == "Skin" for fp in FEATURE_POINTS
               if fp.group in (2, 3, 4, 5, 8, 10) and fp.id not in ("3.5", "3.6"))


def test_fapu_is_plausible(face, other):
    for f in (face, other):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            fapu = FAPU.from_feature_points(f.points)
        assert not fapu.problems()
        assert fapu == f.fapu
    mm = {k: v * 1000 for k, v in face.fapu.as_dict().items()}   # metres -> mm
    assert 55 < mm["ES0"] < 75 and 9 < mm["IRISD0"] < 14 and 40 < mm["MW0"] < 60
    assert 15 < mm["MNS0"] < 28 and 38 < mm["ENS0"] < 58


def test_neutral_face_conditions(face):
    p = face.points
    # eyelids tangent to the iris: the lid opening is the iris diameter (IRISD0)
    assert np.isclose(p["3.1"][1] - p["3.3"][1], face.fapu.IRISD0)
    # lips in contact (the inner contours meet), lip line level with the corners
    assert 0 < p["2.2"][1] - p["2.3"][1] < 1e-4
    assert np.isclose(p["2.4"][1], p["2.5"][1]) and abs(p["2.4"][1] - p["2.2"][1]) < 1e-4
    # teeth together, tongue tip behind them at the level where they meet
    assert abs(p["9.10"][1] - p["9.11"][1]) < 2e-3
    assert p["6.1"][2] < p["9.11"][2] and abs(p["6.1"][1] - p["9.10"][1]) < 3e-3
    # the whole inner lip contour touches: upper and lower halves a hair apart
    V = face.meshes["Skin"].vertices
    up, lo = face.regions["lips_upper"], face.regions["lips_lower"]
    assert np.allclose(V[up, 0], V[lo, 0]) and (V[up, 1] - V[lo, 1] < 1e-4).all()


def test_fat_covers_every_fap_viseme_and_expression(face):
    assert face.fat.faps == list(range(3, 69))
    assert face.fat.visemes == list(range(1, 15)) == sorted(VISEME_FAPS)
    assert face.fat.expressions == list(range(1, 7)) == sorted(EXPRESSION_FAPS)
    for table in face.fat:
        for m in table.meshes:
            if table.fap <= 2:
                assert m.borders.tolist() == [0.0, 63.0]
            elif FAP[table.fap].unidirectional:
                assert m.borders[0] == 0
            else:
                assert m.borders[0] < 0 < m.borders[-1]
    jaw = [t for t in face.fat[3].transforms if t.transform == "Jaw"]
    assert jaw and jaw[0].field == "rotation"
    assert any(t.transform == "Jaw" for t in face.fat[1, 10].transforms)      # "aa" opens it


def test_check_fat_and_ratios(face, other):
    for f in (face, other):
        assert check_fat(f) == []
        ratios = fap_ratios(f)
        measured = {k: v for k, v in ratios.items() if v is not None}
        assert len(measured) >= 60
        worst = max(measured, key=lambda k: abs(measured[k] - 1))
        assert abs(measured[worst] - 1) < 0.02, (worst, measured[worst])
        # the unmeasurable ones: eyeball thrusts (transform translations), pupils, tongue roll
        assert {k for k, v in ratios.items() if v is None} <= {27, 28, 29, 30, 47}


def test_validate_object_and_file(face, tmp_path):
    report = validate(face)
    assert report.findings == [] and report.ok
    path = tmp_path / "reference_head.wrl"
    save_face(face, path)
    assert validate(path).findings == []
    back = load_face(path)
    assert len(back.fat) == len(face.fat)
    for a in face.fat:
        b = back.fat[a.fap, a.select]
        assert len(a.meshes) == len(b.meshes) and len(a.transforms) == len(b.transforms)
        for m, n in zip(a.meshes, b.meshes):
            assert m.mesh == n.mesh
            assert np.array_equal(m.borders, n.borders) and np.array_equal(m.indices, n.indices)
            assert np.array_equal(m.displacements, n.displacements)
        for m, n in zip(a.transforms, b.transforms):
            assert (m.transform, m.field, m.rotation, m.translation, m.scale) == \
                   (n.transform, n.field, n.rotation, n.translation, n.scale)
    assert set(back.points) == set(face.points)
    assert all(np.allclose(back.points[k], face.points[k]) for k in face.points)


def test_every_fap_is_compliant(face, other):
    stream = _all_faps_stream()
    for f in (face, other):
        report = assert_fap_compliant(f, stream, tolerance=0.02)
        assert len(report.checked) == 63
        assert set(report.skipped) == {29, 30, 47}          # scale and curl: not checkable
        assert max(report.worst.values()) < 1e-6


def test_upper_and_lower_lips_are_independent(face):
    upper, lower = face.regions["upper_lip_area"], face.regions["lower_lip_area"]
    assert len(upper) and len(lower) and not set(upper) & set(lower)
    neutral = face.meshes["Skin"].vertices
    # the slit: each upper inner-lip vertex has a separate lower twin at (almost) its place
    assert len(np.intersect1d(face.regions["upper_lip"], face.regions["lower_lip"])) == 0
    moved = face.pose({"raise_b_midlip": 512}).vertices("Skin")[0] - neutral
    assert np.abs(moved[upper]).max() == 0.0
    assert np.abs(moved[lower]).max() > 0.0
    lower_faps = (5, 10, 11, 16, 52, 57, 58)
    upper_faps = (4, 8, 9, 17, 51, 55, 56)
    for faps, other_side in ((lower_faps, upper), (upper_faps, lower)):
        for n in faps:
            d = face.pose({n: 512}).vertices("Skin")[0] - neutral
            assert np.abs(d[other_side]).max() == 0.0, n
    # lips closed in the standard's sense: when each pair of inner lip FAPs adds up to 0
    # the inner contours still touch all along
    p = face.pose({"lower_t_midlip": 300, "raise_b_midlip": -300, "lower_t_lip_lm": 200,
                   "raise_b_lip_lm": -200, "lower_t_lip_rm": 250,
                   "raise_b_lip_rm": -250}).vertices("Skin")[0]
    up, lo = face.regions["lips_upper"], face.regions["lips_lower"]
    assert np.allclose(p[up] - p[lo], neutral[up] - neutral[lo], atol=1e-12)


def test_left_and_right_are_separate(face):
    x = face.meshes["Skin"].vertices[:, 0]
    for left, right in ((19, 20), (31, 32), (39, 40), (41, 42), (61, 62), (65, 66), (12, 13)):
        dl = np.abs(face.pose({left: 300}).vertices("Skin")[0] - face.meshes["Skin"].vertices).max(axis=1)
        dr = np.abs(face.pose({right: 300}).vertices("Skin")[0] - face.meshes["Skin"].vertices).max(axis=1)
        assert (x[dl > 0] > -1e-3).all() and (x[dr > 0] < 1e-3).all(), (left, right)


def test_eyes_close_when_top_and_bottom_add_to_1024(face):
    V = face.meshes["Skin"].vertices
    for top, bottom in ((512, 512), (1024, 0), (700, 324)):
        p = face.pose({"close_t_l_eyelid": top, "close_b_l_eyelid": bottom,
                       "close_t_r_eyelid": top, "close_b_r_eyelid": bottom}).vertices("Skin")[0]
        for side in ("left", "right"):
            up, lo = face.regions[side + "_margin_upper"], face.regions[side + "_margin_lower"]
            assert np.allclose(V[up, 0], V[lo, 0])
            assert np.abs(p[up, 1] - p[lo, 1]).max() < 1e-9      # every column meets
    # half-way, the lids leave half the opening
    p = face.pose({"close_t_l_eyelid": 256, "close_b_l_eyelid": 256}).vertices("Skin")[0]
    i1, i3 = face.points.vertex("3.1")[1], face.points.vertex("3.3")[1]
    assert np.isclose(p[i1, 1] - p[i3, 1], face.fapu.IRISD0 / 2)


def test_jaw_teeth_and_tongue_follow(face):
    play = face.pose({"open_jaw": 600})
    chin = face.points.vertex("2.1")[1]
    drop = face.meshes["Skin"].vertices[chin, 1] - play.vertices("Skin")[0][chin, 1]
    assert np.isclose(drop, 600 * face.fapu.MNS)
    lower = play.world_vertices("LowerTeeth")[0] - face.world_vertices("LowerTeeth")
    upper = play.world_vertices("UpperTeeth")[0] - face.world_vertices("UpperTeeth")
    tongue = play.world_vertices("Tongue")[0] - face.world_vertices("Tongue")
    tip = face.points.vertex("9.11")[1]
    assert np.isclose(-lower[tip, 1], 600 * face.fapu.MNS, rtol=0.1)
    assert np.abs(upper).max() == 0 and (tongue[:, 1] < 0).all()


def test_visemes_and_expressions_are_their_fap_combinations(face):
    from mpeg4fba.models.shapes import shape_values
    for fap, select, faps in [(1, 10, VISEME_FAPS[10]), (2, 1, EXPRESSION_FAPS[1])]:
        high = face.pose({}, visemes=[select, 0, 63, 0]) if fap == 1 else \
            face.pose({}, expressions=[select, 63, 0, 0, 0, 0])
        values = shape_values(faps)
        low = face.pose({n + 1: v for n, v in enumerate(values) if v})
        for mesh in face.meshes:
            assert np.allclose(high.world_vertices(mesh), low.world_vertices(mesh), atol=1e-12)


def test_deterministic():
    a, b = reference_head(resolution=0.6), reference_head(resolution=0.6)
    for name in a.meshes:
        assert np.array_equal(a.meshes[name].vertices, b.meshes[name].vertices)
        assert np.array_equal(a.meshes[name].triangles, b.meshes[name].triangles)
    assert a.points == b.points
    for ta, tb in zip(a.fat, b.fat):
        assert ta.key == tb.key
        for m, n in zip(ta.meshes, tb.meshes):
            assert np.array_equal(m.indices, n.indices)
            assert np.array_equal(m.displacements, n.displacements)


def test_parameters_change_the_face(face, other):
    assert len(other.meshes["Skin"].vertices) != len(face.meshes["Skin"].vertices)
    assert other.fapu.MW0 > face.fapu.MW0 and other.fapu.ES0 < face.fapu.ES0
    reseeded = reference_head(seed=1)
    assert not np.array_equal(reseeded.meshes["Skin"].triangles, face.meshes["Skin"].triangles)
    assert np.isclose(reseeded.fapu.MW0, face.fapu.MW0)        # same shape, new triangulation
    with pytest.raises(ValueError):
        reference_head(nose=3.0)
    with pytest.raises(ValueError):
        reference_head(resolution=5)


def test_skin_is_a_clean_surface_with_three_openings(face):
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    for name in ("Skin", "other"):
        f = face if name == "Skin" else reference_head(resolution=0.6, seed=5)
        m = f.meshes["Skin"]
        T, n = m.triangles, len(m.vertices)
        e = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
        key = e[:, 0] * n + e[:, 1]
        assert len(np.unique(key)) == len(key)                  # manifold, consistently wound
        border = e[~np.isin(e[:, 1] * n + e[:, 0], key)]
        g = sp.coo_matrix((np.ones(len(border)), (border[:, 0], border[:, 1])), shape=(n, n))
        labels = connected_components(g, directed=False)[1]
        assert len(np.unique(labels[np.unique(border)])) == 3   # the eyes and the mouth
        assert len(np.unique(T)) == n
        # no spikes, neutral or in any viseme / expression: no vertex far off its neighbours
        A = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
        A = ((A + A.T) > 0).astype(float)
        deg = np.asarray(A.sum(axis=1)).ravel()
        r, c = A.nonzero()
        frames = [m.vertices] + [f.pose({}, visemes=[k, 0, 63, 0]).vertices("Skin")[0]
                                 for k in (1, 10, 14)]
        for V in frames:
            lap = np.linalg.norm(V - (A @ V) / deg[:, None], axis=1)
            edge = np.bincount(r, np.linalg.norm(V[r] - V[c], axis=1), n) / deg
            assert (lap / edge).max() < 1.5
