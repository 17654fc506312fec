"""Feature point files: Xface .fdp XML, our JSON sidecar, and the FDP node of a scene."""
from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from mpeg4fba import vrml
from mpeg4fba.fba import FAPU, FEATURE_POINTS, FeaturePointError, FeaturePointSet
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.fpjson import (dumps_feature_points_json, loads_confidences,
                                     loads_feature_points_json, read_confidences,
                                     read_feature_points_json, write_feature_points_json)
from mpeg4fba.formats.wrl_fdp import (fdp_coordinate, feature_points_from_fdp,
                                      feature_points_from_scene)
from mpeg4fba.formats.xface_fdp import (Influence, XfaceFdp, XfaceFdpItem, dumps_xface_fdp,
                                        loads_xface_fdp, read_xface_fdp, write_xface_fdp)
from mpeg4fba.vrml import Node, Scene

REPO = Path(__file__).resolve().parents[1]
EXAMPLE_JSON = REPO / "spec_fixtures" / "feature_points" / "example.json"
IDS = [fp.id for fp in FEATURE_POINTS]


# -- Xface .fdp: the real alice.fdp ---------------------------------------------------------

@pytest.fixture(scope="module")
def alice_path(shared_dir) -> Path:
    path = shared_dir / "data" / "xface" / "alice.fdp"
    if not path.is_file():
        pytest.skip(f"../shared is absent: {path} does not exist")
    return path


@pytest.fixture(scope="module")
def alice(alice_path) -> XfaceFdp:
    return read_xface_fdp(alice_path)


def test_alice_fapu_is_stored_as_written(alice):
    assert alice.fapu == FAPU(IRISD0=16, ES0=69, ENS0=51, MNS0=30, MW0=50)


def test_alice_has_every_fdp_element_of_the_file(alice, alice_path):
    text = alice_path.read_text("utf-8")
    names = re.findall(r'<fdp\b[^>]*\bname="([^"]+)"', text)
    assert len(names) == 35 == len(alice.items)
    assert [item.name for item in alice.items] == names
    # Two feature points appear twice, on different meshes: 33 distinct ids.
    assert sorted(alice.points.ids) == sorted(set(names)) and len(set(names)) == 33
    assert len(alice.points) == 0          # vertex ids only, no positions


def test_alice_points_are_vertices_of_the_named_mesh(alice):
    assert alice.points.vertex("2.1") == ("alice.wrl_3", 2395)
    assert alice.points.vertex("3.5") == ("alice.wrl_1", 19)
    assert [(i.mesh, i.vertex) for i in alice.items_of("2.1")] == [("alice.wrl_3", 2395),
                                                                    ("alice.wrl_5", 0)]
    assert [(i.mesh, i.vertex) for i in alice.items_of("3.1")] == [("alice.wrl_3", 2585),
                                                                    ("alice.wrl_1", 123)]
    first = alice.items[0]
    assert first.indices.dtype == np.int64 and first.indices[:3].tolist() == [0, 1, 2]


def test_alice_influence_fap_numbers_are_one_based(alice, alice_path):
    # The file says fap="2" for FP 2.1: Xface counts from 0, so that is FAP 3, open_jaw.
    assert re.search(r'name="2\.1">\s*<indices>[^<]*</indices>\s*<influence fap="2"',
                     alice_path.read_text("utf-8"))
    assert alice.influences["2.1"] == [Influence(3, "RaisedCosInfluenceSph", 0.3)]
    assert alice.influences["2.2"] == [Influence(4, "RaisedCosInfluenceWaveY", 0.25),
                                       Influence(17, "RaisedCosInfluenceSph", 0.2)]
    assert alice.influences["8.2"] == []   # the file gives 8.2 no influence


def test_alice_head_and_source(alice, alice_path):
    assert alice.version == "0.2"
    assert alice.translation == (0.0, -1.0, -659.0)
    assert alice.rotation == pytest.approx((-0.999632, -0.0154467, 0.0223226, 0.407589))
    assert len(alice.entities) == len(re.findall(r"<entity\b", alice_path.read_text("utf-8")))
    rest = alice.rest
    assert (rest.alias, rest.category, rest.mesh_file) == ("Rest", "Expression", "alice.wrl")
    binds = {b.item: b for b in rest.binds}
    assert binds["LeftEye"].submesh == "alice.wrl_1"
    assert binds["LeftEye"].pivot == (-33.8, -33.2, -28.8)
    assert binds["Hair"].pivot is None
    visemes = [e.alias for e in alice.entities if e.category == "Viseme"]
    assert "aah" in visemes and "th" in visemes


def test_alice_problems_find_the_lower_lip_influences(alice):
    # 8.7 and 8.8 carry fap="57"/"58", which are FAPs 58/59: one higher than theirs.
    problems = alice.problems()
    assert len(problems) == 2
    assert problems[0].startswith("fdp 8.7 on alice.wrl_3: FAP 58 (raise_b_lip_rm_o)")
    assert problems[1].startswith("fdp 8.8 on alice.wrl_3: FAP 59 (raise_l_cornerlip_o)")


def test_alice_round_trip(alice, tmp_path):
    out = tmp_path / "alice.fdp"
    write_xface_fdp(alice, out)
    assert os.listdir(tmp_path) == ["alice.fdp"]      # no temporary file left behind
    again = read_xface_fdp(out)
    assert again == alice
    text = out.read_text("utf-8")
    assert re.search(r'<fdp name="2\.1"[^>]*>\s*<indices>[^<]*</indices>\s*'
                     r'<influence fap="2" ', text)  # written 0-based again
    assert '<fapu ES0="69" IRISD0="16" ENS0="51" MNS0="30" MW0="50" />' in text


# -- Xface .fdp: built and broken documents ---------------------------------------------

HEAD = '<head><fapu ES0="69" IRISD0="16" ENS0="51" MNS0="30" MW0="50"/></head>'


def test_minimal_document_and_defaults():
    fdp = loads_xface_fdp(f'<xfdp>{HEAD}<fdp name="9.15" index="4"/></xfdp>')
    assert fdp.translation is None and fdp.rotation is None and fdp.version is None
    assert fdp.entities == [] and fdp.influences == {"9.15": []}
    assert fdp.points.vertex("9.15") == (None, 4)
    assert loads_xface_fdp(dumps_xface_fdp(fdp)) == fdp


def test_built_document_round_trips():
    fdp = XfaceFdp(FAPU(10, 62, 57, 15, 50), [
        XfaceFdpItem("3.5", "eye", 19, np.arange(5), (Influence(25, "RaisedCosInfluenceWaveX", 0.0),)),
        XfaceFdpItem("8.3", "skin", 35, np.array([33, 35]),
                     (Influence(59, "RaisedCosInfluenceSph", 0.4),
                      Influence(53, "RaisedCosInfluenceSph", 1 / 3)))],
        translation=(0.5, 0, -1e-3), rotation=(1, 0, 0, 0.25))
    text = dumps_xface_fdp(fdp)
    assert 'fap="24"' in text and 'fap="58"' in text and 'fap="52"' in text
    assert loads_xface_fdp(text) == fdp
    assert fdp.problems() == []


def _error(text: str) -> FormatError:
    with pytest.raises(FormatError) as info:
        loads_xface_fdp(text, "t.fdp")
    return info.value


@pytest.mark.parametrize("text, line, words", [
    ("<xfdp>\n<head>\n</xfdp>", 3, ["not well-formed XML", "mismatched tag"]),
    ("", 1, ["not well-formed XML"]),
    ("version 2.1 of something\n", 1, ["not well-formed XML"]),
    ("<fdp>\n</fdp>", 1, ["root element is <fdp>", "<xfdp>"]),
    ("<xfdp>\n<head>\n<file version='0.2'/></head></xfdp>", 2, ["no <fapu>"]),
    ("<xfdp>\n</xfdp>", 1, ["no <head>"]),
    ('<xfdp><head>\n<fapu ES0="6x9" IRISD0="16" ENS0="51" MNS0="30" MW0="50"/></head></xfdp>',
     2, ["<fapu> attribute ES0", "'6x9' is not a number"]),
    ('<xfdp><head>\n<fapu ES0="69" IRISD0="16" ENS0="51" MNS0="30"/></head></xfdp>',
     2, ["<fapu> has no MW0 attribute"]),
    (f'<xfdp>{HEAD}\n<head/><translation x="1" y="nan" z="0"/></xfdp>', None, None),
    (f'<xfdp>{HEAD}\n\n<fdp name="2.1" index="3"/>\n<fdp name="12.1" index="4"/>'
     '\n<fdp name="3.15" index="5"/></xfdp>', 4,
     ["'12.1' (line 4)", "'3.15' (line 5)", "not feature points of the standard"]),
    (f'<xfdp>{HEAD}\n<fdp name="2.1" index="three"/></xfdp>', 2,
     ["<fdp> attribute index", "'three' is not an integer"]),
    (f'<xfdp>{HEAD}\n<fdp name="2.1" index="3">\n<indices>1 2 x</indices></fdp></xfdp>', 3,
     ["<indices> of fdp 2.1", "'x' is not a vertex index"]),
    (f'<xfdp>{HEAD}\n<fdp name="2.1" index="3">\n<influence fap="68" type="RaisedCosInfluenceSph"'
     ' weight="1"/></fdp></xfdp>', 3, ['fap="68"', "counts FAPs from 0"]),
    (f'<xfdp>{HEAD}\n<fdp name="2.1" index="3">\n<influence fap="2" type="RaisedCosInfluenceSph"'
     ' weight="heavy"/></fdp></xfdp>', 3, ["<influence> attribute weight", "'heavy'"]),
])
def test_xface_errors_say_where_and_what(text, line, words):
    if words is None:   # a <translation> outside <head> is ignored, as Xface does
        assert loads_xface_fdp(text).translation is None
        return
    e = _error(text)
    assert e.path == "t.fdp" and e.line == line
    assert str(e).startswith(f"t.fdp:{line}")
    for w in words:
        assert w in e.message


def test_xface_refuses_doctype_and_entities():
    laughs = ('<?xml version="1.0"?>\n<!DOCTYPE xfdp [\n <!ENTITY a "aaaaaaaaaa">\n'
              ' <!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">\n]>\n<xfdp>&b;</xfdp>')
    e = _error(laughs)
    assert e.line == 2 and "DOCTYPE" in e.message
    with pytest.raises(FormatError, match="DOCTYPE"):
        loads_xface_fdp('<!DOCTYPE xfdp SYSTEM "x.dtd"><xfdp/>')


def test_xface_error_names_the_file(tmp_path):
    bad = tmp_path / "bad.fdp"
    bad.write_bytes(b"<xfdp>\n<head>\n<fapu ES0='1'/>\n</head>\n</xfdp>\n")
    with pytest.raises(FormatError) as info:
        read_xface_fdp(bad)
    assert str(info.value) == f"{bad}:3: <fapu> has no IRISD0 attribute"


# -- JSON sidecar ---------------------------------------------------------------------------

def test_example_json_has_a_plausible_face():
    points, fapu = read_feature_points_json(EXAMPLE_JSON)
    assert list(points) == IDS and len(points) == 84
    with warnings.catch_warnings():
        warnings.simplefilter("error")           # FAPUWarning would fail the test
        computed = FAPU.from_feature_points(points)
    assert computed.problems() == []
    assert all(v > 0 for v in computed.as_dict().values())
    assert 50 <= computed.ES0 <= 75             # millimetres, an adult's eye separation
    assert computed == fapu                      # the file's FAPU is the one its points give
    # left is +x: the face's left pupil, lip corner and ear
    assert points["3.5"][0] > 0 > points["3.6"][0] and points["10.1"][0] > 0


def test_json_round_trip(tmp_path):
    points = FeaturePointSet({"3.5": (31, 30, 72), "2.1": (0, -75.25, 1e-9)},
                             {"3.5": ("Skin", 1204), "9.15": ("Skin", 331), "2.10": (None, 7)})
    fapu = FAPU(10, 62, 57, 15, 50.5)
    path = tmp_path / "fp.json"
    write_feature_points_json(points, path, fapu, units="mm")
    assert os.listdir(tmp_path) == ["fp.json"]
    again, fapu2 = read_feature_points_json(path)
    assert again == points and fapu2 == fapu
    assert loads_feature_points_json(dumps_feature_points_json(points)) == (points, None)
    empty = FeaturePointSet()
    assert loads_feature_points_json(dumps_feature_points_json(empty)) == (empty, None)
    example = EXAMPLE_JSON.read_text("utf-8")
    pts, f = loads_feature_points_json(example)
    assert dumps_feature_points_json(pts, f, units=
                                     "millimetres; x = the face's left, y = up, z = forward "
                                     "(toward the viewer); a synthetic adult face") == example


def test_json_confidences_round_trip(tmp_path):
    points = FeaturePointSet({"3.5": (31, 30, 72), "2.1": (0, -75.25, 1e-9)},
                             {"3.5": ("Skin", 1204), "9.15": ("Skin", 331)})
    conf = {"9.15": 0.125, "3.5": 1, "2.1": np.float32(0.5)}
    path = tmp_path / "fp.json"
    write_feature_points_json(points, path, units="mm", confidences=conf)
    text = path.read_text("utf-8")
    assert '"3.5": {"position": [31.0, 30.0, 72.0], "mesh": "Skin", "vertex": 1204, ' \
           '"confidence": 1.0}' in text
    assert '"9.15": {"mesh": "Skin", "vertex": 331, "confidence": 0.125}' in text
    assert read_confidences(path) == {"2.1": 0.5, "3.5": 1.0, "9.15": 0.125}
    assert list(read_confidences(path)) == ["2.1", "3.5", "9.15"]      # the standard's order
    assert read_feature_points_json(path) == (points, None)           # unchanged return value
    assert loads_confidences(dumps_feature_points_json(points)) == {}
    partial = dumps_feature_points_json(points, confidences={" 9.15": 0.0})   # ids normalised
    assert loads_confidences(partial) == {"9.15": 0.0}
    assert dumps_feature_points_json(points, confidences={}) == dumps_feature_points_json(points)


@pytest.mark.parametrize("conf, message", [
    ({"3.6": 0.5}, "a confidence for feature point 3.6, which the points do not have"),
    ({"3.5": 1.5}, "feature point 3.5: a confidence is a number from 0 to 1, not 1.5"),
    ({"3.5": -0.1}, "from 0 to 1"),
    ({"3.5": float("nan")}, "from 0 to 1"),
    ({"3.5": True}, "from 0 to 1"),
    ({"3.5": "0.5"}, "from 0 to 1"),
    ({"3.55": 0.5}, "not a feature point of the standard"),
])
def test_json_confidences_refused_when_written(conf, message):
    points = FeaturePointSet({"3.5": (1, 2, 3)})
    with pytest.raises(ValueError, match=re.escape(message)):
        dumps_feature_points_json(points, confidences=conf)


@pytest.mark.parametrize("confidence, message", [
    ("1.5", 'points["3.5"].confidence: expected a number from 0 to 1, not 1.5'),
    ("-0.5", "not -0.5"),
    ('"high"', 'not "high"'),
    ("true", "not true"),
    ("null", "not null"),
    ("[1]", "not [1]"),
    ("1e999", "not Infinity"),
])
def test_json_confidence_errors_name_the_item(confidence, message):
    text = _doc('{"3.5": {"position": [1, 2, 3], "confidence": %s}}' % confidence)
    for reader in (loads_feature_points_json, loads_confidences):
        with pytest.raises(FormatError) as info:
            reader(text, "fp.json")
        assert str(info.value).startswith("fp.json: ") and message in str(info.value)


def test_json_confidence_edges_are_accepted():
    text = _doc('{"3.5": {"position": [1, 2, 3], "confidence": 0}, "3.6": {"vertex": 1, "confidence": 1}}')
    assert loads_confidences(text) == {"3.5": 0.0, "3.6": 1.0}
    assert loads_feature_points_json(text)[0] == FeaturePointSet({"3.5": (1, 2, 3)}, {"3.6": (None, 1)})


def _doc(points='{"3.5": {"position": [1, 2, 3]}}', extra=""):
    return ('{"format": "mpeg4fba-feature-points", "version": 1, "points": %s%s}'
            % (points, extra))


@pytest.mark.parametrize("text, message", [
    (_doc('{"3.5": {"position": [1, 2]}}'), 'points["3.5"].position: expected 3 numbers'),
    (_doc('{"3.5": {"position": [1, 2, "3"]}}'), 'points["3.5"].position: expected 3 numbers'),
    (_doc('{"3.5": {"position": [1, 2, NaN]}}'), 'points["3.5"].position: expected 3 numbers'),
    (_doc('{"3.5": {"position": [1, 2, 3], "colour": "red"}}'),
     'points["3.5"]: unknown key "colour"; allowed: position, mesh, vertex, confidence'),
    (_doc(extra=', "scale": 2'),
     'unknown key "scale"; allowed: format, version, units, points, fapu'),
    (_doc('{"3.55": {"position": [1, 2, 3]}}'),
     'points["3.55"]: \'3.55\' is not a feature point of the standard'),
    (_doc('{"3.5": {"position": [1, 2, 3]}, "3.5": {"vertex": 1}}'),
     'points: key "3.5" given more than once'),
    (_doc('{"3.5": {"position": [1, 2, 3]}, " 3.5": {"vertex": 1}}'),
     'points[" 3.5"]: feature point 3.5 is also given as "3.5"'),
    (_doc('{"3.5": {"mesh": "Skin"}}'), 'points["3.5"]: a "mesh" without a "vertex"'),
    (_doc('{"3.5": {}}'), 'points["3.5"]: a point needs a "position", a "vertex" or both'),
    (_doc('{"3.5": {"vertex": -1}}'), 'points["3.5"].vertex: expected an integer >= 0 (a vertex index, below 2**31), not -1'),
    (_doc('{"3.5": {"vertex": true}}'), 'points["3.5"].vertex: expected an integer >= 0'),
    (_doc('{"3.5": {"vertex": 2.5}}'), 'points["3.5"].vertex: expected an integer >= 0'),
    (_doc('{"3.5": {"vertex": 2, "mesh": 4}}'), 'points["3.5"].mesh: expected a string'),
    (_doc('{"3.5": [1, 2, 3]}'), 'points["3.5"]: expected an object'),
    (_doc('[]'), "points: expected an object"),
    (_doc(extra=', "fapu": {"ES0": 1}'), "fapu: missing IRISD0, ENS0, MNS0, MW0"),
    (_doc(extra=', "fapu": {"ES0": 1, "IRISD0": 1, "ENS0": 1, "MNS0": 1, "MW0": "1"}'),
     'fapu.MW0: expected a number, not "1"'),
    (_doc(extra=', "fapu": {"ES": 1}'), 'fapu: unknown key "ES"; allowed: IRISD0, ES0'),
    (_doc(extra=', "units": 1'), "units: expected a string"),
    ('{"format": "xface", "version": 1, "points": {}}', 'format: "xface" is not'),
    ('{"format": "mpeg4fba-feature-points", "version": 2, "points": {}}',
     "version: 2 is not supported (this reader reads version 1)"),
    ('{"format": "mpeg4fba-feature-points", "version": 1}', 'no "points" key'),
    ("[1, 2, 3]", "expected an object (the document), not an array"),
])
def test_json_errors_name_the_item(text, message):
    with pytest.raises(FormatError) as info:
        loads_feature_points_json(text, "fp.json")
    assert message in str(info.value)
    assert str(info.value).startswith("fp.json: ")


def test_json_syntax_error_has_the_line(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{\n  "format": "mpeg4fba-feature-points",\n  "version": 1\n  "points": {}\n}')
    with pytest.raises(FormatError) as info:
        read_feature_points_json(path)
    e = info.value
    assert e.line == 4 and e.path == str(path) and "not valid JSON" in e.message
    assert str(e).startswith(f"{path}:4:3: ")   # line and column


# -- FDP node in a scene --------------------------------------------------------------------

def test_fdp_coordinate_order_and_undefined_points():
    pts = np.zeros((84, 3))
    pts[:, 0] = np.arange(84)
    pts[5] = (-10000, 0, 0)          # 2.6 undefined
    pts[6] = (-9999, 1, 1)           # 2.7: exactly -9999 is not "below": defined
    fdp = Node("FDP", featurePointsCoord=Node("Coordinate", point=pts))
    got = feature_points_from_fdp(fdp)
    assert "2.6" not in got and len(got) == 83
    assert got["2.1"][0] == 0 and got["3.5"][0] == IDS.index("3.5") == 18
    assert got["11.6"][0] == 83 and got["2.7"].tolist() == [-9999, 1, 1]


def test_fdp_coordinate_round_trip_through_vrml_text():
    points, _ = read_feature_points_json(EXAMPLE_JSON)
    partial = FeaturePointSet({k: points[k] for k in ("2.1", "3.5", "3.6", "9.15", "11.6")})
    for pts in (points, partial):
        coord = fdp_coordinate(pts)
        assert coord["point"].shape == (84, 3)
        scene = Scene([Node("Transform", children=[
            Node("Face", name="Alice", fdp=Node("FDP", featurePointsCoord=coord))])])
        again = vrml.loads(vrml.dumps(scene))
        assert feature_points_from_scene(again) == pts


def test_fdp_coordinate_refuses_what_it_cannot_write():
    with pytest.raises(FeaturePointError, match="9.15 only name a mesh vertex"):
        fdp_coordinate(FeaturePointSet({"3.5": (1, 2, 3)}, {"9.15": ("Skin", 3)}))
    with pytest.raises(ValueError, match="-12000"):
        fdp_coordinate(FeaturePointSet({"3.5": (-12000, 2, 3)}))


def test_wrong_point_count_names_the_node_location(tmp_path):
    path = tmp_path / "face.wrl"
    path.write_text("#VRML V2.0 utf8\nDEF F Face {\n  fdp FDP {\n    featurePointsCoord\n"
                    "      Coordinate { point [ 0 0 0, 1 1 1, 2 2 2 ] }\n  }\n}\n")
    with pytest.raises(FormatError) as info:
        feature_points_from_scene(vrml.load(path))
    e = info.value
    assert (e.path, e.line, e.column) == (str(path), 5, 7)
    assert "has 3 points; it must hold the 84 feature points" in e.message


@pytest.mark.parametrize("scene, message", [
    (Scene([Node("Transform")]), "no MPEG-4 Face node in the scene"),
    (Scene([Node("Face", name="F")]), "Face 'F' has no fdp"),
    (Scene([Node("Face", fdp=Node("FDP"))]), "FDP has no featurePointsCoord"),
    (Scene([Node("Face", name="A"), Node("Face", name="B")]),
     "the scene has 2 Face nodes (A, B); say which with face=<DEF name>"),
])
def test_scene_errors_say_what_is_missing(scene, message):
    with pytest.raises(FormatError) as info:
        feature_points_from_scene(scene)
    assert message in info.value.message


def test_scene_with_two_faces_picks_by_name():
    a = FeaturePointSet({"3.5": (1, 2, 3)})
    b = FeaturePointSet({"3.6": (-1, 2, 3)})
    scene = Scene([Node("Face", name=n, fdp=Node("FDP", featurePointsCoord=fdp_coordinate(p)))
                   for n, p in (("A", a), ("B", b))])
    assert feature_points_from_scene(scene, face="B") == b
    with pytest.raises(FormatError, match="no Face node DEF'd as 'C'.*A, B"):
        feature_points_from_scene(scene, face="C")
