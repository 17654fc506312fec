"""Tests of mpeg4fba.vrml.walk: matrices, paths, meshes."""
from __future__ import annotations

import numpy as np
import pytest

from mpeg4fba import vrml
from mpeg4fba.vrml import Node, Scene, VRMLError, VRMLWarning
from mpeg4fba.vrml.walk import (Mesh, NodePath, fan_triangulate, iter_meshes, iter_paths,
                                rotation_matrix, scene_bounds, transform_matrix, world_matrices,
                                world_matrix)

HEADER = "#VRML V2.0 utf8\n"


def tri_ifs(points=((0, 0, 0), (1, 0, 0), (0, 1, 0)), index=(0, 1, 2), **kw) -> Node:
    return Node("IndexedFaceSet", coord=Node("Coordinate", point=np.array(points, float)),
                coordIndex=np.array(index), **kw)


# -- matrices ------------------------------------------------------------------------------

def test_identity_for_defaults_and_non_transforms():
    assert np.array_equal(transform_matrix(Node("Transform")), np.eye(4))
    for t in ("Group", "Shape", "Billboard", "Switch"):
        assert np.array_equal(transform_matrix(Node(t)), np.eye(4))


def test_translation_rotation_scale_center_by_hand():
    t = Node("Transform", translation=(1, 2, 3), rotation=(0, 0, 1, np.pi / 2),
             scale=(2, 3, 4), center=(1, 0, 0))
    # p' = T + C + R S (p - C); R turns x to y and y to -x.
    expected = np.array([[0, -3, 0, 2],
                         [2, 0, 0, 0],
                         [0, 0, 4, 3],
                         [0, 0, 0, 1]], float)
    m = transform_matrix(t)
    assert np.allclose(m, expected)
    assert np.allclose(m @ [2, 1, 1, 1], [-1, 4, 7, 1])
    assert np.allclose(m @ [1, 0, 0, 1], [2, 2, 3, 1])  # the centre only moves by T


def test_scale_orientation():
    # Scaling by 2 along x turned 90 degrees about z scales along y.
    t = Node("Transform", scale=(2, 1, 1), scaleOrientation=(0, 0, 1, np.pi / 2))
    assert np.allclose(transform_matrix(t), np.diag([1, 2, 1, 1]))


def test_rotation_axis_is_normalised_and_zero_axis_is_identity():
    assert np.allclose(rotation_matrix((0, 0, 5, np.pi / 2)), rotation_matrix((0, 0, 1, np.pi / 2)))
    assert np.array_equal(rotation_matrix((0, 0, 0, 1.3)), np.eye(3))
    assert np.array_equal(transform_matrix(Node("Transform", rotation=(0, 0, 0, 2))), np.eye(4))
    r = rotation_matrix((1, 1, 1, 0.7))
    assert np.allclose(r @ r.T, np.eye(3)) and np.isclose(np.linalg.det(r), 1)


def test_world_matrix_composes_parents_then_node():
    shape = Node("Shape")
    inner = Node("Transform", rotation=(0, 1, 0, np.pi / 2), children=[shape])
    outer = Node("Transform", translation=(1, 0, 0), children=[inner])
    scene = Scene([outer])
    m = world_matrix(scene, shape)
    assert np.allclose(m @ [1, 0, 0, 1], [1, 0, -1, 1])
    assert np.allclose(world_matrix(scene, inner), m)        # its own transform included
    assert np.allclose(world_matrix(scene, outer), transform_matrix(outer))


def test_world_matrix_of_missing_node():
    scene = Scene([Node("Group", children=[Node("Shape")])])
    with pytest.raises(KeyError, match="not in the scene graph"):
        world_matrix(scene, Node("Shape"))
    with pytest.raises(KeyError, match="not in the scene graph"):
        world_matrices(scene, Node("Shape"))


# -- paths ---------------------------------------------------------------------------------

def test_paths_and_def_use_twice():
    scene = vrml.loads(HEADER + """
DEF A Transform { translation 1 0 0 children DEF S Shape { geometry IndexedFaceSet {
  coord Coordinate { point [ 0 0 0, 1 0 0, 0 1 0 ] } coordIndex [ 0 1 2 ] } } }
DEF B Transform { translation 0 0 -3 children USE S }""")
    a, b, s = scene.find("A"), scene.find("B"), scene.find("S")
    places = [(n, p) for n, p in iter_paths(scene) if n is s]
    assert [p for _, p in places] == [(a,), (b,)]
    assert [tuple(p) for _, p in places] == [(a,), (b,)]
    meshes = list(iter_meshes(scene))
    assert len(meshes) == 2 and meshes[0].geometry is meshes[1].geometry
    assert meshes[0].shape is s and meshes[0].path == (a,) and meshes[1].path == (b,)
    assert np.allclose(meshes[0].matrix[:3, 3], [1, 0, 0])
    assert np.allclose(meshes[1].matrix[:3, 3], [0, 0, -3])
    assert np.allclose(meshes[1].vertices, meshes[1].local_vertices + [0, 0, -3])
    assert [m[:3, 3].tolist() for m in world_matrices(scene, s)] == [[1, 0, 0], [0, 0, -3]]
    lo, hi = scene_bounds(scene)
    assert lo.tolist() == [0, 0, -3] and hi.tolist() == [2, 1, 0]


def test_switch_rules():
    kids = [Node("Shape"), Node("Shape"), Node("Shape")]
    for which, expected in ((1, [kids[1]]), (-1, []), (3, []), (0, [kids[0]])):
        sw = Node("Switch", choice=kids, whichChoice=which)
        got = [n for n, _ in iter_paths(sw)][1:]
        assert got == expected, which


def test_lod_first_level_only_and_other_groups():
    near, far = Node("Shape"), Node("Shape")
    lod = Node("LOD", level=[near, far], range=[10])
    assert [n for n, _ in iter_paths(lod)] == [lod, near]
    for t in ("Group", "Transform", "Anchor", "Billboard", "Collision"):
        s = Node("Shape")
        assert [n for n, _ in iter_paths(Node(t, children=[s]))][1:] == [s]
    # Collision's proxy is not rendered; Shape is a leaf.
    col = Node("Collision", proxy=Node("Shape"))
    assert [n.type for n, _ in iter_paths(col)] == ["Collision"]
    assert [n.type for n, _ in iter_paths(Node("Shape", geometry=tri_ifs()))] == ["Shape"]


def test_face_node_is_descended():
    scene = vrml.loads(HEADER + """
Face {
  renderedFace [ DEF R Shape {} ]
  fdp FDP { faceSceneGraph [ DEF F Transform { children DEF G Shape {} } ] }
}""")
    order = [(n.name or n.type, len(p)) for n, p in iter_paths(scene)]
    assert order == [("Face", 0), ("R", 1), ("FDP", 1), ("F", 2), ("G", 3)]


def test_proto_bodies_are_not_entered():
    scene = vrml.loads(HEADER + """
PROTO Thing [ field SFVec3f where 0 0 0 ] { Transform { translation IS where children Shape {} } }
Thing { where 1 2 3 }""")
    assert [n.type for n, _ in iter_paths(scene)] == ["Thing"]
    assert list(iter_meshes(scene)) == []


def test_hundred_thousand_nested_groups():
    depth = 100_000
    shape = Node("Shape", geometry=tri_ifs())
    node = shape
    for i in range(depth):
        if i % 10_000 == 0:
            node = Node("Transform", translation=(1, 0, 0), children=[node])
        else:
            node = Node("Group", children=[node])
    scene = Scene([node])
    count, deepest = 0, None
    for n, path in iter_paths(scene):
        count += 1
        deepest = (n, path)
    assert count == depth + 1
    assert deepest[0] is shape and len(deepest[1]) == depth
    assert deepest[1][0] is node and deepest[1][-1].type == "Transform"
    assert np.allclose(world_matrix(scene, shape)[:3, 3], [10, 0, 0])
    (mesh,) = iter_meshes(scene)
    assert len(mesh.path) == depth and mesh.path[0] is node
    assert np.allclose(mesh.vertices[0], [10, 0, 0])


def test_own_ancestor_is_not_entered_twice():
    g = Node("Group")
    g["children"] = [Node("Shape"), g]
    with pytest.warns(VRMLWarning, match="its own ancestor"):
        assert [n.type for n, _ in iter_paths(g)] == ["Group", "Shape"]


def test_node_path_behaves_like_a_tuple():
    a, b, c = Node("Group"), Node("Transform"), Node("Shape")
    p = NodePath().child(a).child(b).child(c)
    assert len(p) == 3 and list(p) == [a, b, c] and p[1] is b and p[-1] is c
    assert p[1:] == (b, c) and b in p and Node("Group") not in p
    assert p == (a, b, c) and p != (a, b) and hash(p) == hash((a, b, c))
    assert p == NodePath().child(a).child(b).child(c)
    with pytest.raises(IndexError):
        p[3]


# -- meshes --------------------------------------------------------------------------------

QUAD_TRI_PENTAGON = [0, 1, 2, 3, -1, 4, 5, 6, -1, 7, 8, 9, 10, 11]


@pytest.mark.parametrize("trailing", [False, True])
def test_fan_triangulation_mixed_polygons(trailing):
    index = np.array(QUAD_TRI_PENTAGON + ([-1] if trailing else []))
    tris, faces = fan_triangulate(index)
    assert tris.dtype == np.int64 and tris.shape == (6, 3)
    assert tris.tolist() == [[0, 1, 2], [0, 2, 3], [4, 5, 6], [7, 8, 9], [7, 9, 10], [7, 10, 11]]
    assert faces.tolist() == [0, 0, 1, 2, 2, 2]


def test_fan_triangulation_skips_degenerate_polygons():
    tris, faces = fan_triangulate(np.array([0, 1, -1, 2, -1, 3, 4, 5, -1]))
    assert tris.tolist() == [[3, 4, 5]] and faces.tolist() == [2]
    tris, faces = fan_triangulate(np.array([], dtype=np.int32))
    assert tris.shape == (0, 3) and faces.shape == (0,)


def test_mesh_from_text_with_quads_and_pentagon():
    pts = np.random.default_rng(1).normal(size=(12, 3))
    ifs = tri_ifs(pts, QUAD_TRI_PENTAGON)
    (mesh,) = iter_meshes(Scene([Node("Shape", geometry=ifs)]))
    assert isinstance(mesh, Mesh)
    assert mesh.vertices.dtype == np.float64 and mesh.vertices.shape == (12, 3)
    assert np.array_equal(mesh.vertices, pts) and np.array_equal(mesh.matrix, np.eye(4))
    assert len(mesh.triangles) == 6 and mesh.faces_of_triangles.tolist() == [0, 0, 1, 2, 2, 2]
    assert np.allclose(mesh.bounds[0], pts.min(0)) and np.allclose(mesh.bounds[1], pts.max(0))


def test_ccw_false_flips_winding():
    (mesh,) = iter_meshes(Node("Shape", geometry=tri_ifs(index=(0, 1, 2), ccw=False)))
    assert mesh.triangles.tolist() == [[0, 2, 1]]
    pts = np.zeros((4, 3))
    (mesh,) = iter_meshes(Node("Shape", geometry=tri_ifs(pts, (0, 1, 2, 3), ccw=False)))
    assert mesh.triangles.tolist() == [[0, 2, 1], [0, 3, 2]]


def test_index_out_of_range_names_node_and_place():
    text = HEADER + """Shape {
  geometry DEF Bad IndexedFaceSet {
    coord Coordinate { point [ 0 0 0, 1 0 0, 0 1 0 ] }
    coordIndex [ 0 1 2 -1 0 2 7 -1 ]
  }
}"""
    scene = vrml.loads(text, path="bad.wrl")
    with pytest.raises(VRMLError) as info:
        list(iter_meshes(scene))
    e = info.value
    assert "'Bad'" in str(e) and "coordIndex[6] is 7" in str(e) and "3 points" in str(e)
    assert (e.path, e.line, e.column) == ("bad.wrl", 3, 20)
    assert str(e).startswith("bad.wrl:3:20: ")


def test_negative_index_and_built_nodes():
    ifs = tri_ifs(index=(0, -2, 1))
    with pytest.raises(VRMLError, match=r"coordIndex\[1\] is -2"):
        list(iter_meshes(Node("Shape", geometry=ifs)))


def test_ifs_without_coord_is_empty():
    scene = Scene([Node("Shape", geometry=Node("IndexedFaceSet", coordIndex=[0, 1, 2]))])
    with pytest.raises(VRMLError):  # indices into nothing are out of range
        list(iter_meshes(scene))
    scene = Scene([Node("Shape", geometry=Node("IndexedFaceSet")),
                   Node("Shape", geometry=Node("Box"))])
    (mesh,) = iter_meshes(scene)
    assert mesh.vertices.shape == (0, 3) and mesh.triangles.shape == (0, 3)
    assert mesh.bounds is None and scene_bounds(scene) is None


def test_bare_ifs_reached_by_the_walk():
    ifs = tri_ifs()
    scene = vrml.loads(HEADER + "Group {}")
    scene.nodes[0].fields["children"] = [ifs]   # only a lenient read makes this
    (mesh,) = iter_meshes(scene)
    assert mesh.shape is None and mesh.geometry is ifs and len(mesh.path) == 1


def _fan_by_hand(ci):
    idx = [int(v) for v in ci] + ([-1] if len(ci) and ci[-1] != -1 else [])
    tris, faces, face, cur = [], [], 0, []
    for v in idx:
        if v == -1:
            tris += [[cur[0], cur[j], cur[j + 1]] for j in range(1, len(cur) - 1)]
            faces += [face] * max(len(cur) - 2, 0)
            face, cur = face + 1, []
        else:
            cur.append(v)
    return np.array(tris, np.int64).reshape(-1, 3), np.array(faces, np.int64)


@pytest.mark.parametrize("seed", range(4))
def test_fan_triangulate_uniform_and_mixed_polygons_agree_with_a_plain_loop(seed):
    # polygons all of one size take a reshape; mixed sizes the general path
    rng = np.random.default_rng(seed)
    for t in range(120):
        n = int(rng.integers(0, 25))
        if t % 2:
            k = int(rng.integers(1, 7))
            ci = np.c_[rng.integers(0, 50, (n, k)), -np.ones(n, int)].ravel()
            if t % 4 == 1 and ci.size:
                ci = ci[:-1]                         # the last -1 is optional
        else:
            ci = np.array(sum((list(rng.integers(0, 50, int(rng.integers(0, 7)))) + [-1]
                               for _ in range(n)), []), np.int64)
        ci = ci.astype(np.int32 if t % 3 else np.int64)
        tris, faces = fan_triangulate(ci)
        want_t, want_f = _fan_by_hand(ci)
        assert tris.dtype == faces.dtype == np.int64
        assert np.array_equal(tris, want_t) and np.array_equal(faces, want_f)
