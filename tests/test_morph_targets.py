"""Morph targets -> FAT from files (mpeg4fba.formats.morph_targets: OBJ, VRML97, glTF) and
``convert --morph-targets``.  The pure builder (mpeg4fba.fba.morph): test_morph_fat.py."""
from __future__ import annotations

import base64
import json

import numpy as np
import pytest
from click.testing import CliRunner

from mpeg4fba.cli import main
from mpeg4fba.fba.face import FaceModel
from mpeg4fba.fba.morph import parse_target_name
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.morph_targets import (parse_obj, read_mapping, read_morph_face,
                                            read_morph_targets, target_stem)

from _morph import (assert_same_shape, grid_triangles, grid_vertices, moved_copy,  # noqa: F401
                    neutral, posed_vertices)  # (neutral: a fixture)


# -- OBJ -------------------------------------------------------------------------------------

def test_parse_obj_forms():
    text = """# a comment
mtllib x.mtl
v 0 0 0
v 1 0 0 1.0
v 1 1 0 0.5 0.5 0.5
v 0 1 0
vt 0 0
vn 0 0 1
f 1 2 3
f 1/1 3/1 4/1   # trailing comment
v 5 5 5
v 6 5 5
v 6 6 5
f -3//1 -2//1 -1//1
"""
    ((name, v, t),) = parse_obj(text)
    assert name is None and len(v) == 7
    assert v[:, 0].tolist() == [0, 1, 1, 0, 5, 6, 6]        # order kept
    assert t.tolist() == [[0, 1, 2], [0, 2, 3], [4, 5, 6]]


def test_parse_obj_groups():
    text = """v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 9 9 9
v 2 0 0
v 2 1 0
f 1 2 3
o Skin
f 1/1/1 2/2/2 3/3/3 4/4/4
g Teeth
f 2 6 7 3
o Skin
f 4 3 7
g
"""
    meshes = {name: (v, t) for name, v, t in parse_obj(text)}
    assert list(meshes) == [None, "Skin", "Teeth"]
    v, t = meshes["Skin"]                                   # vertices 1, 2, 3, 4, 7
    assert v[:, 0].tolist() == [0, 1, 1, 0, 2] and t.tolist() == [[0, 1, 2], [0, 2, 3], [3, 2, 4]]
    v, t = meshes["Teeth"]                                  # vertices 2, 3, 6, 7
    assert v.tolist() == [[1, 0, 0], [1, 1, 0], [2, 0, 0], [2, 1, 0]]
    assert t.tolist() == [[0, 2, 3], [0, 3, 1]]
    assert meshes[None][1].tolist() == [[0, 1, 2]]


@pytest.mark.parametrize("text, line, message", [
    ("v 0 0 0\nv 1 0\n", 2, "needs x, y and z"),
    ("v 0 0 0\nv 1 0 x\n", 2, "not numbers"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 0 1 2\n", 5, "vertex index 0"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n", 5, "vertex index 4 is out of range (3 vertices)"),
    ("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", 3, "vertex index -3 is out of range (3 vertices, "
                                                    "2 before this line)"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3.5\n", 4, "whole numbers"),
    ("# nothing\n", None, "no vertices"),
])
def test_parse_obj_errors(text, line, message):
    with pytest.raises(FormatError) as e:
        parse_obj(text, "x.obj")
    assert e.value.path == "x.obj" and e.value.line == line and message in e.value.message


def _obj_text(meshes: dict, tris: dict) -> str:
    out, base = [], 0
    for name, v in meshes.items():
        out.append(f"o {name}")
        out += [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
        out += [f"f {a + base + 1}/1 {b + base + 1}/1 {c + base + 1}/1"
                for a, b, c in tris[name].tolist()]
        base += len(v)
    return "\n".join(out) + "\n"


@pytest.fixture
def obj_set(tmp_path, neutral):
    tris = {"Skin": grid_triangles(6), "Teeth": grid_triangles(3)}
    shapes = {"open_jaw@1024": moved_copy(neutral, 30), "raise_b_midlip@-512": moved_copy(neutral, 31),
              "viseme_PP": moved_copy(neutral, 32), "expression_joy": moved_copy(neutral, 33, "Teeth", 2)}
    (tmp_path / "neutral.obj").write_text(_obj_text(neutral, tris))
    for stem, shape in shapes.items():
        (tmp_path / f"{stem}.obj").write_text(_obj_text(shape, tris))
    paths = [str(tmp_path / f"{stem}.obj") for stem in shapes]
    return str(tmp_path / "neutral.obj"), paths, shapes


def _check_reproduces(face: FaceModel, shapes: dict) -> None:
    for stem, shape in shapes.items():
        key, value = parse_target_name(stem)
        if key.fap == 1:
            got = posed_vertices(face, visemes=[key.select, 0, 63, 0])
        elif key.fap == 2:
            got = posed_vertices(face, expressions=[key.select, 63, 0, 0, 0, 0])
        else:
            got = posed_vertices(face, {key.fap: value})
        assert_same_shape(got, shape)


def test_read_obj_set(obj_set, neutral):
    neutral_path, paths, shapes = obj_set
    base, targets = read_morph_targets(neutral_path, paths)
    assert_same_shape(base, neutral)
    assert [t.name for t in targets] == [p.rsplit("/", 1)[1] for p in paths]
    assert [str(t.key) for t in targets] == ["open_jaw", "raise_b_midlip", "viseme:PP",
                                             "expression:joy"]
    face = read_morph_face(neutral_path, paths)
    assert face.name == "neutral" and set(face.meshes) == {"Skin", "Teeth"}
    assert len(face.meshes["Skin"].triangles) == len(grid_triangles(6))
    assert face.fat.faps == [3, 5] and face.fat.visemes == [1] and face.fat.expressions == [1]
    _check_reproduces(face, shapes)


def test_read_obj_one_mesh_takes_the_neutral_name(tmp_path):
    v = grid_vertices(4)
    body = "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in grid_triangles(4).tolist())
    (tmp_path / "head.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in v) + body)
    moved = v.copy()
    moved[5] += [0, 0.25, 0]
    (tmp_path / "fap3@100.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in moved) + body)
    face = read_morph_face(tmp_path / "head.obj", [tmp_path / "fap3@100.obj"])
    assert list(face.meshes) == ["head"]
    assert_same_shape(posed_vertices(face, {3: 100}), {"head": moved})


def test_mapping(obj_set, tmp_path, neutral):
    neutral_path, paths, shapes = obj_set
    renamed = []
    for k, p in enumerate(paths):
        q = tmp_path / f"shape{k}.obj"
        q.write_text(open(p).read())
        renamed.append(str(q))
    stems = list(shapes)
    as_dict = {"shape0.obj": stems[0], "shape1": stems[1], renamed[2]: "viseme:PP",
               "shape3.obj": "expression:joy"}
    _check_reproduces(read_morph_face(neutral_path, renamed, mapping=as_dict), shapes)
    (tmp_path / "map.json").write_text(json.dumps({f"shape{k}.obj": s for k, s in enumerate(stems)}))
    _check_reproduces(read_morph_face(neutral_path, renamed, mapping=tmp_path / "map.json"), shapes)
    (tmp_path / "map.tsv").write_text("# file\ttarget\n\n" + "".join(
        f"shape{k}.obj\t{s}\n" for k, s in enumerate(stems)))
    _check_reproduces(read_morph_face(neutral_path, renamed, mapping=str(tmp_path / "map.tsv")),
                      shapes)
    # a mapping naming nonsense is an error that points at the mapping
    with pytest.raises(FormatError, match=r"shape0.obj: target 'open_yaw@3'.*fix the mapping"):
        read_morph_targets(neutral_path, renamed[:1], mapping={"shape0.obj": "open_yaw@3"})


def test_mapping_file_errors(tmp_path):
    (tmp_path / "bad.tsv").write_text("a.obj\topen_jaw@10\nb.obj\n")
    with pytest.raises(FormatError) as e:
        read_mapping(tmp_path / "bad.tsv")
    assert e.value.line == 2 and "separated by a tab" in e.value.message
    (tmp_path / "twice.tsv").write_text("a.obj open_jaw@10\na.obj open_jaw@20\n")
    with pytest.raises(FormatError, match="mapped twice"):
        read_mapping(tmp_path / "twice.tsv")
    (tmp_path / "bad.json").write_text('{"a.obj": "open_jaw@10",\n "b.obj": }')
    with pytest.raises(FormatError) as e:
        read_mapping(tmp_path / "bad.json")
    assert e.value.line == 2 and "not valid JSON" in e.value.message
    (tmp_path / "num.json").write_text('{"a.obj": 3}')
    with pytest.raises(FormatError, match="not a string"):
        read_mapping(tmp_path / "num.json")


def test_file_errors(obj_set, tmp_path, neutral):
    neutral_path, paths, _ = obj_set
    (tmp_path / "jaw.obj").write_text(open(paths[0]).read())
    with pytest.raises(FormatError) as e:
        read_morph_targets(neutral_path, [tmp_path / "jaw.obj"])
    assert e.value.path == str(tmp_path / "jaw.obj")
    assert "no FAP named 'jaw'" in e.value.message and "mapping" in e.value.message
    with pytest.raises(FormatError, match="unknown morph-target file type"):
        read_morph_targets(neutral_path, [tmp_path / "open_jaw@10.xyz"])
    # an extra vertex and triangle in the teeth
    bigger = {"Skin": neutral["Skin"], "Teeth": np.vstack([neutral["Teeth"], [[2, 2, 0]]])}
    tris = {"Skin": grid_triangles(6), "Teeth": np.vstack([grid_triangles(3), [[8, 7, 9]]])}
    (tmp_path / "open_jaw@10.obj").write_text(_obj_text(bigger, tris))
    with pytest.raises(ValueError, match="target 'open_jaw@10.obj' mesh Teeth has 10 vertices, "
                                         "the neutral 9"):
        read_morph_face(neutral_path, [tmp_path / "open_jaw@10.obj"])
    # a stray vertex line shifts the absolute face indices after it: caught as a reordering
    shifted = open(paths[0]).read().replace("o Teeth", "o Teeth\nv 0 0 0", 1)
    (tmp_path / "open_jaw@20.obj").write_text(shifted)
    with pytest.raises(ValueError, match="open_jaw@20.obj' mesh Teeth: .*vertex order differs"):
        read_morph_face(neutral_path, [tmp_path / "open_jaw@20.obj"])
    with pytest.raises(OSError):
        read_morph_targets(neutral_path, [tmp_path / "missing@10.obj"])


def test_target_stem():
    assert target_stem("a/b/open_jaw@-12.OBJ") == "open_jaw@-12"
    assert target_stem("viseme_PP.wrl.gz") == "viseme_PP"
    assert target_stem("x.glb") == "x"


# -- VRML ------------------------------------------------------------------------------------

def _wrl(skin: np.ndarray, teeth: np.ndarray) -> str:
    def pts(v):
        return ", ".join(" ".join(repr(c) for c in p) for p in v.tolist())

    def idx(t):
        return " ".join(f"{a} {b} {c} -1" for a, b, c in t.tolist())
    return f"""#VRML V2.0 utf8
DEF Head Transform {{
  translation 0 1.5 0 scale 2 2 2
  children [
    Shape {{ geometry DEF Skin IndexedFaceSet {{
      coord Coordinate {{ point [ {pts(skin)} ] }} coordIndex [ {idx(grid_triangles(6))} ] }} }}
    Transform {{ translation 0 -0.2 0 children Shape {{ geometry IndexedFaceSet {{
      coord Coordinate {{ point [ {pts(teeth)} ] }} coordIndex [ {idx(grid_triangles(3))} ] }} }} }}
  ]
}}
"""


def test_read_vrml_set(tmp_path, neutral):
    shapes = {"open_jaw@800": moved_copy(neutral, 40), "expression_surprise": moved_copy(neutral, 41, "Teeth", 3)}
    (tmp_path / "neutral.wrl").write_text(_wrl(neutral["Skin"], neutral["Teeth"]))
    paths = []
    for stem, s in shapes.items():
        (tmp_path / f"{stem}.wrl").write_text(_wrl(s["Skin"], s["Teeth"]))
        paths.append(tmp_path / f"{stem}.wrl")
    base, targets = read_morph_targets(tmp_path / "neutral.wrl", paths)
    assert list(base) == ["Skin", "mesh_2"]
    np.testing.assert_array_equal(base["Skin"], neutral["Skin"])   # local, not world
    face = read_morph_face(tmp_path / "neutral.wrl", paths)
    assert face.meshes["Skin"].parent == "Head" and face.meshes["mesh_2"].parent == "transform_2"
    assert face.transforms["transform_2"].parent == "Head"
    assert face.transforms["Head"].scale == (2.0, 2.0, 2.0)
    renamed = {stem: {"Skin": s["Skin"], "mesh_2": s["Teeth"]} for stem, s in shapes.items()}
    _check_reproduces(face, renamed)


def test_read_vrml_structure_differs(tmp_path, neutral):
    (tmp_path / "neutral.wrl").write_text(_wrl(neutral["Skin"], neutral["Teeth"]))
    (tmp_path / "open_jaw@10.wrl").write_text(_wrl(neutral["Skin"], neutral["Teeth"]).replace(
        "DEF Skin", "DEF Face"))
    with pytest.raises(ValueError, match="'open_jaw@10.wrl' lacks mesh Skin and has mesh Face"):
        read_morph_face(tmp_path / "neutral.wrl", [tmp_path / "open_jaw@10.wrl"])


# -- glTF ------------------------------------------------------------------------------------

def _gltf(path, meshes: list, embed: bool = False, sparse: bool = False, node_names=True) -> None:
    """Write a glTF: ``meshes`` = [(name, vertices, triangles, [(target name or None,
    deltas), ...])], each mesh on a node named like it (translated by (0, 1, 0))."""
    import pygltflib as g
    blob = bytearray()
    views, accessors = [], []

    def add(arr: np.ndarray, component: int, kind: str) -> int:
        while len(blob) % 4:
            blob.append(0)
        data = arr.tobytes()
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
        blob.extend(data)
        return len(views) - 1

    def accessor(arr: np.ndarray, component: int, kind: str) -> int:
        accessors.append(g.Accessor(bufferView=add(arr, component, kind), componentType=component,
                                    count=len(arr), type=kind))
        return len(accessors) - 1

    gmeshes, nodes = [], []
    for name, v, t, targets in meshes:
        prim = g.Primitive(attributes=g.Attributes(POSITION=accessor(v.astype("<f4"), 5126, "VEC3")),
                           indices=accessor(t.astype("<u2").ravel(), 5123, "SCALAR"))
        for _, d in targets:
            if sparse:
                moved = np.flatnonzero((d != 0).any(axis=1)).astype("<u2")
                sp = g.Sparse(count=len(moved),
                              indices=g.AccessorSparseIndices(bufferView=add(moved, 5123, ""),
                                                              componentType=5123),
                              values=g.AccessorSparseValues(bufferView=add(d[moved].astype("<f4"),
                                                                           5126, "")))
                accessors.append(g.Accessor(componentType=5126, count=len(d), type="VEC3",
                                            sparse=sp))
                prim.targets.append({"POSITION": len(accessors) - 1})
            else:
                prim.targets.append({"POSITION": accessor(d.astype("<f4"), 5126, "VEC3")})
        extras = {}
        if targets and all(n is not None for n, _ in targets):
            extras = {"targetNames": [n for n, _ in targets]}
        gmeshes.append(g.Mesh(name=name, primitives=[prim], extras=extras))
        nodes.append(g.Node(name=name if node_names else None, mesh=len(gmeshes) - 1,
                            translation=[0, 1, 0]))
    doc = g.GLTF2(scene=0, scenes=[g.Scene(nodes=list(range(len(nodes))))], nodes=nodes,
                  meshes=gmeshes, accessors=accessors, bufferViews=views)
    if embed:
        uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()
        doc.buffers = [g.Buffer(byteLength=len(blob), uri=uri)]
    else:
        doc.buffers = [g.Buffer(byteLength=len(blob))]
        doc.set_binary_blob(bytes(blob))
    doc.save(str(path))


@pytest.fixture
def gltf_set(neutral):
    pytest.importorskip("pygltflib")
    jaw, pp, up = moved_copy(neutral, 50), moved_copy(neutral, 51), moved_copy(neutral, 52)
    meshes = [("Skin", neutral["Skin"], grid_triangles(6),
               [("open_jaw@1024", jaw["Skin"] - neutral["Skin"]),
                ("viseme_PP", pp["Skin"] - neutral["Skin"]),
                ("raise_b_midlip@-100", up["Skin"] - neutral["Skin"])]),
              ("Teeth", neutral["Teeth"], grid_triangles(3), [])]
    shapes = {"open_jaw@1024": {"Skin": jaw["Skin"], "Teeth": neutral["Teeth"]},
              "viseme_PP": {"Skin": pp["Skin"], "Teeth": neutral["Teeth"]},
              "raise_b_midlip@-100": {"Skin": up["Skin"], "Teeth": neutral["Teeth"]}}
    return meshes, shapes


def _f32(shapes: dict) -> dict:
    """glTF stores float32: the shapes as read back."""
    return {k: {m: v.astype(np.float32).astype(np.float64) for m, v in s.items()}
            for k, s in shapes.items()}


@pytest.mark.parametrize("suffix, embed, sparse", [(".glb", False, False), (".gltf", True, False),
                                                   (".glb", False, True)])
def test_read_gltf_morph_targets(tmp_path, gltf_set, suffix, embed, sparse):
    meshes, shapes = gltf_set
    path = tmp_path / f"head{suffix}"
    _gltf(path, meshes, embed=embed, sparse=sparse)
    base, targets = read_morph_targets(path)
    assert list(base) == ["Skin", "Teeth"]
    assert [t.name for t in targets] == [f"{k} (in head{suffix})" for k in shapes]
    face = read_morph_face(path)
    assert face.meshes["Skin"].parent == "Skin_2"                 # the node, renamed
    assert face.transforms["Skin_2"].translation == (0.0, 1.0, 0.0)
    assert len(face.meshes["Teeth"].triangles) == 8
    assert [m.mesh for m in face.fat[3].meshes] == ["Skin"]
    # deltas are added in float64 to float32 positions: compare with float32 tolerance
    for stem, shape in _f32(shapes).items():
        key, value = parse_target_name(stem)
        got = posed_vertices(face, visemes=[key.select, 0, 63, 0]) if key.fap == 1 else \
            posed_vertices(face, {key.fap: value})
        for m in shape:
            np.testing.assert_allclose(got[m], shape[m], rtol=0, atol=1e-6)


def test_gltf_target_names_need_a_mapping(tmp_path, gltf_set, neutral):
    meshes, shapes = gltf_set
    meshes[0] = meshes[0][:3] + ([(None, d) for _, d in meshes[0][3]],)
    path = tmp_path / "head.glb"
    _gltf(path, meshes, node_names=False)
    with pytest.raises(FormatError) as e:
        read_morph_targets(path)
    assert e.value.path == str(path) and "'target0'" in e.value.message \
        and "mapping" in e.value.message
    mapping = {f"target{k}": stem for k, stem in enumerate(shapes)}
    face = read_morph_face(path, mapping=mapping)
    assert face.meshes["Skin"].parent == "node_1"
    assert face.fat.faps == [3, 5] and face.fat.visemes == [1]


def test_gltf_neutral_with_file_targets(tmp_path, gltf_set, neutral):
    meshes, _ = gltf_set
    _gltf(tmp_path / "head.glb", [m[:3] + ([],) for m in meshes])
    smile = moved_copy(neutral, 60)
    _gltf(tmp_path / "expression_joy.glb", [("Skin", smile["Skin"], grid_triangles(6), []),
                                             ("Teeth", smile["Teeth"], grid_triangles(3), [])])
    face = read_morph_face(tmp_path / "head.glb", [tmp_path / "expression_joy.glb"])
    got = posed_vertices(face, expressions=[1, 63, 0, 0, 0, 0])
    np.testing.assert_allclose(got["Skin"], smile["Skin"], atol=1e-6)


def test_gltf_errors(tmp_path):
    pytest.importorskip("pygltflib")
    (tmp_path / "junk.glb").write_bytes(b"not a glb at all")
    with pytest.raises(FormatError) as e:
        read_morph_targets(tmp_path / "junk.glb")
    assert e.value.path == str(tmp_path / "junk.glb") and "not a readable glTF" in e.value.message
    with pytest.raises(OSError):
        read_morph_targets(tmp_path / "missing.glb")


# -- the command line ------------------------------------------------------------------------

def test_cli_morph_targets(obj_set, tmp_path):
    wrl_face = pytest.importorskip("mpeg4fba.formats.wrl_face")
    neutral_path, paths, shapes = obj_set
    out = tmp_path / "face.wrl"
    r = CliRunner().invoke(main, ["convert", "--morph-targets", neutral_path, *paths, "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert r.stdout.strip() == f"wrote {out}: 2 meshes, 2 FAPs, 1 visemes, 1 expressions"
    face = wrl_face.load_face(out)
    assert face.fat.faps == [3, 5] and face.fat.visemes == [1] and face.fat.expressions == [1]
    _check_reproduces(face, shapes)


def test_cli_morph_targets_mapping_and_errors(obj_set, tmp_path):
    pytest.importorskip("mpeg4fba.formats.wrl_face")
    neutral_path, paths, shapes = obj_set
    runner = CliRunner()
    q = tmp_path / "a.obj"
    q.write_text(open(paths[0]).read())
    out = tmp_path / "face.wrl"
    r = runner.invoke(main, ["convert", "--morph-targets", neutral_path, str(q), "-o", str(out)])
    assert r.exit_code == 1 and not out.exists()
    assert r.stderr.startswith(f"mpeg4fba: error: {q}: target 'a.obj': no FAP named 'a'")
    assert len(r.stderr.splitlines()) == 1
    (tmp_path / "names.tsv").write_text("a.obj\topen_jaw@1024\n")
    r = runner.invoke(main, ["convert", "--morph-targets", neutral_path, str(q), "-o", str(out),
                             "--mapping", str(tmp_path / "names.tsv")])
    assert r.exit_code == 0, r.output
    r = runner.invoke(main, ["convert", "--morph-targets", neutral_path, str(q)])
    assert r.exit_code == 2 and "needs -o" in r.output
    r = runner.invoke(main, ["convert", neutral_path, str(out), "--mapping", "x.tsv"])
    assert r.exit_code == 2 and "--mapping goes with --morph-targets" in r.output


def test_cli_plain_convert_unchanged(tmp_path):
    src = tmp_path / "in.wrl"
    src.write_text("#VRML V2.0 utf8\nGroup { children [] }\n")
    runner = CliRunner()
    for args in (["convert", str(src), str(tmp_path / "a.wrl")],
                 ["convert", str(src), "-o", str(tmp_path / "b.wrl")]):
        r = runner.invoke(main, args)
        assert r.exit_code == 0, r.output
    assert (tmp_path / "a.wrl").read_text() == (tmp_path / "b.wrl").read_text()
    r = runner.invoke(main, ["convert", str(src)])
    assert r.exit_code == 2 and "give IN.wrl and OUT.wrl" in r.output
