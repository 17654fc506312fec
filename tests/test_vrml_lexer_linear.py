"""The VRML lexer is linear in its input, whatever the input.

Until 2026-12 the lexer's skip pattern was ``(?:[\\s,]+|COMMENT)*``: a run of n blanks
that a failing match backed out of was re-split in 2**n ways, so a valid file ending in
40 blanks took days.  Each case here would never end with that pattern; an alarm far
above the expected milliseconds (``_guards.alarm``) turns a hang into a failure.
"""
from __future__ import annotations

import pytest

from _guards import alarm

from mpeg4fba import vrml

HEADER = "#VRML V2.0 utf8\n"
N = 10_000


def blanks(n: int = N) -> str:
    return (" ,\t\n\r" * (n // 5 + 1))[:n]


@pytest.mark.parametrize("kind", ["spaces", "mixed"])
def test_trailing_blanks(kind):
    tail = " " * N if kind == "spaces" else blanks()
    with alarm():
        scene = vrml.loads(HEADER + "Group { children [ Shape {} ] }" + tail)
    assert len(scene.nodes) == 1


@pytest.mark.parametrize("failure, message", [
    ('"an unclosed string', "string not closed"),
    ("'", "unexpected character"),
    ("+", "unexpected character"),
    ("-", "unexpected character"),
    ("\udc81", "invalid UTF-8"),
])
@pytest.mark.parametrize("where", ["top", "in a node", "after a number"])
def test_blanks_before_each_lexing_failure(failure, message, where):
    body = {"top": "Group {}", "in a node": "Transform { translation 1 2 3",
            "after a number": "Transform { translation 1 2"}[where]
    text = HEADER + body + blanks() + failure
    with alarm(), pytest.raises(vrml.VRMLError) as err:
        vrml.loads(text)
    assert message in str(err.value)
    # the error points at the failure, after the blanks
    assert err.value.line == text.count("\n", 0, text.rindex(failure)) + 1


def test_alternating_comment_and_blank_runs():
    tail = "".join(f"# comment {i}  \n \t ,\n" for i in range(N // 4))
    with alarm():
        scene = vrml.loads(HEADER + "Group {}" + tail)
        assert len(scene.nodes) == 1
        with pytest.raises(vrml.VRMLError, match="unexpected character"):
            vrml.loads(HEADER + "Group {}" + tail + "'")


def test_blank_runs_inside_number_lists():
    numbers = "".join(f" {i} # c\n ,\t" for i in range(N // 4 // 3 * 3))
    text = (HEADER + "Shape { geometry PointSet { coord Coordinate { point [" + numbers + "]" + blanks() + "} } }"
            + blanks())
    with alarm():
        scene = vrml.loads(text)
    assert scene.nodes[0]["geometry"]["coord"]["point"].shape == (N // 4 // 3, 3)


def test_comment_lines_without_newline_at_the_end():
    with alarm():
        scene = vrml.loads(HEADER + "Group {}" + "\n#" * N)
    assert len(scene.nodes) == 1
