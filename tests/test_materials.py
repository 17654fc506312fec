"""What people see: each mesh keeps its own material and colours through glTF and VRML;
closed meshes are single-sided, so an open mouth shows the teeth (the mouth cavity is
wound inward, and drawn two-sided its near wall covers them); a face saved and read back
renders as it did."""
from __future__ import annotations

import numpy as np
import pytest

from mpeg4fba import vrml
from mpeg4fba.fba.appearance import is_closed, mesh_color
from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.wrl_face import load_face, save_face, scene_from_face
from mpeg4fba.models import reference_head
from mpeg4fba.render import render_face
from mpeg4fba.vrml.scene import Node, iter_nodes

AA = (10, 0, 63, 0)                  # viseme "aa" at full blend: the mouth wide open
GREEN = (0.0, 1.0, 0.0)              # teeth painted a colour nothing else has
TETRAHEDRON = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]


@pytest.fixture(scope="module")
def head() -> FaceModel:
    return reference_head(resolution=0.5)


def _linear(c) -> list:
    c = np.asarray(c, float)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).tolist()


# -- closed meshes ----------------------------------------------------------------------------

def test_closed_means_every_edge_twice_in_opposite_directions():
    assert is_closed(TETRAHEDRON)
    assert is_closed(np.asarray(TETRAHEDRON)[:, [0, 2, 1]])            # wound inward: closed too
    assert not is_closed(TETRAHEDRON[:3])                               # a hole
    assert not is_closed(TETRAHEDRON[:3] + [[0, 2, 3]])                 # one triangle flipped
    assert not is_closed(TETRAHEDRON + [TETRAHEDRON[0]])                # a triangle twice
    assert not is_closed(np.zeros((0, 3), int))


def test_the_reference_head_is_closed_but_for_skin_and_hair(head):
    open_meshes = sorted(n for n, m in head.meshes.items() if not m.is_closed())
    assert open_meshes == ["Hair", "Skin"]


def test_a_mesh_colour_is_three_numbers_from_0_to_1():
    assert FaceMesh("M", np.eye(3), [[0, 1, 2]], color=[1, 0.5, 0]).color == (1.0, 0.5, 0.0)
    for bad in [(1, 0), (0, 0, 1.5), (0, float("nan"), 0)]:
        with pytest.raises(ValueError, match="mesh M: color"):
            FaceMesh("M", np.eye(3), [[0, 1, 2]], color=bad)


# -- glTF -----------------------------------------------------------------------------------

def test_gltf_one_material_per_mesh_single_sided_where_closed(head):
    from mpeg4fba.formats.gltf import face_to_gltf
    doc = face_to_gltf(head)
    material = {m.name: doc.materials[m.primitives[0].material] for m in doc.meshes}
    assert {name: mat.name for name, mat in material.items()} == {n: n for n in head.meshes}
    sided = {name: mat.doubleSided for name, mat in material.items()}
    # The cavity, teeth, tongue and eyes are single-sided: back faces culled, so the
    # inward-wound cavity shows its far wall behind the teeth, not its near one before them.
    assert sided == {n: n in ("Skin", "Hair") for n in head.meshes}
    assert len({id(mat) for mat in material.values()}) == len(head.meshes)
    for mat in material.values():           # COLOR_0 gives every colour: white bases
        assert mat.pbrMetallicRoughness.baseColorFactor in (None, [1.0, 1.0, 1.0, 1.0])


def test_gltf_base_colour_is_the_mesh_colour_without_vertex_colours():
    from mpeg4fba.formats.gltf import face_to_gltf
    tri = [[0, 1, 2]]
    face = FaceModel([FaceMesh("UpperTeeth", np.eye(3), tri), FaceMesh("Skin", np.eye(3), tri),
                      FaceMesh("Cap", np.eye(3), tri, color=(0.2, 0.4, 0.6)),
                      FaceMesh("Tongue", np.eye(3), tri)])
    face.colors = {"Tongue": (1.0, 0.0, 0.0)}          # one colour for the mesh
    doc = face_to_gltf(face)
    base = {m.name: doc.materials[m.primitives[0].material].pbrMetallicRoughness.baseColorFactor
            for m in doc.meshes}
    assert base["UpperTeeth"] == pytest.approx(_linear(mesh_color("UpperTeeth")) + [1.0])
    assert base["Skin"] == pytest.approx(_linear(mesh_color("Skin")) + [1.0])
    assert base["UpperTeeth"] != base["Skin"]
    assert base["Cap"] == pytest.approx(_linear((0.2, 0.4, 0.6)) + [1.0])
    assert base["Tongue"] == pytest.approx([1.0, 0.0, 0.0, 1.0])
    assert all(m.primitives[0].attributes.COLOR_0 is None for m in doc.meshes)


def test_colours_of_the_wrong_shape_are_refused_and_nothing_is_written(tmp_path):
    face = FaceModel([FaceMesh("Tongue", np.eye(3), [[0, 1, 2]])])
    face.colors = {"Tongue": np.zeros((2, 3))}
    for name in ("face.glb", "face.wrl"):
        with pytest.raises(ValueError, match=r"face.colors\['Tongue'\].*\[3, 3\]"):
            save_face(face, tmp_path / name)
    assert list(tmp_path.iterdir()) == []


# -- PNG previews -----------------------------------------------------------------------------

def _backends() -> list:
    from mpeg4fba.render.gl import gl_available
    gl = pytest.param("gl", marks=pytest.mark.skipif(not gl_available()[0],
                                                     reason=f"no OpenGL here: {gl_available()[1]}"))
    return ["matplotlib", gl]


def _green_in_mouth(image: np.ndarray, background) -> int:
    """Pixels of the marker colour (the teeth), checked to lie round the mouth: in the
    lower half of the face and its middle third across."""
    img = image.astype(int)
    g = img[..., 1]
    green = (g > 80) & (g > 2 * img[..., 0] + 20) & (g > 2 * img[..., 2] + 20)
    face = np.abs(img - np.asarray(background)).sum(-1) > 30
    rows, cols = np.nonzero(face)
    r, c = np.nonzero(green)
    if len(r):
        top, bottom, left, right = rows.min(), rows.max(), cols.min(), cols.max()
        assert (r > (top + bottom) / 2).all() and (r < bottom).all()
        assert (c > left + (right - left) / 3).all() and (c < right - (right - left) / 3).all()
    return len(r)


@pytest.mark.parametrize("backend", _backends())
@pytest.mark.parametrize("cull", [True, False], ids=["cull", "no-cull"])
def test_preview_open_mouth_shows_the_teeth(head, backend, cull):
    colors = {"UpperTeeth": GREEN, "LowerTeeth": GREEN}
    kw = dict(size=(240, 280), colors=colors, cull=cull, backend=backend,
              background=(1.0, 1.0, 1.0))
    closed = render_face(head, head.pose({}), **kw)
    wide = render_face(head, head.pose({}, visemes=AA), **kw)
    assert _green_in_mouth(closed, (255, 255, 255)) == 0      # behind the lips
    assert _green_in_mouth(wide, (255, 255, 255)) > 40        # in the open mouth


# -- VRML -----------------------------------------------------------------------------------

def test_saved_face_writes_each_mesh_material_colours_and_sides(head):
    scene = scene_from_face(head)
    shapes = {s["geometry"].name: s for s in iter_nodes(scene.nodes) if s.type == "Shape"}
    assert sorted(shapes) == sorted(head.meshes)
    diffuse = {n: tuple(s["appearance"]["material"]["diffuseColor"]) for n, s in shapes.items()}
    assert diffuse == {n: m.display_color() for n, m in head.meshes.items()}
    assert len(set(diffuse.values())) >= 6          # skin, hair, eyes, teeth, tongue, mouth
    for n, s in shapes.items():
        ifs = s["geometry"]
        assert ifs["solid"] == (n not in ("Skin", "Hair")), n
        assert np.abs(ifs["color"]["color"] - head.colors[n]).max() <= 5e-5, n


def test_render_save_load_render_gives_the_same_picture(head, tmp_path):
    path = tmp_path / "head.wrl"
    save_face(head, path)
    back = load_face(path)
    assert {n: m.color for n, m in back.meshes.items()} == \
        {n: m.display_color() for n, m in head.meshes.items()}
    assert sorted(back.colors) == sorted(head.colors)
    for n in head.colors:
        assert np.abs(back.colors[n] - head.colors[n]).max() <= 5e-5, n
    for frames in (None, {"open_jaw": 600}):
        a = render_face(head, frames, size=(200, 230), backend="matplotlib").astype(int)
        b = render_face(back, frames, size=(200, 230), backend="matplotlib").astype(int)
        diff = np.abs(a - b).max(axis=-1)
        assert diff.max() <= 2 and (diff > 0).mean() < 0.01


def test_the_player_glb_of_a_reloaded_face_has_the_demo_colours(head, tmp_path):
    from mpeg4fba.formats.gltf import face_to_gltf
    path = tmp_path / "head.wrl"
    save_face(head, path)
    docs = [face_to_gltf(f) for f in (head, load_face(path))]

    def colours(doc) -> dict:
        blob = doc.binary_blob()
        out = {}
        for m in doc.meshes:
            acc = doc.accessors[m.primitives[0].attributes.COLOR_0]
            view = doc.bufferViews[acc.bufferView]
            out[m.name] = np.frombuffer(blob, "<f4", acc.count * 3, view.byteOffset).reshape(-1, 3)
        return out

    a, b = colours(docs[0]), colours(docs[1])
    assert sorted(a) == sorted(b) == sorted(head.meshes)
    for n in a:
        assert np.abs(a[n] - b[n]).max() < 2e-4, n       # 4 decimals, then linearised
    assert [(m.name, m.doubleSided) for m in docs[0].materials] == \
        [(m.name, m.doubleSided) for m in docs[1].materials]


def _tiny_face_file(folder, edit):
    """A face of one quad (two triangles) saved in ``folder``, its scene changed first by
    ``edit(shape, ifs)``."""
    quad = FaceMesh("Patch", [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    scene = scene_from_face(FaceModel([quad]))
    shape = next(s for s in iter_nodes(scene.nodes) if s.type == "Shape")
    edit(shape, shape["geometry"])
    folder.mkdir(exist_ok=True)
    path = folder / "patch.wrl"
    path.write_text(vrml.dumps(scene))
    return path


def _no_appearance(shape, ifs):
    shape["appearance"] = None


def _blue_material(shape, ifs):
    shape["appearance"]["material"]["diffuseColor"] = (0.1, 0.3, 0.9)


def _colour_per_face(shape, ifs):
    ifs["color"] = Node("Color", color=np.array([[1.0, 0, 0], [0, 0, 1.0]]))
    ifs["colorPerVertex"] = False


def _colour_index(shape, ifs):
    ifs["color"] = Node("Color", color=np.array([[1.0, 1, 1], [0, 0, 0]]))
    ifs["colorIndex"] = np.array([0, 1, 0, -1, 1, 1, 1, -1])


def _material_too_bright(shape, ifs):
    shape["appearance"]["material"]["diffuseColor"] = (0.5, 1.5, 0)


def _too_few_colours(shape, ifs):
    ifs["color"] = Node("Color", color=np.zeros((2, 3)))


def test_without_a_material_the_defaults_stay(tmp_path):
    face = load_face(_tiny_face_file(tmp_path, _no_appearance))
    assert face.meshes["Patch"].color is None and face.colors == {}
    assert face.meshes["Patch"].display_color() == mesh_color("Patch")


def test_a_material_colour_is_read_and_drawn(tmp_path):
    face = load_face(_tiny_face_file(tmp_path, _blue_material))
    assert face.meshes["Patch"].color == (0.1, 0.3, 0.9)
    image = render_face(face, size=(40, 40), backend="matplotlib").astype(int)
    r, g, b = image[20, 20]
    assert b > g > r


def test_colours_per_face_and_through_colorindex_are_averaged_per_vertex(tmp_path):
    face = load_face(_tiny_face_file(tmp_path / "per_face", _colour_per_face))
    assert face.colors["Patch"].tolist() == [[0.5, 0, 0.5], [1, 0, 0], [0.5, 0, 0.5], [0, 0, 1]]
    face = load_face(_tiny_face_file(tmp_path / "indexed", _colour_index))
    assert face.colors["Patch"].tolist() == [[0.5] * 3, [0] * 3, [0.5] * 3, [0] * 3]


@pytest.mark.parametrize("edit, node, message", [
    (_material_too_bright, "Material",
     r"mesh 'Patch': Material.diffuseColor: 1.5 \(item 1\) is not a colour component"),
    (_too_few_colours, "IndexedFaceSet",
     r"IndexedFaceSet 'Patch': coordIndex picks colour 2, but the Color node has 2"),
])
def test_bad_colours_are_errors_at_their_line(tmp_path, edit, node, message):
    path = _tiny_face_file(tmp_path, edit)
    with pytest.raises(FormatError, match=message) as info:
        load_face(path)
    assert info.value.path == str(path)
    assert node in path.read_text().splitlines()[info.value.line - 1]
