"""Heads whose surface is cut at texture seams (as every glTF exporter stores a textured
mesh): the detector and the cloner see one surface (mpeg4fba.cloning.seams), and the
cloned face keeps the mesh as given."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from mpeg4fba.cloning import FacialMotionCloner
from mpeg4fba.cloning.detect import find_feature_points
from mpeg4fba.cloning.seams import weld_seams
from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable
from mpeg4fba.fba.featurepoints import FeaturePointSet
from mpeg4fba.models import reference_head

from benchmarks.ict import cut_at_seams


@pytest.fixture(scope="module")
def head():
    return reference_head(resolution=0.5, seed=3)


@pytest.fixture(scope="module")
def cut(head):
    return cut_at_seams(head)


@pytest.fixture(scope="module")
def whole(head):
    """The points found on the head as it is, the yardstick of the cut ones."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return find_feature_points(head)


def test_the_cut_head_has_its_islands_apart(cut):
    from mpeg4fba.cloning.parts import mesh_components
    face, origin = cut
    m = face.meshes["Skin"]
    assert len(origin) > len(np.unique(origin)) + 100
    assert mesh_components(m.triangles, len(m.vertices)).max() >= 2


def test_welding_joins_the_islands_and_keeps_every_row(cut):
    from mpeg4fba.cloning.parts import mesh_components
    face, origin = cut
    w = weld_seams(face)
    m, o = w.face.meshes["Skin"], face.meshes["Skin"]
    assert w.count == len(origin) - len(np.unique(origin))
    assert np.array_equal(m.vertices, o.vertices)                 # rows kept
    used = np.unique(m.triangles)
    lab = mesh_components(m.triangles, len(m.vertices))
    assert len(np.unique(lab[used])) == 1                         # one surface again
    assert np.array_equal(origin[w.first["Skin"]], origin)         # copies onto their first
    assert weld_seams(reference_head(resolution=0.5)).count == 0   # nothing to weld: as is


def test_copies_a_fat_moves_apart_stay_apart():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    T = [[0, 1, 2], [3, 5, 4]]
    # vertex 3 (a copy of 1) moves with FAP 3, vertex 1 does not: lips modelled touching
    fat = FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 1024], [3, 4], [[[0, -1, 0]], [[0, 0, 0]]])])])
    face = FaceModel([FaceMesh("Skin", V, T)], fat=fat)
    w = weld_seams(face)
    assert w.first["Skin"].tolist() == [0, 1, 2, 3, 2, 5]
    assert w.face.meshes["Skin"].triangles.tolist() == [[0, 1, 2], [3, 5, 2]]


def test_points_are_found_on_a_triangle_soup(head, whole):
    soup, origin = triangle_soup(head)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = find_feature_points(soup)
    es = float(np.linalg.norm(head.points["3.5"] - head.points["3.6"]))
    assert set(found.points) == set(whole.points)
    assert max(np.linalg.norm(found.points[k] - whole.points[k]) for k in whole.points) < 0.02 * es


def test_points_are_found_on_a_head_cut_at_seams(head, cut, whole):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = find_feature_points(cut[0])
    assert set(found.points) == set(whole.points)
    es = float(np.linalg.norm(head.points["3.5"] - head.points["3.6"]))
    worst = max(np.linalg.norm(found.points[k] - whole.points[k]) for k in whole.points)
    assert worst < 1e-6 * es
    # every tie names a vertex of the cut mesh at the point's place
    V = cut[0].meshes["Skin"].vertices
    for k, (mesh, i) in found.points.vertices.items():
        if mesh == "Skin":
            assert np.allclose(V[i], head.meshes["Skin"].vertices[whole.points.vertex(k)[1]]), k


def triangle_soup(face: FaceModel, mesh: str = "Skin") -> tuple:
    """``face`` with every triangle of ``mesh`` given its own three vertices (an STL
    file's way); (face, without a FAT, the original vertex of each new vertex)."""
    m = face.meshes[mesh]
    origin = m.triangles.ravel()
    out = face.copy()
    out.meshes[mesh] = FaceMesh(mesh, m.vertices[origin], np.arange(len(origin)).reshape(-1, 3),
                                m.parent, m.color)
    out.points = FeaturePointSet({k: face.points[k] for k in face.points})   # no ties
    out.fat = FAT()
    if mesh in face.colors and np.ndim(face.colors[mesh]) == 2:
        out.colors[mesh] = np.asarray(face.colors[mesh])[origin]
    return out, origin


@pytest.mark.parametrize("how", [cut_at_seams, triangle_soup], ids=["seams", "soup"])
def test_a_head_cut_apart_clones_as_the_whole_one_and_keeps_its_mesh(how):
    source = reference_head(resolution=0.6)
    target = reference_head(resolution=0.5, face_width=1.1, nose=0.9, seed=3)
    target.fat = FAT()
    face, origin = how(target)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = FacialMotionCloner(source, target).clone()
        split = FacialMotionCloner(source, face).clone()
    m = split.meshes["Skin"]
    assert np.array_equal(m.vertices, face.meshes["Skin"].vertices)
    assert np.array_equal(m.triangles, face.meshes["Skin"].triangles)
    es = float(np.linalg.norm(target.points["3.5"] - target.points["3.6"]))
    for fap in (3, 6, 12, 31, 53):
        a = whole.pose({fap: 400}).world_vertices("Skin")[0] - target.world_vertices("Skin")
        b = split.pose({fap: 400}).world_vertices("Skin")[0] - face.world_vertices("Skin")
        # every copy moves as its first, and as the whole head's vertex
        assert np.abs(b - b[weld_seams(face).first["Skin"]]).max() == 0
        assert np.abs(b - a[origin]).max() < 0.02 * es, fap


def test_clone_and_points_on_a_glb_cut_at_seams(tmp_path):
    from click.testing import CliRunner
    from mpeg4fba.cli import main
    from mpeg4fba.formats.face_files import read_face
    from mpeg4fba.formats.gltf import write_glb
    target = reference_head(resolution=0.5, face_width=0.95, mouth_width=1.1, seed=6)
    face, origin = cut_at_seams(target)
    face.points = FeaturePointSet()               # a dumb mesh, as exported
    write_glb(face, tmp_path / "head.glb")
    given = read_face(tmp_path / "head.glb")
    n = {k: len(m.vertices) for k, m in given.meshes.items()}
    assert sum(n.values()) >= len(origin)          # the copies are in the file
    r = CliRunner().invoke(main, ["points", str(tmp_path / "head.glb"), "-o", str(tmp_path / "head.json")])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["clone", str(tmp_path / "head.glb"), "-o", str(tmp_path / "out.glb")])
    assert r.exit_code == 0, r.output
    out = read_face(tmp_path / "out.glb")
    skin = max(given.meshes, key=lambda k: len(given.meshes[k].vertices))
    got = next(m for m in out.meshes.values() if len(m.vertices) == n[skin])
    assert np.array_equal(np.sort(got.triangles, axis=1), np.sort(given.meshes[skin].triangles, axis=1))
