"""A FAP stream baked into VRML97 interpolators: what a browser would show at each frame is
what playback computes."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from mpeg4fba import vrml
from mpeg4fba.fba import FapStream
from mpeg4fba.fba.face import FaceMesh, FaceModel, FaceTransform
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform
from mpeg4fba.formats.wrl_anim import CLOCK_NAME, animated_scene, write_animated_wrl
from mpeg4fba.formats.wrl_face import load_face
from mpeg4fba.models.reference_head import reference_head
from mpeg4fba.vrml.walk import iter_meshes, rotation_matrix

N = 6


@pytest.fixture(scope="module")
def head():
    return reference_head(resolution=0.5)


@pytest.fixture(scope="module")
def stream():
    return FapStream.from_values({
        "open_jaw": [0, 500, 1500, 4320, 800, 0],
        "close_t_l_eyelid": [0, 300, 1080, -540, -900, 0],
        "raise_l_i_eyebrow": [0, 900, -900, 0, 1800, 0],
        "thrust_jaw": [0, 100, 300, 600, 0, 50],
        "head_yaw": [0, 5000, -8000, 20000, 0, 100],
        "head_pitch": [0, -3000, 5000, 0, 10000, 0],
        "yaw_l_eyeball": [0, 10000, -10000, 0, 5000, 0],
        "pitch_r_eyeball": [0, -5000, 0, 8000, 0, 0],
    }, fps=25,
        visemes=[[0, 0, 0, 0], [1, 4, 63, 0], [2, 10, 40, 0], [10, 2, 10, 0], [3, 0, 63, 0],
                 [0, 0, 0, 0]],
        expressions=[[0, 0, 0, 0, 0, 0], [1, 63, 0, 0, 0, 0], [1, 20, 4, 30, 0, 0],
                     [6, 63, 0, 0, 0, 0], [2, 40, 3, 10, 0, 0], [0, 0, 0, 0, 0, 0]])


@pytest.fixture(scope="module")
def written(head, stream, tmp_path_factory):
    path = tmp_path_factory.mktemp("wrl") / "head_anim.wrl"
    write_animated_wrl(head, stream, path)
    return path


def _routes(scene) -> dict:
    """(from node name, from field) -> [(to node, to field)]."""
    out: dict = {}
    for r in scene.routes:
        out.setdefault((r.from_node.name, r.from_field), []).append((r.to_node, r.to_field))
    return out


def _browser_frame(scene, k: int) -> dict:
    """What a browser shows at frame k (fraction k / frames): each interpolator's k-th key
    value set on the field its ROUTE names; then mesh name -> world vertices, through
    vrml.walk (independent of the face model's own matrices)."""
    routes = _routes(scene)
    for clock_target, _ in routes[(CLOCK_NAME, "fraction_changed")]:
        interp = clock_target
        key = np.asarray(interp["key"])
        i = int(np.flatnonzero(np.isclose(key, k / len(key)))[0])
        values = np.asarray(interp["keyValue"])
        for node, field in routes[(interp.name, "value_changed")]:
            field = field[4:] if field.startswith("set_") else field
            if interp.type == "CoordinateInterpolator":
                n = len(values) // len(key)
                node[field] = values[i * n:(i + 1) * n]
            else:
                node[field] = tuple(values[i])
    return {m.geometry.name: m.vertices for m in iter_meshes(scene)}


def test_scene_layout(head, stream, written):
    scene = vrml.load(written)
    clock = scene.find(CLOCK_NAME)
    assert clock.type == "TimeSensor" and clock["loop"] is True
    assert clock["cycleInterval"] == pytest.approx(N / 25)
    routes = _routes(scene)
    interps = [n for n, f in routes[(CLOCK_NAME, "fraction_changed")]]
    assert all(f == "set_fraction" for _, f in routes[(CLOCK_NAME, "fraction_changed")])
    kinds = {}
    for interp in interps:
        np.testing.assert_allclose(interp["key"], np.arange(N) / N)
        (target, field), = routes[(interp.name, "value_changed")]
        kinds[(target.type, target.name, field)] = interp.type
    moved = {"Skin", "Hair", "Tongue"}
    for m in moved:
        assert kinds[("Coordinate", f"{m}_coord", "set_point")] == "CoordinateInterpolator"
        # the routed Coordinate is the one of the mesh's IndexedFaceSet
        assert scene.find(m)["coord"] is scene.find(f"{m}_coord")
    for t in ("Head", "Jaw", "LeftEye", "RightEye"):
        assert kinds[("Transform", t, "set_rotation")] == "OrientationInterpolator"
    assert kinds[("Transform", "Jaw", "set_translation")] == "PositionInterpolator"
    # meshes and fields the stream leaves alone get nothing
    assert len(kinds) == len(moved) + 5
    assert "Spine_coord" not in scene.defs and "LeftEye_translation" not in scene.defs


def test_interpolators_reproduce_playback(head, stream, written):
    scene = vrml.load(written)
    frames = head.play(stream)
    for m in ("Skin", "Hair", "Tongue"):
        kv = np.asarray(scene.find(f"{m}_motion")["keyValue"]).reshape(N, -1, 3)
        np.testing.assert_array_equal(kv, frames.vertices(m))     # text round trip is exact
    for t in ("Head", "Jaw", "LeftEye", "RightEye"):
        kv = np.asarray(scene.find(f"{t}_rotation")["keyValue"])
        R = np.stack([rotation_matrix(r) for r in kv])
        np.testing.assert_allclose(R, frames.transform(t)["rotation"], atol=1e-12)
    np.testing.assert_array_equal(scene.find("Jaw_translation")["keyValue"],
                                  frames.transform("Jaw")["translation"])


def test_browser_view_matches_playback(head, stream, written):
    """Transform centres are left to VRML: the walk's matrices (T C R SR S -SR -C) with
    the routed values give playback's world positions at every frame."""
    scene = vrml.load(written)
    frames = head.play(stream)
    want = {m: frames.world_vertices(m) for m in head.meshes}
    for k in range(N):
        seen = _browser_frame(scene, k)
        assert set(seen) == set(head.meshes)
        for m in head.meshes:
            np.testing.assert_allclose(seen[m], want[m][k], rtol=0, atol=1e-9,
                                       err_msg=f"{m} frame {k}")


def test_file_is_still_a_face(head, written):
    face = load_face(written)
    assert list(face.meshes) == list(head.meshes) and set(face.transforms) == set(head.transforms)
    assert len(face.fat) == len(head.fat)
    np.testing.assert_array_equal(face.meshes["Skin"].vertices, head.meshes["Skin"].vertices)


def test_scale_rotation_center_and_gzip(tmp_path):
    """A Transform with center and scaleOrientation, its rotation, translation and scale
    driven; written gzipped."""
    tri = [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0.05]]
    t = FaceTransform("T", translation=(0.1, 0, 0), rotation=(0, 1, 0, 0.3), scale=(1, 2, 1),
                      center=(0, 0.2, 0), scale_orientation=(1, 0, 0, 0.4))
    fat = FAT([FaceDefTable(48, [FaceDefMesh("M", [-10, 0, 10], [1], [[0, 1e-3, 0], [1e-3, 0, 0]])],
                            [FaceDefTransform("T", "rotation", rotation=(1, 0, 0, 1e-5))]),
               FaceDefTable(49, [], [FaceDefTransform("T", "translation", translation=(1e-5, 0, 0)),
                                     FaceDefTransform("T", "scale", scale=(0, 1e-5, 0))])])
    face = FaceModel([FaceMesh("M", tri, [[0, 1, 2]], "T")], [t], fat=fat)
    stream = FapStream.from_values({48: [0, -20, 30000], 49: [0, 5000, -5000]}, fps=10)
    path = tmp_path / "t.wrl.gz"
    write_animated_wrl(face, stream, path)
    scene = vrml.load(path)
    assert scene.find("T_scale").type == "PositionInterpolator"
    want = face.play(stream).world_vertices("M")
    for k in range(len(stream)):
        np.testing.assert_allclose(_browser_frame(scene, k)["M"], want[k], atol=1e-12)


def test_errors_and_atomic_writing(tmp_path, head):
    skin = FaceMesh("Skin", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="no frames"):
        write_animated_wrl(FaceModel([skin]), FapStream.empty(), tmp_path / "a.wrl")
    bad = FaceModel([skin], fat=FAT([FaceDefTable(3, [FaceDefMesh("Lips", [0, 10], [0],
                                                                  [[0, 1, 0]])])]))
    with pytest.raises(ValueError, match="Lips"):
        write_animated_wrl(bad, FapStream.from_values({3: [0, 5]}), tmp_path / "b.wrl")
    with pytest.raises(ValueError, match="glTF"):
        write_animated_wrl(FaceModel([skin]), FapStream.from_values({3: [0]}), tmp_path / "c.glb")
    assert not any(tmp_path.iterdir())


def test_names_do_not_clash(tmp_path):
    """A mesh named like the clock and a Transform whose interpolator name is taken."""
    tri = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    face = FaceModel([FaceMesh("FapClock", tri, [[0, 1, 2]], "Jaw"),
                      FaceMesh("Jaw_rotation", tri, [[0, 1, 2]])], [FaceTransform("Jaw")],
                     fat=FAT([FaceDefTable(3, [FaceDefMesh("FapClock", [0, 10], [0], [[0, 1, 0]])],
                                           [FaceDefTransform("Jaw", rotation=(1, 0, 0, 1e-3))])]))
    scene = vrml.loads(vrml.dumps(animated_scene(face, FapStream.from_values({3: [0, 5, 10]}))))
    assert scene.find("FapClock").type == "IndexedFaceSet"
    assert scene.find("FapClock_2").type == "TimeSensor"
    assert scene.find("Jaw_rotation_2").type == "OrientationInterpolator"
    assert scene.find("FapClock_coord").type == "Coordinate"


_PYVRML97 = textwrap.dedent("""
    import sys
    from vrml.vrml97 import parser
    text = open(sys.argv[1], encoding="utf-8").read()
    try:
        ok, children, end = parser.buildParser().parse(text)
    except BaseException as e:
        print("REJECTED", type(e).__name__, e)
        sys.exit(1)
    print("OK" if ok and end == len(text) else f"PARTIAL {ok} {end} {len(text)}")
    sys.exit(0 if ok and end == len(text) else 1)
""")


def test_pyvrml97_accepts_the_animated_file(written, tmp_path):
    """An independent VRML97 parser (in its own process: it keeps PROTOs globally)."""
    pytest.importorskip("vrml.vrml97.parser", reason="PyVRML97 is not installed")
    result = subprocess.run([sys.executable, "-c", _PYVRML97, str(written)], capture_output=True,
                            text=True, timeout=300, cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr[-2000:]
