"""FapFrame and FapStream: frames as numpy arrays, the hold rule, slicing, resampling."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpeg4fba.fba import FAP, FapRangeWarning, FapStream


def test_from_values_and_frames():
    s = FapStream.from_values({"open_jaw": [0, 100, 200], "head_yaw": 5000}, fps=25)
    assert len(s) == 3 and s.fps == 25 and s.animated == [3, 49]
    f = s[2]
    assert f["open_jaw"] == 200.0 and f[49] == 5000.0 and f["lower_t_midlip"] is None
    assert f.faps == [3, 49] and s[-1].number == 2
    with pytest.raises(IndexError):
        s[3]


def test_viseme_and_expression_fields():
    vis = np.array([[1, 10, 63, 0], [1, 10, 32, 0]])
    exp = np.array([[1, 63, 0, 0, 0, 0], [1, 40, 6, 20, 0, 0]])
    s = FapStream.from_values({}, fps=10, n_frames=2, visemes=vis, expressions=exp)
    assert s.animated == [1, 2]
    assert s[1][1] == {"viseme_select1": 1, "viseme_select2": 10, "viseme_blend": 32, "viseme_def": 0}
    assert s[1]["expression"]["expression_select2"] == 6


def test_hold_rule_for_faps_a_frame_leaves_out():
    values = np.zeros((4, 68))
    mask = np.zeros((4, 68), bool)
    values[1, 2], mask[1, 2] = 300, True       # open_jaw given at frame 1 only
    values[3, 2], mask[3, 2] = 100, True
    s = FapStream(values, mask, 25)
    held, given, _, _ = s.held()
    assert held[:, 2].tolist() == [0, 300, 300, 100]
    assert given[:, 2].tolist() == [False, True, True, True]


def test_slicing_and_concatenation():
    s = FapStream.from_values({3: np.arange(10.0)}, fps=25)
    part = s[2:5]
    assert len(part) == 3 and part[0][3] == 2.0
    both = part + s[7:]
    assert len(both) == 6 and [f[3] for f in both] == [2, 3, 4, 7, 8, 9]
    with pytest.raises(ValueError, match="different frame rates"):
        s + FapStream.from_values({3: [1.0]}, fps=30)
    with pytest.raises(ValueError, match="step 1"):
        s[::2]


def test_resampling():
    s = FapStream.from_values({3: [0, 100, 200, 300]}, fps=10)       # 0.4 s
    up = s.resample(20)
    assert len(up) == 8 and up.fps == 20
    assert [f[3] for f in up] == [0, 50, 100, 150, 200, 250, 300, 300]
    down = s.resample(5)
    assert len(down) == 2 and [f[3] for f in down] == [0, 200]
    assert up.duration == s.duration == 0.4


def test_resampling_keeps_selections_whole():
    vis = np.array([[1, 0, 63, 0], [4, 0, 63, 0]])
    s = FapStream.from_values({}, fps=2, n_frames=2, visemes=vis)
    up = s.resample(8)
    assert [f[1]["viseme_select1"] for f in up] == [1, 1, 1, 1, 4, 4, 4, 4]


def test_out_of_range_values_are_named_by_fap_and_frame():
    s = FapStream.from_values({"open_jaw": [10, -5, 5000], "head_yaw": 0}, fps=25)
    assert s.out_of_range() == [(1, 3, -5.0), (2, 3, 5000.0)]
    with pytest.warns(FapRangeWarning) as got:
        assert s.warn_out_of_range("x.fap") == 2
    messages = [str(w.message) for w in got]
    assert messages == ["x.fap: frame 1: FAP 3 open_jaw = -5.0 is outside 0 to 4320",
                        "x.fap: frame 2: FAP 3 open_jaw = 5000.0 is outside 0 to 4320"]
    bad = FapStream.from_values({}, fps=25, n_frames=1, visemes=[20, 0, 63, 0])
    assert bad.out_of_range() == [(0, 1, [20, 0, 63, 0])]


def test_bad_construction_is_refused():
    with pytest.raises(ValueError, match="fps"):
        FapStream.from_values({3: [1.0]}, fps=0)
    with pytest.raises(ValueError, match="finite"):
        FapStream.from_values({3: [np.nan]})
    with pytest.raises(ValueError, match="shape"):
        FapStream(np.zeros((2, 68)), np.zeros((3, 68)), 25)
    with pytest.raises(KeyError, match="no FAP"):
        FapStream.from_values({"jaw_open": [1.0]})


def test_summary():
    s = FapStream.from_values({"open_jaw": [0, 100, 50]}, fps=25, name="talk")
    info = s.summary()
    assert info["frames"] == 3 and info["duration"] == 0.12
    assert info["faps"][3] == {"name": "open_jaw", "frames": 3, "min": 0.0, "max": 100.0}


@settings(max_examples=60, deadline=None, derandomize=True)
@given(n=st.integers(1, 40), fps=st.sampled_from([10, 24, 25, 30, 60]),
       new_fps=st.sampled_from([5, 12.5, 25, 50, 100]), seed=st.integers(0, 2**31))
def test_resampling_properties(n, fps, new_fps, seed):
    rng = np.random.default_rng(seed)
    values = rng.integers(-500, 500, size=(n, 68)).astype(float)
    mask = rng.random((n, 68)) < 0.6
    s = FapStream(values, mask, fps)
    r = s.resample(new_fps)
    held, given, _, _ = s.held()
    assert abs(len(r) / new_fps - len(s) / fps) <= 1 / new_fps + 1e-9
    # values stay within the bounds of the held values they come from
    lo = np.where(given, held, np.inf).min(axis=0)
    hi = np.where(given, held, -np.inf).max(axis=0)
    v = np.where(r.mask, r.values, np.nan)
    ok = np.isnan(v) | ((v >= lo - 1e-9) & (v <= hi + 1e-9))
    assert ok.all()
    same = s.resample(fps)
    assert np.allclose(np.where(same.mask, same.values, 0), np.where(given, held, 0))
