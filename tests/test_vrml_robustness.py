"""The VRML codec on hostile and extreme input: deep nesting, a 200 MB file, invalid
UTF-8, truncation, gzip, header variants, and writes that fail.
"""
from __future__ import annotations

import errno
import gzip
import os
import re
import warnings

import numpy as np
import pytest

from _guards import alarm

from mpeg4fba import vrml
from mpeg4fba.vrml import Node, Scene

HEADER = "#VRML V2.0 utf8\n"
DEPTH = 100_000


def _quiet_load(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vrml.VRMLWarning)
        return vrml.load(path, **kw)


def _quiet_loads(text, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vrml.VRMLWarning)
        return vrml.loads(text, **kw)


# -- (a, b) deep nesting -------------------------------------------------------------------

def _nested(depth: int, closers: int) -> str:
    return HEADER + "Group { children [\n" * depth + "] }\n" * closers


def test_100000_nested_groups_read_write_round_trip():
    scene = vrml.loads(_nested(DEPTH, DEPTH))
    assert len(scene.statements) == 1
    node, depth = scene.nodes[0], 1
    while True:
        assert node.type == "Group"
        kids = node["children"]
        if not kids:
            break
        assert len(kids) == 1
        node, depth = kids[0], depth + 1
    assert depth == DEPTH

    text = vrml.dumps(scene)
    assert text.startswith(HEADER)
    assert text.count("Group {") == DEPTH
    again = vrml.loads(text)
    assert again == scene


def test_100000_nested_groups_missing_brace_is_unexpected_end_of_file():
    # The last line lacks its '}': the outermost Group is never closed.
    text = _nested(DEPTH, DEPTH - 1) + "]\n"
    with pytest.raises(vrml.VRMLError) as info:
        vrml.loads(text)
    e = info.value
    assert e.message == "unexpected end of file"
    assert e.line == text.count("\n") + 1
    assert e.column is not None


def test_nested_groups_end_of_file_error_through_load(tmp_path):
    p = tmp_path / "deep.wrl"
    p.write_text(_nested(DEPTH, DEPTH - 1), encoding="utf-8")
    with pytest.raises(vrml.VRMLError, match="unexpected end of file") as info:
        vrml.load(p)
    assert info.value.line is not None and info.value.path == str(p)


# -- (c) a 200 MB point list -------------------------------------------------------------

def test_200mb_point_list(tmp_path):
    """A 200 MB IndexedFaceSet reads in seconds with every point exact (no slow mark:
    about 10 s here, well under the 30 s that would call for one)."""
    rng = np.random.default_rng(20240601)
    block_pts = rng.integers(-10**6, 10**6, size=(20_000, 3)) / 1000.0
    block = "".join("%r %r %r,\n" % tuple(r) for r in block_pts.tolist())
    reps = 200_000_000 // len(block)
    first = (-1.5e-300, 3.141592653589793, 1.7976931348623157e308)
    last = (-0.0, 5e-324, -7.125e-05)
    path = tmp_path / "big.wrl"
    try:
        with open(path, "w", encoding="ascii") as f:
            f.write(HEADER + "Shape { geometry IndexedFaceSet {\n"
                    "  coord Coordinate { point [\n")
            f.write("%r %r %r,\n" % first)
            for _ in range(reps):
                f.write(block)
            f.write("%r %r %r\n  ] }\n  coordIndex [ 0 1 2 -1 ]\n} }\n" % last)
        assert os.path.getsize(path) > 190_000_000
        scene = vrml.load(path)   # its speed: benchmarks/bench_vrml_read.py
        ifs = scene.nodes[0]["geometry"]
        points = ifs["coord"]["point"]
        assert points.shape == (reps * len(block_pts) + 2, 3)
        assert points.dtype == np.float64
        assert points[0].tobytes() == np.array(first).tobytes()
        assert points[-1].tobytes() == np.array(last).tobytes()   # -0.0 keeps its sign
        assert np.array_equal(points[1:1 + len(block_pts)], block_pts)
        assert np.array_equal(points[-1 - len(block_pts):-1], block_pts)
        assert ifs["coordIndex"].tolist() == [0, 1, 2, -1]
        del scene, ifs, points
    finally:
        path.unlink(missing_ok=True)
    assert not path.exists()


# -- (d) invalid UTF-8 ---------------------------------------------------------------------

def test_invalid_utf8_in_strings_warns_and_is_written_back_unchanged(tmp_path):
    title = b"caf\xff\xe9 \xc3"          # 0xFF, a lone Latin-1 byte, a cut UTF-8 sequence
    info = [b"x\xffy", b"\xfe\xfd \xe2\x82\xac ok"]   # bad bytes next to a real euro sign
    src = (b"#VRML V2.0 utf8\nWorldInfo {\n  title \"" + title + b"\"\n  info [ \"" +
           b"\" \"".join(info) + b"\" ]\n}\n")
    p = tmp_path / "bad.wrl"
    p.write_bytes(src)
    with pytest.warns(vrml.VRMLWarning, match="invalid UTF-8") as record:
        scene = vrml.load(p)
    assert any(str(p) in str(w.message) for w in record), "the warning should name the file"
    out = tmp_path / "out.wrl"
    vrml.dump(scene, out)
    written = out.read_bytes()
    strings = re.findall(rb'"((?:[^"\\]|\\.)*)"', written)
    assert strings == [title] + info
    # And through a second read, the same bytes again (a fixed point).
    with pytest.warns(vrml.VRMLWarning):
        again = vrml.load(out)
    assert again == scene
    out2 = tmp_path / "out2.wrl.gz"
    vrml.dump(again, out2)
    assert gzip.decompress(out2.read_bytes()) == written


def test_invalid_utf8_in_strings_through_loads_and_dumps():
    src = b'#VRML V2.0 utf8\nWorldInfo { title "a\xffb" }\n'
    text = src.decode("utf-8", "surrogateescape")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vrml.VRMLWarning)
        scene = vrml.loads(text)
    out = vrml.dumps(scene).encode("utf-8", "surrogateescape")
    assert re.findall(rb'"([^"]*)"', out) == [b"a\xffb"]


@pytest.mark.parametrize("body", [
    b"Gr\xffoup { }",                                  # in a node type name
    b"\xffGroup { }",                                  # before a node type name
    b"Group { \xff children [] }",                     # between fields
    b"Group { children [] \xff }",                     # after the last field
    b"Transform { transl\xffation 1 2 3 }",            # in a field name
    b"Transform { translation 1 \xff 2 3 }",           # among numbers
    b"Coordinate { point [ 1 2 3 4 5 6 7 8 9 10 11 \xff 12 ] }",  # in a long number run
    b"Group { children [ \xff ] }",                    # in a node list
    b"DEF \xff Group { }",                             # as a DEF name
    b"DEF A Group { } USE \xff",                       # as a USE name
    b"\xff",                                           # alone
    b"Group { } \xff\xfe\xfd",                         # at the end of the file
    b"WorldInfo { title \"ok\" \xff }",                # right after a string
    b"# comment \xff\nGroup { }",                      # in a comment (kept)
], ids=lambda b: repr(b)[2:30])
def test_invalid_utf8_outside_strings_is_an_error_or_a_scene(tmp_path, body):
    p = tmp_path / "bad.wrl"
    p.write_bytes(b"#VRML V2.0 utf8\n" + body + b"\n")
    for strict in (True, False):
        try:
            result = _quiet_load(p, strict=strict)
        except vrml.VRMLError as e:
            assert e.line is not None and e.column is not None, str(e)
            assert e.path == str(p)
        else:
            assert isinstance(result, Scene)


# -- (e) truncated files -------------------------------------------------------------------

_GENERATED = HEADER + """
PROTO Blob [ field SFColor c 1 0 0  exposedField MFString label [ "a \\"quoted\\" label" ] ]
{ Shape { appearance Appearance { material Material { diffuseColor IS c } }
          geometry Sphere { radius 0.5 } } }
DEF Root Transform {
  translation 1 2.5 -3e2 rotation 0 1 0 1.5708
  children [
    DEF S Shape { geometry IndexedFaceSet {
      coord Coordinate { point [ 0 0 0, 1 0 0, 1 1 0, 0 1 0, 0.5 0.5 1 ] }
      coordIndex [ 0 1 2 3 -1, 0 1 4 -1, 1 2 4 -1 ] solid FALSE } }
    Blob { c 0 0 1 }
    USE S
    DEF Clock TimeSensor { loop TRUE cycleInterval 2 }
    DEF Mover PositionInterpolator { key [ 0 1 ] keyValue [ 0 0 0, 0 1 0 ] }
    WorldInfo { title "caf\u00e9 # not a comment" info [ "x", "y\\\\z" ] }  # a comment
  ]
}
ROUTE Clock.fraction_changed TO Mover.set_fraction
ROUTE Mover.value_changed TO Root.set_translation
"""


@pytest.fixture(scope="module")
def mid_size_file(shared_dir_or_none):
    """(name, bytes) of a mid-size corpus file rich in features (5-50 kB, PROTOs and
    DEF/USE first), or of a generated file when ../shared is absent."""
    if shared_dir_or_none is not None:
        d = shared_dir_or_none / "data" / "vrml-corpus"
        import csv
        try:
            with open(d / "MANIFEST.tsv", newline="", encoding="utf-8") as f:
                rows = list(csv.DictReader(f, delimiter="\t"))
        except OSError:
            rows = []
        candidates = [r for r in rows if r["role"].startswith("positive")
                      and 5_000 <= int(r["size"] or 0) <= 50_000]
        if candidates:
            best = max(candidates, key=lambda r: ("PROTO" in r["features"],
                                                  r["features"].count(","), -int(r["size"])))
            return best["local_path"], (d / best["local_path"]).read_bytes()
    return "generated.wrl", (_GENERATED * 20).encode("utf-8")


def test_every_prefix_is_an_error_or_a_scene(mid_size_file):
    name, data = mid_size_file
    assert _quiet_loads(data.decode("utf-8", "surrogateescape")) is not None
    cuts = sorted(set(np.linspace(0, len(data), 50, dtype=int).tolist()))
    outcomes = {"error": 0, "scene": 0}
    for cut in cuts:
        text = data[:cut].decode("utf-8", "surrogateescape")   # a cut may split a character
        try:
            with alarm(30, f"reading the cut at {cut} of {name}"):
                result = _quiet_loads(text, path=name)
        except vrml.VRMLError as e:
            assert e.line is not None, f"cut at {cut}: {e}"
            outcomes["error"] += 1
        else:
            assert isinstance(result, Scene)
            outcomes["scene"] += 1
    assert outcomes["error"] > 0


# -- (f) gzip ------------------------------------------------------------------------------

_SMALL = HEADER + "DEF T Transform { translation 1 2 3 children Shape { geometry Box { } } }\n"


def test_gzip_with_any_extension_loads(tmp_path):
    p = tmp_path / "scene.txt"
    p.write_bytes(gzip.compress(_SMALL.encode("utf-8")))
    scene = vrml.load(p)
    assert scene == vrml.loads(_SMALL)
    assert scene.find("T")["translation"] == (1.0, 2.0, 3.0)


def _gz():
    return gzip.compress((_SMALL * 50).encode("utf-8"), mtime=0)


@pytest.mark.parametrize("damage", [
    lambda b: b[:len(b) // 2],                              # truncated in the deflate data
    lambda b: b[:-4],                                       # trailer cut
    lambda b: b[:12],                                       # header only
    lambda b: b[:3],                                        # magic and a byte
    lambda b: b[:20] + bytes(len(b) - 40) + b[-20:],        # deflate data zeroed
    lambda b: b[:-8] + bytes(a ^ 0xFF for a in b[-8:-4]) + b[-4:],   # wrong CRC
    lambda b: b + b"\x1f\x8b\x08\x00garbage",               # a second, broken member
], ids=["half", "no-size", "header-only", "magic", "zeroed", "bad-crc", "bad-member"])
def test_corrupt_gzip_is_a_vrml_error_with_the_path(tmp_path, damage):
    p = tmp_path / "broken.wrl.gz"
    p.write_bytes(damage(_gz()))
    with pytest.raises(vrml.VRMLError) as info:
        _quiet_load(p)
    assert info.value.path == str(p)


# -- (g) headers, BOM, line ends -----------------------------------------------------------

@pytest.mark.parametrize("data", [
    b"\xef\xbb\xbf#VRML V2.0 utf8\nGroup { }\n",
    b"#VRML V2.0 utf8\r\nGroup {\r\n  children [ ]\r\n}\r\n",
    b"\xef\xbb\xbf#VRML V2.0 utf8\r\nGroup { }\r\n",
    b"#VRML  V2.0   utf8\nGroup { }\n",
    b"#VRML V2.0\tutf8 \t produced by a modeller\r\nGroup { }\n",
], ids=["bom", "crlf", "bom-crlf", "extra-spaces", "tab-and-comment"])
def test_header_variants_accepted(tmp_path, data):
    p = tmp_path / "ok.wrl"
    p.write_bytes(data)
    scene = vrml.load(p)
    assert [n.type for n in scene.nodes] == ["Group"]
    assert vrml.loads(data.decode("utf-8")).nodes[0].type == "Group"   # BOM in a str too


@pytest.mark.parametrize("text", [
    "Group { }\n",
    "\n#VRML V2.0 utf8\nGroup { }\n",
    "# just a comment\nGroup { }\n",
    "#VRML V1.0 ascii\nSeparator { }\n",
    "#X3D V3.0 utf8\nPROFILE Immersive\nGroup { }\n",
    "#VRML V2.0 utf16\nGroup { }\n",
    "",
], ids=["missing", "blank-first-line", "comment", "vrml1", "x3d", "utf16", "empty"])
def test_bad_header_is_an_error_on_line_1(tmp_path, text):
    with pytest.raises(vrml.VRMLError) as info:
        vrml.loads(text)
    assert info.value.line == 1
    p = tmp_path / "bad.wrl"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(vrml.VRMLError) as info:
        vrml.load(p)
    assert info.value.line == 1 and info.value.path == str(p)


# -- (h) writes that fail ------------------------------------------------------------------

def _scene_with_points():
    coord = Node("Coordinate", point=[[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    ifs = Node("IndexedFaceSet", coord=coord, coordIndex=[0, 1, 2, -1])
    return Scene([Node("Shape", geometry=ifs)]), coord


def test_dump_into_missing_folder_raises_oserror(tmp_path):
    scene, _ = _scene_with_points()
    target = tmp_path / "no" / "such" / "dir" / "out.wrl"
    with pytest.raises(OSError):
        vrml.dump(scene, target)
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["out.wrl", "out.wrl.gz"])
def test_dump_of_unwritable_value_leaves_no_file(tmp_path, name):
    scene, coord = _scene_with_points()
    coord.fields["point"] = np.array([[0.0, np.nan, 1.0]])   # bypasses the field's check
    with pytest.raises(vrml.VRMLError):
        vrml.dump(scene, tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_failed_dump_keeps_the_old_file(tmp_path):
    scene, coord = _scene_with_points()
    target = tmp_path / "out.wrl"
    vrml.dump(scene, target)
    before = target.read_bytes()
    coord.fields["point"] = np.array([[np.inf, 0.0, 1.0]])
    with pytest.raises(vrml.VRMLError):
        vrml.dump(scene, target)
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["out.wrl"]


def _file_size_limit_works() -> bool:
    try:
        import resource
        import signal
    except ImportError:
        return False
    return (hasattr(resource, "RLIMIT_FSIZE") and hasattr(signal, "SIGXFSZ")
            and signal.getsignal(signal.SIGXFSZ) == signal.SIG_IGN)


@pytest.mark.skipif(not _file_size_limit_works(), reason="needs RLIMIT_FSIZE with SIGXFSZ ignored")
@pytest.mark.parametrize("name", ["new.wrl", "old.wrl", "new.wrl.gz"])
def test_dump_failing_midway_leaves_no_partial_or_temp_file(tmp_path, name):
    """The file may grow to only 4 kB (as on a full disk): the write fails half way with
    an OSError (EFBIG), and neither a partial file nor a temp file is left."""
    import resource
    rng = np.random.default_rng(7)
    coord = Node("Coordinate", point=rng.random((20_000, 3)))
    scene = Scene([Node("Shape", geometry=Node("IndexedFaceSet", coord=coord))])
    old = tmp_path / "old.wrl"
    old.write_bytes(b"previous content")
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, hard))
    try:
        with pytest.raises(OSError) as info:
            vrml.dump(scene, tmp_path / name)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert info.value.errno == errno.EFBIG
    assert [p.name for p in tmp_path.iterdir()] == ["old.wrl"]
    assert old.read_bytes() == b"previous content"


def test_dump_onto_a_directory_leaves_no_temp_file(tmp_path):
    scene, _ = _scene_with_points()
    (tmp_path / "taken").mkdir()
    with pytest.raises(OSError):
        vrml.dump(scene, tmp_path / "taken")
    assert [p.name for p in tmp_path.iterdir()] == ["taken"]
    assert list((tmp_path / "taken").iterdir()) == []
