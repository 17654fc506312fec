"""Morph targets -> FAT, the pure builder (mpeg4fba.fba.morph): target names, linear
morphs, visemes and expressions, and its errors.  The file readers and the command line:
test_morph_targets.py."""
from __future__ import annotations

import numpy as np
import pytest

from _morph import assert_same_shape, face_of, moved_copy, neutral, posed_vertices  # noqa: F401 (fixture)
from mpeg4fba.fba.morph import (MorphTarget, MorphTargetWarning, TargetKey,
                                fat_from_morph_targets, parse_target_name)


# -- target names ----------------------------------------------------------------------------

@pytest.mark.parametrize("text, key, value", [
    ("open_jaw@1024", TargetKey(3), 1024.0),
    ("3@1024", TargetKey(3), 1024.0),
    ("fap3@1024", TargetKey(3), 1024.0),
    ("FAP3@+1024", TargetKey(3), 1024.0),
    ("Open_Jaw@1e3", TargetKey(3), 1000.0),
    ("raise_b_midlip@-512", TargetKey(5), -512.0),
    ("stretch_l_cornerlip@100", TargetKey(6), 100.0),        # Visual naming wins
    ("lower_t_lip_lm@40", TargetKey(8), 40.0),               # a BIFS-only name
    (" open_jaw @ 7 ", TargetKey(3), 7.0),
    ("viseme:PP", TargetKey(1, 1), None),
    ("viseme_pp", TargetKey(1, 1), None),
    ("viseme:14", TargetKey(1, 14), None),
    ("expression:joy", TargetKey(2, 1), None),
    ("Expression_Surprise", TargetKey(2, 6), None),
    ("expression:1", TargetKey(2, 1), None),
])
def test_parse_target_name(text, key, value):
    assert parse_target_name(text) == (key, value)


@pytest.mark.parametrize("text, message", [
    ("opne_jaw@10", "no FAP named 'opne_jaw'; did you mean open_jaw?"),
    ("open_jaw", "give the FAP value the shape shows, e.g. 'open_jaw@1024'"),
    ("open_jaw@0", "a FAP value of 0 is the neutral face"),
    ("open_jaw@12.5", "is not a whole number"),
    ("open_jaw@abc", "FAP value 'abc' is not a number"),
    ("open_jaw@inf", "is not finite"),
    ("1@63", "FAP 1 selects a shape"),
    ("2@10", "FAP 2 selects a shape"),
    ("viseme@63", "FAP 1 selects a shape"),
    ("fap69@10", "there is no FAP 69"),
    ("viseme:PP@63", "a viseme takes no @value"),
    ("expression:joy@20", "an expression takes no @value"),
    ("viseme:XY", "no viseme 'XY' (visemes: PP, FF"),
    ("expression:jyo", "did you mean expression:joy?"),
    ("viseme:0", "neutral face, which is no target"),
    ("joy@3", "did you mean expression:joy?"),
    ("@5", "no FAP, viseme or expression named"),
])
def test_parse_target_name_errors(text, message):
    with pytest.raises(ValueError) as e:
        parse_target_name(text)
    assert message in str(e.value) and repr(text.strip()) in str(e.value)


def test_morph_target_forms():
    for key, value in (("open_jaw", 1024), ("open_jaw@1024", None), (3, 1024),
                       (TargetKey(3), 1024), ("fap3", 1024.0), ("open_jaw@1024", 1024)):
        t = MorphTarget(key, value, {})
        assert (t.key, t.value, t.name) == (TargetKey(3), 1024.0, "open_jaw@1024")
    assert MorphTarget("viseme_PP", None, {}).name == "viseme:PP"
    assert MorphTarget(TargetKey(2, 4), None, {}).name == "expression:fear"
    with pytest.raises(ValueError, match="value 512 given besides @1024"):
        MorphTarget("open_jaw@1024", 512, {})
    with pytest.raises(ValueError, match="'viseme:PP': a viseme takes no value"):
        MorphTarget("viseme:PP", 63, {})
    with pytest.raises(ValueError, match="'expression:joy': an expression takes no value"):
        MorphTarget("expression:joy", 63, {})
    with pytest.raises(ValueError, match="'my shape'.*takes no value"):
        MorphTarget(TargetKey(1, 1), 63, {}, name="my shape")
    with pytest.raises(ValueError, match="FAP 2 selects a shape"):
        MorphTarget(2, 63, {})
    with pytest.raises(ValueError, match="a FAP value of 0"):
        MorphTarget("open_jaw", 0, {})


# -- building the FAT ------------------------------------------------------------------------

def test_one_target_is_a_linear_morph(neutral):
    shape = moved_copy(neutral, 1)
    fat = fat_from_morph_targets(neutral, [MorphTarget("open_jaw@1024", None, shape)])
    assert fat.faps == [3] and len(fat) == 1
    (m,) = fat[3].meshes                                   # Teeth does not move
    assert m.mesh == "Skin" and m.borders.tolist() == [0.0, 1024.0]
    moved = np.flatnonzero((shape["Skin"] != neutral["Skin"]).any(axis=1))
    assert m.indices.tolist() == moved.tolist()
    face = face_of(neutral, fat)
    assert_same_shape(posed_vertices(face, {3: 1024}), shape)
    half = {n: (neutral[n] + shape[n]) / 2 for n in neutral}
    assert_same_shape(posed_vertices(face, {3: 512}), half)
    double = {n: 2 * shape[n] - neutral[n] for n in neutral}
    assert_same_shape(posed_vertices(face, {"open_jaw": 2048}), double)       # extrapolates
    assert_same_shape(posed_vertices(face, {3: -100}), neutral)                # no interval below 0


def test_one_negative_target(neutral):
    shape = moved_copy(neutral, 2)
    fat = fat_from_morph_targets(neutral, [MorphTarget("raise_b_midlip", -300, shape)])
    assert fat[5].meshes[0].borders.tolist() == [-300.0, 0.0]
    face = face_of(neutral, fat)
    assert_same_shape(posed_vertices(face, {5: -300}), shape)
    assert_same_shape(posed_vertices(face, {5: -100}), {n: neutral[n] + (shape[n] - neutral[n]) / 3
                                           for n in neutral})
    assert_same_shape(posed_vertices(face, {5: 100}), neutral)


def test_targets_on_both_sides_and_several_on_one(neutral):
    values = [-600, -200, 300, 1000]
    shapes = {v: moved_copy(neutral, 10 + i, k=7) for i, v in enumerate(values)}
    targets = [MorphTarget(f"lower_t_midlip@{v}", None, shapes[v]) for v in (300, -600, 1000, -200)]
    fat = fat_from_morph_targets(neutral, targets)
    (m,) = fat[4].meshes
    assert m.borders.tolist() == [-600.0, -200.0, 0.0, 300.0, 1000.0]
    face = face_of(neutral, fat)
    for v in values:
        assert_same_shape(posed_vertices(face, {4: v}), shapes[v])
    assert_same_shape(posed_vertices(face, {4: 0}), neutral)
    # between two targets: a linear blend of the two shapes
    w = (650 - 300) / 700
    assert_same_shape(posed_vertices(face, {4: 650}), {n: (1 - w) * shapes[300][n] + w * shapes[1000][n]
                                          for n in neutral})
    w = (-400 + 200) / -400
    assert_same_shape(posed_vertices(face, {4: -400}), {n: (1 - w) * shapes[-200][n] + w * shapes[-600][n]
                                           for n in neutral})
    assert_same_shape(posed_vertices(face, {4: 100}), {n: neutral[n] + (shapes[300][n] - neutral[n]) / 3
                                          for n in neutral})


def test_visemes_and_expressions(neutral):
    pp, joy, sad = moved_copy(neutral, 20), moved_copy(neutral, 21, mesh="Teeth", k=3), moved_copy(neutral, 22)
    jaw = moved_copy(neutral, 23)
    fat = fat_from_morph_targets(neutral, [
        MorphTarget("viseme:PP", None, pp), MorphTarget("expression_joy", None, joy),
        MorphTarget("expression:2", None, sad), MorphTarget("open_jaw@1000", None, jaw)])
    assert fat.visemes == [1] and fat.expressions == [1, 2] and fat.faps == [3]
    assert fat[1, 1].meshes[0].borders.tolist() == [0.0, 63.0]
    assert [m.mesh for m in fat[2, 1].meshes] == ["Teeth"]
    face = face_of(neutral, fat)
    assert_same_shape(posed_vertices(face, visemes=[1, 0, 63, 0]), pp)
    assert_same_shape(posed_vertices(face, expressions=[1, 63, 0, 0, 0, 0]), joy)
    assert_same_shape(posed_vertices(face, expressions=[2, 63, 0, 0, 0, 0]), sad)
    assert_same_shape(posed_vertices(face, visemes=[1, 0, 21, 0]),
                  {n: neutral[n] + (pp[n] - neutral[n]) / 3 for n in neutral})
    # everything adds: viseme + expression + low-level FAP
    assert_same_shape(posed_vertices(face, {3: 1000}, visemes=[1, 0, 63, 0], expressions=[1, 63, 0, 0, 0, 0]),
                  {n: pp[n] + joy[n] + jaw[n] - 2 * neutral[n] for n in neutral})


def test_tolerance_drops_small_motion(neutral):
    shape = {n: v.copy() for n, v in neutral.items()}
    shape["Skin"][3] += [0, 1e-7, 0]
    shape["Skin"][7] += [0, 0.01, 0]
    assert fat_from_morph_targets(neutral, [MorphTarget("open_jaw@10", None, shape)])[3] \
        .meshes[0].indices.tolist() == [3, 7]
    assert fat_from_morph_targets(neutral, [MorphTarget("open_jaw@10", None, shape)], tol=1e-6)[3] \
        .meshes[0].indices.tolist() == [7]


def test_target_that_moves_nothing_warns(neutral):
    with pytest.warns(MorphTargetWarning, match="'open_jaw@10' moves no vertex"):
        fat = fat_from_morph_targets(neutral, [MorphTarget("open_jaw@10", None, neutral)])
    assert len(fat) == 0


def test_accepts_a_face_model_as_neutral(neutral):
    face = face_of(neutral, None)
    fat = fat_from_morph_targets(face, [MorphTarget("open_jaw@10", None, moved_copy(neutral, 3))])
    assert fat.faps == [3]


def test_error_vertex_count(neutral):
    shape = moved_copy(neutral, 4)
    shape["Skin"] = shape["Skin"][:-2]
    with pytest.raises(ValueError) as e:
        fat_from_morph_targets(neutral, [MorphTarget("open_jaw@1024", None, shape)])
    assert str(e.value) == "target 'open_jaw@1024' mesh Skin has 34 vertices, the neutral 36"


def test_error_mesh_set(neutral):
    shape = moved_copy(neutral, 4)
    del shape["Teeth"]
    shape["Tongue"] = np.zeros((3, 3))
    with pytest.raises(ValueError, match="target 'open_jaw@1024' lacks mesh Teeth and has mesh "
                                         "Tongue that the neutral has not"):
        fat_from_morph_targets(neutral, [MorphTarget("open_jaw@1024", None, shape)])


def test_error_vertex_order(neutral):
    shape = moved_copy(neutral, 5)
    shape["Skin"] = shape["Skin"][np.random.default_rng(0).permutation(36)]
    with pytest.raises(ValueError, match=r"target 'viseme:PP' mesh Skin: .*vertex order differs\?"):
        fat_from_morph_targets(neutral, [MorphTarget("viseme:PP", None, shape)])
    # a whole mesh moved (e.g. the teeth with the jaw) is no reordering
    shape = {n: v.copy() for n, v in neutral.items()}
    shape["Teeth"] += [0, -5, 0]
    assert fat_from_morph_targets(neutral, [MorphTarget("open_jaw@100", None, shape)]).faps == [3]
    # and the check can be switched off
    shape["Skin"] = shape["Skin"][::-1]
    assert fat_from_morph_targets(neutral, [MorphTarget("open_jaw@100", None, shape)],
                                  order_check=None).faps == [3]


def test_error_duplicates(neutral):
    a, b = moved_copy(neutral, 6), moved_copy(neutral, 7)
    with pytest.raises(ValueError, match="targets 'jaw1' and 'jaw2' are both open_jaw at value 1024"):
        fat_from_morph_targets(neutral, [MorphTarget("open_jaw@1024", None, a, name="jaw1"),
                                         MorphTarget("3@1024", None, b, name="jaw2")])
    with pytest.raises(ValueError, match="targets 'viseme:PP' and 'viseme:1' are both viseme:PP$"):
        fat_from_morph_targets(neutral, [MorphTarget("viseme:PP", None, a),
                                         MorphTarget("viseme:1", None, b, name="viseme:1")])


def test_error_bad_arrays(neutral):
    shape = moved_copy(neutral, 8)
    shape["Skin"] = shape["Skin"].copy()
    shape["Skin"][0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        fat_from_morph_targets(neutral, [MorphTarget("open_jaw@10", None, shape)])
    shape["Skin"] = np.zeros((36, 2))
    with pytest.raises(ValueError, match=r"\[n, 3\] array"):
        fat_from_morph_targets(neutral, [MorphTarget("open_jaw@10", None, shape)])
