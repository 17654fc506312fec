"""Property tests of the VRML codec (hypothesis, derandomized so CI is reproducible).

1. Random scenes built with ``Node(...)`` from the catalogue round-trip:
   ``loads(dumps(s)) == s``, floats come back bit for bit (-0.0, subnormals, 1e308),
   dumps is a fixed point, and sharing (one node object in two places, DEF/USE) is
   kept: the two places hold one object after reading, distinct nodes stay distinct.
2. Random mutations of small real corpus files never make ``loads`` fail with
   anything but a VRMLError (no IndexError, no RecursionError, ...).
"""
from __future__ import annotations

import re
import struct
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mpeg4fba import vrml
from mpeg4fba.vrml import Node, Scene

COMMON = dict(deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# -- strategies for scenes ------------------------------------------------------------------

KEYWORDS = {"DEF", "USE", "PROTO", "EXTERNPROTO", "ROUTE", "TO", "IS", "TRUE", "FALSE",
            "NULL", "eventIn", "eventOut", "field", "exposedField"}

floats = st.floats(allow_nan=False, allow_infinity=False, width=64)
unit = st.floats(0, 1, allow_nan=False, width=64)
vec3 = st.tuples(floats, floats, floats)
colors = st.tuples(unit, unit, unit)
rotations = st.tuples(floats, floats, floats, floats)

# Text with anything but surrogates, and text made mostly of what needs care in a
# string literal: quotes, backslashes, line ends, '#', brackets, non-ASCII.
any_text = st.text(st.characters(exclude_categories=("Cs",)), max_size=24)
tricky_text = st.text(st.sampled_from(list('"\\\n\r\t #[]{},é€😀\x00\u2028 ab')), max_size=24)
strings = st.one_of(any_text, tricky_text)
mfstrings = st.lists(strings, max_size=5)

_first = st.one_of(st.characters(categories=("Lu", "Ll", "Lo")), st.just("_"))
_rest = st.text(st.one_of(st.characters(categories=("Lu", "Ll", "Lo", "Nd")),
                          st.sampled_from(list("_-+:;!$%&*<=>?@^|~"))), max_size=8)
names = st.builds(lambda a, b: a + b, _first, _rest).filter(lambda s: s not in KEYWORDS)

mfvec3f = st.lists(vec3, max_size=12).map(
    lambda rows: np.array(rows, dtype=np.float64).reshape(-1, 3))
mfint32 = st.lists(st.one_of(st.integers(-1, 20), st.integers(-2**31, 2**31 - 1)),
                   max_size=16).map(lambda xs: np.array(xs, dtype=np.int32))


@st.composite
def _some_fields(draw, options: dict) -> dict:
    """A random subset of the field strategies in ``options``, in a random order."""
    chosen = draw(st.lists(st.sampled_from(sorted(options)), unique=True,
                           max_size=len(options)))
    return {k: draw(options[k]) for k in chosen}


@st.composite
def geometries(draw):
    kind = draw(st.sampled_from(["Box", "Sphere", "IndexedFaceSet"]))
    if kind == "Box":
        return Node("Box", **draw(_some_fields({"size": vec3})))
    if kind == "Sphere":
        return Node("Sphere", **draw(_some_fields({"radius": floats})))
    fields = draw(_some_fields({
        "coord": st.builds(lambda p: Node("Coordinate", point=p), mfvec3f),
        "coordIndex": mfint32, "solid": st.booleans(), "ccw": st.booleans(),
        "convex": st.booleans(), "colorPerVertex": st.booleans(),
        "color": st.builds(lambda c: Node("Color", color=np.array(c).reshape(-1, 3)),
                           st.lists(colors, max_size=4)),
    }))
    return Node("IndexedFaceSet", **fields)


@st.composite
def shapes(draw):
    fields = draw(_some_fields({
        "geometry": geometries(),
        "appearance": st.builds(
            lambda m: Node("Appearance", **({"material": m} if m is not None else {})),
            st.none() | st.builds(lambda f: Node("Material", **f), _some_fields({
                "diffuseColor": colors, "emissiveColor": colors,
                "transparency": unit, "shininess": unit}))),
    }))
    return Node("Shape", **fields)


@st.composite
def leaves(draw):
    if draw(st.integers(0, 3)):
        return draw(shapes())
    return Node("WorldInfo", **draw(_some_fields({"info": mfstrings, "title": strings})))


@st.composite
def groups(draw, depth: int):
    kind = draw(st.sampled_from(["Transform", "Group", "Anchor"]))
    options = {"Transform": {"rotation": rotations, "translation": vec3, "scale": vec3,
                             "center": vec3},
               "Group": {"bboxCenter": vec3},
               "Anchor": {"description": strings, "url": mfstrings, "parameter": mfstrings}}
    fields = draw(_some_fields(options[kind]))
    children = draw(st.lists(st.one_of(leaves(), groups(depth - 1)) if depth > 0
                             else leaves(), max_size=3))
    if children or draw(st.booleans()):
        fields["children"] = children
    return Node(kind, **fields)


def _walk(roots):
    """Every node reachable from ``roots`` (a tree plus shared leaves: no cycles)."""
    stack = list(roots)
    while stack:
        n = stack.pop()
        yield n
        stack.extend(n.children_nodes())


@st.composite
def scenes(draw, name_shared: bool):
    """(scene, [paths of the shared node]): a random scene where one Shape object is
    placed twice.  With ``name_shared`` the shared node always has a DEF name."""
    roots = draw(st.lists(groups(2), min_size=1, max_size=3))
    pool = iter(draw(st.lists(names, unique=True, min_size=40, max_size=40)))
    shared_name = next(pool) if name_shared else None
    # DEF names on some nodes (unique, so every USE is unambiguous).
    for n in _walk(roots):
        if draw(st.integers(0, 3)) == 0:
            n.name = next(pool, None)
    shared = draw(shapes())
    shared.name = shared_name
    # The places it can go: the root list or any grouping node's children.
    slots = [roots] + [n for n in _walk(roots) if n.type in ("Transform", "Group", "Anchor")]
    for _ in range(2):
        slot = draw(st.sampled_from(slots))
        lst = slot if isinstance(slot, list) else slot.fields.setdefault("children", [])
        lst.insert(draw(st.integers(0, len(lst))), shared)
    scene = Scene(roots)
    paths = [p for p, n in _occurrences(scene) if n is shared]
    assert len(paths) == 2
    return scene, paths


def _occurrences(scene):
    """(path, node) for each place a node is held; a path is (root index, (field,
    index or None), ...)."""
    out = []
    stack = [((i,), n) for i, n in enumerate(scene.statements) if isinstance(n, Node)]
    while stack:
        path, n = stack.pop()
        out.append((path, n))
        for fname, v in n.fields.items():
            if isinstance(v, Node):
                stack.append((path + ((fname, None),), v))
            elif isinstance(v, list):
                stack.extend((path + ((fname, j),), c) for j, c in enumerate(v)
                             if isinstance(c, Node))
    return out


def _resolve(scene, path):
    node = scene.statements[path[0]]
    for fname, j in path[1:]:
        v = node.fields[fname]
        node = v if j is None else v[j]
    return node


def _bits(value):
    """A value with every float replaced by its bit pattern (so -0.0 != 0.0)."""
    if isinstance(value, float):
        return struct.pack("<d", value)
    if isinstance(value, tuple):
        return tuple(_bits(v) for v in value)
    if isinstance(value, np.ndarray):
        return (value.dtype.kind, value.shape, value.tobytes())
    return value


def _check_round_trip(scene, shared_paths):
    text = vrml.dumps(scene)
    again = vrml.loads(text)
    assert again == scene, text
    assert vrml.dumps(again) == text, "dumps is not a fixed point"
    # Sharing: the shared node is one object after reading ...
    a, b = (_resolve(again, p) for p in shared_paths)
    assert a is b, "the shared node became two nodes"
    # ... and, over all places, nodes are the same object exactly when they were.
    forward, backward = {}, {}
    for path, orig in _occurrences(scene):
        read = _resolve(again, path)
        assert read.type == orig.type
        assert forward.setdefault(id(orig), id(read)) == id(read), f"split at {path}"
        assert backward.setdefault(id(read), id(orig)) == id(orig), f"merged at {path}"
        # Exact values: floats bit for bit (negative zero, subnormals, 1.8e308).
        for fname, v in orig.fields.items():
            if not (isinstance(v, Node) or isinstance(v, list) and v and isinstance(v[0], Node)):
                assert _bits(read.fields[fname]) == _bits(v), f"{orig.type}.{fname} at {path}"


@settings(max_examples=80, **COMMON)
@given(data=st.data())
def test_random_scene_round_trips(data):
    scene, paths = data.draw(scenes(name_shared=True), label="scene")
    _check_round_trip(scene, paths)


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # libcst, imported to report
@settings(max_examples=20, **COMMON)
@given(data=st.data())
def test_random_scene_with_unnamed_shared_node_round_trips(data):
    scene, paths = data.draw(scenes(name_shared=False), label="scene")
    _check_round_trip(scene, paths)


def test_unnamed_shared_node_round_trip_minimal():
    """The smallest case of the bug above: the scene.py docstring's own example."""
    box = Node("Shape", geometry=Node("Box", size=(1, 2, 3)))
    t = Node("Transform", translation=(0, 1, 0), children=[box, box])
    again = vrml.loads(vrml.dumps(Scene([t])))
    kids = again.nodes[0]["children"]
    assert kids[0] is kids[1]


def test_unnamed_shared_node_equality_minimal():
    box = Node("Shape", geometry=Node("Box", size=(1, 2, 3)))
    t = Node("Transform", translation=(0, 1, 0), children=[box, box])
    assert vrml.loads(vrml.dumps(Scene([t]))) == Scene([t])


# -- mutations of real files ----------------------------------------------------------------

N_FILES = 20
MAX_SIZE = 8_000

TOKEN_RE = re.compile(
    rb'[{}\[\]"]|\b(?:DEF|USE|PROTO|EXTERNPROTO|ROUTE|TO|IS|NULL|TRUE|FALSE|field|'
    rb'exposedField|eventIn|eventOut|Transform|Group|Shape|children)\b|'
    rb'[-+]?(?:0[xX][0-9a-fA-F]+|(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)')
REPLACEMENTS = [b"{", b"}", b"[", b"]", b'"', b"DEF", b"USE", b"DEF X", b"USE X", b"PROTO",
                b"EXTERNPROTO", b"ROUTE", b"TO", b"IS", b"NULL", b"TRUE", b"FALSE", b"0",
                b"-1", b"1e400", b"-1e-400", b"0x", b"0xFFFFFFFFFF", b"1.2.3", b"#", b"\\",
                b"Group {", b"children [", b"field SFInt32 x", b"eventIn SFBool", b".",
                b"\xff", b"\xc3", b"IMPORT", b"Script {", b"url", b" "]


@pytest.fixture(scope="module")
def small_positives(corpus_manifest, corpus_dir):
    """~20 small positive corpus files (bytes), spread over the sizes below 8 kB."""
    rows = sorted((int(r["size"]), r["local_path"]) for r in corpus_manifest
                  if r["_role"] == "positive" and 0 < int(r["size"] or 0) <= MAX_SIZE)
    if not rows:
        pytest.skip("no small positive files in the corpus")
    step = max(1, len(rows) // N_FILES)
    picked = rows[::step][:N_FILES]
    return [(p, (corpus_dir / p).read_bytes()) for _, p in picked]


def _mutate(data, buf: bytearray) -> bytearray:
    op = data.draw(st.sampled_from(["delete byte", "insert byte", "replace byte", "truncate",
                                    "delete token", "replace token", "insert token",
                                    "duplicate token"]), label="op")
    if op.endswith("byte"):
        pos = data.draw(st.integers(0, max(0, len(buf) - 1)), label="pos")
        if op == "insert byte":
            buf.insert(pos, data.draw(st.integers(0, 255), label="byte"))
        elif buf:
            if op == "delete byte":
                del buf[pos]
            else:
                buf[pos] = data.draw(st.integers(0, 255), label="byte")
        return buf
    if op == "truncate":
        return buf[:data.draw(st.integers(0, len(buf)), label="cut")]
    tokens = list(TOKEN_RE.finditer(bytes(buf)))
    if not tokens:
        return buf
    m = tokens[data.draw(st.integers(0, len(tokens) - 1), label="token")]
    if op == "delete token":
        new = b""
    elif op == "duplicate token":
        new = m.group() + b" " + m.group()
    else:
        new = data.draw(st.sampled_from(REPLACEMENTS), label="new")
        if op == "insert token":
            new = new + b" " + m.group()
    buf[m.start():m.end()] = new
    return buf


def _mutated(small_positives, data) -> tuple:
    """(path, text) of a corpus file mutated 1-3 times, decoded as load() does (bytes
    that are not UTF-8 become surrogate escapes)."""
    path, original = small_positives[data.draw(st.integers(0, len(small_positives) - 1),
                                               label="file")]
    buf = bytearray(original)
    for _ in range(data.draw(st.integers(1, 3), label="mutations")):
        buf = _mutate(data, buf)
    return path, bytes(buf).decode("utf-8", "surrogateescape")


@settings(max_examples=600, **COMMON)
@given(data=st.data())
def test_mutated_corpus_files_fail_only_with_vrml_error(small_positives, data):
    path, text = _mutated(small_positives, data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vrml.VRMLWarning)
        try:
            result = vrml.loads(text, path=path)
        except vrml.VRMLError as e:
            assert e.line is not None, f"VRMLError without a line: {e}"
            event("rejected")
            return
    # Any other exception (IndexError, RecursionError, ...) propagates and fails.
    assert isinstance(result, Scene)
    event("accepted")


# -- our LALR loop against lark's own, the reference ----------------------------------------

def _with_both_loops(text: str, strict: bool = True, path=None) -> tuple:
    """(outcome with the reader's own LALR loop, outcome with lark's): a Scene, or the
    text of the VRMLError raised."""
    from mpeg4fba.vrml import reader

    def outcome():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", vrml.VRMLWarning)
            try:
                return vrml.loads(text, strict=strict, path=path)
            except vrml.VRMLError as e:
                return str(e)

    ours = outcome()
    saved = reader._parse
    reader._parse = lambda parser, text: parser.parse(text)
    try:
        theirs = outcome()
    finally:
        reader._parse = saved
    return ours, theirs


@settings(max_examples=20, **COMMON)
@given(data=st.data())
def test_generated_scenes_read_the_same_with_larks_loop(data):
    scene, _ = data.draw(scenes(name_shared=data.draw(st.booleans())))
    ours, theirs = _with_both_loops(vrml.dumps(scene))
    assert isinstance(ours, Scene) and ours == theirs


@settings(max_examples=120, **COMMON)
@given(data=st.data())
def test_mutated_files_read_or_fail_the_same_with_larks_loop(small_positives, data):
    path, text = _mutated(small_positives, data)
    strict = data.draw(st.booleans(), label="strict")
    ours, theirs = _with_both_loops(text, strict, path)
    assert ours == theirs
    event("same error" if isinstance(ours, str) else "same scene")
