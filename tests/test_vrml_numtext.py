"""The vectorised number writer gives exactly the text ``repr``/``str`` would."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra import numpy as hnp

from mpeg4fba import vrml
from mpeg4fba.vrml import numtext


def repr_join(x, per_line, indent):
    items = [r[:-2] if r.endswith(".0") else r for r in map(repr, x.tolist())]
    if not per_line:
        return " ".join(items)
    return (",\n" + indent).join(" ".join(items[i:i + per_line])
                                 for i in range(0, len(items), per_line))


def str_join(v, indent, faces):
    items = list(map(str, v.tolist()))
    nl = ",\n" + indent
    if faces:
        out = []
        for it in items:
            out += [it, nl if it == "-1" else " "]
        return "".join(out[:-1])
    return nl.join(" ".join(items[i:i + 16]) for i in range(0, len(items), 16))


EDGES = [0.0, -0.0, 1e-4, -1e-4, 9.999e-5, 1e-5, 2.0 ** 22, 2.0 ** 22 - 2 ** -30, 4194303.999999999,
         0.1 + 0.2, 1 / 3, 5e-324, 1.7976931348623157e308, 1e16, 123456.789, -7.0, 0.5, np.nan]


@pytest.mark.parametrize("per_line", [0, 1, 3, 4, 10])
def test_float_edges(per_line):
    x = np.array(EDGES * 3)
    assert numtext.float_text(x, per_line, "    ") == repr_join(x, per_line, "    ")


@settings(max_examples=150, deadline=None)
@given(hnp.arrays(np.float64, st.integers(1, 400),
                  elements=st.floats(allow_infinity=False, allow_nan=True)),
       st.sampled_from([0, 1, 2, 3, 4, 10]), st.integers(0, 8))
def test_float_any(x, per_line, indent):
    assert numtext.float_text(x, per_line, " " * indent) == repr_join(x, per_line, " " * indent)


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 500), st.integers(0, 9), st.integers(-3, 7), st.integers(0, 2 ** 32 - 1))
def test_float_decimals(n, decimals, scale, seed):
    """Numbers as files hold them: a few decimals, any magnitude."""
    rng = np.random.default_rng(seed)
    x = np.round(rng.normal(size=n) * 10.0 ** scale, decimals)
    assert numtext.float_text(x, 3, "  ") == repr_join(x, 3, "  ")
    assert np.array_equal(np.array(numtext.float_text(x, 0, "").split(), float), x)


@settings(max_examples=150, deadline=None)
@given(hnp.arrays(np.int64, st.integers(1, 400),
                  elements=st.integers(-2 ** 31, 2 ** 31 - 1) | st.just(-1)),
       st.booleans(), st.integers(0, 8))
def test_ints(v, faces, indent):
    assert numtext.int_text(v, " " * indent, faces) == str_join(v, " " * indent, faces)


def test_beyond_int32_and_empty():
    v = np.array([10 ** 15, -(10 ** 13), 5, -1, 0])
    assert numtext.int_text(v, "", True) == str_join(v, "", True)
    assert numtext.int_text(np.array([], int), "", False) == ""
    assert numtext.float_text(np.array([]), 3, "") == ""


def test_mesh_round_trip_same_text_both_ways():
    """A mesh long enough for the vectorised path writes what the short path would
    write for each piece, and reads back to the same numbers."""
    rng = np.random.default_rng(7)
    pts = np.round(rng.normal(size=(5000, 3)), 5)
    faces = np.concatenate([rng.integers(0, 5000, (3000, 3)), -np.ones((3000, 1), int)], 1)
    node = vrml.Node("IndexedFaceSet", coord=vrml.Node("Coordinate", point=pts),
                     coordIndex=faces.ravel())
    text = vrml.dumps(vrml.Scene([vrml.Node("Shape", geometry=node)]))
    back = vrml.loads(text).nodes[0]["geometry"]
    assert np.array_equal(back["coord"]["point"], pts)
    assert np.array_equal(back["coordIndex"], faces.ravel())
    assert "-1,\n      " in text and numtext.float_text(pts.ravel(), 3, "        ") in text
