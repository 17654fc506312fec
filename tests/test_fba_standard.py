"""The standard as typed objects: FAP records, feature points, visemes, expressions, FAPU."""
import warnings

import numpy as np
import pytest

import mpeg4fba as m
from mpeg4fba.fba import (EXPRESSIONS, FAP, FAPU, FEATURE_POINTS, LOW_LEVEL, VISEMES,
                          FAPUWarning, FeaturePointError, FeaturePointSet)


# -- FAP records -------------------------------------------------------------------------

def test_all_68_faps_in_number_order_with_units():
    assert [r.number for r in FAP] == list(range(1, 69))
    assert len(FAP.low_level) == 66 and LOW_LEVEL == tuple(range(3, 69))
    assert {r.fapu for r in FAP.low_level} == {"MNS", "MW", "ES", "ENS", "IRISD", "AU"}
    assert FAP[1].high_level and FAP[1].fapu is None and FAP[2].name == "expression"


def test_top_level_api_names():
    assert m.FAP[3].name == "open_jaw" and m.FAP["open_jaw"] is m.FAP[3]
    assert m.FAPU is FAPU


@pytest.mark.parametrize("number, name, fapu, uni", [
    (3, "open_jaw", "MNS", True), (14, "thrust_jaw", "MNS", True),
    (41, "lift_l_cheek", "ENS", True), (42, "lift_r_cheek", "ENS", True),
    (47, "tongue_roll", "AU", True), (19, "close_t_l_eyelid", "IRISD", False),
    (23, "yaw_l_eyeball", "AU", False), (37, "squeeze_l_eyebrow", "ES", False),
    (48, "head_pitch", "AU", False), (68, "pull_r_ear", "ENS", False)])
def test_fap_facts(number, name, fapu, uni):
    r = FAP[number]
    assert (r.name, r.fapu, r.unidirectional) == (name, fapu, uni)
    assert FAP[name] is r


def test_exactly_the_five_unidirectional_faps():
    assert [r.number for r in FAP if r.unidirectional] == [3, 14, 41, 42, 47]


def test_directions_follow_the_face_frame():
    # x = the face's left, y = up, z = forward
    assert FAP["open_jaw"].axis == (0, -1, 0)
    assert FAP["stretch_l_cornerlip"].axis == (1, 0, 0)
    assert FAP["stretch_r_cornerlip"].axis == (-1, 0, 0)
    assert FAP["thrust_jaw"].axis == (0, 0, 1)
    assert FAP["squeeze_l_eyebrow"].axis == (-1, 0, 0)   # squeeze_l moves right
    assert FAP["head_yaw"].motion == "rotation" and FAP["head_yaw"].axis == (0, 1, 0)
    assert FAP["head_pitch"].axis == (1, 0, 0) and FAP["head_roll"].axis == (0, 0, 1)
    assert FAP["dilate_l_pupil"].motion == "scale"
    for r in FAP.low_level:
        if r.motion == "translation":
            assert np.isclose(np.linalg.norm(r.axis), 1.0)


def test_feature_points_of_faps():
    assert FAP[3].feature_point == "2.1"
    assert FAP["tongue_roll"].feature_points == ("6.3", "6.4")
    assert FAP["yaw_l_eyeball"].feature_point == "3.5"
    assert FAP["head_roll"].feature_point == "7.1"
    for r in FAP.low_level:
        assert r.feature_points, r
        for fp in r.feature_points:
            assert fp in FEATURE_POINTS


def test_the_bifs_and_visual_namings():
    # stretch_l_cornerlip is FAP 6 in the Visual naming and FAP 53 in the BIFS naming
    assert FAP["stretch_l_cornerlip"].number == 6
    assert FAP.bifs("stretch_l_cornerlip").number == 53
    assert FAP.bifs("stretch_l_corner").number == 6
    assert FAP["stretch_l_corner"].number == 6          # unambiguous BIFS names work too
    assert FAP["lower_b_lip_lm"].number == 10 and FAP["raise_b_lip_lm"].number == 10
    assert FAP[53].bifs_name == "stretch_l_cornerlip" and FAP[53].name == "stretch_l_cornerlip_o"
    with pytest.raises(KeyError, match="did you mean open_jaw"):
        FAP["open_jaws"]
    with pytest.raises(KeyError):
        FAP[69]


def test_ranges_are_dequantised_iframe_bounds():
    assert FAP["open_jaw"].range == (0, 4320)              # +1080 x step 4
    assert FAP["lower_t_midlip"].range == (-1200, 1200)    # +-600 x 2
    lo, hi = FAP["yaw_l_eyeball"].range
    assert np.isclose(hi * 1e-5, 1.536)                   # about 88 degrees
    assert FAP[1].range is None


# -- feature points, visemes, expressions -----------------------------------------------

def test_84_feature_points_in_group_order():
    ids = [fp.id for fp in FEATURE_POINTS]
    assert len(ids) == 84
    assert ids[0] == "2.1" and ids[-1] == "11.6"
    groups = [fp.group for fp in FEATURE_POINTS]
    assert groups == sorted(groups)
    sizes = [groups.count(g) for g in range(2, 12)]
    assert sizes == [14, 14, 6, 4, 4, 1, 10, 15, 10, 6]    # visage's group sizes
    assert FEATURE_POINTS["2.10"].index == 10 and FEATURE_POINTS["2.1"].index == 1
    assert FEATURE_POINTS["2.1"].faps == (3, 14, 15)
    assert FEATURE_POINTS["8.3"].defines_fapu == ("MW0",)


def test_visemes_and_expressions():
    assert len(VISEMES) == 15 and len(EXPRESSIONS) == 7
    assert VISEMES[1].phonemes == ("p", "b", "m") and VISEMES["aa"].number == 10
    assert EXPRESSIONS["surprise"].number == 6 and EXPRESSIONS[0].name == "neutral"


def test_feature_point_set():
    pts = FeaturePointSet({"9.15": (0, 1, 1), (3, 5): (3, 4.5, 0)}, {"2.1": ("Skin", 7)})
    assert list(pts) == ["3.5", "9.15"] and pts.ids == ["2.1", "3.5", "9.15"]
    assert pts.positions.shape == (2, 3)
    with pytest.raises(KeyError, match="vertex 7 of Skin"):
        pts["2.1"]
    resolved = pts.resolve({"Skin": np.arange(30.0).reshape(10, 3)})
    assert resolved["2.1"].tolist() == [21.0, 22.0, 23.0]
    with pytest.raises(FeaturePointError) as e:
        pts.require(["2.1", "3.5", "8.3"], "cloning")
    assert e.value.ids == ["2.1", "8.3"] and "cloning" in str(e.value)
    with pytest.raises(FeaturePointError, match="not a feature point"):
        FeaturePointSet({"12.1": (0, 0, 0)})
    with pytest.raises(FeaturePointError, match="out of range"):
        pts.resolve({"Skin": np.zeros((3, 3))})


# -- FAPU ---------------------------------------------------------------------------------

def face_points(**moves):
    pts = {"3.1": (3, 5, 0), "3.3": (3, 4, 0), "3.2": (-3, 5, 0), "3.4": (-3, 4, 0),
           "3.5": (3, 4.5, 0), "3.6": (-3, 4.5, 0), "9.15": (0, 1, 1), "2.2": (0, -0.5, 1),
           "8.3": (2.5, -0.5, 0.8), "8.4": (-2.5, -0.5, 0.8)}
    pts.update(moves)
    return pts


def test_fapu_from_feature_points():
    u = FAPU.from_feature_points(face_points())
    assert (u.IRISD0, u.ES0, u.ENS0, u.MNS0, u.MW0) == (1.0, 6.0, 3.5, 1.5, 5.0)
    assert u.MNS == 1.5 / 1024 and u["AU"] == 1e-5 and u.unit("head_yaw") == 1e-5
    assert u.unit(3) == u.MNS and u.unit(1) == 0.0
    assert u.units().shape == (68,)
    # a FeaturePointSet works as well as a dict
    assert FAPU.from_feature_points(FeaturePointSet(face_points())) == u


def test_fapu_names_missing_points():
    pts = face_points()
    for k in ("8.4", "9.15", "3.1", "3.3", "3.2", "3.4"):
        del pts[k]
    with pytest.raises(ValueError) as e:
        FAPU.from_feature_points(pts)
    assert "3.1, 3.3, 9.15, 8.4" in str(e.value)


def test_one_eye_is_enough_for_irisd():
    pts = face_points()
    del pts["3.1"], pts["3.3"]
    assert FAPU.from_feature_points(pts).IRISD0 == 1.0


def test_fapu_warns_on_swapped_sides_and_implausible_values():
    with pytest.warns(FAPUWarning, match="ES0 = -6 is not positive; .*swapped"):
        FAPU.from_feature_points(face_points(**{"3.5": (-3, 4.5, 0), "3.6": (3, 4.5, 0)}))
    with pytest.warns(FAPUWarning, match="MW0 = 50 is 8.33 times ES0"):
        FAPU.from_feature_points(face_points(**{"8.3": (25, -0.5, 0.8), "8.4": (-25, -0.5, 0.8)}))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        FAPU.from_feature_points(face_points())       # a plausible face: no warning


def test_closed_eyes_give_a_fapu_the_cloner_refuses_with_the_reason():
    # the lids' points of a head scanned with its eyes shut: IRISD0 is not positive, and
    # both the FAPU's warning and the cloner's refusal say the eyes may be closed
    import warnings

    from mpeg4fba.cloning.normalise import region_factors
    from mpeg4fba.fba.fapu import FAPU
    from mpeg4fba.fba.featurepoints import FeaturePointSet
    pts = {"3.1": (3, 4.0, 0), "3.3": (3, 4.05, 0), "3.5": (3, 4.5, 0), "3.6": (-3, 4.5, 0),
           "9.15": (0, 1, 1), "2.2": (0, -0.5, 1), "8.3": (2.5, -0.5, 0.8), "8.4": (-2.5, -0.5, 0.8)}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fapu = FAPU.from_feature_points(pts)
    assert any("eyes closed" in str(w.message) for w in caught)
    with pytest.raises(ValueError, match="IRISD0 = -0.05 is not positive.*eyes closed"):
        region_factors(FeaturePointSet(pts), fapu)
    # lids all but touching: a warning that asks the same
    pts["3.3"] = (3, 3.95, 0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        FAPU.from_feature_points(pts)
    assert any("0.01 times ES0" in str(w.message) and "eyes closed" in str(w.message) for w in caught)
