"""glTF 2.0 export: node tree (VRML center / scaleOrientation), morph targets that reproduce
the FAT exactly, the animation of a FAP stream, errors, atomic writing, Khronos validator."""
import json
import os
import shutil
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pygltflib")

from mpeg4fba.fba import FapStream  # noqa: E402
from mpeg4fba.fba.face import FaceMesh, FaceModel, FaceTransform  # noqa: E402
from mpeg4fba.fba.fat import (FAT, FaceDefMesh, FaceDefTable, FaceDefTransform,  # noqa: E402
                              interval_weights)
from mpeg4fba.formats.gltf import dumps_glb, dumps_gltf, face_to_gltf, write_glb  # noqa: E402
from mpeg4fba.formats.gltf_file import Gltf  # noqa: E402
from mpeg4fba.models.reference_head import reference_head  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
N = 8


# -- fixtures -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def head():
    return reference_head(resolution=0.5)


def _head_stream() -> FapStream:
    """8 frames within every table's borders: jaw, multi-interval eyelids (both signs),
    lips, brows, head and eye turns, eye and jaw thrusts, visemes and expressions, and
    one FAP first given in frame 3 (held at 0 before)."""
    s = FapStream.from_values({
        "open_jaw": [0, 300, 900, 1500, 2500, 4320, 3000, 1000],
        "close_t_l_eyelid": [0, 200, 400, 700, 1080, -300, -800, 100],
        "close_b_r_eyelid": [0, -600, -150, 75, 600, 450, 0, 10],
        "raise_b_midlip": [0, -200, -3720, 1000, 0, 50, 3000, -10],
        "raise_l_i_eyebrow": [0, 100, -900, 1800, -1800, 0, 10, 20],
        "shift_jaw": [0, -500, 500, 0, 100, -1080, 0, 20],
        "thrust_jaw": [0, 100, 200, 300, 600, 0, 100, 50],
        "head_yaw": [0, 2000, 8000, -12000, 30000, 0, -5000, 100],
        "head_pitch": [0, -3000, 5000, 0, 10000, -20000, 0, 300],
        "head_roll": [0, 1000, 0, -4000, 0, 2000, 7000, 0],
        "yaw_l_eyeball": [0, 5000, -5000, 20000, 0, 100, -30000, 0],
        "pitch_r_eyeball": [0, -5000, 2000, 0, 15000, 0, 0, 0],
        "thrust_l_eyeball": [0, 10, 20, 30, 40, 50, 60, 70],
        "stretch_l_cornerlip_o": [0, 600, 1200, -600, -1200, 0, 0, 300],
        "dilate_l_pupil": [0, 200, 420, -420, -100, 0, 300, 0],
    }, fps=25,
        visemes=[[0, 0, 0, 0], [1, 4, 63, 0], [1, 4, 30, 0], [2, 10, 50, 0], [10, 2, 0, 0],
                 [14, 1, 40, 0], [3, 3, 20, 0], [0, 0, 0, 0]],
        expressions=[[0, 0, 0, 0, 0, 0], [1, 63, 0, 0, 0, 0], [1, 30, 4, 20, 0, 0],
                     [6, 63, 2, 10, 0, 0], [2, 5, 5, 60, 0, 0], [3, 63, 1, 63, 0, 0],
                     [4, 40, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0]])
    col = 22 - 1                                   # close_b_r_eyelid: given from frame 3
    s.mask[:3, col] = False
    return s


@pytest.fixture(scope="module")
def stream():
    return _head_stream()


@pytest.fixture(scope="module")
def head_glb(head, stream, tmp_path_factory):
    path = tmp_path_factory.mktemp("glb") / "head.glb"
    write_glb(head, path, stream)
    return path


def _rig() -> FaceModel:
    """A face whose Transforms use every VRML field: translation, rotation, non-uniform
    scale, center and scaleOrientation, nested, all three driven by FAPs."""
    rng = np.random.default_rng(7)
    tri = rng.normal(size=(6, 3)) * 0.1
    tris = [[0, 1, 2], [2, 3, 4], [4, 5, 0], [1, 3, 5]]
    transforms = [
        FaceTransform("Root", None, translation=(0.1, 0.2, 0.3), rotation=(1, 1, 0, 0.4),
                      scale=(1.5, 0.5, 2.0), center=(0.05, -0.1, 0.2),
                      scale_orientation=(0, 1, 1, 0.7)),
        FaceTransform("Child", "Root", translation=(0, 0.1, 0), rotation=(0, 0, 1, 0.2),
                      scale=(2, 2, 2), center=(0.3, 0, 0)),
        FaceTransform("Plain", "Root", translation=(0, 0, -0.2), rotation=(0, 1, 0, -0.3)),
        FaceTransform("Twisted", "Child", scale=(1, 3, 1), scale_orientation=(1, 0, 0, 0.5)),
    ]
    meshes = [FaceMesh("InChild", tri, tris, "Child"), FaceMesh("InRoot", tri * 2, tris, "Root"),
              FaceMesh("Top", tri + 1, tris), FaceMesh("InPlain", tri - 1, tris, "Plain"),
              FaceMesh("InTwisted", tri * 3, tris, "Twisted")]
    fat = FAT([
        FaceDefTable(48, [FaceDefMesh("InChild", [-100, 0, 100], [0, 3],
                                      [[0, 1e-3, 0], [1e-3, 0, 0], [0, 0, 2e-3], [1e-3, 1e-3, 0]])],
                     [FaceDefTransform("Root", "rotation", rotation=(0, 1, 0, 1e-5))]),
        FaceDefTable(49, [], [FaceDefTransform("Child", "translation", translation=(1e-5, 0, 2e-5)),
                              FaceDefTransform("Root", "scale", scale=(1e-5, 0, -1e-5))]),
        FaceDefTable(50, [], [FaceDefTransform("Twisted", "rotation", rotation=(1, 0, 0, 1e-5)),
                              FaceDefTransform("Root", "rotation", rotation=(0, 0, 1, 1e-5))]),
    ])
    return FaceModel(meshes, transforms, fat=fat, name="rig")


# -- reading a glTF back and evaluating it ----------------------------------------------------

def _quat_matrices(q: np.ndarray) -> np.ndarray:
    x, y, z, w = np.asarray(q, dtype=np.float64).reshape(-1, 4).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], 1)


class Evaluated:
    """A glTF file read back (accessors through the project's glTF reader), with world
    matrices and morphed positions at each keyframe."""

    def __init__(self, path):
        self.g = Gltf(path)
        self.doc = self.g.doc
        self.parent = {c: i for i, n in enumerate(self.doc.nodes) for c in n.children or []}
        self.by_name = {n.name: i for i, n in enumerate(self.doc.nodes)}
        self.anim = {}
        for a in self.doc.animations or []:
            for ch in a.channels:
                s = a.samplers[ch.sampler]
                self.anim[(ch.target.node, ch.target.path)] = (self.acc(s.input)[:, 0],
                                                               self.acc(s.output), s)

    def acc(self, i: int) -> np.ndarray:
        return self.g.accessor(i, "test")

    def trs(self, i: int, frame=None) -> tuple:
        n = self.doc.nodes[i]
        t = np.asarray(n.translation or (0, 0, 0), float)
        q = np.asarray(n.rotation or (0, 0, 0, 1), float)
        s = np.asarray(n.scale or (1, 1, 1), float)
        if frame is not None:
            if (i, "translation") in self.anim:
                t = self.anim[(i, "translation")][1][frame]
            if (i, "rotation") in self.anim:
                q = self.anim[(i, "rotation")][1][frame]
            if (i, "scale") in self.anim:
                s = self.anim[(i, "scale")][1][frame]
        return t, q, s

    def local(self, i: int, frame=None) -> np.ndarray:
        t, q, s = self.trs(i, frame)
        M = np.eye(4)
        M[:3, :3] = _quat_matrices(q)[0] * s[None, :]
        M[:3, 3] = t
        return M

    def world(self, i: int, frame=None) -> np.ndarray:
        M = np.eye(4)
        while i is not None:
            M = self.local(i, frame) @ M
            i = self.parent.get(i)
        return M

    def mesh(self, name: str):
        i = self.by_name[name]
        return i, self.doc.meshes[self.doc.nodes[i].mesh]

    def morphed(self, name: str, frame=None) -> np.ndarray:
        """Mesh-local positions: neutral + sum(weight * target) at a keyframe."""
        i, mesh = self.mesh(name)
        prim = mesh.primitives[0]
        v = self.acc(prim.attributes.POSITION)
        if frame is None or (i, "weights") not in self.anim:
            w = np.asarray(mesh.weights or [], float)
        else:
            out = self.anim[(i, "weights")][1]
            w = out.reshape(-1, len(prim.targets))[frame]
        for k, t in enumerate(prim.targets or []):
            if w[k]:
                v = v + w[k] * self.acc(t["POSITION"])
        return v

    def world_vertices(self, name: str, frame=None) -> np.ndarray:
        M = self.world(self.by_name[name], frame)
        return self.morphed(name, frame) @ M[:3, :3].T + M[:3, 3]


# -- structure ----------------------------------------------------------------------------------

def test_nodes_meshes_and_target_names(head, head_glb):
    e = Evaluated(head_glb)
    doc = e.doc
    names = [n.name for n in doc.nodes]
    # centred Transforms get a pivot node; the eyes (no center) do not
    assert {"Head", "Head_pivot", "Jaw", "Jaw_pivot", "LeftEye", "RightEye"} <= set(names)
    assert "LeftEye_pivot" not in names
    assert doc.nodes[e.by_name["Jaw"]].children == [e.by_name["Jaw_pivot"]]
    assert set(names) - {"Head_pivot", "Jaw_pivot"} == set(head.meshes) | set(head.transforms)
    assert [doc.nodes[i].name for i in doc.scenes[doc.scene].nodes] == ["Head"]
    for name, m in head.meshes.items():
        i, mesh = e.mesh(name)
        assert doc.nodes[e.parent[i]].name == (m.parent + "_pivot" if m.parent in ("Head", "Jaw")
                                               else m.parent)
        prim = mesh.primitives[0]
        pos = doc.accessors[prim.attributes.POSITION]
        assert pos.componentType == 5126 and pos.count == len(m.vertices)
        np.testing.assert_array_equal(e.acc(prim.attributes.POSITION),
                                      m.vertices.astype(np.float32))
        normals = e.acc(prim.attributes.NORMAL)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-6)
        assert doc.accessors[prim.indices].componentType == 5125
        np.testing.assert_array_equal(e.acc(prim.indices)[:, 0].reshape(-1, 3), m.triangles)
        n_slots = sum(entry.n_intervals for t in head.fat for entry in t.meshes
                      if entry.mesh == name)
        assert len(prim.targets or []) == n_slots == len(mesh.weights or [])
        assert len((mesh.extras or {}).get("targetNames", [])) == n_slots
    skin = e.mesh("Skin")[1].extras["targetNames"]
    assert len(set(skin)) == len(skin)
    assert {"open_jaw[0,4320]", "close_t_l_eyelid[-1080,-540]", "close_t_l_eyelid[810,1080]",
            "viseme:PP[0,63]", "expression:joy[0,63]", "expression:surprise[0,63]"} <= set(skin)
    # the normals point out of the head: the skin's front vertex (max z) faces +z
    i, mesh = e.mesh("Skin")
    front = np.argmax(head.meshes["Skin"].vertices[:, 2])
    assert e.acc(mesh.primitives[0].attributes.NORMAL)[front, 2] > 0.9


def test_sparse_targets_are_resolved(head, head_glb):
    e = Evaluated(head_glb)
    _, mesh = e.mesh("Skin")
    accessors = [e.doc.accessors[t["POSITION"]] for t in mesh.primitives[0].targets]
    sparse = [a for a in accessors if a.sparse is not None]
    assert sparse and all(a.bufferView is None for a in sparse)
    # a sparse target decodes to the interval's full displacement: open_jaw[0,4320]
    k = mesh.extras["targetNames"].index("open_jaw[0,4320]")
    entry = head.fat[3].meshes[0]
    want = np.zeros((len(head.meshes["Skin"].vertices), 3))
    want[entry.indices] = entry.displacements[:, 0] * 4320
    got = e.acc(mesh.primitives[0].targets[k]["POSITION"])
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9)
    acc = accessors[k]
    np.testing.assert_allclose(acc.min, got.min(axis=0))
    np.testing.assert_allclose(acc.max, got.max(axis=0))


# -- the node tree reproduces the Transforms ------------------------------------------------------

def test_neutral_world_positions(head, head_glb):
    e = Evaluated(head_glb)
    for name in head.meshes:
        np.testing.assert_allclose(e.world_vertices(name), head.world_vertices(name),
                                   rtol=0, atol=1e-6, err_msg=name)


def test_center_and_scale_orientation(tmp_path):
    face = _rig()
    path = tmp_path / "rig.glb"
    stream = FapStream.from_values({48: [0, 5000, -80, 12000, 100], 49: [0, 3000, -2000, 0, 9000],
                                    50: [0, -7000, 4000, 20000, 1]}, fps=10)
    write_glb(face, path, stream)
    e = Evaluated(path)
    names = [n.name for n in e.doc.nodes]
    assert {"Root_pivot", "Child_pivot", "Twisted_pivot"} <= set(names)
    assert "Plain_pivot" not in names
    for name in face.meshes:
        np.testing.assert_allclose(e.world_vertices(name), face.world_vertices(name),
                                   rtol=0, atol=1e-6, err_msg=name)
    frames = face.play(stream)
    for name in face.meshes:
        want = frames.world_vertices(name)
        for f in range(len(stream)):
            np.testing.assert_allclose(e.world_vertices(name, f), want[f], rtol=0, atol=1e-5,
                                       err_msg=f"{name} frame {f}")
    # the animated fields sit on the named node: Root is rotated and scaled, Child moved
    root, child = e.by_name["Root"], e.by_name["Child"]
    assert {p for (n, p) in e.anim if n == root} == {"rotation", "scale"}
    assert {p for (n, p) in e.anim if n == child} == {"translation"}
    t = frames.transform("Child")["translation"] + np.asarray(face.transforms["Child"].center)
    np.testing.assert_allclose(e.anim[(child, "translation")][1], t, atol=1e-7)
    np.testing.assert_allclose(e.anim[(root, "scale")][1], frames.transform("Root")["scale"],
                               atol=1e-7)


# -- morph targets and weights --------------------------------------------------------------------

def test_morph_weights_reproduce_playback(head, stream, head_glb):
    e = Evaluated(head_glb)
    frames = head.play(stream)
    anim = e.doc.animations[0]
    assert anim.name == "fap_stream" and len(e.doc.animations) == 1
    moved = set()
    for name in head.meshes:
        i, mesh = e.mesh(name)
        if not mesh.primitives[0].targets:
            assert (i, "weights") not in e.anim
            continue
        times, out, sampler = e.anim[(i, "weights")]
        assert sampler.interpolation == "LINEAR"
        np.testing.assert_allclose(times, np.arange(N) / 25, rtol=1e-7)
        W = out.reshape(N, -1)
        # within the borders, weights stay in [0, 1] (1: an interval P has passed)
        assert W.min() >= -1e-7 and W.max() <= 1 + 1e-6, name
        want = frames.vertices(name)
        for f in range(N):
            np.testing.assert_allclose(e.morphed(name, f), want[f], rtol=0, atol=1e-5,
                                       err_msg=f"{name} frame {f}")
        if np.abs(want - head.meshes[name].vertices).max() > 1e-4:
            moved.add(name)
    assert {"Skin", "Hair", "Tongue", "LeftEyeball"} <= moved
    # close_b_r_eyelid, first given in frame 3, has zero weight before it
    i, mesh = e.mesh("Skin")
    names = mesh.extras["targetNames"]
    W = e.anim[(i, "weights")][1].reshape(N, -1)
    cols = [k for k, n in enumerate(names) if n.startswith("close_b_r_eyelid[")]
    assert not W[:3, cols].any() and W[3:, cols].any()


def test_animated_nodes_reproduce_playback(head, stream, head_glb):
    e = Evaluated(head_glb)
    frames = head.play(stream)
    paths = {(e.doc.nodes[n].name, p) for (n, p) in e.anim if p != "weights"}
    assert paths == {("Head", "rotation"), ("Jaw", "rotation"), ("Jaw", "translation"),
                     ("LeftEye", "rotation"), ("RightEye", "rotation"),
                     ("LeftEye", "translation"), ("RightEye", "translation")}
    for name in ("Head", "Jaw", "LeftEye", "RightEye"):
        i = e.by_name[name]
        q = e.anim[(i, "rotation")][1]
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1, atol=1e-6)
        np.testing.assert_allclose(_quat_matrices(q), frames.transform(name)["rotation"],
                                   atol=1e-6)
        assert (np.einsum("ij,ij->i", q[1:], q[:-1]) >= 0).all()      # slerp the short way
    for name in head.meshes:
        want = frames.world_vertices(name)
        for f in range(N):
            np.testing.assert_allclose(e.world_vertices(name, f), want[f], rtol=0, atol=1e-5,
                                       err_msg=f"{name} frame {f}")


def test_weight_convention_and_extrapolation(tmp_path):
    """Targets hold each interval's full displacement; weights are the share of the
    interval P has crossed, past 1 only beyond the outermost border (the FAT's rule)."""
    skin = FaceMesh("Skin", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    d = [[0, -1e-3, 0], [0, 2e-3, 0], [0, 4e-3, 0]]          # vertex 2, intervals 0..2
    fat = FAT([FaceDefTable(3, [FaceDefMesh("Skin", [-100, 0, 50, 100], [2], d)]),
               FaceDefTable(1, [FaceDefMesh("Skin", [0, 63], [1], [[1e-3, 0, 0]])], select=1)])
    face = FaceModel([skin], fat=fat)
    values = [75, -50, 150, -300, 0, 50]
    stream = FapStream.from_values({3: values}, fps=10,
                                   visemes=[[1, 0, 63, 0], [1, 0, 21, 0], [0, 1, 63, 0],
                                            [0, 0, 0, 0], [1, 1, 10, 0], [2, 2, 0, 0]])
    path = tmp_path / "tri.glb"
    write_glb(face, path, stream)
    e = Evaluated(path)
    i, mesh = e.mesh("Skin")
    # in playback's order: tables by (FAP, select), then intervals
    assert mesh.extras["targetNames"] == ["viseme:PP[0,63]", "open_jaw[-100,0]", "open_jaw[0,50]",
                                          "open_jaw[50,100]"]
    W = e.anim[(i, "weights")][1].reshape(len(values), -1)
    np.testing.assert_allclose(W, [[1, 0, 1, 0.5], [1 / 3, 0.5, 0, 0], [0, 0, 1, 2],
                                   [0, 3, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0]], atol=1e-7)
    targets = [e.acc(t["POSITION"])[1 if k == 0 else 2] for k, t in
               enumerate(mesh.primitives[0].targets)]
    np.testing.assert_allclose(targets, [[0.063, 0, 0], [0, 0.1, 0], [0, 0.1, 0], [0, 0.2, 0]],
                               atol=1e-8)
    want = face.play(stream).vertices("Skin")
    for f in range(len(values)):
        np.testing.assert_allclose(e.morphed("Skin", f), want[f], atol=1e-6)
    w = interval_weights(np.array([-100, 0, 50, 100]), np.array(values))
    np.testing.assert_allclose(W[:, 1:] * [-100, 50, 50], w, atol=1e-5)


def test_static_export_has_no_animation(head):
    doc = face_to_gltf(head)
    assert not doc.animations
    assert all(all(w == 0 for w in (m.weights or [])) for m in doc.meshes)


# -- files ----------------------------------------------------------------------------------------

def test_gltf_with_embedded_buffer_matches_glb(head, stream, head_glb, tmp_path):
    path = tmp_path / "head.gltf"
    write_glb(head, path, stream)
    text = path.read_text(encoding="utf-8")
    data = json.loads(text)
    assert data["buffers"][0]["uri"].startswith("data:application/octet-stream;base64,")
    assert text == dumps_gltf(head, stream)
    a, b = Evaluated(path), Evaluated(head_glb)
    for name in ("Skin", "LeftEyeball"):
        np.testing.assert_array_equal(a.morphed(name, 4), b.morphed(name, 4))
    assert head_glb.read_bytes() == dumps_glb(head, stream)


def test_write_is_atomic(tmp_path, monkeypatch):
    face = _rig()
    path = tmp_path / "rig.glb"
    path.write_bytes(b"old")
    broken = FaceModel([FaceMesh("Bad", [[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])])
    with pytest.raises(ValueError, match="mesh Bad: vertex positions"):
        write_glb(broken, path)
    assert path.read_bytes() == b"old"
    with pytest.raises(ValueError, match="mesh Bad"):
        write_glb(broken, tmp_path / "new.glb")

    def fail(*args):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="No space"):
        write_glb(face, tmp_path / "full.gltf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rig.glb"]
    assert path.read_bytes() == b"old"


# -- errors ---------------------------------------------------------------------------------------

def _tri(**kw) -> FaceMesh:
    return FaceMesh("Skin", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], **kw)


@pytest.mark.parametrize("face, stream, message", [
    (FaceModel([FaceMesh("Empty", np.zeros((0, 3)), np.zeros((0, 3)))]), None,
     "mesh Empty: 0 vertices and 0 triangles"),
    (FaceModel([FaceMesh("Dots", np.eye(3), np.zeros((0, 3)))]), None,
     "mesh Dots: 3 vertices and 0"),
    (FaceModel([FaceMesh("Far", [[0, 0, 1e39], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])]), None,
     r"mesh Far: vertex positions: 1e\+39 can't be stored"),
    (FaceModel([_tri()], fat=FAT([FaceDefTable(5, [FaceDefMesh("Skin", [0, 100], [1],
                                                               [[0, 1e37, 0]])])])), None,
     r"mesh Skin: morph target raise_b_midlip\[0,100\] \(table of FAP 5"),
    (FaceModel([_tri()], fat=FAT([FaceDefTable(1, [FaceDefMesh("Lips", [0, 63], [1],
                                                               [[0, 1, 0]])], select=2)])), None,
     "the FAT of FAP 1 deforms mesh 'Lips', which the face does not have"),
    (FaceModel([_tri(parent="T")], [FaceTransform("T", translation=(np.inf, 0, 0))]), None,
     "Transform T: inf"),
    (FaceModel([_tri()]), FapStream.from_values({3: [0, 1]}),
     "its FAT moves no mesh and no Transform"),
    (FaceModel([_tri()], fat=FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 10], [1],
                                                               [[0, 1, 0]])])])),
     FapStream.empty(), "the FAP stream has no frames"),
    (FaceModel([_tri()], fat=FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 10], [1, 2],
                                                               [[0, 1, 0]])])])),
     None, "FAP 3 FaceDefMesh on Skin: 1 displacements for 2 vertices"),
    (FaceModel([_tri()], [FaceTransform("A", "Nope")]), None,
     "Transform A hangs under 'Nope', which is not a Transform of the face"),
    (FaceModel([_tri()], [FaceTransform("A", "B"), FaceTransform("B", "A")]), None,
     "the transform tree loops"),
], ids=["empty-mesh", "no-triangles", "beyond-float32", "target-beyond-float32", "missing-mesh",
        "infinite-transform", "nothing-to-animate", "empty-stream", "bad-fat-entry",
        "unknown-parent", "loop"])
def test_errors_name_what_glTF_cant_hold(face, stream, message, tmp_path):
    path = tmp_path / "face.glb"
    with pytest.raises(ValueError, match=message):
        write_glb(face, path, stream)
    assert not any(tmp_path.iterdir())


def test_unknown_extension(tmp_path):
    with pytest.raises(ValueError, match=r"ends in \.glb .* or \.gltf"):
        write_glb(FaceModel([_tri()]), tmp_path / "face.obj")
    assert not any(tmp_path.iterdir())


# -- the Khronos glTF validator --------------------------------------------------------------------

_VALIDATE = textwrap.dedent("""
    const validator = require('gltf-validator');
    const fs = require('fs');
    const data = fs.readFileSync(process.argv[1]);
    validator.validateBytes(new Uint8Array(data.buffer, data.byteOffset, data.length))
        .then((report) => { console.log(JSON.stringify(report.issues)); })
        .catch((error) => { console.error(String(error)); process.exit(2); });
""")


@pytest.fixture(scope="module")
def node_env() -> dict:
    """The environment for node, with npm's global folder on NODE_PATH (``require`` does
    not look there by itself); skips when node or the npm package gltf-validator is not
    usable (nothing is downloaded)."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("the Khronos glTF validator needs Node.js, which is not installed")
    env = dict(os.environ)
    npm = shutil.which("npm")
    if npm is not None:
        try:
            root = subprocess.run([npm, "root", "-g", "--offline"], capture_output=True,
                                  text=True, timeout=60).stdout.strip()
        except (OSError, subprocess.TimeoutExpired):
            root = ""
        if root:
            env["NODE_PATH"] = os.pathsep.join(p for p in (env.get("NODE_PATH"), root) if p)
    found = subprocess.run([node, "-e", "require('gltf-validator')"], capture_output=True,
                           text=True, timeout=60, cwd=REPO, env=env)
    if found.returncode:
        pytest.skip("the npm package gltf-validator is not installed (npm install "
                    "gltf-validator, here or globally, or put its node_modules on NODE_PATH)")
    return env


def _validate(path, env: dict) -> dict:
    result = subprocess.run(["node", "-e", _VALIDATE, str(path)], capture_output=True, text=True,
                            timeout=120, cwd=REPO, env=env)
    assert result.returncode == 0, result.stderr
    issues = json.loads(result.stdout)
    serious = [m for m in issues["messages"] if m["severity"] <= 1]   # errors and warnings
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, serious[:10]
    assert issues["numInfos"] == 0, issues["messages"][:10]
    return issues


def test_khronos_validator_accepts_the_animated_head(head_glb, node_env):
    _validate(head_glb, node_env)


def test_khronos_validator_accepts_pivots_and_embedded_buffers(tmp_path, node_env):
    path = tmp_path / "rig.gltf"
    write_glb(_rig(), path, FapStream.from_values({48: [0, 5000, -80], 49: [0, 3000, -2000],
                                                   50: [0, -7000, 4000]}, fps=10))
    _validate(path, node_env)


def test_our_glb_reads_back_as_the_same_fat(tmp_path):
    """Interval-named targets (open_jaw[0,4320]) rebuild the tables exactly; the FAPs that
    only turn Transforms are not morph targets and do not come back."""
    from mpeg4fba.formats.morph_targets import read_morph_face

    face = reference_head(resolution=0.5)
    path = tmp_path / "head.glb"
    write_glb(face, path)
    back = read_morph_face(path)
    mesh_faps = {t.fap for t in face.fat if t.fap > 2 and t.meshes}
    assert set(back.fat.faps) == mesh_faps
    assert len(back.fat.visemes) == 14 and len(back.fat.expressions) == 6
    for key in [(3, 0), (5, 0), (19, 0), (44, 0), (1, 4), (2, 6)]:
        a, b = face.fat[key], back.fat[key]
        for m in a.meshes:
            n = next(x for x in b.meshes if x.mesh == m.mesh)
            assert np.array_equal(n.borders, m.borders)
            full = np.zeros((len(face.meshes[m.mesh].vertices), m.n_intervals, 3))
            full[m.indices] = m.displacements
            got = np.zeros_like(full)
            got[n.indices] = n.displacements
            assert np.allclose(got, full, atol=1e-7)
