"""The ICT-FaceKit benchmark face (benchmarks.ict): mesh split, feature points, FAPU,
identities, decimation, regions, and facts of the data the benchmark relies on.

Needs ``../shared/data/ict-facekit`` (skips without it), read in place.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from benchmarks import ict
from benchmarks.ict_pick_points import MIRROR_TOL, PAIRS, Picker, check
from mpeg4fba.cloning.alignment import REQUIRED_POINTS
from mpeg4fba.cloning.rigid import fit_rigid
from mpeg4fba.fba.fapu import FAPU, FAPUWarning

#: Feature points the benchmark face must have (6.1 lives in the JSON only).
LISTED = ([f"2.{i}" for i in range(1, 15)] + [f"3.{i}" for i in range(1, 15)]
          + [f"4.{i}" for i in range(1, 7)] + [f"5.{i}" for i in range(1, 5)]
          + [f"8.{i}" for i in range(1, 11)]
          + ["9.1", "9.2", "9.3", "9.6", "9.7", "9.8", "9.9", "9.10", "9.11", "9.15",
             "11.1", "11.2", "11.3"])
EXPECTED_MESH = {"3.5": "LeftEyeball", "3.6": "RightEyeball", "9.8": "UpperTeeth",
                 "9.10": "UpperTeeth", "9.9": "LowerTeeth", "9.11": "LowerTeeth",
                 "6.1": "GumsTongue"}


@pytest.fixture(scope="session")
def data(ict_data):
    return ict_data


@pytest.fixture(scope="session")
def face(data):
    return ict.ict_face(data)


@pytest.fixture(scope="session")
def decimated(data):
    return ict.ict_face_decimated(data, None, 0.25)


def test_missing_data_names_the_path(tmp_path):
    with pytest.raises(FileNotFoundError, match="ict_facekit_light.npz"):
        ict.load_ict(tmp_path)


# -- the mesh split ------------------------------------------------------------------------------
def test_layout_partitions_the_head(data):
    lay = ict.mesh_layout(data)
    ids = np.concatenate([lay.ids[m] for m in lay.meshes])
    assert np.array_equal(np.sort(ids), np.arange(data.n_vertices))
    n_tris = sum(len(lay.triangles[m]) for m in lay.meshes) + len(lay.dropped)
    assert n_tris == len(data.triangles)
    assert lay.findings["teeth components"] == 32 and lay.findings["upper teeth components"] == 16
    assert lay.findings["gums_tongue components"] == 1 and "GumsTongue" in lay.meshes
    assert lay.findings["triangles crossing ranges"] == 719
    assert lay.dropped_pairs == {"face+mouth_socket": 148, "face+eye_socket_L": 84,
                                 "face+eye_socket_R": 84}
    a, b = data.ranges["face"]
    c, d = data.ranges["head_neck"]
    assert np.array_equal(lay.ids["Skin"], np.r_[a:b + 1, c:d + 1])
    V = data.neutral
    assert V[lay.ids["UpperTeeth"], 1].mean() > V[lay.ids["LowerTeeth"], 1].mean()
    assert V[lay.ids["LeftEyeball"], 0].min() > 0 > V[lay.ids["RightEyeball"], 0].max()


def test_split_and_join_are_inverse(data, face):
    X = data.expression_deltas(["jawOpen", "eyeBlink_L"])
    parts = ict.split_deltas(face, X)
    assert parts["Skin"].shape == (2, len(face.meshes["Skin"].vertices), 3)
    assert np.array_equal(ict.join(face, parts), X)
    assert np.array_equal(ict.join(ict.mesh_layout(data), ict.split_deltas(face, X[0])), X[0])
    for m, mesh in face.meshes.items():
        assert np.array_equal(mesh.vertices, data.neutral[face.regions[ict.IDS_PREFIX + m]])


# -- feature points --------------------------------------------------------------------------------
def test_feature_points_present_and_on_their_meshes(face):
    pts = face.points
    assert not pts.missing(LISTED + ["7.1"])
    assert not pts.missing(REQUIRED_POINTS)
    assert "6.1" not in pts                          # GumsTongue is not a tongue alone
    for fp in LISTED:
        mesh, i = pts.vertex(fp)
        assert mesh == EXPECTED_MESH.get(fp, "Skin"), fp
        assert np.array_equal(face.meshes[mesh].vertices[i], pts[fp])
    assert pts.vertex("7.1") is None
    skin_ids = face.regions[ict.IDS_PREFIX + "Skin"]
    front = skin_ids[face.regions[ict.SKIN_FRONT]]
    for fp, v in ict.feature_point_ids().items():    # Skin points: on the ICT face range
        if EXPECTED_MESH.get(fp, "Skin") == "Skin":
            assert v in front, fp


def test_tongue_tip_on_request(data):
    f = ict.ict_face(data, tongue_tip=True)
    assert f.points.vertex("6.1")[0] == "GumsTongue"


def test_symmetric_pairs_mirror(face):
    for left, right in PAIRS:
        p, q = face.points[left], face.points[right]
        assert p[0] > 0, left
        assert np.linalg.norm(p - q * [-1, 1, 1]) <= MIRROR_TOL, (left, right)


def test_json_matches_the_derivation(data):
    picked = Picker(data).pick()
    assert picked == ict.feature_point_ids()
    assert check(data, picked) == []


def test_fapu_plausible(face):
    with warnings.catch_warnings():
        warnings.simplefilter("error", FAPUWarning)
        u = FAPU.from_feature_points(face.points)
    assert 6.0 < u.ES0 < 7.0                         # eye separation, cm
    assert 0.8 < u.IRISD0 < 1.2
    assert 4.3 < u.ENS0 < 5.3
    assert 1.8 < u.MNS0 < 2.5
    assert 4.5 < u.MW0 < 5.6
    assert face.fapu == u


def test_spine_top(face):
    p = face.points
    s = p["7.1"]
    assert abs(s[0]) < 1e-9
    assert s[1] == p["9.15"][1]
    assert p["2.13"][2] - 5 < s[2] < p["2.13"][2]          # well behind the jaw corners
    V = face.meshes["Skin"].vertices
    assert V[:, 2].min() < s[2] - 5                         # well inside the head


# -- identities ------------------------------------------------------------------------------------
def test_identities(data):
    a, b = ict.identity(data, 1), ict.identity(data, 2)
    assert np.array_equal(a, ict.identity(data, 1))
    assert np.abs(a - data.neutral).max() > 0.3 and np.abs(a - b).max() > 0.3
    assert np.array_equal(ict.identity(data, 1, scale=0.0), data.neutral)
    f = ict.ict_face(data, a, name="id1")
    assert f.fapu.ES0 != pytest.approx(ict.ict_face(data).fapu.ES0, abs=1e-6)
    assert np.allclose(f.points["3.5"], a[ict.feature_point_ids()["3.5"]])


# -- decimation ------------------------------------------------------------------------------------
def test_decimation(data, face, decimated):
    full, dec = face.meshes["Skin"], decimated.meshes["Skin"]
    ids = decimated.regions[ict.IDS_PREFIX + "Skin"]
    assert abs(len(dec.vertices) / len(full.vertices) - 0.25) <= 0.2 * 0.25
    assert np.array_equal(dec.vertices, data.neutral[ids])
    T = dec.triangles
    assert T.min() >= 0 and T.max() < len(dec.vertices)
    assert ((T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 2] != T[:, 0])).all()
    area = np.linalg.norm(np.cross(dec.vertices[T[:, 1]] - dec.vertices[T[:, 0]],
                                   dec.vertices[T[:, 2]] - dec.vertices[T[:, 0]]), axis=1)
    assert (area > 0).all()
    assert len(np.unique(np.sort(T, axis=1), axis=0)) == len(T)
    for fp in face.points:                                   # feature points survive
        assert np.array_equal(decimated.points[fp], face.points[fp]), fp
        tie = decimated.points.vertex(fp)
        if tie is not None:
            assert np.array_equal(decimated.meshes[tie[0]].vertices[tie[1]], face.points[fp])
    assert list(decimated.meshes) == list(face.meshes)
    for m in face.meshes:                                    # other meshes unchanged
        if m != "Skin":
            assert np.array_equal(decimated.meshes[m].triangles, face.meshes[m].triangles)
            assert np.array_equal(decimated.meshes[m].vertices, face.meshes[m].vertices)
    kept = np.searchsorted(face.regions[ict.IDS_PREFIX + "Skin"], ids)
    rep = ict.decimation_report(full.vertices, full.triangles, kept, T)
    assert rep["triangles_also_original"] < 0.5 * len(T)     # a different topology
    assert rep["flipped_vs_original_normals"] < 0.02 * len(T)
    assert rep["zero_area"] == 0


def test_decimated_ground_truth(data, face, decimated):
    J = data.expressions["jawOpen"]
    gt = ict.split_deltas(decimated, J)
    ids = decimated.regions[ict.IDS_PREFIX + "Skin"]
    kept = np.searchsorted(face.regions[ict.IDS_PREFIX + "Skin"], ids)
    assert np.array_equal(gt["Skin"], ict.split_deltas(face, J)["Skin"][kept])
    assert np.array_equal(gt["LowerTeeth"], ict.split_deltas(face, J)["LowerTeeth"])
    back = ict.join(decimated, gt, fill=np.nan)
    assert np.array_equal(back[ids], J[ids]) and np.isnan(back).any()
    skin = decimated.meshes["Skin"]                          # the lips are not welded:
    T = skin.triangles                                       # no edge stretches much
    before = np.linalg.norm(skin.vertices[T] - skin.vertices[T[:, [1, 2, 0]]], axis=2)
    moved = skin.vertices + gt["Skin"]
    after = np.linalg.norm(moved[T] - moved[T[:, [1, 2, 0]]], axis=2)
    assert (after / before).max() < 4.0


def test_decimate_keeps_and_fraction():
    g = np.stack(np.meshgrid(np.arange(40.0), np.arange(30.0)), -1).reshape(-1, 2)
    V = np.c_[g, np.sin(g[:, 0] / 5)]
    q = (np.arange(29)[:, None] * 40 + np.arange(39)).ravel()
    T = np.r_[np.c_[q, q + 1, q + 41], np.c_[q, q + 41, q + 40]]
    keep = [0, 1, 40, 41, 600, 601]                          # neighbours: same cells
    for f in (0.5, 0.25, 0.1):
        kept, tris = ict.decimate(V, T, f, keep=keep)
        assert abs(len(kept) / len(V) - f) <= 0.2 * f
        assert set(keep) <= set(kept.tolist())
        assert ict.flipped_triangles(V[kept], V[kept], tris) == 0


# -- regions -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["face", "decimated"])
def test_skin_regions_partition(which, face, decimated):
    f = face if which == "face" else decimated
    R = ict.skin_regions(f)
    assert list(R) == list(ict.REGION_NAMES)
    allv = np.concatenate(list(R.values()))
    assert np.array_equal(np.sort(allv), np.arange(len(f.meshes["Skin"].vertices)))
    assert all(len(R[k]) > 10 for k in ("mouth", "eyes", "brows"))
    ids = f.regions[ict.IDS_PREFIX + "Skin"]
    for k in ("mouth", "eyes", "brows"):
        assert (ids[R[k]] <= 9408).all()                   # the face range only
    V = f.meshes["Skin"].vertices
    assert V[R["mouth"], 1].max() < f.points["9.15"][1]
    assert V[R["brows"], 1].min() > f.points["3.1"][1]


# -- facts of the data -----------------------------------------------------------------------------
def test_inner_lips_under_jaw_open(data, face):
    dy = -data.expressions["jawOpen"][:, 1]
    ids = ict.feature_point_ids()
    for up, lo in (("2.2", "2.3"), ("2.6", "2.8"), ("2.7", "2.9")):
        assert dy[ids[up]] < 0.3 * dy[ids[lo]], (up, lo)
        assert face.points[up][1] > face.points[lo][1]
    blink = {"3.1": "eyeBlink_L", "3.3": "eyeBlink_L", "3.2": "eyeBlink_R", "3.4": "eyeBlink_R"}
    moved = {fp: -data.expressions[e][ids[fp], 1] for fp, e in blink.items()}
    assert moved["3.1"] > 5 * abs(moved["3.3"]) and moved["3.2"] > 5 * abs(moved["3.4"])


def test_teeth_under_jaw_open(data, face):
    J = ict.split_deltas(face, data.expressions["jawOpen"])
    lower = face.meshes["LowerTeeth"].vertices
    fit = fit_rigid(lower, lower + J["LowerTeeth"])
    assert np.degrees(fit.angle) == pytest.approx(25.3, abs=1.0)
    assert fit.residual < 0.05
    assert np.abs(J["UpperTeeth"]).max() < 1e-6
