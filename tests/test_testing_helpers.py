"""mpeg4fba.testing (FAP compliance, golden playback files) and its pytest plugin."""
import os

import numpy as np
import pytest

from mpeg4fba.fba import FAPU, FapStream, FeaturePointSet
from mpeg4fba.fba.face import FaceMesh, FaceModel, FaceTransform
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform
from mpeg4fba.testing import UPDATE_ENV, assert_fap_compliant, assert_playback_matches

pytest_plugins = ["pytester"]

# The FAPU of these points: IRISD0 1, ES0 6, ENS0 3.5, MNS0 1.5, MW0 5.
POINTS = {"3.1": (3, 5, 0.2), "3.3": (3, 4, 0.2), "3.5": (3, 4.5, 0), "3.6": (-3, 4.5, 0),
          "9.15": (0, 1, 1), "2.2": (0, -0.5, 1), "2.1": (0, -3, 0.9), "8.3": (2.5, -0.5, 0.8),
          "8.4": (-2.5, -0.5, 0.8), "4.1": (1, 6, 0.5)}
SKIN_POINTS = ["2.1", "2.2", "8.3", "8.4", "3.1", "3.3", "9.15", "4.1"]


def small_face(jaw=1.0, eyelid=1.0, yaw=1.0, thrust=1.0, lip_axis=(0, -1, 0)) -> FaceModel:
    """A face whose FAT follows the FAPU: each FAP moves its feature point by value x
    unit (times the factor given, to make wrong ones), its neighbour by half of that."""
    fapu = FAPU.from_feature_points(POINTS)
    fp = np.array([POINTS[k] for k in SKIN_POINTS], float)
    verts = np.vstack([fp, fp + [0.3, 0, 0]])              # a neighbour right of each point
    n = len(SKIN_POINTS)
    tris = [[i, i + n, (i + 1) % n] for i in range(n)]
    skin = FaceMesh("Skin", verts, tris, parent="Head")
    # The eyeball hangs under LeftEye at the pupil minus 1 in z: its front vertex is 3.5.
    ball = FaceMesh("LeftEyeball", [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0]],
                    [[0, 2, 3], [1, 2, 3]], parent="LeftEye")
    head = FaceTransform("Head")
    eye = FaceTransform("LeftEye", parent="Head", translation=(3, 4.5, -1))
    at = {k: i for i, k in enumerate(SKIN_POINTS)}

    def moves(fap, point, unit, borders, factor=1.0, axis=None):
        axis = np.asarray(axis if axis is not None else _axis(fap), float)
        k = len(borders) - 1
        d = np.array([[factor * unit * axis] * k, [0.5 * unit * axis] * k])   # [2, k, 3]
        return FaceDefTable(fap, [FaceDefMesh("Skin", borders, [at[point], at[point] + n], d)])

    tables = [
        moves(3, "2.1", fapu.MNS, [0, 1024, 4320], jaw),                  # open_jaw
        moves(4, "2.2", fapu.MNS, [-1200, 0, 600, 1200], axis=lip_axis),  # lower_t_midlip
        moves(53, "8.3", fapu.MW, [-1200, 0, 1200]),                      # stretch_l_cornerlip_o
        moves(19, "3.1", fapu.IRISD, [-1080, 0, 1080], eyelid),          # close_t_l_eyelid
        moves(31, "4.1", fapu.ENS, [-1800, 0, 900, 1800]),                # raise_l_i_eyebrow
        FaceDefTable(23, transforms=[FaceDefTransform("LeftEye", "rotation",
                                                      rotation=(0, 1, 0, yaw * 1e-5))]),
        FaceDefTable(27, transforms=[FaceDefTransform("LeftEye", "translation",
                                                      translation=(0, 0, thrust * fapu.ES))]),
        FaceDefTable(48, transforms=[FaceDefTransform("Head", "rotation", rotation=(1, 0, 0, 1e-5))]),
    ]
    return FaceModel([skin, ball], [head, eye], points=FeaturePointSet(POINTS), fapu=fapu,
                     fat=FAT(tables), name="small")


def _axis(fap):
    from mpeg4fba.fba import FAP
    return FAP[fap].axis


def stream(frames=40) -> FapStream:
    t = np.linspace(0, 1, frames)
    return FapStream.from_values({
        "open_jaw": 2000 * t, "lower_t_midlip": 1000 * np.sin(6 * t),
        "stretch_l_cornerlip_o": -800 * t, "close_t_l_eyelid": 900 * np.sin(3 * t),
        "raise_l_i_eyebrow": 1500 * np.cos(4 * t), "yaw_l_eyeball": 50000 * np.sin(5 * t),
        "thrust_l_eyeball": 400 * t, "head_pitch": -30000 * t,
        "raise_b_midlip": 100 * t,            # no table: skipped
        "dilate_l_pupil": 50 * t})            # no table either


# -- assert_fap_compliant -----------------------------------------------------------------
def test_a_face_true_to_its_fapu_is_compliant():
    report = assert_fap_compliant(small_face(), stream())
    assert report.checked == [3, 4, 19, 23, 27, 31, 48, 53]
    assert report.skipped == {5: "no table in the FAT", 29: "no table in the FAT"}
    assert max(report.worst.values()) < 1e-9
    assert "checked 3 open_jaw" in repr(report)


def test_a_jaw_ten_percent_too_wide_fails_naming_the_fap():
    with pytest.raises(AssertionError) as e:
        assert_fap_compliant(small_face(jaw=1.1), stream())
    msg = str(e.value)
    assert "1 FAP of 8 checked is not compliant" in msg
    assert "FAP 3 open_jaw: feature point 2.1 (Skin vertex 0)" in msg
    assert "error 10.0%" in msg and "expected [0, -" in msg
    assert "FAP 19" not in msg and "skipped: 5 raise_b_midlip" in msg


def test_worst_offenders_come_first_and_tolerance_applies():
    bad = small_face(jaw=1.1, eyelid=0.7, yaw=1.03)
    with pytest.raises(AssertionError) as e:
        assert_fap_compliant(bad, stream())
    lines = str(e.value).splitlines()
    assert lines[0].startswith("2 FAPs of 8")                    # yaw 3% is within 5%
    assert lines[1].startswith("  FAP 19 close_t_l_eyelid") and "error 30.0%" in lines[1]
    assert lines[2].startswith("  FAP 3 open_jaw")
    with pytest.raises(AssertionError, match="FAP 23 yaw_l_eyeball: Transform LeftEye"):
        assert_fap_compliant(bad, stream(), tolerance=0.01, faps=["yaw_l_eyeball"])
    report = assert_fap_compliant(bad, stream(), tolerance=0.35, faps=[3, 19, 23])
    assert report.checked == [3, 19, 23] and report.worst[19] == pytest.approx(0.3)


def test_motion_off_the_axis_and_a_wrong_eyeball_translation_fail():
    with pytest.raises(AssertionError, match="FAP 4 lower_t_midlip"):
        assert_fap_compliant(small_face(lip_axis=(0, 1, 0)), stream())   # up instead of down
    with pytest.raises(AssertionError, match=r"FAP 27 thrust_l_eyeball: feature point 3.5 "
                                             r"\(LeftEyeball vertex 0\)"):
        assert_fap_compliant(small_face(thrust=0.5), stream())


def test_only_the_fap_itself_counts():
    # Head pitch turns the whole skin, yet open_jaw is judged on its own displacement.
    s = FapStream.from_values({"open_jaw": [0, 500, 1000], "head_pitch": [0, 80000, 150000]})
    assert assert_fap_compliant(small_face(), s).checked == [3, 48]


def test_nothing_to_check_is_an_error():
    s = FapStream.from_values({"raise_b_midlip": [0, 10]})
    with pytest.raises(AssertionError, match="no FAP could be checked.*5 raise_b_midlip"):
        assert_fap_compliant(small_face(), s)


# -- assert_playback_matches -----------------------------------------------------------------
def test_golden_file_written_then_matched_then_a_change_is_located(tmp_path):
    golden = tmp_path / "golden" / "small.npz"
    face, s = small_face(), stream()
    with pytest.raises(AssertionError, match="does not exist.*update=True"):
        assert_playback_matches(face, s, golden)
    assert_playback_matches(face, s, golden, update=True)
    assert sorted(p.name for p in golden.parent.iterdir()) == ["small.npz"]   # no temporaries
    with np.load(golden) as z:
        assert z["mesh/Skin"].shape == (40, 16, 3) and "transform/LeftEye/rotation" in z.files
    assert_playback_matches(face, s, golden)
    assert_playback_matches(small_face(jaw=1 + 1e-9), s, golden)               # within atol
    with pytest.raises(AssertionError) as e:
        assert_playback_matches(small_face(jaw=1.01), s, golden)
    msg = str(e.value)
    assert "mesh 'Skin': max difference" in msg
    assert "frame 39, vertex 0 (y)" in msg                 # the jaw point, widest open at the end
    assert "LeftEye" not in msg
    with pytest.raises(AssertionError, match=r"transform 'LeftEye' rotation: .* at frame \d+"):
        assert_playback_matches(small_face(yaw=1.5), s, golden)
    with pytest.raises(AssertionError, match="shape"):
        assert_playback_matches(face, s[:10], golden)


def test_golden_update_through_the_environment(tmp_path, monkeypatch):
    golden = tmp_path / "g.npz"
    monkeypatch.setenv(UPDATE_ENV, "1")
    assert_playback_matches(small_face(jaw=1.2), stream(), golden)
    mtime = os.stat(golden).st_mtime_ns
    assert_playback_matches(small_face(jaw=1.2), stream(), golden)         # same: untouched
    assert os.stat(golden).st_mtime_ns == mtime
    monkeypatch.delenv(UPDATE_ENV)
    assert_playback_matches(small_face(jaw=1.2), stream(), golden)
    with pytest.raises(AssertionError, match="mesh 'Skin'"):
        assert_playback_matches(small_face(), stream(), golden)


def test_meshes_and_transforms_missing_from_the_golden_file(tmp_path):
    golden = tmp_path / "g.npz"
    face = small_face()
    assert_playback_matches(face, stream(), golden, update=True)
    del face.meshes["LeftEyeball"]
    face.invalidate()
    with pytest.raises(AssertionError, match="mesh 'LeftEyeball' is in the golden file but not"):
        assert_playback_matches(face, stream(), golden)


# -- the pytest plugin ----------------------------------------------------------------------------
PLUGGED = '''
import numpy as np
from mpeg4fba.fba import FAPU, FapStream, FeaturePointSet
from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable

FAPU_ = FAPU(IRISD0=1.0, ES0=6.0, ENS0=3.5, MNS0=1.5, MW0=5.0)
SCALE = {scale}

def face():
    jaw = FaceDefMesh("Skin", [0, 4320], [0], [[0, -SCALE * FAPU_.MNS, 0]])
    skin = FaceMesh("Skin", [[0, -3, 1], [1, -3, 1], [0, -2, 1]], [[0, 1, 2]])
    return FaceModel([skin], points=FeaturePointSet({{"2.1": (0, -3, 1)}}), fapu=FAPU_,
                     fat=FAT([FaceDefTable(3, [jaw])]))

STREAM = FapStream.from_values({{"open_jaw": [0, 300, 1000]}})

def test_compliance(fap_compliance):
    assert fap_compliance(face(), STREAM).checked == [3]

def test_golden(playback_golden):
    path = playback_golden(face(), STREAM)
    assert path.name == "test_golden.npz" and path.parent.name == "golden"
'''


def _run(pytester, scale, *args):
    pytester.makepyfile(test_face=PLUGGED.format(scale=scale))
    # -p no:mpeg4fba: don't also load the installed entry point (if any) under its name.
    return pytester.runpytest("-p", "no:mpeg4fba", "-p", "mpeg4fba.pytest_plugin", *args)


def test_plugin_fixtures(pytester, monkeypatch):
    monkeypatch.delenv(UPDATE_ENV, raising=False)
    result = _run(pytester, 1.0)
    result.assert_outcomes(passed=1, failed=1)             # no golden file yet
    result.stdout.fnmatch_lines(["*golden file*test_golden.npz does not exist*"])
    _run(pytester, 1.0, "--update-golden").assert_outcomes(passed=2)
    assert (pytester.path / "golden" / "test_golden.npz").is_file()
    _run(pytester, 1.0).assert_outcomes(passed=2)
    result = _run(pytester, 1.1)                           # the jaw 10% too wide: both fail
    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(["*FAP 3 open_jaw: feature point 2.1*",
                                 "*mesh 'Skin': max difference*frame 2, vertex 0 (y)*"])


def test_plugin_registers_the_option(pytester):
    result = pytester.runpytest("-p", "no:mpeg4fba", "-p", "mpeg4fba.pytest_plugin", "--help")
    result.stdout.fnmatch_lines(["*--update-golden*"])
