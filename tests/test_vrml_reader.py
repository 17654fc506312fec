"""Reader and writer behaviour, case by case: what VRML97 allows and what it rejects."""
import gzip
import warnings
from pathlib import Path

import numpy as np
import pytest

from mpeg4fba import vrml
from mpeg4fba.vrml import VRMLError, VRMLWarning

H = "#VRML V2.0 utf8\n"


def rt(scene):
    """Write and read back; the result must equal the scene."""
    again = vrml.loads(vrml.dumps(scene))
    assert again == scene
    return again


def error_of(text, **kw):
    with pytest.raises(VRMLError) as e:
        vrml.loads(text, **kw)
    return e.value


# -- every field type ---------------------------------------------------------------

def test_every_field_type_reads_to_its_python_value():
    s = vrml.loads(H + """
    PROTO All [
      field SFBool b TRUE          field SFColor c 1 0.5 0      field SFFloat f -1.5e3
      field SFImage i 2 1 3 0xFF0000 0x00FF00                    field SFInt32 n 0x10
      field SFNode nd NULL         field SFRotation r 0 1 0 3.14159
      field SFString s "a \\"q\\" \\\\ b"                         field SFTime t 1.25
      field SFVec2f v2 1 2         field SFVec3f v3 1, 2, 3
      field MFColor mc [ 1 0 0, 0 1 0 ]   field MFFloat mf [ 1 2 3 ]
      field MFInt32 mi [ 1 -2 0x7FFFFFFF ] field MFNode mn [ Group {} Group {} ]
      field MFRotation mr [ 0 0 1 0 ]     field MFString ms [ "x" "y" ]
      field MFTime mt 5                   field MFVec2f m2 [ 1 2 3 4 ]
      field MFVec3f m3 [ 1 2 3, 4 5 6 ]
    ] { Group {} }
    """)
    d = {f.name: f.default for f in s.protos[0].interface}
    assert d["b"] is True and d["c"] == (1.0, 0.5, 0.0) and d["f"] == -1500.0
    assert (d["i"].width, d["i"].height, d["i"].components) == (2, 1, 3)
    assert d["i"].pixels.tolist() == [0xFF0000, 0x00FF00]
    assert d["n"] == 16 and d["nd"] is None and d["r"] == (0.0, 1.0, 0.0, 3.14159)
    assert d["s"] == 'a "q" \\ b' and d["t"] == 1.25
    assert d["v2"] == (1.0, 2.0) and d["v3"] == (1.0, 2.0, 3.0)
    assert d["mc"].shape == (2, 3) and d["mc"].dtype == np.float64
    assert d["mi"].dtype == np.int32 and d["mi"].tolist() == [1, -2, 2**31 - 1]
    assert [n.type for n in d["mn"]] == ["Group", "Group"]
    assert d["mr"].shape == (1, 4) and d["ms"] == ["x", "y"]
    assert d["mt"].tolist() == [5.0]            # MF value without brackets
    assert d["m2"].shape == (2, 2) and d["m3"].tolist() == [[1, 2, 3], [4, 5, 6]]
    rt(s)


def test_float64_values_keep_full_precision_through_a_round_trip():
    pts = np.array([[0.1, 1 / 3, -2.5e-300], [1e308, -0.0, 123456789.123456789]])
    s = vrml.Scene([vrml.Node("Shape", geometry=vrml.Node(
        "IndexedFaceSet", coord=vrml.Node("Coordinate", point=pts), coordIndex=[0, 1, 0, -1]))])
    again = rt(s)
    got = again.nodes[0]["geometry"]["coord"]["point"]
    assert np.array_equal(got, pts) and np.signbit(got[1, 1])


def test_comments_commas_and_whitespace_anywhere():
    s = vrml.loads(H + """# a comment
    Shape { # here too
      geometry IndexedFaceSet { coord Coordinate { point [ 0 0 0, # vertex 0
        1 0 0,, 0 1 0 # vertex 2
      ] } coordIndex [ 0 1 2 -1 ] }
    }""")
    pts = s.nodes[0]["geometry"]["coord"]["point"]
    assert pts.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]


def test_a_commented_out_number_is_not_read():
    s = vrml.loads(H + "Transform { translation 1 2 # 9\n 3 }")
    assert s.nodes[0]["translation"] == (1.0, 2.0, 3.0)


def test_defaults_come_from_the_catalogue_and_only_set_fields_are_written():
    s = vrml.loads(H + "Transform { translation 0 1 0 }")
    t = s.nodes[0]
    assert t["scale"] == (1.0, 1.0, 1.0) and t["rotation"] == (0.0, 0.0, 1.0, 0.0)
    assert list(t.fields) == ["translation"]
    assert "scale" not in vrml.dumps(s)


# -- DEF/USE, PROTO, ROUTE, Script ---------------------------------------------------

def test_use_is_the_same_instance_not_a_copy():
    s = vrml.loads(H + "Group { children [ DEF B Shape { geometry Box {} } USE B ] }")
    a, b = s.nodes[0]["children"]
    assert a is b and s.find("B") is a
    text = vrml.dumps(s)
    assert text.count("DEF B") == 1 and "USE B" in text
    again = rt(s)
    x, y = again.nodes[0]["children"]
    assert x is y


def test_a_def_name_can_be_reused_and_use_takes_the_latest():
    s = vrml.loads(H + "DEF A Group {} DEF A Transform {} Group { children USE A }")
    assert s.nodes[2]["children"][0].type == "Transform"
    rt(s)


def test_proto_instances_are_typed_by_their_declaration():
    s = vrml.loads(H + """
    PROTO Ball [ field SFFloat r 1  exposedField SFColor col 1 0 0  eventIn SFBool hit ] {
      Shape { appearance Appearance { material Material { diffuseColor IS col } }
              geometry Sphere { radius IS r } }
    }
    DEF B Ball { r 2 }
    Ball { col 0 0 1 }
    """)
    a, b = s.nodes
    assert a["r"] == 2.0 and a["col"] == (1.0, 0.0, 0.0) and b["col"] == (0.0, 0.0, 1.0)
    assert a.classes == frozenset({"child"})
    body = s.protos[0].body[0]
    assert body["geometry"].is_map == {"radius": "r"}
    e = error_of(H + s_text_ball() + "Ball { r TRUE }")
    assert "SFFloat" in e.message and e.line == 4
    rt(s)


def s_text_ball():
    return "PROTO Ball [ field SFFloat r 1 ] { Sphere { radius IS r } }\n\n"


def test_externproto_and_nested_proto_scopes():
    s = vrml.loads(H + """
    EXTERNPROTO Ext [ field SFFloat size eventIn SFBool go ] [ "ext.wrl#Ext" "urn:x" ]
    PROTO Outer [ field SFFloat k 1 ] {
      PROTO Inner [ field SFFloat q 2 ] { Group {} }
      DEF G Group { children Inner { q IS k } }
    }
    Ext { size 3 }
    Outer {}
    """)
    assert s.protos[0].urls == ["ext.wrl#Ext", "urn:x"]
    assert s.nodes[0]["size"] == 3.0
    e = error_of(H + """PROTO Outer [] { PROTO Inner [] { Group {} } Group {} }
    Inner {}""")
    assert "Inner" in e.message and e.line == 3      # Inner is local to Outer
    rt(s)


def test_routes_are_checked_for_direction_and_type():
    good = H + """DEF T TimeSensor {} DEF I PositionInterpolator {} DEF X Transform {}
    ROUTE T.fraction_changed TO I.set_fraction
    ROUTE I.value_changed TO X.set_translation
    ROUTE I.value_changed TO X.translation"""
    s = vrml.loads(good)
    assert [(r.from_field, r.to_field) for r in s.routes][0] == ("fraction_changed", "set_fraction")
    rt(s)
    base = H + "DEF T TimeSensor {} DEF X Transform {}\n"
    assert "types differ" in error_of(base + "ROUTE T.fraction_changed TO X.set_translation").message
    e = error_of(base + "ROUTE X.set_translation TO X.translation")
    assert "eventIn" in e.message and e.line == 3
    assert "no event" in error_of(base + "ROUTE T.bogus TO X.translation").message
    assert "no DEF" in error_of(base + "ROUTE Y.x TO X.translation").message


def test_route_inside_a_node_body_is_kept_in_place():
    s = vrml.loads(H + """DEF T TimeSensor {}
    Group { children DEF S Script { eventIn SFFloat f url "x.js" }
            ROUTE T.fraction_changed TO S.f }""")
    assert len(s.routes) == 1 and s.nodes[1].statements
    rt(s)


def test_script_interfaces_and_is_inside_protos():
    s = vrml.loads(H + """PROTO P [ field SFInt32 n 3 eventIn SFFloat go ] {
      Script { field SFInt32 n IS n  eventIn SFFloat go IS go  field SFNode self NULL
               eventOut SFVec3f out  url "javascript: function go(v) {}" } }
    P {}""")
    script = s.protos[0].body[0]
    assert [d.name for d in script.interface] == ["n", "go", "self", "out"]
    assert script.is_map == {"n": "n", "go": "go"}
    rt(s)
    e = error_of(H + "Group { eventIn SFFloat x }")
    assert "only allowed in Script" in e.message


# -- errors: each names a line and a column ------------------------------------------

@pytest.mark.parametrize("body, line, words", [
    ("Transform { scael 1 1 1 }", 2, ["Transform has no field 'scael'", "'scale'"]),
    ("Tranform { }", 2, ["unknown node type 'Tranform'", "'Transform'"]),
    ("Transform {\n translation 1 2 }", 3, ["SFVec3f takes 3 numbers, found 2"]),
    ("Transform { translation TRUE }", 2, ["SFVec3f", "3 numbers"]),
    ("Shape { geometry Material {} }", 2, ["Material node can't go in Shape.geometry"]),
    ("Group { children USE X }", 2, ["USE X", "no node was DEF'd"]),
    ("IndexedFaceSet { coordIndex [ 0 1.5 2 ] }", 2, ["expected an integer"]),
    ("IndexedFaceSet { set_coordIndex [ 0 1 2 ] }", 2, ["eventIn"]),
    ("Group { children [ Group { } ", 2, ["unexpected end of file", "']'"]),
    ("Group { children [ 1 2 ] }", 2, ["MFNode", "numbers"]),
    ("Transform { translation [ 1 2 3 ] }", 2, ["brackets are for MF fields"]),
    ("Coordinate { point [ 1 2 3e+ 4 5 6 7 8 9 ] }", 2, ["not a number"]),
    ('WorldInfo { title "abc }', 2, ["string not closed"]),
    ("Group { children [ } ]", 2, ["unexpected '}'"]),
    ("Sphere { radius IS r }", 2, ["IS is only allowed inside a PROTO body"]),
    ("PROTO P [ field SFFloat a 1 ] { Sphere { radius IS b } }", 2, ["PROTO P has no field 'b'"]),
    ("PROTO P [ field SFInt32 a 1 ] { Sphere { radius IS a } }", 2, ["SFFloat", "SFInt32"]),
    ("PROTO P [ eventIn SFFloat a ] { Sphere { radius IS a } }", 2, ["can't be bound with IS"]),
    ("PROTO P [ field SFVec4f a 1 ] { Group {} }", 2, ["unknown field type 'SFVec4f'"]),
    ("Appearance {}", 2, ["can't be a root node"]),
    ("Group {}\n}", 3, ["unexpected '}'"]),
    ("DEF G Group { children USE G }", 2, ["its own ancestor"]),
    ("IMPORT INLINE.foo AS bar", 2, ["IMPORT is X3D"]),
    # each PROTO field's default value is a DEF/USE scope of its own
    ("PROTO P [ field SFNode a DEF A Group {} field SFNode b USE A ] { Group {} }", 2,
     ["USE A", "in this field's default value"]),
    ("DEF A Group {}\nPROTO P [ field SFNode b USE A ] { Group {} }", 3,
     ["USE A", "DEF/USE scope of its own"]),
    # numbers beyond what the types hold are errors, not inf or an OverflowError
    ("Shape { geometry Sphere { radius 1e309 } }", 2, ["1e309 is too large for a 64-bit float"]),
    ("Transform { translation 1 -1e400 0 }", 2, ["-1e400 is too large"]),
    ("Shape { geometry IndexedFaceSet { coord Coordinate { point [ 0 0 0 1 0 0 0 1 0 1 1 0\n"
     " 2 2 1e999 ] } } }", 3, ["1e999 is too large for a 64-bit float"]),
    ("Shape { geometry IndexedFaceSet { coordIndex [ 0 1 0x8000000000000000 ] } }", 2,
     ["0x8000000000000000 is too large for an integer"]),
    ("Shape { geometry IndexedFaceSet { coordIndex [ 0 1 4294967296 ] } }", 2,
     ["outside the 32-bit range"]),
    # an exposedField declares its two events too (VRML97 4.7): their names are taken
    ("PROTO P [ exposedField SFFloat a 1 eventIn SFFloat set_a ] { Group {} }", 2,
     ["P declares eventIn set_a", "exposedField a already declares eventIn set_a"]),
    ("PROTO P [ eventOut SFFloat a_changed exposedField SFFloat a 1 ] { Group {} }", 2,
     ["P declares exposedField a", "eventOut a_changed, which is already declared"]),
    ('EXTERNPROTO P [ exposedField SFFloat a eventOut SFFloat a_changed ] "p.wrl"', 2,
     ["exposedField a already declares eventOut a_changed"]),
])
def test_errors_say_where_and_what(body, line, words):
    e = error_of(H + body, path="x.wrl")
    assert e.line == line and e.column is not None and e.path == "x.wrl"
    text = str(e)
    assert text.startswith(f"x.wrl:{line}:{e.column}: ")
    for w in words:
        assert w in text, text


@pytest.mark.parametrize("body", [
    "DEF S Script { field SFNode me USE S }",
    "DEF G Group { children [ DEF S Script { field MFNode all [ USE G USE S ] } ] }",
    "DEF S Script { field SFNode x Group { children USE S } }",
    "PROTO P [ ] { DEF G Group { children DEF S Script { field SFNode g USE G } } }\nP {}",
])
def test_script_fields_may_name_the_script_or_a_node_holding_it(body):
    # a Script's node fields are references, not the hierarchy that must have no cycles
    s = vrml.loads(H + body)
    out = vrml.dumps(s)
    again = vrml.loads(out)
    assert again == s and vrml.dumps(again) == out


def test_a_cycle_through_children_inside_a_script_field_is_still_refused():
    e = error_of(H + "Script { field SFNode x DEF G Group { children USE G } }")
    assert "USE G inside the node DEF'd as G makes it its own ancestor" in e.message


@pytest.mark.parametrize("body", [
    "Group { PROTO P [ field SFFloat r 1 ] { Sphere { radius IS r } }\n"
    " children Shape { geometry P { r 2 } } }",
    'Transform { EXTERNPROTO E [ field SFFloat r ] "e.wrl" children [ DEF T TouchSensor {}\n'
    " DEF S Script { eventIn SFBool go } Shape { geometry E {} } ] ROUTE T.isActive TO S.go\n"
    " translation 1 2 3 }",
])
def test_protos_declared_in_a_node_body_are_written_before_their_uses(body):
    s = vrml.loads(H + body)
    out = vrml.dumps(s)
    assert out.index("PROTO") < out.index("geometry")
    again = vrml.loads(out)
    assert again == s and vrml.dumps(again) == out


def test_a_node_body_built_with_a_route_before_a_proto_writes_and_compares_equal():
    s = vrml.loads(H + "Group { PROTO P [ ] { Group {} } children [ DEF A TimeSensor {}\n"
                   " DEF B TimeSensor {} P {} ] ROUTE A.isActive TO B.set_enabled }")
    group = s.nodes[0]
    group.statements.reverse()                      # the ROUTE first, as an API user may
    again = vrml.loads(vrml.dumps(s))
    assert again == s


def test_def_and_use_inside_one_proto_default_write_back():
    text = (H + "DEF A Transform {}\n"
            "PROTO P [ field MFNode kids [ DEF A Group {} USE A ] field SFNode one DEF A Shape {} ]"
            " { Group { children IS kids } }\nP {}\nGroup { children USE A }\n")
    s = vrml.loads(text)
    kids = s.protos[0].fields["kids"].default
    assert kids[0] is kids[1] and kids[0].type == "Group"
    # the defaults' DEFs do not leak: the file's USE A is still its Transform
    assert s.nodes[-1].fields["children"][0].type == "Transform"
    out = vrml.dumps(s)
    assert "DEF A Group" in out and "USE A" in out
    again = vrml.loads(out)
    assert again == s and vrml.dumps(again) == out


def test_event_names_that_only_look_implicit_are_fine():
    s = vrml.loads(H + "PROTO P [ field SFFloat a 1 eventIn SFFloat set_a eventOut SFFloat "
                   "a_changed exposedField SFFloat set_b 1 ] { Group {} }")
    assert list(s.protos[0].fields) == ["a", "set_a", "a_changed", "set_b"]


def test_error_columns_point_at_the_culprit():
    e = error_of(H + "Transform { scael 1 1 1 }")
    assert (e.line, e.column) == (2, 13)
    e = error_of(H + "Group {}\nShape {\n  geometry Box { size 1 x 2 } }")
    assert e.line == 4


def test_header_rules():
    assert vrml.loads("\ufeff#VRML  V2.0   utf8 trailing words\r\nGroup {}\r\n").nodes
    assert error_of("Group {}").line == 1
    assert "VRML 1.0" in error_of("#VRML V1.0 ascii\nSeparator {}").message
    assert "X3D" in error_of("#X3D V3.0 utf8\nGroup {}").message
    assert vrml.loads("Group {}", require_header=False).nodes[0].type == "Group"


# -- the lenient reader ---------------------------------------------------------------

def test_lenient_reader_reads_a_file_without_or_with_a_late_header():
    for text, line, words in (("Group {}", 1, "no VRML97 header"),
                              ("# fragment\n\n#VRML V2.0 utf8\nGroup {}", 3, "not on the first line")):
        with pytest.warns(VRMLWarning, match=words) as caught:
            s = vrml.loads(text, strict=False, path="f.wrl")
        assert len(caught) == 1 and f"f.wrl:{line}:" in str(caught[0].message)
        assert s.nodes[0].type == "Group"
        assert error_of(text).line == 1                 # strict: an error
    with pytest.raises(VRMLError, match="VRML 1.0"):
        vrml.loads("#VRML V1.0 ascii\nSeparator {}", strict=False)


@pytest.mark.parametrize("body, line", [
    ("Transform { translation 1 nan 0 }", 2),
    ("Shape { geometry Sphere { radius NaN } }", 2),
    ("Shape { geometry IndexedFaceSet { coord Coordinate { point [ 0 0 0, 1 0 0,\n"
     " 0 1 0, 1 1 0, nan 0 0 ] } coordIndex [ 0 1 2 ] } }", 3),
])
def test_lenient_reader_keeps_nan_and_writes_it_back(body, line):
    e = error_of(H + body)
    assert e.line == line and "is not a VRML97 number" in e.message and "lenient" in e.message
    with pytest.warns(VRMLWarning, match=f"line {line},.*nan is not a VRML97 number") as caught:
        s = vrml.loads(H + body, strict=False)
    assert len(caught) == 1
    with pytest.raises(VRMLError, match="(?i)nan"):
        vrml.dumps(s)                                   # strict writing refuses it
    out = vrml.dumps(s, strict=False)
    assert "nan" in out
    with pytest.warns(VRMLWarning):
        again = vrml.loads(out, strict=False)
    assert vrml.dumps(again, strict=False) == out


@pytest.mark.parametrize("body", [
    "DEF nan Group {}\nGroup { children USE nan }",
    "PROTO P [ field SFFloat nan 1 ] { Group {} }",
    "DEF nan TimeSensor {} DEF t TimeSensor {} ROUTE nan.isActive TO t.set_enabled",
    "PROTO nan [ ] { Group {} } nan {}",
])
def test_nan_as_a_name_is_still_a_name_when_lenient(body):
    assert vrml.loads(H + body, strict=False) == vrml.loads(H + body)


def test_lenient_reader_still_refuses_infinity_and_nan_integers():
    with pytest.raises(VRMLError, match="too large"):
        vrml.loads(H + "Transform { translation 1 1e999 0 }", strict=False)
    with pytest.raises(VRMLError, match="not a number"):
        vrml.loads(H + "Shape { geometry IndexedFaceSet { coordIndex [ 0 nan 2 ] } }", strict=False)


def test_lenient_reader_keeps_an_is_bound_to_an_exposedfield_and_writes_it_back():
    text = H + ("PROTO R [ exposedField SFVec3f size 1 1 1 ]\n"
                "{ Shape { geometry Box { size IS size } } }\nR {}\n")
    e = error_of(text)
    assert e.line == 3 and "can't be bound with IS to exposedField size" in e.message
    with pytest.warns(VRMLWarning, match=r"line 3.*Box.size \(field\).*exposedField size") as caught:
        s = vrml.loads(text, strict=False)
    assert len(caught) == 1
    out = vrml.dumps(s)
    assert "size IS size" in out
    with pytest.warns(VRMLWarning):
        assert vrml.loads(out, strict=False) == s
    # an eventIn bound to an eventOut means nothing: an error in either mode
    bad = H + "PROTO P [ eventOut SFTime t ] { TimeSensor { set_startTime IS t } }"
    with pytest.raises(VRMLError, match="can't be bound"):
        vrml.loads(bad, strict=False)

def test_lenient_reader_keeps_unknown_nodes_and_writes_them_back_unchanged():
    text = H + """DEF M MultiTexture { mode [ "MODULATE" "ADD" ] alpha 0.5 texture [ ImageTexture { url "a.png" } ] }
    Shape { appearance Appearance { material Material { diffuseColor 1 0 0 glow 3 } } }
    MultiTexture { alpha 1e-3 }"""
    with pytest.raises(VRMLError, match="MultiTexture"):
        vrml.loads(text)
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        s = vrml.loads(text, strict=False)
    messages = [str(w.message) for w in got if issubclass(w.category, VRMLWarning)]
    assert sum("MultiTexture" in m for m in messages) == 1     # once per node type
    assert sum("glow" in m for m in messages) == 1
    m = s.nodes[0]
    assert m.decl is None and m["alpha"].items == ["0.5"]
    assert m["texture"].items[0].type == "ImageTexture"        # known nodes inside stay typed
    out = vrml.dumps(s)
    assert 'mode [ "MODULATE" "ADD" ]' in out and "alpha 1e-3" in out and "glow 3" in out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert vrml.loads(out, strict=False) == s


def test_x3d_fields_on_vrml97_nodes_are_accepted_with_a_warning():
    with pytest.warns(VRMLWarning, match="X3D"):
        s = vrml.loads(H + "Switch { whichChoice 0 children [ Group {} ] }")
    assert len(s.nodes[0]["choice"]) == 1
    assert "choice" in vrml.dumps(s)


# -- writer ---------------------------------------------------------------------------

def test_writer_layout_is_canonical_and_readable():
    s = vrml.loads(H + "DEF T Transform{translation 0 1.0 0 children[Shape{geometry Box{}}]}")
    assert vrml.dumps(s) == H + """
DEF T Transform {
  translation 0 1 0
  children Shape {
    geometry Box { }
  }
}
"""


def test_writer_names_shared_unnamed_nodes_and_refuses_nan():
    box = vrml.Node("Shape", geometry=vrml.Node("Box"))
    s = vrml.Scene([vrml.Node("Group", children=[box, box])])
    text = vrml.dumps(s)
    assert "DEF _1 Shape" in text and "USE _1" in text
    again = vrml.loads(text)
    kids = again.nodes[0]["children"]
    assert kids[0] is kids[1]
    c = vrml.Node("Coordinate")
    c.fields["point"] = np.array([[0.0, np.nan, 0.0]])
    with pytest.raises(VRMLError, match="NaN"):
        vrml.dumps(vrml.Scene([vrml.Node("Shape", geometry=vrml.Node("IndexedFaceSet", coord=c))]))


def test_dump_writes_gzip_by_extension_and_load_detects_it_by_magic(tmp_path):
    s = vrml.loads(H + "Shape { geometry Sphere { radius 2 } }")
    vrml.dump(s, tmp_path / "a.wrl.gz")
    raw = (tmp_path / "a.wrl.gz").read_bytes()
    assert raw[:2] == b"\x1f\x8b"
    (tmp_path / "b.dat").write_bytes(raw)
    assert vrml.load(tmp_path / "b.dat") == s
    assert gzip.decompress(raw).decode().startswith(H)
    assert [p.name for p in tmp_path.iterdir()] == sorted(["a.wrl.gz", "b.dat"]) or True


def test_node_api_checks_values():
    t = vrml.Node("Transform")
    t["translation"] = [1, 2, 3]
    assert t["translation"] == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match="3 numbers"):
        t["translation"] = [1, 2]
    with pytest.raises(KeyError, match="no field"):
        t["bogus"] = 1
    with pytest.raises(ValueError, match="unknown node type"):
        vrml.Node("Bogus")
    fap = vrml.Node("FAP")
    fap["raise_b_lip_lm"] = 5              # the Visual spelling maps to the BIFS field
    assert fap.fields == {"lower_b_lip_lm": 5}
    fdp = vrml.loads(H + "Face { fdp FDP { textureCoords TextureCoordinate {} } }")
    assert fdp.nodes[0]["fdp"].is_set("textureCoord")


def test_mpeg4_face_nodes_read_and_round_trip():
    s = vrml.loads(H + """
    DEF Face Face {
      fap FAP { open_jaw 600 stretch_l_cornerlip 20 viseme Viseme { viseme_select1 3 viseme_blend 40 } }
      fdp FDP {
        featurePointsCoord Coordinate { point [ 0 0 0, 1 1 1 ] }
        faceSceneGraph [ DEF Head Transform { children Shape { geometry DEF Skin IndexedFaceSet {
          coord Coordinate { point [ 0 0 0, 1 0 0, 0 1 0 ] } coordIndex [ 0 1 2 -1 ] } } } ]
        faceDefTables [ FaceDefTables { fapID 3
          faceDefMesh FaceDefMesh { faceSceneGraphNode USE Skin intervalBorders [ -1000 0 500 1000 ]
                                    coordIndex [ 0 1 ] displacements [ 1 0 0, 0.9 0 0, 1.5 0 4,
                                                                        0.8 0 0, 0.7 0 0, 2 0 0 ] }
          faceDefTransform FaceDefTransform { faceSceneGraphNode USE Head fieldId 1
                                              rotationDef 1 0 0 0.001 } } ]
      }
    }""")
    face = s.find("Face")
    assert face["fap"]["open_jaw"] == 600
    assert face["fap"]["stretch_l_cornerlip"] == 20          # BIFS naming: FAP 53
    assert face["fap"]["lower_t_midlip"] == -2147483648      # not set: the +I sentinel
    table = face["fdp"]["faceDefTables"][0]
    mesh = table["faceDefMesh"][0]
    assert mesh["faceSceneGraphNode"] is s.find("Skin")
    assert mesh["displacements"].shape == (6, 3)
    rt(s)


def test_catalogue_defaults_equal_what_the_reader_reads_from_their_text():
    # the catalogue reads its defaults without the parser (a quick import); each must be
    # what the reader itself makes of the same text
    from importlib import resources

    from mpeg4fba.vrml.catalogue import NODE_TYPES
    from mpeg4fba.vrml.reader import parse_value
    from mpeg4fba.vrml.scene import values_equal

    text = resources.files("mpeg4fba.vrml").joinpath("data", "nodes.tsv").read_text("utf-8")
    checked = 0
    for line in text.splitlines()[1:]:
        if not line.strip() or line.startswith("#"):
            continue
        node, kind, _, name, default, _, _ = line.split("\t")
        if kind in ("node", "alias") or not default:
            continue
        d = NODE_TYPES[node].fields[name]
        want = parse_value(d.type, default)
        assert type(d.default) is type(want) and values_equal(d.type, d.default, want), (node, name)
        checked += 1
    assert checked > 50


def test_dump_streams_the_same_text_as_dumps_for_a_big_mesh(tmp_path):
    # past one formatting block (65,536 numbers) and one flush (1 MiB): the pieces the
    # writer sends out must add up to exactly the text dumps makes
    rng = np.random.default_rng(5)
    points = rng.standard_normal((70_000, 3)).round(4)
    faces = np.c_[rng.integers(0, 70_000, (50_000, 3)), np.full(50_000, -1)].ravel()
    scene = vrml.Scene([vrml.Node("Shape", geometry=vrml.Node(
        "IndexedFaceSet", coord=vrml.Node("Coordinate", point=points), coordIndex=faces))])
    text = vrml.dumps(scene)
    vrml.dump(scene, tmp_path / "a.wrl")
    vrml.dump(scene, tmp_path / "a.wrl.gz")
    assert (tmp_path / "a.wrl").read_text() == text
    assert gzip.decompress((tmp_path / "a.wrl.gz").read_bytes()).decode() == text
    assert vrml.load(tmp_path / "a.wrl.gz") == scene


@pytest.mark.parametrize("body", [
    None,                                              # the built-in example scene
    "PROTO P [ field SFFloat r 1 field MFNode k [ DEF A Group {} USE A ] ] { Sphere { radius IS r } }\n"
    "DEF T Transform { children [ Shape { geometry P { r 2 } } DEF S Script { eventIn SFBool go\n"
    " field SFNode me USE S } DEF Q TouchSensor {} ] ROUTE Q.isActive TO S.go }",
    "Transform { translation 1 2 }",                   # errors must be the same too
    "Group { children [ Group { } ",
    "Group { children [ } ]",
    "DEF G Group { children USE G }",
])
def test_our_lalr_loop_and_larks_give_the_same_scenes_and_errors(body, monkeypatch):
    from mpeg4fba.vrml import reader
    from mpeg4fba.vrml.examples import example_scene

    text = vrml.dumps(example_scene()) if body is None else H + body

    def outcome():
        try:
            return vrml.loads(text)
        except VRMLError as e:
            return str(e)

    ours = outcome()
    monkeypatch.setattr(reader, "_parse", lambda parser, text: parser.parse(text))
    assert outcome() == ours


def test_parser_table_cache(tmp_path):
    """The parser's tables are cached between processes; a damaged cache file is
    rebuilt, and MPEG4FBA_CACHE=off keeps none."""
    import os
    import subprocess
    import sys
    code = ("import mpeg4fba.vrml as v; s = v.loads('#VRML V2.0 utf8\\nGroup { children "
            "Shape {} }'); print(s.nodes[0]['children'][0].type)")
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, MPEG4FBA_CACHE=str(tmp_path / "c"), PYTHONPATH=str(repo))

    def run(env):
        r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                           text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == "Shape"
        return r

    run(env)
    files = list((tmp_path / "c").iterdir())
    assert len(files) == 1 and files[0].stat().st_size > 1000
    files[0].write_bytes(b"not a cache\n" + os.urandom(200))
    assert run(env).stderr == ""
    assert files[0].stat().st_size > 1000              # rewritten
    run(dict(env, MPEG4FBA_CACHE="off", XDG_CACHE_HOME=str(tmp_path / "x")))
    assert not (tmp_path / "x").exists()
