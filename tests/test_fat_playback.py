"""FAT evaluation as the standard defines it, and playback of streams on a FaceModel."""
import numpy as np
import pytest

from mpeg4fba.fba import FapStream
from mpeg4fba.fba.face import FaceMesh, FaceModel, FaceTransform
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform, interval_weights

WORKED = dict(borders=[-1000, 0, 500, 1000], indices=[50, 51],
              displacements=[[1, 0, 0], [0.9, 0, 0], [1.5, 0, 4],
                             [0.8, 0, 0], [0.7, 0, 0], [2, 0, 0]])


def worked_face():
    skin = FaceMesh("Skin", np.zeros((60, 3)), [[0, 1, 2]])
    return FaceModel([skin], fat=FAT([FaceDefTable(3, [FaceDefMesh("Skin", **WORKED)])]))


def test_the_standards_worked_example():
    m = FaceDefMesh("Skin", **WORKED)
    assert m.displacements.shape == (2, 3, 3)           # vertex-major order
    assert m.displacement(600)[0].tolist() == [600, 0, 400]
    assert m.displacement(-200)[1].tolist() == [-160, 0, 0]
    v = worked_face().pose({3: 600}).vertices("Skin")[0]
    assert v[50].tolist() == [600, 0, 400] and not v[:50].any()


@pytest.mark.parametrize("p, expected", [
    (0, [0, 0, 0]), (250, [0, 250, 0]), (500, [0, 500, 0]), (1000, [0, 500, 500]),
    (1500, [0, 500, 1000]),          # beyond the top border: the last interval goes on
    (-500, [-500, 0, 0]), (-1500, [-1500, 0, 0])])
def test_interval_weights_walk_from_zero(p, expected):
    assert interval_weights(np.array([-1000, 0, 500, 1000]), np.array([p]))[0].tolist() == expected


def test_one_sided_tables_ignore_the_other_side():
    assert interval_weights(np.array([0, 100]), np.array([-50, 50, 200])).tolist() == [[0], [50], [200]]
    assert interval_weights(np.array([-100, 0]), np.array([-50, 50])).tolist() == [[-50], [0]]


def test_superposition_of_faps_on_one_vertex():
    skin = FaceMesh("Skin", np.zeros((3, 3)), [[0, 1, 2]])
    fat = FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 100], [0], [[0, -1, 0]])]),
               FaceDefTable(4, [FaceDefMesh("Skin", [-100, 0, 100], [0, 1],
                                            [[1, 0, 0], [2, 0, 0], [0, 0, 1], [0, 0, 3]])])])
    face = FaceModel([skin], fat=fat)
    v = face.pose({3: 10, 4: 5}).vertices("Skin")[0]
    assert v[0].tolist() == [10, -10, 0] and v[1].tolist() == [0, 0, 15]


def test_transforms_rotate_about_their_centre_and_compose_in_fap_order():
    eye = FaceTransform("LeftEye", translation=(3, 4, 0))
    ball = FaceMesh("Ball", [[0, 0, 1], [0, 0, -1], [1, 0, 0]], [[0, 1, 2]], parent="LeftEye")
    fat = FAT([FaceDefTable(23, transforms=[FaceDefTransform("LeftEye", 1, rotation=(0, 1, 0, 1e-5))]),
               FaceDefTable(25, transforms=[FaceDefTransform("LeftEye", "rotation", rotation=(1, 0, 0, 1e-5))])])
    face = FaceModel([ball], [eye], fat=fat)
    quarter = np.pi / 2 / 1e-5
    play = face.pose({23: quarter})
    w = play.world_vertices("Ball")[0]
    assert np.allclose(w[0], [4, 4, 0])        # the gaze (+z) turned to the face's left (+x)
    both = face.pose({23: quarter, 25: quarter}).transform("LeftEye")["rotation"][0]
    yaw = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    pitch = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    assert np.allclose(both, pitch @ yaw)        # 23 first, then 25


def test_translation_and_scale_add_to_the_neutral_value():
    jaw = FaceTransform("Jaw", translation=(0, -1, 0), scale=(1, 1, 1))
    teeth = FaceMesh("Teeth", [[0, 0, 0]] * 3, [[0, 1, 2]], parent="Jaw")
    fat = FAT([FaceDefTable(3, transforms=[FaceDefTransform("Jaw", 3, translation=(0, -0.001, 0))]),
               FaceDefTable(29, transforms=[FaceDefTransform("Jaw", 2, scale=(0.001, 0.001, 0.001))])])
    t = FaceModel([teeth], [jaw], fat=fat).pose({3: 1000, 29: 500}).transform("Jaw")
    assert np.allclose(t["translation"][0], [0, -2, 0]) and np.allclose(t["scale"][0], 1.5)


def test_visemes_blend_and_expressions_add():
    skin = FaceMesh("Skin", np.zeros((2, 3)), [[0, 1, 1]])
    full = lambda v: [[x / 63 for x in v]]          # a shape stored per 1/63
    fat = FAT([FaceDefTable(1, [FaceDefMesh("Skin", [0, 63], [0], full([63, 0, 0]))], select=1),
               FaceDefTable(1, [FaceDefMesh("Skin", [0, 63], [0], full([0, 63, 0]))], select=10),
               FaceDefTable(2, [FaceDefMesh("Skin", [0, 63], [1], full([0, 0, 63]))], select=1),
               FaceDefTable(2, [FaceDefMesh("Skin", [0, 63], [1], full([63, 0, 0]))], select=6)])
    face = FaceModel([skin], fat=fat)
    v = face.pose({}, visemes=[1, 10, 21, 0]).vertices("Skin")[0, 0]
    assert np.allclose(v, [21, 42, 0])           # viseme1 x 21/63 + viseme10 x 42/63
    v = face.pose({}, expressions=[1, 63, 6, 32, 0, 0]).vertices("Skin")[0, 1]
    assert np.allclose(v, [32, 0, 63])           # joy at 63/63 plus surprise at 32/63
    v = face.pose({}, visemes=[1, 1, 10, 0]).vertices("Skin")[0, 0]
    assert np.allclose(v, [63, 0, 0])            # both selects the same viseme: all of it


def test_playback_of_a_stream_and_the_hold_rule():
    values = np.zeros((3, 68))
    mask = np.zeros((3, 68), bool)
    values[0, 2], mask[0, 2] = 600, True          # open_jaw given in frame 0 only: held
    stream = FapStream(values, mask, 25)
    v = worked_face().play(stream).vertices("Skin")
    assert v.shape == (3, 60, 3) and (v[:, 50] == [600, 0, 400]).all()


def test_bad_tables_are_reported_when_compiling():
    skin = FaceMesh("Skin", np.zeros((3, 3)), [[0, 1, 2]])
    bad = FaceModel([skin], fat=FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 100], [7], [[0, 1, 0]])])]))
    with pytest.raises(ValueError, match="vertex index 7 out of range"):
        bad.compile()
    bad = FaceModel([skin], fat=FAT([FaceDefTable(3, [FaceDefMesh("Lips", [0, 100], [0], [[0, 1, 0]])])]))
    with pytest.raises(ValueError, match="mesh 'Lips'"):
        bad.compile()
    bad = FaceModel([skin], fat=FAT([FaceDefTable(3, [FaceDefMesh("Skin", [10, 100], [0], [[0, 1, 0]])])]))
    with pytest.raises(ValueError, match="no 0"):
        bad.compile()
