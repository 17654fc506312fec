"""Tests of the ASCII ``.fap`` reader and writer (``mpeg4fba.formats.fap``).

Real files: the eight Xface streams in ``<shared>/data/xface/*.fap`` (skipped when the
shared folder is absent).  Our own cases: ``spec_fixtures/fap/`` (see its README).
"""
from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mpeg4fba
from mpeg4fba.cli import main
from mpeg4fba.fba.stream import FapRangeWarning, FapStream
from mpeg4fba._numbers import number_text
from mpeg4fba.formats.fap import (FapError, FapWarning, _decimals, dumps_fap, loads_fap, read_fap,
                                  write_fap)
from mpeg4fba.formats.fap_writer import _format_tokens

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "spec_fixtures" / "fap"
XFACE = {"anger.fap": 108, "beg.fap": 107, "disgust.fap": 107, "fear.fap": 107,
         "happy-for.fap": 107, "hate.fap": 107, "joy.fap": 108, "pride.fap": 107}


def mask_line(faps, columns: int = 68, extra=()) -> str:
    bits = ["0"] * columns
    for f in list(faps) + list(extra):
        bits[f - 1] = "1"
    return " ".join(bits)


def reference_parse(text: str) -> tuple:
    """A slow, obvious reader (68-column masks, no FAP 1/2) to check the fast one against."""
    rows = [line.split() for line in text.splitlines()[1:]
            if line.strip() and not line.lstrip().startswith("#")]
    masks = np.array([[int(x) for x in r[:68]] for r in rows[0::2]], dtype=bool)
    values = np.zeros(masks.shape)
    for i, r in enumerate(rows[1::2]):
        values[i, np.flatnonzero(masks[i])] = [float(x) for x in r[1:]]
    return masks, values


def quiet(fn, *args, **kw):
    """Call fn with warnings recorded; return (result, [warning messages])."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fn(*args, **kw)
    return result, caught


# -- the real Xface streams --------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(XFACE))
def test_xface_streams_read_and_round_trip(shared_dir, name, tmp_path):
    path = shared_dir / "data" / "xface" / name
    if not path.is_file():
        pytest.skip(f"../shared is absent: {path} does not exist")
    raw = path.read_bytes()
    assert b"\r\n" in raw and raw.count(b"\r\n") == raw.count(b"\n")       # CRLF file
    stream, caught = quiet(read_fap, path)
    assert not [w for w in caught if issubclass(w.category, FapWarning)]
    assert len(stream) == XFACE[name]
    assert stream.fps == 25 and stream.version == "2.1"
    assert stream.name == r"C:\Users\balci\Work\FACE\exml2fap\files\TempFile"
    masks, values = reference_parse(raw.decode("ascii"))
    assert np.array_equal(stream.mask, masks)
    assert np.array_equal(np.where(masks, stream.values, 0), values)
    assert not stream.mask[:, :2].any()                   # no visemes or expressions
    out = tmp_path / name
    write_fap(stream, out)
    again, _ = quiet(read_fap, out)
    assert again == stream and again.fps == 25 and len(again) == XFACE[name]
    assert b"\r" not in out.read_bytes()


# -- our fixtures --------------------------------------------------------------------------------
ERRORS = {
    "bad_mask_count.fap": (4, "67 mask entries (expected 68"),
    "bad_value_count.fap": (5, "3 numbers on the value line (expected 4 for this mask: the "
                               "frame number, 3 FAP values)"),
    "bad_token.fap": (5, "'1O' is not a number"),
    "truncated.fap": (4, "mask line without its value line"),
}


@pytest.mark.parametrize("name", sorted(ERRORS))
def test_bad_fixtures_raise_with_line(name):
    line, message = ERRORS[name]
    path = FIXTURES / name
    with pytest.raises(FapError) as info:
        read_fap(path)
    e = info.value
    assert e.line == line and message in e.message, str(e)
    assert e.path == str(path)
    assert str(e).startswith(f"{path}:{line}: ")
    assert isinstance(e, ValueError)


def test_minimal():
    s = read_fap(FIXTURES / "minimal_2_1.fap")
    assert (len(s), s.fps, s.version, s.name, s.animated) == (3, 25.0, "2.1", "minimal",
                                                              [3, 4, 48])
    assert s.values[:, [2, 3, 47]].tolist() == [[0, 0, 0], [120, -35, 2000], [240, -70, 4000]]


def test_viseme_expression():
    s = read_fap(FIXTURES / "viseme_expression.fap")
    assert s.animated == [1, 2, 3]
    assert s.visemes.tolist() == [[1, 10, 40, 0], [4, 14, 63, 1]]
    assert s.expressions.tolist() == [[3, 50, 0, 0, 0, 0], [6, 63, 1, 20, 1, 1]]
    assert s.values[:, 2].tolist() == [120, 300]
    assert s[1]["viseme"]["viseme_blend"] == 63
    assert loads_fap(dumps_fap(s)) == s


def test_greta_69_columns():
    path = FIXTURES / "greta_69_columns.fap"
    s, caught = quiet(read_fap, path)
    assert s.name == "AU Interpolation_1111.fap"
    assert s.animated == [19, 20, 21, 22]
    assert s.values[:, 18:22].tolist() == [[100, 100, -50, -50], [200, 200, -100, -100]]
    fap = [w for w in caught if issubclass(w.category, FapWarning)]
    assert len(fap) == 1 and f"{path}:4:" in str(fap[0].message)
    assert "dropped" in str(fap[0].message)


def test_crlf_tabs_comments():
    s = read_fap(FIXTURES / "crlf_tabs_comments.fap")
    assert (len(s), s.fps, s.name, s.animated) == (2, 10.0, "crlf_tabs", [3, 5])
    assert s.values[:, [2, 4]].tolist() == [[150, -20], [300, -40]]


def test_legacy_2_0():
    s = read_fap(FIXTURES / "legacy_2_0.fap")
    assert s.version == "2.0" and s.name == "eyes.fap" and s.fps == 2
    assert s.values[:, 47:50].tolist() == [[200, -400, 0], [2000, 4000, -20]]
    vreng = read_fap(FIXTURES / "legacy_2_0.fap", legacy_divisor=20)
    assert vreng.values[:, 47:50].tolist() == [[10, -20, 0], [100, 200, -1]]
    # The divisor applies to 2.0 only.
    assert read_fap(FIXTURES / "minimal_2_1.fap", legacy_divisor=20) == \
        read_fap(FIXTURES / "minimal_2_1.fap")
    with pytest.raises(ValueError):
        read_fap(FIXTURES / "legacy_2_0.fap", legacy_divisor=0)


def test_varying_masks():
    s = read_fap(FIXTURES / "varying_masks.fap")
    assert [f.faps for f in s] == [[3, 4], [3, 19, 20], [1, 4]]
    assert s.values[:, [2, 3, 18, 19]].tolist() == [[100, 10, 0, 0], [150, 0, 500, 500],
                                                    [0, -25, 0, 0]]
    assert s.visemes[2].tolist() == [10, 2, 32, 0]
    assert loads_fap(dumps_fap(s)) == s


def test_frame_count_mismatch_warns():
    path = FIXTURES / "frame_count_mismatch.fap"
    with pytest.warns(FapWarning, match=re.escape(f"{path}:1: the header says 5 frames but "
                                                  "the file has 3")):
        s = read_fap(path)
    assert len(s) == 3


def test_out_of_range_warns():
    path = FIXTURES / "out_of_range.fap"
    s, caught = quiet(read_fap, path)
    text = [str(w.message) for w in caught if issubclass(w.category, FapRangeWarning)]
    assert len(text) == 2
    assert "frame 1: FAP 3 open_jaw = -100.0" in text[0] and str(path) in text[0]
    assert "frame 1: FAP 14 thrust_jaw = 900.0" in text[1]
    assert s.values[1, 2] == -100                          # kept as read


def test_fixture_readme_lists_every_fixture():
    readme = (FIXTURES / "README.md").read_text()
    for path in FIXTURES.glob("*.fap"):
        assert f"`{path.name}`" in readme


# -- more reader cases ------------------------------------------------------------------------
def frames_text(header: str, *frames: tuple) -> str:
    """A .fap text from (mask line, value line) pairs."""
    return header + "\n" + "".join(f"{m}\n{v}\n" for m, v in frames)


def test_68_and_69_mask_columns_read_alike():
    f68 = frames_text("2.1 a 25 2", (mask_line([3]), "0 5"), (mask_line([3]), "1 6"))
    f69 = frames_text("2.1 a 25 2", (mask_line([3], 69), "0 5"), (mask_line([3], 69), "1 6"))
    s68, c68 = quiet(loads_fap, f68)
    s69, c69 = quiet(loads_fap, f69)
    assert s68 == s69 and not c68 and not c69
    # Mixed widths in one file, and the 69th column set (one extra value, dropped).
    mixed = frames_text("2.1 a 25 2", (mask_line([3]), "0 5"),
                        (mask_line([3], 69, extra=[69]), "1 6 99"))
    s, caught = quiet(loads_fap, mixed)
    assert s == s68 and len(caught) == 1 and str(caught[0].message).startswith("line 4: ")


@pytest.mark.parametrize("text, line, message", [
    ("", 1, "no header line"),
    ("# only a comment\n\n", 1, "no header line"),
    ("3.1 body 25 0\n", 1, "unsupported .fap version '3.1'"),
    ("# c\n2.2 x 25 0\n", 2, "unsupported .fap version '2.2'"),
    ("2.1 25\n", 1, "too few fields"),
    ("2.1 x fast 0\n", 1, "FPS 'fast' is not a number"),
    ("2.1 x 0 0\n", 1, "not a positive frame rate"),
    ("2.1 x 25 many\n", 1, "NFRAMES 'many' is not an integer"),
    (frames_text("2.1 x 25 1", (mask_line([3]).replace("1", "2"), "0 5")), 2,
     "mask entry '2' in column 3 is not 0 or 1"),
    (frames_text("2.1 x 25 1", (mask_line([3]).replace("1", "1.0"), "0 5")), 2,
     "mask entry '1.0' in column 3"),
    (frames_text("2.1 x 25 1", (mask_line([3]), "0.5 5")), 3,
     "frame number '0.5' is not an integer"),
    (frames_text("2.1 x 25 1", (mask_line([1]), "0 1 2 3.5 0")), 3,
     "FAP 1 (viseme) field '3.5' is not an integer"),
    (frames_text("2.1 x 25 1", (mask_line([3]), "0 nan")), 3, "'nan' is not a number"),
    (frames_text("2.1 x 25 1", (mask_line([3]), "0 1e400")), 3, "'1e400' is too large"),
    ("0 0 1 0\n0 5\n", 1, "unsupported .fap version '0' (expected 2.1 or 2.0; is the header "
                          "line missing?)"),
    (frames_text("2.1 x 25 1", (mask_line([1, 2, 3]), "0 1 2 3 0 5")), 3,
     "6 numbers on the value line (expected 12 for this mask: the frame number, "
     "4 for FAP 1, 6 for FAP 2, 1 FAP value)"),
    # The earliest problem in the file is the one reported.
    (frames_text("2.1 x 25 2", (mask_line([3]), "0 x"), (mask_line([3])[:-2], "1 5")), 3,
     "'x' is not a number"),
    (frames_text("2.1 x 25 2", (mask_line([3]), "0 5 6"), (mask_line([3]), "1 y")), 3,
     "3 numbers on the value line (expected 2"),
])
def test_reader_errors(text, line, message):
    with pytest.raises(FapError) as info:
        loads_fap(text, path="t.fap")
    assert info.value.line == line and message in info.value.message, str(info.value)
    assert str(info.value).startswith(f"t.fap:{line}: ")


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["minimal_2_1", "viseme_expression", "varying_masks", "greta_69_columns",
                        "crlf_tabs_comments"]),
       st.lists(st.tuples(st.floats(0, 1), st.sampled_from(list(b"0123456789 .-+eE\n\r\t#x")),
                          st.integers(0, 2)), min_size=1, max_size=4))
def test_damaged_files_raise_fap_error_or_read(name, edits):
    """Any damage gives a FapError (a ValueError with a line) or a stream, nothing else."""
    data = bytearray((FIXTURES / f"{name}.fap").read_bytes())
    for where, byte, op in edits:
        i = int(where * (len(data) - 1))
        if op == 0:
            del data[i]
        elif op == 1:
            data[i:i] = bytes([byte])
        else:
            data[i] = byte
    try:
        quiet(loads_fap, bytes(data))
    except FapError as e:
        assert e.line is not None and e.line >= 1


def test_empty_stream_and_header_forms():
    s = loads_fap("2.1 nothing 30 0\n")
    assert len(s) == 0 and s.fps == 30 and s.name == "nothing"
    s = loads_fap("2.1 25 0")                               # no name, no final newline
    assert s.name == "" and len(s) == 0
    s = loads_fap("2.1   a  spaced   name 25 0\r\n")
    assert s.name == "a  spaced   name"


def test_frames_renumbered_with_warning():
    text = frames_text("2.1 x 25 2", (mask_line([3]), "5 10"), (mask_line([3]), "6 20"))
    with pytest.warns(FapWarning, match=r"^line 3: frames are not numbered 0\.\.1"):
        s = loads_fap(text)
    assert [f.number for f in s] == [0, 1] and s.values[:, 2].tolist() == [10, 20]


def test_floats_big_integers_and_signs():
    text = frames_text("2.1 x 25 1", (mask_line([3, 4, 5, 6]),
                                      "0 1e3 -2.5 +7 99999999999999999999"))
    s, _ = quiet(loads_fap, text)
    assert s.values[0, 2:6].tolist() == [1000.0, -2.5, 7.0, 1e20]
    big = frames_text("2.1 x 25 1", (mask_line([3]), "0 -99999999999999999999"))
    assert quiet(loads_fap, big)[0].values[0, 2] == -1e20


def test_top_level_names():
    assert mpeg4fba.read_fap is read_fap and mpeg4fba.write_fap is write_fap
    assert "read_fap" in mpeg4fba.__all__ and "write_fap" in mpeg4fba.__all__


# -- writer -------------------------------------------------------------------------------------
def test_writer_standard_form(tmp_path):
    s = FapStream.from_values({"open_jaw": [0, 100.5, 200], "head_yaw": 5}, fps=25.0,
                              name="my face", visemes=[1, 2, 30, 0])
    text = dumps_fap(s)
    lines = text.split("\n")
    assert lines[0] == "2.1 my_face 25 3" and lines[-1] == ""
    assert "\r" not in text and "#" not in text
    for k in range(3):
        assert len(lines[1 + 2 * k].split()) == 68
    assert lines[2] == "0 1 2 30 0 0 5"
    assert lines[4] == "1 1 2 30 0 100.5 5"
    assert dumps_fap(FapStream.empty(12.5)) == "2.1 mpeg4fba 12.5 0\n"
    p = tmp_path / "w.fap"
    write_fap(s, p)
    assert p.read_text() == text and read_fap(p) == s
    assert [q.name for q in tmp_path.iterdir()] == ["w.fap"]     # no temporary left


# -- hypothesis: any stream survives dumps -> loads exactly ------------------------------------
@st.composite
def streams(draw) -> FapStream:
    n = draw(st.integers(0, 6))
    mask = np.array(draw(st.lists(st.lists(st.booleans(), min_size=68, max_size=68),
                                  min_size=n, max_size=n)), dtype=bool).reshape(n, 68)
    number = st.one_of(st.integers(-5000, 5000).map(float),
                       st.floats(allow_nan=False, allow_infinity=False, width=64),
                       st.floats(-1e4, 1e4).map(lambda x: round(x, 3)))
    values = np.array(draw(st.lists(number, min_size=68 * n, max_size=68 * n)),
                      dtype=np.float64).reshape(n, 68)
    values[:, :2] = 0        # FAPs 1 and 2 live in visemes/expressions, not in values
    field = st.integers(0, 63)
    visemes = np.array(draw(st.lists(field, min_size=4 * n, max_size=4 * n))).reshape(n, 4)
    expressions = np.array(draw(st.lists(field, min_size=6 * n, max_size=6 * n))).reshape(n, 6)
    fps = draw(st.one_of(st.sampled_from([25.0, 10.0, 29.97, 2.0]),
                         st.floats(0.01, 1000.0, allow_nan=False)))
    name = draw(st.text(max_size=12))
    return FapStream(values, mask, fps, visemes, expressions, name=name)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(streams())
def test_random_streams_round_trip_exactly(stream):
    text = dumps_fap(stream)
    back, caught = quiet(loads_fap, text)
    assert not [w for w in caught if issubclass(w.category, FapWarning)]
    assert back == stream
    assert back.fps == stream.fps and len(back) == len(stream)
    # Bit for bit, where transmitted (-0.0 is written 0).
    assert np.array_equal(np.where(stream.mask, stream.values, 0),
                          np.where(back.mask, back.values, 0))
    assert back.name == ("_".join(stream.name.split()) or "mpeg4fba")
    assert dumps_fap(back) == text


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(finite, finite.map(lambda x: round(x, 2)),
                          st.decimals(-10 ** 6, 10 ** 6, places=4).map(str)), max_size=40))
def test_decimal_fast_path_matches_float(items):
    """The point-free integer parse + one division gives float(token), or declines."""
    tokens = [t if isinstance(t, str) else repr(t) for t in items]
    tokens = [t for t in tokens if "e" not in t and "n" not in t]   # no exponents, inf, nan
    raw = np.frombuffer(" ".join(tokens).encode() + b"\n", np.uint8)
    got = _decimals(raw, len(tokens))
    if got is not None:
        assert [v.hex() for v in got.tolist()] == [float(t).hex() if float(t) != 0 else
                                                   abs(float(t)).hex() for t in tokens]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(finite, st.integers(-10 ** 15, 10 ** 15).map(float),
                          finite.map(lambda x: round(x, 3))), min_size=1, max_size=40))
def test_token_formatting_is_shortest_repr(xs):
    x = np.array(xs, dtype=np.float64)
    sep = np.full(len(x), 32, np.uint8)
    out, lengths = _format_tokens(x, sep)
    words = out.tobytes().decode().split(" ")[:-1]
    assert words == [number_text(v) for v in xs]
    assert lengths.tolist() == [len(w) + 1 for w in words]
    assert [float(w) for w in words] == xs


def test_decimal_values_round_trip_through_a_file():
    rng = np.random.default_rng(7)
    values = np.zeros((50, 68))
    scale = 10.0 ** rng.integers(0, 7, (50, 66))           # 0 to 6 decimals
    values[:, 2:] = np.round(rng.normal(0, 300, (50, 66)) * scale) / scale
    s = FapStream(values, np.ones((50, 68), bool) & (np.arange(68) >= 2), 25)
    back, _ = quiet(loads_fap, dumps_fap(s))
    assert back == s


# -- the info command ---------------------------------------------------------------------------
def test_info_on_a_fap_file():
    r = CliRunner().invoke(main, ["info", str(FIXTURES / "minimal_2_1.fap")])
    assert r.exit_code == 0, r.output
    out = r.stdout
    for text in ("frames: 3", "fps: 25", "duration: 0.12 s", "version: 2.1", "name: minimal",
                 "animated FAPs: 3 (3-4, 48)", "open_jaw", "lower_t_midlip", "head_pitch"):
        assert text in out, out
    row = next(line for line in out.splitlines() if "head_pitch" in line).split()
    assert row == ["48", "head_pitch", "3", "0", "4000"]


def test_info_on_a_fap_file_json_and_warnings():
    path = FIXTURES / "out_of_range.fap"
    r = CliRunner().invoke(main, ["info", "--json", str(path)])
    assert r.exit_code == 0, r.output
    facts = json.loads(r.stdout)
    assert facts["frames"] == 2 and facts["faps"]["14"]["max"] == 900
    assert r.stderr.count("mpeg4fba: warning:") == 2 and "thrust_jaw" in r.stderr


def test_info_on_an_upper_case_fap_and_errors(tmp_path):
    p = tmp_path / "JOY.FAP"
    p.write_bytes((FIXTURES / "varying_masks.fap").read_bytes())
    r = CliRunner().invoke(main, ["info", str(p)])
    assert r.exit_code == 0 and "frames: 3" in r.stdout
    r = CliRunner().invoke(main, ["info", str(FIXTURES / "bad_token.fap")])
    assert r.exit_code == 1
    assert r.stderr.strip() == (f"mpeg4fba: error: {FIXTURES / 'bad_token.fap'}:5: '1O' is "
                                "not a number (token 3 of the value line)")
