"""Local-frame expression cloning (Kong, Kang, Yin) for faces sharing a mesh."""
from __future__ import annotations

import os
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

import mpeg4fba as fba
from mpeg4fba.cli import main
from mpeg4fba.cloning import LocalFrameCloner, LocalFrameWarning, TopologyError
from mpeg4fba.cloning.local_frames import SPACES, LocalFrame, assign_spaces
from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.featurepoints import FeaturePointError, FeaturePointSet
from mpeg4fba.formats.validate import validate
from mpeg4fba.formats.wrl_face import save_face
from mpeg4fba.models import reference_head


@pytest.fixture(scope="module")
def source():
    return reference_head(resolution=0.5)


def reshaped(face: FaceModel, fn) -> FaceModel:
    """The face's meshes (flattened to world coordinates) and points through ``fn``."""
    meshes = [FaceMesh(n, fn(face.world_vertices(n)), m.triangles) for n, m in face.meshes.items()]
    pts = FeaturePointSet({k: fn(face.points[k][None])[0] for k in face.points},
                          face.points.vertices)
    return FaceModel(meshes, points=pts, name="reshaped")


def warp(p):
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    return np.stack([x * (1.15 + 2 * y), y * 1.05 - 0.3 * x * x, z * 0.95 + 0.5 * y * y], axis=1)


def keys_of(face, fap, value):
    play = face.pose({fap: value})
    return {m: play.world_vertices(m)[0] for m in face.meshes}


def test_frame_round_trip_with_skewed_axes():
    f = LocalFrame.from_points([1, 2, 3], [2, 2, 3], [1.5, 3, 3], [1.2, 2.4, 4])
    assert abs(f.axes[0] @ f.axes[1]) > 0.1          # X and Y are not orthogonal
    p = np.random.default_rng(0).normal(size=(50, 3))
    assert np.allclose(f.world(f.local(p)), p)
    assert np.allclose(f.w, f.local(np.array([[1.2, 2.4, 4]]))[0])
    with pytest.raises(ValueError, match="one line"):
        LocalFrame.from_points([0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 0, 1])


def test_same_face_gets_the_same_shapes(source):
    same = reshaped(source, lambda p: p)
    c = LocalFrameCloner(source, same)
    keys = keys_of(source, 3, 600)
    out = c.clone_keys([keys])[0]
    for m in source.meshes:
        assert np.allclose(out[m], keys[m], atol=1e-12)


def test_uniformly_scaled_face_gets_scaled_shapes(source):
    s, t = 1.7, np.array([0.1, -0.2, 0.05])
    big = reshaped(source, lambda p: p * s + t)
    c = LocalFrameCloner(source, big)
    for space in SPACES:
        assert np.allclose(c.ratio[space], s)
    keys = keys_of(source, 31, 500)
    out = c.clone_keys([keys])[0]
    for m in source.meshes:
        assert np.allclose(out[m], keys[m] * s + t, atol=1e-12)


def test_mixing_spaces_from_different_keys(source):
    target = reshaped(source, warp)
    c = LocalFrameCloner(source, target)
    jaw, brow = keys_of(source, 3, 800), keys_of(source, 33, 600)
    a, b = c.clone_keys([jaw, brow])
    mixed = c.clone_keys([jaw, brow], mix={"mouth": 0, "brows": 1})[0]
    sp = c.spaces["Skin"]
    mouth, brows = sp == SPACES.index("mouth"), sp == SPACES.index("brows")
    other = ~(mouth | brows)
    assert np.allclose(mixed["Skin"][mouth], a["Skin"][mouth])
    assert np.allclose(mixed["Skin"][brows], b["Skin"][brows])
    assert np.allclose(mixed["Skin"][other], target.meshes["Skin"].vertices[other])
    assert np.abs(mixed["Skin"][mouth] - target.meshes["Skin"].vertices[mouth]).max() > 1e-3
    with pytest.raises(ValueError, match="unknown space"):
        c.clone_keys([jaw], mix={"chin": 0})
    with pytest.raises(ValueError, match="out of range"):
        c.clone_keys([jaw], mix={"mouth": 4})


def test_spaces_from_feature_points_and_parts(source):
    verts = {m: source.world_vertices(m) for m in source.meshes}
    sp = assign_spaces(source, verts)
    assert (sp["LowerTeeth"] == SPACES.index("mouth")).all()
    assert (sp["Tongue"] == SPACES.index("mouth")).all()
    assert (sp["LeftEyeball"] == SPACES.index("eyes")).all()
    tie = source.points.vertex("4.3")
    assert sp[tie[0]][tie[1]] == SPACES.index("brows")
    tie = source.points.vertex("9.3")
    assert sp[tie[0]][tie[1]] == SPACES.index("nose")
    user = assign_spaces(source, verts, {"Hair": ["rest"] * len(verts["Hair"])})
    assert (user["Hair"] == SPACES.index("rest")).all()
    with pytest.raises(ValueError, match="unknown space"):
        assign_spaces(source, verts, {"Hair": ["scalp"] * len(verts["Hair"])})


def test_different_meshes_point_to_motion_cloning(source):
    other = reference_head(resolution=0.6)
    with pytest.raises(TopologyError, match="motion cloning"):
        LocalFrameCloner(source, other)


def test_missing_base_points_are_listed(source):
    t = reshaped(source, warp)
    t.points = FeaturePointSet({k: t.points[k] for k in t.points if k not in ("8.3", "11.1")})
    with pytest.raises(FeaturePointError) as e:
        LocalFrameCloner(source, t)
    assert e.value.ids == ["8.3", "11.1"]


def test_w_point_in_the_frame_plane_warns(source):
    t = reshaped(source, warp)
    flat = {"mouth": ("9.15", "8.3", "8.4", "9.15")}      # bp4 = bp1: w = 0
    with pytest.warns(LocalFrameWarning, match="mouth space"):
        c = LocalFrameCloner(source, t, base_points=flat)
    assert np.all(np.isfinite(c.ratio["mouth"]))


def test_clone_builds_a_fat_through_the_morph_target_path(source):
    t = reshaped(source, warp)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = fba.clone(source, t, method="local-frames")
    assert len(out.fat.faps) == 66 and len(out.fat.visemes) == 14
    assert validate(out).ok
    targets = LocalFrameCloner(source, t).morph_targets()
    jaw = [m for m in targets if m.key.fap == 3]
    assert [m.value for m in jaw] == [4320.0]
    # the FAT reproduces each morph target at its value
    shape = out.pose({3: 4320}).vertices("Skin")[0]
    assert np.allclose(shape, jaw[0].meshes["Skin"], atol=1e-12)
    with pytest.raises(ValueError, match="method"):
        fba.clone(source, t, method="rbf")


def test_cli_local_frames(tmp_path, source):
    t = reshaped(source, warp)
    save_face(source, tmp_path / "s.wrl")
    save_face(t, tmp_path / "t.wrl")
    out = tmp_path / "o.wrl"
    r = CliRunner().invoke(main, ["clone", str(tmp_path / "s.wrl"), str(tmp_path / "t.wrl"),
                                  "--method", "local-frames", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert os.path.getsize(out) > 0
    save_face(reference_head(resolution=0.6), tmp_path / "other.wrl")
    r = CliRunner().invoke(main, ["clone", str(tmp_path / "s.wrl"), str(tmp_path / "other.wrl"),
                                  "--method", "local-frames", "-o", str(tmp_path / "x.wrl")])
    assert r.exit_code == 1 and "motion cloning" in r.output
    assert not (tmp_path / "x.wrl").exists()
