"""The VRML FAT codec: Face/FDP/FaceDefTables <-> FaceModel, round trips, VRML97 validity."""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import mpeg4fba
from mpeg4fba import vrml
from mpeg4fba.fba.face import FaceMesh, FaceModel, FaceTransform
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform
from mpeg4fba.fba.featurepoints import FeaturePointSet
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.wrl_face import (FACE_NODES, face_from_scene, load_face, save_face,
                                       scene_from_face, where)
from mpeg4fba.vrml.reader import is_name
from mpeg4fba.vrml.scene import Proto
from mpeg4fba.vrml.walk import iter_meshes

FIXTURES = Path(__file__).resolve().parents[1] / "spec_fixtures" / "fat"
WORKED = FIXTURES / "worked_example.wrl"
HEADER = "#VRML V2.0 utf8\n"


# -- a face with every kind of thing ---------------------------------------------------------

def rich_face() -> FaceModel:
    rng = np.random.default_rng(7)
    head = FaceTransform("Head", translation=(0.1, 1.7, -0.3), rotation=(0, 1, 0, 0.2),
                         center=(0, -0.05, -0.02))
    jaw = FaceTransform("Jaw", parent="Head", scale=(1, 1.1, 0.9),
                        scale_orientation=(0, 0, 1, 0.3), center=(0, -0.04, 0.01))
    eye = FaceTransform("LeftEye", parent="Head", translation=(0.031, 0.03, 0.06))
    skin = FaceMesh("Skin", rng.normal(size=(80, 3)) / 7, rng.integers(0, 80, (120, 3)), "Head")
    teeth = FaceMesh("Teeth", rng.normal(size=(12, 3)), [[0, 1, 2], [2, 3, 4]], "Jaw")
    eyeball = FaceMesh("Eyeball", rng.normal(size=(9, 3)), [[0, 1, 2]], "LeftEye")
    hat = FaceMesh("Hat", rng.normal(size=(3, 3)), [[0, 2, 1]], None)
    fat = FAT([
        FaceDefTable(3, [FaceDefMesh("Skin", [-1000, 0, 500, 1000], [50, 51],
                                     rng.normal(size=(6, 3)) * 1e-4),
                         FaceDefMesh("Teeth", [0, 1024], [0, 1, 2], rng.normal(size=(3, 3)))],
                     [FaceDefTransform("Jaw", 1, rotation=(1, 0, 0, 1e-5))]),
        FaceDefTable(48, [], [FaceDefTransform("Head", 1, rotation=(1, 0, 0, 1e-5))]),
        FaceDefTable(14, [], [FaceDefTransform("Jaw", 3, translation=(0, 0, 1e-6))]),
        FaceDefTable(29, [], [FaceDefTransform("LeftEye", 2, scale=(1e-4, 1e-4, 1e-4))]),
        FaceDefTable(1, [FaceDefMesh("Skin", [0, 63], [1, 2, 3], rng.normal(size=(3, 3)))],
                     select=4),
        FaceDefTable(2, [FaceDefMesh("Skin", [0, 63], [7], rng.normal(size=(1, 3)))], select=6),
    ])
    points = FeaturePointSet({"3.5": (0.031, 0.03, 0.07), "3.6": (-0.031, 0.03, 0.07),
                              "9.15": (0, -0.02, 0.09), "2.2": (0, -0.035, 0.085)})
    face = FaceModel([skin, teeth, eyeball, hat], [head, jaw, eye], points, fat=fat, name="Rich")
    face.initial_faps = {3: 120, 53: -40, 48: 7}
    face.initial_viseme = {"viseme_select1": 3, "viseme_select2": 5, "viseme_blend": 20,
                           "viseme_def": False}
    face.initial_expression = {"expression_select1": 1, "expression_intensity1": 40,
                               "expression_select2": 0, "expression_intensity2": 0,
                               "init_face": True, "expression_def": False}
    return face


def assert_same_face(a: FaceModel, b: FaceModel) -> None:
    assert list(a.meshes) == list(b.meshes)
    for name, m in a.meshes.items():
        n = b.meshes[name]
        assert np.array_equal(m.vertices, n.vertices), name
        assert np.array_equal(m.triangles, n.triangles), name
        assert m.parent == n.parent, name
    assert sorted(a.transforms) == sorted(b.transforms)
    for name, t in a.transforms.items():
        u = b.transforms[name]
        assert (t.parent, t.translation, t.rotation, t.scale, t.center, t.scale_orientation) == \
            (u.parent, u.translation, u.rotation, u.scale, u.center, u.scale_orientation), name
    assert list(a.points) == list(b.points)
    assert np.array_equal(a.points.positions, b.points.positions)
    assert len(a.fat) == len(b.fat)
    for s, t in zip(a.fat, b.fat):
        assert (s.fap, s.select) == (t.fap, t.select)
        assert len(s.meshes) == len(t.meshes) and len(s.transforms) == len(t.transforms)
        for m, n in zip(s.meshes, t.meshes):
            assert m.mesh == n.mesh
            assert np.array_equal(m.borders, n.borders)
            assert np.array_equal(m.indices, n.indices)
            assert m.displacements.shape == n.displacements.shape
            assert np.array_equal(m.displacements, n.displacements)
        for x, y in zip(s.transforms, t.transforms):
            assert (x.transform, x.field, x.rotation, x.scale, x.translation) == \
                (y.transform, y.field, y.rotation, y.scale, y.translation)
    for attr in ("initial_faps", "initial_viseme", "initial_expression"):
        assert getattr(a, attr, None) == getattr(b, attr, None), attr


def reread(face: FaceModel, protos: bool = True) -> FaceModel:
    return face_from_scene(vrml.loads(vrml.dumps(scene_from_face(face, protos=protos))))


# -- round trips -------------------------------------------------------------------------------

@pytest.mark.parametrize("protos", [True, False])
def test_round_trip_is_exact(protos):
    face = rich_face()
    back = reread(face, protos)
    assert_same_face(face, back)
    assert back.name == "Rich"
    # and it plays the same
    pose = {3: 600, 48: -3000, 14: 200, 29: 100}
    a, b = face.pose(pose), back.pose(pose)
    for name in face.meshes:
        assert np.array_equal(a.world_vertices(name), b.world_vertices(name))


def test_written_text_is_stable():
    text = vrml.dumps(scene_from_face(rich_face()))
    again = vrml.dumps(scene_from_face(face_from_scene(vrml.loads(text))))
    assert again == text


def test_protos_layout_renders_the_graph_once():
    scene = scene_from_face(rich_face())
    protos = [s.name for s in scene.statements if isinstance(s, Proto)]
    assert protos == ["Face", "FDP", "FaceDefTables", "FaceDefMesh", "FaceDefTransform", "FAP",
                      "Viseme", "Expression"]
    for p in scene.statements[:len(protos)]:        # the catalogue's interface, no IS
        assert [d.name for d in p.interface] == list(vrml.NODE_TYPES[p.name].fields)
        assert [d.type for d in p.interface] == [d.type for d in
                                                 vrml.NODE_TYPES[p.name].fields.values()]
        assert [(n.type, n.fields, n.is_map) for n in p.body] == [("Group", {}, {})]
    graph, face_node = scene.nodes
    assert graph.type == "Group" and graph.name == "FaceSceneGraph"
    assert face_node.type == "Face" and face_node.is_proto_instance
    assert face_node["fdp"]["faceSceneGraph"] == [graph]
    read = vrml.loads(vrml.dumps(scene))
    assert sorted(m.geometry.name for m in iter_meshes(read)) == ["Eyeball", "Hat", "Skin", "Teeth"]


def test_bifs_style_has_no_protos_and_the_graph_inside_the_fdp():
    scene = scene_from_face(rich_face(), protos=False)
    assert not scene.protos and [n.type for n in scene.nodes] == ["Face"]
    fdp = scene.nodes[0]["fdp"]
    assert not fdp.is_proto_instance
    assert [n.type for n in fdp["faceSceneGraph"]] == ["Transform", "Shape"]   # Head, Hat
    assert list(fdp.fields) == ["featurePointsCoord", "faceSceneGraph", "faceDefTables"]
    read = vrml.loads(vrml.dumps(scene))
    assert sorted(m.geometry.name for m in iter_meshes(read)) == ["Eyeball", "Hat", "Skin", "Teeth"]


def test_minimal_face_writes_only_the_five_protos(tmp_path):
    face = FaceModel([FaceMesh("Tri", np.eye(3), [[0, 1, 2]])])
    text = vrml.dumps(scene_from_face(face))
    assert text.count("PROTO ") == 5 and "PROTO FAP" not in text and "fap FAP" not in text
    assert "featurePointsCoord Coordinate" not in text
    back = face_from_scene(vrml.loads(text))
    assert back.initial_faps == {} and len(back.points) == 0 and len(back.fat) == 0


def test_names_are_sanitised_and_unique():
    face = FaceModel([FaceMesh("left eye", np.eye(3), [[0, 1, 2]], "Skin"),
                      FaceMesh("Skin", np.eye(3), [[0, 1, 2]]),
                      FaceMesh("3d.mesh", np.eye(3), [[0, 1, 2]]),
                      FaceMesh("TRUE", np.eye(3), [[0, 1, 2]])],
                     [FaceTransform("Skin")],
                     fat=FAT([FaceDefTable(3, [FaceDefMesh("left eye", [0, 10], [0], [[1, 0, 0]])],
                                           [FaceDefTransform("Skin", 3, translation=(1, 0, 0))])]))
    scene = scene_from_face(face)
    names = [n.name for n in scene if n.name]
    assert all(is_name(n) for n in names) and len(set(names)) == len(names)
    back = face_from_scene(vrml.loads(vrml.dumps(scene)))
    assert sorted(back.meshes) == ["Skin_2", "TRUE_", "_3d_mesh", "left_eye"]
    assert back.meshes["left_eye"].parent == "Skin" and "Skin" in back.transforms
    assert back.fat[3].meshes[0].mesh == "left_eye"
    assert back.fat[3].transforms[0].transform == "Skin"


def test_vertex_tied_points_are_resolved_when_written():
    skin = FaceMesh("Skin", [[0, 0, 0], [1, 2, 3], [4, 5, 6]], [[0, 1, 2]], "T")
    points = FeaturePointSet({"3.5": (1, 1, 1)}, {"9.15": ("Skin", 2)})
    face = FaceModel([skin], [FaceTransform("T", translation=(0, 10, 0))], points)
    back = reread(face)
    assert back.points["9.15"].tolist() == [4, 15, 6] and back.points["3.5"].tolist() == [1, 1, 1]


def test_unwritable_faces_are_refused():
    skin = FaceMesh("Skin", np.eye(3), [[0, 1, 2]])
    with pytest.raises(ValueError, match="Nose"):
        scene_from_face(FaceModel([skin], fat=FAT([FaceDefTable(
            3, [FaceDefMesh("Nose", [0, 1], [0], [[1, 0, 0]])])])))
    with pytest.raises(ValueError, match="32-bit integers"):
        scene_from_face(FaceModel([skin], fat=FAT([FaceDefTable(
            3, [FaceDefMesh("Skin", [0, 0.5], [0], [[1, 0, 0]])])])))
    with pytest.raises(ValueError, match="Head"):
        scene_from_face(FaceModel([skin], fat=FAT([FaceDefTable(
            48, [], [FaceDefTransform("Head")])])))
    with pytest.raises(ValueError, match="outside"):
        scene_from_face(FaceModel([FaceMesh("Bad", np.eye(3), [[0, 1, 3]])]))
    loop = FaceModel([], [FaceTransform("A", "B"), FaceTransform("B", "A")])
    with pytest.raises(ValueError, match="loops"):
        scene_from_face(loop)


def test_save_face_and_load_face(tmp_path):
    face = rich_face()
    for name in ("rich.wrl", "rich.wrl.gz"):
        path = tmp_path / name
        save_face(face, path)
        back = load_face(path)
        assert_same_face(face, back)
        assert back.source["path"] == str(path)
    assert (tmp_path / "rich.wrl.gz").read_bytes()[:2] == b"\x1f\x8b"
    assert sorted(os.listdir(tmp_path)) == ["rich.wrl", "rich.wrl.gz"]   # no temporary left
    save_face(face, tmp_path / "plain.wrl", protos=False)
    assert_same_face(face, load_face(tmp_path / "plain.wrl"))
    save_face(face, tmp_path / "rich.glb")                 # glTF by extension
    assert (tmp_path / "rich.glb").read_bytes()[:4] == b"glTF"
    umask = os.umask(0)
    os.umask(umask)
    assert os.stat(tmp_path / "rich.wrl").st_mode & 0o777 == 0o666 & ~umask  # an ordinary file's mode


def test_package_exports():
    assert mpeg4fba.load_face is load_face and mpeg4fba.save_face is save_face
    assert "load_face" in mpeg4fba.__all__ and "save_face" in mpeg4fba.__all__


# -- an independent VRML97 parser ---------------------------------------------------------------

_PYVRML97 = textwrap.dedent("""
    import sys
    from vrml.vrml97 import parser
    text = open(sys.argv[1], encoding="utf-8").read()
    try:
        ok, children, end = parser.buildParser().parse(text)
    except BaseException as e:          # its syntax errors come out as all sorts of things
        print("REJECTED", type(e).__name__)
        sys.exit(1)
    print("OK" if ok and end == len(text) else f"PARTIAL {ok} {end} {len(text)}")
    sys.exit(0 if ok and end == len(text) else 1)
""")


def pyvrml97(tmp_path, text: str) -> subprocess.CompletedProcess:
    """PyVRML97's verdict on ``text``, in a fresh process: PyVRML97 keeps the PROTOs it
    has seen in a global registry, so one process would let a later file use them."""
    pytest.importorskip("vrml.vrml97.parser", reason="PyVRML97 is not installed")
    path = tmp_path / "check.wrl"
    path.write_text(text, encoding="utf-8")
    return subprocess.run([sys.executable, "-c", _PYVRML97, str(path)], capture_output=True,
                          text=True, timeout=300, cwd=tmp_path)


def test_pyvrml97_accepts_the_protos_file_with_every_node_kind(tmp_path):
    scene = scene_from_face(rich_face())
    kinds = {n.type for n in scene}
    assert set(FACE_NODES) <= kinds         # Face, FDP, ..., FAP, Viseme, Expression
    result = pyvrml97(tmp_path, vrml.dumps(scene))
    assert result.returncode == 0, result.stdout + result.stderr[-2000:]


def test_pyvrml97_accepts_the_worked_example_once_saved(tmp_path):
    result = pyvrml97(tmp_path, vrml.dumps(scene_from_face(load_face(WORKED))))
    assert result.returncode == 0, result.stdout + result.stderr[-2000:]


def test_pyvrml97_rejects_bifs_style_text(tmp_path):
    """The control: without the PROTOs the MPEG-4 nodes are unknown to VRML97."""
    result = pyvrml97(tmp_path, vrml.dumps(scene_from_face(rich_face(), protos=False)))
    assert result.returncode != 0


# -- reading -----------------------------------------------------------------------------------

def test_worked_example_fixture():
    face = load_face(WORKED)
    assert face.name == "WorkedFace"
    assert list(face.meshes) == ["Skin"] and list(face.transforms) == ["Head"]
    skin = face.meshes["Skin"]
    assert skin.vertices.shape == (60, 3) and skin.triangles.shape == (90, 3)
    assert skin.parent == "Head"                      # the Group between is flattened
    assert len(face.points) == 84 and face.fapu is not None
    neutral = skin.vertices
    for value, vertex, moved in ((600, 50, [600, 0, 400]), (-200, 51, [-160, 0, 0])):
        d = face.pose({3: value}).vertices("Skin")[0] - neutral
        assert d[vertex].tolist() == moved
        others = np.delete(d, [50, 51], axis=0)
        assert not others.any()
    d = face.pose({3: 600}).vertices("Skin")[0] - neutral
    assert d[51].tolist() == [550, 0, 0]
    play = face.pose({48: 10000})
    R = play.transform("Head")["rotation"][0]
    c, s = np.cos(0.1), np.sin(0.1)
    assert np.allclose(R, [[1, 0, 0], [0, c, -s], [0, s, c]])
    spine = face.points["7.1"]                        # the head turns about the top of the spine
    M = play.local_matrices("Head")[0]
    assert np.allclose(M[:3, :3] @ spine + M[:3, 3], spine)


def test_source_locations_point_at_the_lines():
    face = load_face(WORKED)
    lines = WORKED.read_text().splitlines()

    def line_of(obj):
        return int(where(face, obj).rsplit(":", 1)[1])

    assert lines[line_of(face.fat[3]) - 1].strip() == "FaceDefTables {"
    assert lines[line_of(face.fat[3].meshes[0]) - 1].strip() == "faceDefMesh FaceDefMesh {"
    assert lines[line_of(face.fat[48].transforms[0]) - 1].strip().startswith(
        "faceDefTransform FaceDefTransform")
    assert "DEF Skin IndexedFaceSet" in lines[line_of(face.meshes["Skin"]) - 1]
    assert "DEF Head Transform" in lines[line_of(face.transforms["Head"]) - 1]
    src = face.source
    assert src["path"] == str(WORKED) and src["face"].name == "WorkedFace"
    assert src["nodes"][id(face.fat[3])].type == "FaceDefTables"
    assert where(face, face.fat[3]).startswith(str(WORKED) + ":")


def face_text(graph: str, tables: str = "", extra: str = "", protos: str = "") -> str:
    return (HEADER + protos + "DEF F Face {\n" + extra + " fdp FDP {\n faceSceneGraph [\n" + graph
            + "\n]\n faceDefTables [\n" + tables + "\n]\n}\n}\n")


def tri(name: str = "", points: str = "0 0 0, 1 0 0, 0 1 0, 1 1 0", index: str = "0 1 2 3 -1",
        extra: str = "") -> str:
    head = f"DEF {name} " if name else ""
    return (f"Shape {{ geometry {head}IndexedFaceSet {{ coord Coordinate {{ point [ {points} ] }} "
            f"coordIndex [ {index} ] {extra} }} }}")


def test_graph_walk_groups_names_and_triangulation():
    graph = f"""
      Group {{ children [
        Transform {{ translation 0 1 0 children [
          Group {{ children [ {tri()} ] }}
          DEF Inner Transform {{ children [ {tri('Lip', extra='ccw FALSE')} ] }}
          Switch {{ whichChoice 1 choice [ {tri('NotChosen')} {tri('Chosen')} ] }}
          LOD {{ level [ {tri('Near')} {tri('Far')} ] }}
          DirectionalLight {{ }}
          Shape {{ geometry Box {{ }} }}
        ] }}
        {tri('Free')}
        Transform {{ }}
      ] }}"""
    face = face_from_scene(vrml.loads(face_text(graph)))
    assert list(face.meshes) == ["mesh_1", "Lip", "Chosen", "Near", "Free"]
    assert list(face.transforms) == ["transform_1", "Inner", "transform_2"]
    assert face.transforms["transform_1"].translation == (0, 1, 0)
    assert face.meshes["mesh_1"].parent == "transform_1"
    assert face.meshes["Lip"].parent == "Inner" and face.transforms["Inner"].parent == "transform_1"
    assert face.meshes["Free"].parent is None
    assert face.meshes["mesh_1"].triangles.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert face.meshes["Lip"].triangles.tolist() == [[0, 2, 1], [0, 3, 2]]   # ccw FALSE


def test_generated_names_avoid_def_names():
    graph = f"{tri()} {tri('mesh_1')}"
    face = face_from_scene(vrml.loads(face_text(graph)))
    assert list(face.meshes) == ["mesh_2", "mesh_1"]


def test_a_node_in_two_places_gives_two_and_the_fat_follows():
    graph = f"""
      DEF L Transform {{ translation 1 0 0 children [ {tri('Eye')} ] }}
      DEF R Transform {{ translation -1 0 0 children [ Shape {{ geometry USE Eye }} ] }}
      Transform {{ translation 0 5 0 children USE L }}"""
    tables = """
      FaceDefTables { fapID 23 faceDefMesh FaceDefMesh { faceSceneGraphNode USE Eye
          intervalBorders [ 0 10 ] coordIndex [ 0 ] displacements [ 1 0 0 ] } }
      FaceDefTables { fapID 25 faceDefTransform FaceDefTransform { faceSceneGraphNode USE L
          fieldId 3 translationDef 0 1 0 } }"""
    face = face_from_scene(vrml.loads(face_text(graph, tables)))
    assert list(face.meshes) == ["Eye", "Eye_2", "Eye_3"]
    assert [face.meshes[n].parent for n in face.meshes] == ["L", "R", "L_2"]
    assert face.transforms["L_2"].parent == "transform_1"
    assert [m.mesh for m in face.fat[23].meshes] == ["Eye", "Eye_2", "Eye_3"]
    assert [t.transform for t in face.fat[25].transforms] == ["L", "L_2"]
    v = face.pose({23: 5}).vertices("Eye_2")[0]
    assert v[0].tolist() == [5, 0, 0]
    nodes = face.source["nodes"]
    assert nodes[id(face.fat[23].meshes[0])] is nodes[id(face.fat[23].meshes[2])]


def test_faps_initial_values_in_bifs_naming():
    extra = """fap FAP { open_jaw 300 stretch_l_cornerlip -20 stretch_l_corner 15
                         head_yaw -2147483648
                         viseme Viseme { viseme_select1 4 viseme_blend 63 }
                         expression Expression { expression_select1 2 init_face TRUE } }\n"""
    face = face_from_scene(vrml.loads(face_text(tri("S"), extra=extra)))
    assert face.initial_faps == {3: 300, 6: 15, 53: -20}
    assert face.initial_viseme == {"viseme_select1": 4, "viseme_select2": 0, "viseme_blend": 63,
                                   "viseme_def": False}
    assert face.initial_expression["expression_select1"] == 2
    assert face.initial_expression["init_face"] is True
    assert reread(face).initial_faps == face.initial_faps


def test_fat_entries_are_read_as_written():
    tables = """
      FaceDefTables { fapID 1 highLevelSelect 9
        faceDefMesh FaceDefMesh { faceSceneGraphNode USE S intervalBorders [ 0 63 ]
          coordIndex [ 2 0 ] displacements [ 1 2 3, 4 5 6 ] } }
      FaceDefTables { fapID 19
        faceDefMesh FaceDefMesh { faceSceneGraphNode USE S intervalBorders [ -5 0 5 ]
          coordIndex [ 1 ] displacements [ 0 -1 0, 0 -2 0 ] } }"""
    face = face_from_scene(vrml.loads(face_text(tri("S"), tables)))
    assert face.fat[1, 9].meshes[0].displacements.tolist() == [[[1, 2, 3]], [[4, 5, 6]]]
    m = face.fat[19].meshes[0]
    assert m.borders.tolist() == [-5, 0, 5]
    assert m.displacements.tolist() == [[[0, -1, 0], [0, -2, 0]]]


def test_malformed_entries_are_kept_for_the_validator():
    tables = """FaceDefTables { fapID 3 faceDefMesh FaceDefMesh { faceSceneGraphNode USE S
          intervalBorders [ 5 1 ] coordIndex [ 99 ] displacements [ 1 0 0, 2 0 0 ] } }"""
    face = face_from_scene(vrml.loads(face_text(tri("S"), tables)))
    entry = face.fat[3].meshes[0]
    assert entry.problems()
    line = next(i for i, t in enumerate(face_text(tri("S"), tables).splitlines(), 1)
                if "FaceDefMesh {" in t)
    assert where(face, entry) == f"line {line}"
    with pytest.raises(ValueError):
        face.pose({3: 1})


def error_of(text: str, **kw) -> FormatError:
    with pytest.raises(FormatError) as info:
        face_from_scene(vrml.loads(text, path="bad.wrl"), **kw)
    return info.value


def test_fat_targets_must_be_in_the_face_scene_graph():
    outside = HEADER + "DEF Out Shape { geometry DEF Other IndexedFaceSet { } }\n"
    cases = [
        (face_text(f"DEF T Transform {{ children {tri('S')} }}", """
      FaceDefTables { fapID 4
        faceDefMesh FaceDefMesh { faceSceneGraphNode USE T } }"""), "FaceDefMesh {",
         "fapID 4: FaceDefMesh.faceSceneGraphNode is Transform 'T', not an IndexedFaceSet"),
        (face_text(f"DEF Sh {tri('S')}", """
      FaceDefTables { fapID 5
        faceDefMesh FaceDefMesh { faceSceneGraphNode USE Sh } }"""), "FaceDefMesh {",
         "point at the Shape's"),
        (outside + face_text(tri("S"), """
      FaceDefTables { fapID 6
        faceDefMesh FaceDefMesh { faceSceneGraphNode USE Other } }""")[len(HEADER):],
         "FaceDefMesh {",
         "IndexedFaceSet 'Other', not an IndexedFaceSet of the FDP's faceSceneGraph"),
        (face_text(f"DEF Sh {tri('S')}", """
      FaceDefTables { fapID 48
        faceDefTransform FaceDefTransform { faceSceneGraphNode USE Sh } }"""),
         "FaceDefTransform {",
         "fapID 48: FaceDefTransform.faceSceneGraphNode is Shape 'Sh', not a Transform"),
        (face_text(f"DEF T Transform {{ children {tri('S')} }}", """
      FaceDefTables { fapID 48
        faceDefTransform FaceDefTransform { faceSceneGraphNode USE T fieldId 4 } }"""),
         "FaceDefTransform {",
         "fapID 48: FaceDefTransform.fieldId is 4"),
        (face_text(tri("S"), """
      FaceDefTables { fapID 7 faceDefMesh FaceDefMesh { } }"""), "FaceDefMesh {",
         "faceSceneGraphNode is NULL"),
    ]
    for text, marker, message in cases:
        line = next(i for i, t in enumerate(text.splitlines(), 1) if marker in t)
        e = error_of(text)
        assert (e.path, e.line) == ("bad.wrl", line), (str(e), text)
        assert message in e.message, e.message


def test_coord_index_out_of_range():
    e = error_of(face_text(tri("S", index="0 1 7 -1")))
    assert e.line == 5 and "coordIndex[2] is 7" in e.message


def test_which_face():
    two = HEADER + "DEF A Face { fdp FDP { } }\nDEF B Face { fdp FDP { } }\n"
    e = error_of(two)
    assert "2 Face nodes (A, B)" in e.message and "face=" in e.message
    assert face_from_scene(vrml.loads(two), face="B").name == "B"
    assert "the scene's Faces: A, B" in error_of(two, face="C").message
    e = error_of(HEADER + "Transform { children Shape { } }\n")
    assert e.path == "bad.wrl" and "no MPEG-4 Face node" in e.message
    e = error_of(HEADER + "Group { children DEF X Face { } }\n")
    assert e.line == 2 and "Face 'X' has no fdp" in e.message


def test_protos_are_recognised_by_interface():
    good = face_from_scene(vrml.loads(vrml.dumps(scene_from_face(rich_face()))))
    assert len(good.fat) == 6
    bad_proto = (HEADER + "PROTO Face [ exposedField SFNode fdp NULL ] { Group { } }\n"
                 "PROTO FDP [ ] { Group { } }\nFace { fdp FDP { } }\n")
    e = error_of(bad_proto)
    assert e.line == 4 and "PROTO Face is not the MPEG-4 Face node: it declares no fap" in e.message
    face_proto = vrml.dumps(vrml.Scene(list(scene_from_face(FaceModel()).protos[:1])))
    wrong_type = (face_proto + "PROTO FDP [ exposedField MFNode featurePointsCoord [] "
                  "exposedField SFNode textureCoord NULL exposedField MFNode faceDefTables [] "
                  "exposedField MFNode faceSceneGraph [] field SFBool useOrthoTexture FALSE ]"
                  " { Group { } }\nFace { fdp FDP { } }\n")
    e = error_of(wrong_type)
    assert "its featurePointsCoord is MFNode, not SFNode" in e.message
