"""Cloning onto heads as users have them (issue 18, part 4): one-mesh OBJ heads, eyes
welded into the skin's mesh or absent, exactly the required feature points, points in
the wrong units or of another face.

The heads are the reference head (resolution 0.5) exported as a user would: its skin
alone, or all its meshes welded into one, its points as positions in our JSON sidecar.
Expensive objects (the faces, the cloned results) are built once per module.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from click.testing import CliRunner

from mpeg4fba.cli import main
from mpeg4fba.cloning import REQUIRED_POINTS, CloneWarning, clone
from mpeg4fba.cloning.checks import PlacementError, check_placement, surface_distances
from mpeg4fba.cloning.parts import (carry_part_points, find_parts, is_eyeball, mesh_components,
                                    part_components, separate_parts)
from mpeg4fba.cloning.surface import vertex_normals
from mpeg4fba.fba.compliance import check_fat
from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.fat import FAT
from mpeg4fba.fba.featurepoints import FeaturePointError, FeaturePointSet
from mpeg4fba.fba.requirements import FAPU_POINTS, fap_points, required_points
from mpeg4fba.formats.face_files import read_face
from mpeg4fba.formats.fpjson import write_feature_points_json
from mpeg4fba.formats.validate import validate
from mpeg4fba.models import reference_head

EYES = ("LeftEyeball", "RightEyeball")


def one_mesh(face: FaceModel, names, ids, name="head") -> FaceModel:
    """``names`` of ``face`` welded into one mesh (world coordinates), the points ``ids``
    as positions only (as a user's sidecar gives them)."""
    verts, tris, first = [], [], 0
    for n in names:
        v = face.world_vertices(n)
        verts.append(v)
        tris.append(face.meshes[n].triangles + first)
        first += len(v)
    mesh = FaceMesh(name, np.vstack(verts), np.vstack(tris))
    return FaceModel([mesh], points=FeaturePointSet({k: face.points[k] for k in ids}), name=name)


def write_obj(path, face: FaceModel) -> None:
    mesh = next(iter(face.meshes.values()))
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in mesh.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.triangles]
    path.write_text("\n".join(lines) + "\n")


def clone_recording(source, target):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = clone(source, target)
    return out, [str(w.message) for w in caught if issubclass(w.category, CloneWarning)]


@pytest.fixture(scope="module")
def source():
    return reference_head(resolution=0.5)


@pytest.fixture(scope="module")
def head():
    """The target head the one-mesh faces are made of."""
    return reference_head(resolution=0.5, face_width=1.1, seed=2)


@pytest.fixture(scope="module")
def skin_only(head):
    """The skin alone, one mesh, exactly the required points."""
    return one_mesh(head, ["Skin"], REQUIRED_POINTS)


@pytest.fixture(scope="module")
def welded(head):
    """Skin, hair, eyeballs, teeth, tongue and mouth in one mesh (each a connected
    component of it), every point the head has."""
    names = [n for n in head.meshes if n != "Spine"]
    return one_mesh(head, names, list(head.points))


@pytest.fixture(scope="module")
def fused(head):
    """Skin and eyeballs in one mesh whose eyeballs share vertices with the lids: one
    connected component, the eyes part of the skin."""
    face = one_mesh(head, ["Skin", *EYES], REQUIRED_POINTS)
    mesh = face.meshes["head"]
    n_skin = len(head.meshes["Skin"].vertices)
    offsets = np.cumsum([n_skin, len(head.meshes[EYES[0]].vertices)])
    extra = []
    for first, pupil in zip(offsets, ("3.5", "3.6")):
        # a triangle from the skin vertex nearest the pupil to two eyeball vertices
        k = int(np.argmin(np.linalg.norm(mesh.vertices[:n_skin] - head.points[pupil], axis=1)))
        extra.append([k, first, first + 1])
    mesh.triangles = np.vstack([mesh.triangles, extra])
    return face


@pytest.fixture(scope="module")
def skin_clone(source, skin_only):
    return clone_recording(source, skin_only)


@pytest.fixture(scope="module")
def welded_clone(source, welded):
    return clone_recording(source, welded)


# -- a. eyes welded into the skin's mesh, or absent -------------------------------------

def test_mesh_components_and_eyeballs():
    assert mesh_components(np.array([[0, 1, 2], [2, 3, 4], [5, 6, 7]]), 9).tolist() == \
        [0, 0, 0, 0, 0, 1, 1, 1, 2]
    d = np.random.default_rng(1).normal(size=(300, 3))
    ball = d / np.linalg.norm(d, axis=1)[:, None]
    assert is_eyeball(ball * 0.012 + 5)
    assert is_eyeball(ball[ball[:, 2] > 0])              # an open half eyeball still is one
    assert not is_eyeball(ball * [2.0, 1.0, 1.0])        # an ellipsoid is not
    assert not is_eyeball(ball, max_radius=0.5)          # nor one larger than half ES0


def test_eyeballs_welded_as_components_are_split_off(welded):
    found = part_components(welded)
    assert set(found.parts) == {"left eye", "right eye", "upper teeth", "lower teeth", "tongue"}
    split = separate_parts(welded)
    assert split is not welded and "head" in split.meshes
    parts = find_parts(split)
    for part in ("left eye", "right eye"):
        (mesh,) = parts[part]
        assert len(split.meshes[mesh].vertices) == 482      # the whole eyeball, nothing else
    assert len(split.meshes["head"].vertices) + sum(
        len(split.meshes[m].vertices) for p, ms in parts.items() if p != "head" for m in ms) \
        == len(welded.meshes["head"].vertices)


def test_find_parts_never_takes_the_whole_skin_for_an_eye(welded, fused):
    reasons = {}
    assert "left eye" not in find_parts(welded, reasons)       # unsplit: refused, said why
    assert "separate_parts" in reasons["left eye"]
    reasons = {}
    parts = find_parts(separate_parts(fused), reasons)
    assert set(parts) == {"head"}
    assert "lies on the skin" in reasons["left eye"]


def test_an_iris_modelled_apart_goes_with_its_eye_not_the_socket(head):
    """One mesh: skin, left eyeball, an iris (a small ball inside the eyeball, at its
    front) and a socket (a ball round the eyeball, a little larger)."""
    eye = head.world_vertices("LeftEyeball")
    tris = head.meshes["LeftEyeball"].triangles
    centre = eye.mean(axis=0)
    front = centre + (head.points["3.5"] - centre) * 0.8
    pieces = [(head.world_vertices("Skin"), head.meshes["Skin"].triangles), (eye, tris),
              ((eye - centre) * 0.15 + front, tris), ((eye - centre) * 1.3 + centre, tris)]
    verts, faces, first = [], [], 0
    for v, t in pieces:
        verts.append(v)
        faces.append(t + first)
        first += len(v)
    face = FaceModel([FaceMesh("head", np.vstack(verts), np.vstack(faces))],
                     points=FeaturePointSet({k: head.points[k] for k in REQUIRED_POINTS}))
    split = separate_parts(face)
    assert len(split.meshes["head_LeftEye"].vertices) == 2 * len(eye)      # eyeball + iris
    assert len(split.meshes["head"].vertices) == len(pieces[0][0]) + len(eye)  # + socket


def test_both_eyes_in_one_mesh_become_two(head):
    eyes = one_mesh(head, list(EYES), [], name="Eyes")
    skin = one_mesh(head, ["Skin"], list(head.points))
    face = FaceModel([skin.meshes["head"], eyes.meshes["Eyes"]], points=skin.points)
    parts = find_parts(separate_parts(face))
    assert parts["left eye"] != parts["right eye"]
    assert {m for p in ("left eye", "right eye") for m in parts[p]} == \
        {"Eyes_LeftEye", "Eyes_RightEye"}


def test_head_without_eyeballs_clones_with_one_warning(skin_clone):
    out, messages = skin_clone
    eyes = [m for m in messages if "eyeball" in m]
    assert len(eyes) == 1 and "23-30" in eyes[0]
    assert not set(range(23, 31)) & set(out.fat.faps)
    assert {3, 4, 31, 48} <= set(out.fat.faps) and len(out.fat.visemes) == 14
    assert not any("FAP 23" in m or "FAP 24" in m for m in messages)   # no one per FAP


def test_fused_eyes_are_skin_and_the_rest_clones(source, fused):
    out, messages = clone_recording(source, fused)
    assert [m for m in messages if "eyeball" in m and "lies on the skin" in m]
    assert not set(range(23, 31)) & set(out.fat.faps)
    assert validate(out).ok


def test_welded_head_clones_its_eyes(welded_clone):
    out, messages = welded_clone
    assert not [m for m in messages if "has no" in m]
    assert set(range(23, 29)) <= set(out.fat.faps)
    eye = out.fat[23].transforms[0].transform
    assert any(out.meshes[m].parent == eye for m in out.meshes)
    assert validate(out).ok


# -- b. one list of required points -----------------------------------------------------

def test_required_points_follow_the_parts():
    assert required_points([65, 66, 43]) == ["6.1", "10.1", "10.2"]
    assert required_points([65, 43], parts=[]) == ["10.1"]           # no tongue: not its FAPs
    assert set(FAPU_POINTS) <= set(REQUIRED_POINTS)
    assert set(fap_points(range(3, 69))) - set(REQUIRED_POINTS) == \
        {"6.1", "6.2", "6.3", "6.4", "10.1", "10.2", "10.3", "10.4"}


def test_validate_asks_for_the_same_points(skin_clone):
    out, _ = skin_clone
    face = FaceModel(out.meshes.values(), out.transforms.values(),
                     points=FeaturePointSet({k: out.points[k] for k in REQUIRED_POINTS}),
                     fat=out.fat)
    (finding,) = [f for f in check_fat(face) if f.code == "FBA002"]
    assert finding.data["missing"] == face.points.missing(required_points(out.fat.faps)) \
        == ["10.1", "10.2", "10.3", "10.4"]


def test_exactly_the_required_points_clone_and_validate(skin_clone, head):
    out, _ = skin_clone
    report = validate(out)
    assert report.ok, str(report)
    es = float(head.fapu.ES0)
    for fp in ("10.1", "10.2", "10.3", "10.4"):      # derived through the mapping
        mesh, vertex = out.points.vertex(fp)
        assert mesh == "head"
        # as near as the mapping puts the ears (the registration is loosest there)
        assert np.linalg.norm(out.points[fp] - head.points[fp]) < 0.15 * es


def separate_meshes(head: FaceModel, names) -> FaceModel:
    """``names`` of ``head`` as meshes of their own at the root, the required points."""
    return FaceModel([FaceMesh(n, head.world_vertices(n), head.meshes[n].triangles)
                      for n in names],
                     points=FeaturePointSet({k: head.points[k] for k in REQUIRED_POINTS}))


def test_teeth_and_tongue_points_are_carried_from_the_source(source, head):
    face = separate_meshes(head, ["Skin", *EYES, "UpperTeeth", "LowerTeeth", "Tongue", "Mouth"])
    carried = carry_part_points(source, face)
    assert set(carried) == {"9.8", "9.9", "9.10", "9.11", "6.1", "6.2", "6.3", "6.4"}
    es = float(head.fapu.ES0)
    for fp, (mesh, vertex) in carried.items():
        assert mesh == head.points.vertex(fp)[0]          # on the right part, clenched or not
        assert np.linalg.norm(face.world_vertices(mesh)[vertex] - head.points[fp]) < 0.02 * es
    out, messages = clone_recording(source, face)
    assert [m for m in messages if "carried over" in m]
    assert set(out.fat.faps) == set(source.fat.faps) and validate(out).ok
    assert not [m for m in messages if "has no" in m]


def test_a_mouth_cavity_is_not_taken_for_teeth(source, head):
    face = separate_meshes(head, ["Skin", *EYES, "Mouth"])
    assert carry_part_points(source, face) == {}


def in_pieces(vertices: np.ndarray, triangles: np.ndarray, pieces: int = 8) -> tuple:
    """The mesh cut across x into ``pieces`` connected components (teeth modelled one
    by one), each with its own copy of its vertices."""
    x = vertices[triangles].mean(axis=1)[:, 0]
    bins = np.digitize(x, np.linspace(x.min(), x.max(), pieces + 1)[1:-1])
    verts, tris, first = [], [], 0
    for k in np.unique(bins):
        t = triangles[bins == k]
        used, index = np.unique(t, return_inverse=True)
        verts.append(vertices[used])
        tris.append(index.reshape(-1, 3) + first)
        first += len(used)
    return np.vstack(verts), np.vstack(tris)


def test_teeth_one_component_per_tooth_are_found_whole(source, head):
    pieces = [(head.world_vertices(n), head.meshes[n].triangles)
              for n in ("Skin", *EYES, "Tongue", "Mouth")]
    teeth = {n: in_pieces(head.world_vertices(n), head.meshes[n].triangles)
             for n in ("UpperTeeth", "LowerTeeth")}
    verts, tris, first = [], [], 0
    for v, t in pieces + list(teeth.values()):
        verts.append(v)
        tris.append(t + first)
        first += len(v)
    face = FaceModel([FaceMesh("head", np.vstack(verts), np.vstack(tris))],
                     points=FeaturePointSet({k: head.points[k] for k in REQUIRED_POINTS}))
    assert len(np.unique(mesh_components(face.meshes["head"].triangles, first))) == 5 + 2 * 8
    out, messages = clone_recording(source, face)
    for name, (v, _) in teeth.items():
        part = "head_" + name
        assert len(out.meshes[part].vertices) == len(v)            # every tooth, nothing else
    assert not [m for m in messages if "has no" in m]
    assert validate(out).ok


def test_missing_required_point_fails_before_any_work(source, skin_only):
    face = FaceModel(skin_only.meshes.values(), points=FeaturePointSet(
        {k: skin_only.points[k] for k in skin_only.points if k not in ("2.1", "9.15")}))
    with pytest.raises(FeaturePointError) as e:
        clone(source, face)
    assert e.value.ids == ["2.1", "9.15"] and "target" in str(e.value)


# -- c. points off the mesh, in other units, of another face --------------------------------

def scaled(face: FaceModel, factor: float) -> FaceModel:
    return FaceModel(face.meshes.values(), points=FeaturePointSet(
        {k: face.points[k] * factor for k in face.points}), name=face.name)


@pytest.mark.parametrize("factor, points, mesh", [(1000.0, "millimetres", "metres"),
                                                  (100.0, "centimetres", "metres")])
def test_unit_mismatch_is_named(skin_only, factor, points, mesh):
    with pytest.raises(PlacementError) as e:
        check_placement(scaled(skin_only, factor), "target")
    text = str(e.value)
    assert f"look like {points} while the mesh is in {mesh}" in text
    assert f"scale them by {1 / factor:g}?" in text


def test_mesh_in_centimetres_points_in_millimetres(skin_only):
    mesh = skin_only.meshes["head"]
    cm = FaceModel([FaceMesh("head", mesh.vertices * 100, mesh.triangles)],
                   points=scaled(skin_only, 1000.0).points)
    with pytest.raises(PlacementError, match="millimetres while the mesh is in centimetres"
                                             r".*scale them by 0\.1\?"):
        check_placement(cm)


def test_points_of_another_face_are_refused(source, skin_only):
    other = reference_head(resolution=0.5, face_width=0.85, jaw=1.2, nose=1.2,
                           eye_spacing=0.85, seed=5)
    face = FaceModel(skin_only.meshes.values(), points=FeaturePointSet(
        {k: other.points[k] + [0.0, 0.02, 0.0] for k in skin_only.points}))
    with pytest.raises(PlacementError, match="another face"):
        clone(source, face)


def test_points_off_the_surface_are_named_with_their_distance(skin_only):
    mesh = skin_only.meshes["head"]
    normals = vertex_normals(mesh.vertices, mesh.triangles)
    pts = {k: skin_only.points[k] for k in skin_only.points}
    size = float(np.ptp(np.array([pts[k] for k in pts if k not in
                                  ("3.5", "3.6", "7.1")]), axis=0).max())
    for fp, share in (("2.1", 0.05), ("4.3", 0.08)):
        k = int(np.argmin(np.linalg.norm(mesh.vertices - pts[fp], axis=1)))
        pts[fp] = mesh.vertices[k] + normals[k] * share * size
    face = FaceModel([mesh], points=FeaturePointSet(pts))
    with pytest.raises(PlacementError) as e:
        check_placement(face, "target")
    assert e.value.ids == ["2.1", "4.3"]
    size = float(np.ptp(np.array([pts[k] for k in pts if k not in ("3.5", "3.6", "7.1")]),
                        axis=0).max())                      # the face size of the moved points
    d = surface_distances(face, np.array([pts["2.1"], pts["4.3"]])) / size * 100
    assert f"2.1 ({d[0]:.1f} %)" in str(e.value) and f"4.3 ({d[1]:.1f} %)" in str(e.value)
    assert "% of the face size" in str(e.value)
    check_placement(skin_only)              # the right points pass


def test_reference_faces_pass_the_placement_check(source, head):
    check_placement(source)
    check_placement(head)


# -- the command line, as a new user runs it --------------------------------------------------

@pytest.fixture(scope="module")
def user_files(tmp_path_factory, skin_only):
    d = tmp_path_factory.mktemp("user")
    write_obj(d / "head.obj", skin_only)
    write_feature_points_json(skin_only.points, d / "head.json")
    write_feature_points_json(scaled(skin_only, 1000.0).points, d / "head_mm.json")
    return d


def test_cli_clones_a_one_mesh_obj_with_the_required_points(user_files):
    d = user_files
    face = read_face(d / "head.obj", d / "head.json")
    assert len(face.points) == len(REQUIRED_POINTS)
    r = CliRunner().invoke(main, ["clone", str(d / "head.obj"), "--target-points",
                                  str(d / "head.json"), "-o", str(d / "out.wrl")])
    assert r.exit_code == 0, r.output
    assert "check: 0 errors" in r.output
    assert sum("eyeballs" in line for line in r.output.splitlines()) <= 1


def test_cli_names_a_unit_mismatch_in_one_line(user_files):
    d = user_files
    r = CliRunner().invoke(main, ["clone", str(d / "head.obj"), "--target-points",
                                  str(d / "head_mm.json"), "-o", str(d / "mm.wrl")])
    assert r.exit_code == 1
    assert "millimetres while the mesh is in metres" in r.output
    assert "Traceback" not in r.output and not (d / "mm.wrl").exists()


# -- a real head: ICT-FaceKit (skips without ../shared) -----------------------------------

def test_ict_head_welded_into_one_mesh(ict_data, source):
    """ICT's 17 meshes welded into one (a decimated identity, only the required points):
    its eyeballs are split off with the shells that hug them (ICT's socket and blend lie
    within a tenth of the eyeball's radius, where turning with the eye moves them little)
    but not the eyelashes, teeth made of one component per tooth and a tongue in one
    piece with the gums
    are not taken for parts (no motion from the source's rigid teeth and tongue), and
    the rest clones and validates."""
    from benchmarks import ict
    face = ict.ict_face_decimated(ict_data, ict.identity(ict_data, 2), 0.25, name="ICT-2")
    welded = one_mesh(face, list(face.meshes), REQUIRED_POINTS)
    out, messages = clone_recording(source, welded)
    assert {"head_LeftEye", "head_RightEye"} <= set(out.meshes)
    size = {n: len(m.vertices) for n, m in face.meshes.items()}
    eye = len(out.meshes["head_LeftEye"].vertices)
    assert size["LeftEyeball"] <= eye <= sum(size[f"Left{n}"] for n in (
        "Eyeball", "EyeSocket", "Lacrimal", "EyeBlend", "EyeOcclusion"))     # no eyelashes
    assert not {"head_UpperTeeth", "head_LowerTeeth", "head_Tongue"} & set(out.meshes)
    assert set(range(23, 29)) <= set(out.fat.faps)
    assert sum("tongue" in m for m in messages) == 1
    assert validate(out).ok
