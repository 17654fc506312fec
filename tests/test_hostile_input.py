"""Each class of hostile or damaged input issue 21 lists ends in the reader's own
located error, naming the file and where (line and column, or the JSON path) —
never a bare ValueError, OverflowError, StopIteration, LookupError or RecursionError,
and never a value silently wrapped.  (The fuzzing harness, tests/fuzz/, keeps the
general property; these are the classes one by one.)"""
from __future__ import annotations

import importlib.util
import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from _guards import alarm
from fuzz import harness

from mpeg4fba import vrml
from mpeg4fba._atomic import PARTIAL, atomic_write, remove_stale
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.fap import FapError, loads_fap
from mpeg4fba.formats.face_files import read_face
from mpeg4fba.formats.fpjson import loads_feature_points_json
from mpeg4fba.formats.morph_targets import parse_obj, read_mapping
from mpeg4fba.formats.xface_fdp import loads_xface_fdp
from mpeg4fba.vrml.errors import LocatedError

needs_gltf = pytest.mark.skipif(importlib.util.find_spec("pygltflib") is None,
                                reason="reading glTF needs pygltflib")

TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"


def _refused(call, *words, error=LocatedError):
    with alarm(30, "reading"), pytest.raises(error) as info:
        call()
    for w in words:
        assert w in str(info.value), str(info.value)
    return info.value


# -- integers beyond 64 bits -------------------------------------------------------------------

@pytest.mark.parametrize("number", ["9" * 30, "-" + "9" * 25, "18446744073709551616"])
def test_obj_face_index_beyond_64_bits(number):
    e = _refused(lambda: parse_obj(TRI + f"f 1 2 {number}\n", "h.obj"), "h.obj:4",
                 "whole numbers")
    assert e.line == 4


def test_vrml_hex_beyond_64_bits():
    _refused(lambda: vrml.loads("#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { "
                                "coordIndex [ 0x" + "f" * 30 + " ] } }", path="h.wrl"),
             "h.wrl:2")


@pytest.mark.parametrize("where, number", [("index", "9" * 30), ("indices", "9" * 30),
                                           ("index", "9" * 5000)])
def test_fdp_index_beyond_32_bits(where, number):
    text = harness._fdp_seed().decode()
    if where == "index":
        text = text.replace('index="10"', f'index="{number}"', 1)
    else:
        text = text.replace("<indices>10 ", f"<indices>{number} ", 1)
    e = _refused(lambda: loads_xface_fdp(text, "a.fdp"), "a.fdp:")
    assert e.line is not None


@pytest.mark.parametrize("digits", [40, 500, 5000])
def test_json_integer_of_hundreds_of_digits(digits):
    text = ('{"format": "mpeg4fba-feature-points", "version": 1, "points": {"3.5": '
            '{"vertex": ' + "7" * digits + "}}}")
    e = _refused(lambda: loads_feature_points_json(text, "p.json"), "p.json:1:",
                 f"{digits}-digit integer")
    assert e.column == text.index("777") + 1


def test_json_vertex_beyond_32_bits():
    text = ('{"format": "mpeg4fba-feature-points", "version": 1, "points": {"3.5": '
            '{"vertex": 99999999999}}}')
    _refused(lambda: loads_feature_points_json(text, "p.json"), 'points["3.5"].vertex')


# -- deeply nested JSON ------------------------------------------------------------------------

@pytest.mark.parametrize("opening, closing", [("[", "]"), ('{"a": ', "}")])
def test_deeply_nested_json(tmp_path, opening, closing):
    deep = opening * 100_000 + "1" + closing * 100_000
    _refused(lambda: loads_feature_points_json(deep, "p.json"), "p.json", "nested")
    (tmp_path / "m.json").write_text(deep)
    _refused(lambda: read_mapping(tmp_path / "m.json"), "m.json")


# -- OBJ: zero indices in other spellings, control characters ------------------------------------

@pytest.mark.parametrize("zero", ["00", "+0", "-0", "000/1/1"])
def test_obj_zero_index_in_any_spelling(zero):
    e = _refused(lambda: parse_obj(TRI + f"f 1 2 {zero}\n", "h.obj"), "vertex index 0")
    assert e.line == 4


@pytest.mark.parametrize("control", ["\x0b", "\x0c", "\x1c", "\x85"])
def test_obj_control_character_in_a_v_line(control):
    e = _refused(lambda: parse_obj(f"v 0 0 0\nv 1{control}0 0\nv 0 1 0\nf 1 2 3\n", "h.obj"),
                 "x, y and z")
    assert e.line == 2


@pytest.mark.parametrize("value", ["1e309", "nan", "-inf"])
def test_obj_non_finite_coordinate(value):
    e = _refused(lambda: parse_obj(f"v 0 0 0\nv 1 {value} 0\nv 0 1 0\nf 1 2 3\n", "h.obj"),
                 "finite")
    assert e.line == 2


# -- Xface .fdp with an encoding nobody can read ---------------------------------------------------

@pytest.mark.parametrize("encoding", ["klingon", "utf-32", "rot13", "uu"])
def test_fdp_unknown_xml_encoding(encoding):
    text = harness._fdp_seed().replace(b'encoding="UTF-8"', f'encoding="{encoding}"'.encode())
    e = _refused(lambda: loads_xface_fdp(text, "a.fdp"), "a.fdp:1", "encoding")
    assert isinstance(e, FormatError)


# -- glTF / GLB with members missing or pointing past their buffers -----------------------------------

def _gltf(tmp_path, edit, glb=False):
    doc, blob = harness._gltf_doc(glb)
    edit(doc)
    if glb:
        text = json.dumps(doc).encode()
        text += b" " * (-len(text) % 4)
        blob += bytes(-len(blob) % 4)
        body = struct.pack("<I4s", len(text), b"JSON") + text + \
            struct.pack("<I4s", len(blob), b"BIN\0") + blob
        path = tmp_path / "f.glb"
        path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    else:
        path = tmp_path / "f.gltf"
        path.write_text(json.dumps(doc))
    return path


EDITS = {
    "accessor count": (lambda d: d["accessors"][0].pop("count"), "accessors[0].count"),
    "bufferView byteLength": (lambda d: d["bufferViews"][1].pop("byteLength"),
                              "bufferViews[1].byteLength"),
    "bufferView buffer": (lambda d: d["bufferViews"][0].pop("buffer"), "bufferViews[0].buffer"),
    "accessor past its view": (lambda d: d["accessors"][2].update(count=40),
                               "accessors[2]: 40 elements"),
    "view past its buffer": (lambda d: d["bufferViews"][0].update(byteLength=10 ** 6),
                             "bufferViews[0] ends at byte"),
    "count of 10^10 without a view": (lambda d: d["accessors"][3].pop("bufferView") and
                                      d["accessors"][3].update(count=10 ** 10),
                                      "accessors[3].count"),
    "count of 10^10": (lambda d: d["accessors"][0].update(count=10 ** 10), "accessors[0]"),
    "sparse without indices": (lambda d: d["accessors"][1].update(
        sparse={"count": 1, "values": {"bufferView": 0}}), "accessors[1].sparse"),
    "indices accessor missing": (lambda d: d["meshes"][0]["primitives"][0].update(indices=9),
                                 "meshes[0].primitives[0].indices"),
    "negative byteOffset": (lambda d: d["bufferViews"][0].update(byteOffset=-8),
                            "bufferViews[0].byteOffset"),
    "negative count": (lambda d: d["accessors"][0].update(count=-1), "accessors[0].count"),
    "list for an index": (lambda d: d["accessors"][0].update(bufferView=[0]),
                          "not a readable glTF"),          # pygltflib's own type check
}


@needs_gltf
@pytest.mark.parametrize("glb", [False, True], ids=["gltf", "glb"])
@pytest.mark.parametrize("case", sorted(EDITS))
def test_gltf_members_missing_or_out_of_bounds(tmp_path, case, glb):
    edit, where = EDITS[case]
    path = _gltf(tmp_path, edit, glb)
    e = _refused(lambda: read_face(path), where, error=FormatError)
    assert e.path == str(path)


@needs_gltf
def test_gltf_seed_itself_reads(tmp_path):
    face = read_face(_gltf(tmp_path, lambda d: None))
    assert face.fat is not None and len(face.meshes) == 1


# -- .fap fields too large for their 32 bits ---------------------------------------------------------

@pytest.mark.parametrize("value", ["1000000000000", "-2147483649", "2147483648"])
def test_fap_viseme_and_expression_values_never_wrap(value):
    text = (Path(__file__).resolve().parents[1] / "spec_fixtures" / "fap" /
            "viseme_expression.fap").read_text()
    bad = text.replace("0 1 10 40 0 3 50", f"0 1 10 40 0 {value} 50", 1)
    e = _refused(lambda: loads_fap(bad, "v.fap"), "v.fap:3", "32 bits", error=FapError)
    assert value in str(e)
    bad = text.replace("0 1 10 40 0 3 50", f"0 {value} 10 40 0 3 50", 1)
    _refused(lambda: loads_fap(bad, "v.fap"), "FAP 1 (viseme)", error=FapError)


# -- temporary files ----------------------------------------------------------------------------------

def test_a_killed_write_leaves_a_recognisable_file_that_the_next_write_removes(tmp_path):
    target = tmp_path / "big.wrl"
    code = ("import os, sys; from mpeg4fba._atomic import atomic_open\n"
            "with atomic_open(sys.argv[1]) as f:\n"
            "    f.write(b'x' * 100000); f.flush(); os._exit(9)\n")
    r = subprocess.run([sys.executable, "-c", code, str(target)], timeout=60)
    assert r.returncode == 9 and not target.exists()
    left = [p.name for p in tmp_path.iterdir()]
    assert len(left) == 1 and left[0].startswith(PARTIAL) and left[0].endswith("-big.wrl")
    mine = tmp_path / f"{PARTIAL}{os.getpid()}-abc-other.wrl"       # a live process's
    mine.write_bytes(b"in progress")
    atomic_write(tmp_path / "next.txt", "done")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["next.txt", mine.name])
    assert remove_stale(str(tmp_path)) == []


def test_atomic_writes_reach_the_disk_before_the_rename(tmp_path, monkeypatch):
    order = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(os, "fsync", lambda fd: (order.append("fsync"), real_fsync(fd))[1])
    monkeypatch.setattr(os, "replace", lambda a, b: (order.append("replace"), real_replace(a, b))[1])
    atomic_write(tmp_path / "a.txt", "x")
    assert order == ["fsync", "replace"]



# -- a face that loads is a face that plays --------------------------------------------------------

FIXTURES = Path(__file__).resolve().parents[1] / "spec_fixtures" / "validate"


@pytest.mark.parametrize("code", ["FBA004", "FBA005", "FBA006", "FBA007", "FBA008", "FBA009",
                                  "FBA010"])
def test_load_face_refuses_a_fat_that_can_not_play(code):
    from mpeg4fba.formats.validate import validate
    from mpeg4fba.formats.wrl_face import load_face
    path = next(FIXTURES.glob(f"{code}_*.wrl"))
    assert code in {f.code for f in validate(path).findings}   # validate lists them all
    if code in ("FBA006", "FBA010"):      # a table aimed at the wrong node: never a model
        e = _refused(lambda: load_face(path, check=False), "faceSceneGraphNode",
                     error=FormatError)
    else:
        e = _refused(lambda: load_face(path), code, error=FormatError)
        face = load_face(path, check=False)          # still there for tools that repair
        assert face.fat is not None
    assert e.path == str(path) and e.line is not None


def test_play_of_a_face_with_fapid_70_is_a_clear_error(tmp_path):
    from click.testing import CliRunner
    from mpeg4fba.cli import main
    from mpeg4fba.fba.stream import FapStream
    from mpeg4fba.formats.fap import write_fap
    stream = tmp_path / "s.fap"
    write_fap(FapStream.from_values({"open_jaw": [0, 100]}, fps=25), stream)
    face = next(FIXTURES.glob("FBA004_*.wrl"))
    r = CliRunner().invoke(main, ["play", str(face), str(stream), "-o", str(tmp_path / "o.glb")])
    assert r.exit_code != 0 and "FBA004" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "o.glb").exists()


# -- work bounded by the input, not by numbers inside it ---------------------------------------------

def _cli(*args):
    from click.testing import CliRunner
    from mpeg4fba.cli import main
    with alarm(120, "the command"):
        return CliRunner().invoke(main, [str(a) for a in args])


def test_render_size_is_bounded_before_any_pixel(tmp_path):
    r = _cli("render", "--example", "--size", "100000x100000", "-o", tmp_path / "x.png")
    assert r.exit_code == 2 and "8192" in r.output and not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("value", ["1e300", "nan", "-inf", "5000"])
def test_render_fap_values_out_of_range_are_an_error(tmp_path, value):
    r = _cli("render", "--example", "--fap", f"open_jaw={value}", "--size", "60x70",
             "-o", tmp_path / "x.png")
    assert r.exit_code == 2 and "0 to 4320" in r.output
    assert "overflow" not in r.output and not (tmp_path / "x.png").exists()


def test_resample_of_a_tiny_fps_is_refused_up_front():
    from mpeg4fba.fba.stream import MAX_FRAMES, FapStream
    s = FapStream.from_values({"open_jaw": [0, 100, 200]}, fps=1e-5)
    with alarm(10, "resample"), pytest.raises(ValueError, match=f"{MAX_FRAMES:,}"):
        s.resample(25)
    assert len(FapStream.from_values({"open_jaw": [0, 100, 200]}, fps=25).resample(50)) == 6


def test_play_to_wrl_of_a_very_long_stream_is_refused_up_front(tmp_path):
    import numpy as np
    from mpeg4fba.fba.stream import FapStream
    from mpeg4fba.formats.fap import write_fap
    write_fap(FapStream.from_values({"open_jaw": (np.arange(40_000) % 200).tolist()}),
              tmp_path / "long.fap")
    r = _cli("play", "--example", tmp_path / "long.fap", "-o", tmp_path / "o.wrl")
    assert r.exit_code == 1 and "40,000 frames" in r.output and ".glb" in r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.fap"]


# -- memory bounded by the input (found by the long fuzzing run) ----------------------------------------

@pytest.mark.parametrize("filler", ["blank lines", "comment lines", "numbers", "a long string"])
def test_long_runs_of_anything_stay_in_proportion(filler):
    import tracemalloc
    body = {"blank lines": " \n" * 200_000 + "1 2 3",
            "comment lines": "# c\n" * 100_000 + "1 2 3",
            "numbers": "# unbracketed-path\n" + " ".join(["1.5"] * 150_000),
            "a long string": '1 2 3 ] } } } WorldInfo { title "' + " " * 300_000 + '" info [ "x"'
            }[filler]
    text = ("#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate { point [ 0 0 0 "
            + body + " ] }" + (" } }" if filler != "a long string" else "") + "\n# "
            + "c\n#" * 50_000 + "\nGroup {}\n")
    vrml.loads("#VRML V2.0 utf8\nGroup {}")
    tracemalloc.start()
    try:
        with alarm(60, "reading"):
            vrml.loads(text)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # the regex engine once kept a backtracking entry per blank or comment: ~300 B each
    assert peak < 6 * len(text), f"{peak / 1e6:.0f} MB for {len(text) / 1e6:.1f} MB of text"


# -- time bounded by the input (found by the long fuzzing run) -----------------------------------------

def test_fap_value_line_with_a_huge_token_is_refused_at_once():
    text = (Path(__file__).resolve().parents[1] / "spec_fixtures" / "fap" /
            "minimal_2_1.fap").read_text().split("\n")
    text[2] = "0 1 2 " + "9" * 200_000 + "{{{{"        # a value line: frame and 3 values
    with alarm(10, "reading the .fap"):
        _refused(lambda: loads_fap("\n".join(text), "a.fap"), "a.fap:3", "not a number",
                 error=FapError)


@pytest.mark.parametrize("token", ["9" * 100_000 + " 1e5", "9" * 5000])
def test_vrml_integer_run_with_a_huge_token_is_refused_at_once(token):
    text = ("#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate { point [ 0 0 0 ] }"
            f" coordIndex [ 0 {token} ] }} }}")
    with alarm(10, "reading"):
        e = _refused(lambda: vrml.loads(text, path="h.wrl"), "h.wrl:2")
    assert len(str(e)) < 400
