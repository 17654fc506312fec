"""The VRML codec against the real-world corpus in ../shared/data/vrml-corpus.

Each MANIFEST.tsv row is one test case per property (parametrised in conftest.py;
without ../shared there is one skipped case and collection still works):

* positive: read strictly, round-trip to an equal scene, and the writer's output is
  a fixed point;
* negative: rejected with a VRMLError naming the file and a line;
* extension: rejected strictly naming a line and the non-VRML97 node type; read
  leniently with exactly one VRMLWarning per such node type, and round-trip.
"""
from __future__ import annotations

import re
import warnings
from collections import Counter

import pytest

from mpeg4fba import vrml

# Rows where the package is known to be wrong: (test name, local_path) -> reason.
CORPUS_XFAIL: dict = {}  # (test name, local_path) -> reason, for known bugs


def _mentions(message: str, word: str) -> bool:
    """``word`` appears in ``message`` as a whole name (case-sensitive)."""
    return re.search(r"(?<![\w])" + re.escape(word) + r"(?![\w])", message) is not None


def _load(path, strict=True):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vrml.VRMLWarning)
        return vrml.load(path, strict=strict)


# -- positive -----------------------------------------------------------------------------

@pytest.mark.corpus_role("positive")
def test_positive_reads_and_round_trips(corpus_row, corpus_dir):
    scene = _load(corpus_dir / corpus_row["local_path"])
    text = vrml.dumps(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vrml.VRMLWarning)
        again = vrml.loads(text)
    assert again == scene, "loads(dumps(scene)) differs from the scene read"
    assert vrml.dumps(again) == text, "dumps is not a fixed point"


def test_all_positives_accepted(corpus_manifest, corpus_dir):
    rows = [r for r in corpus_manifest if r["_role"] == "positive"]
    assert rows, "the manifest lists no positive files"
    accepted, failed = 0, []
    for r in rows:
        try:
            _load(corpus_dir / r["local_path"])
        except vrml.VRMLError as e:
            failed.append(str(e))
        else:
            accepted += 1
    assert accepted == len(rows), f"{len(failed)} positives rejected:\n" + "\n".join(failed)


# -- negative -----------------------------------------------------------------------------

def _assert_rejected_with_line(path):
    with pytest.raises(vrml.VRMLError) as info:
        _load(path)
    assert info.value.line is not None, f"no line in {info.value}"
    assert info.value.path == str(path)


@pytest.mark.corpus_role("negative")
def test_negative_rejected_with_line(corpus_row, corpus_dir):
    _assert_rejected_with_line(corpus_dir / corpus_row["local_path"])


# -- extension ----------------------------------------------------------------------------

@pytest.mark.corpus_role("extension")
def test_extension_strict_rejected_with_line(corpus_row, corpus_dir):
    _assert_rejected_with_line(corpus_dir / corpus_row["local_path"])


@pytest.mark.corpus_role("extension")
def test_extension_strict_error_names_node_type(corpus_row, corpus_dir):
    types = corpus_row["_types"]
    assert types, "an extension row must list its non-VRML97 node types"
    with pytest.raises(vrml.VRMLError) as info:
        _load(corpus_dir / corpus_row["local_path"])
    assert any(_mentions(info.value.message, t) for t in types), (
        f"the strict error names none of {types}: {info.value}")


@pytest.mark.corpus_role("extension")
def test_extension_lenient_warns_once_per_type(corpus_row, corpus_dir):
    types = corpus_row["_types"]
    assert types, "an extension row must list its non-VRML97 node types"
    with pytest.warns(vrml.VRMLWarning) as record:
        scene = vrml.load(corpus_dir / corpus_row["local_path"], strict=False)
    assert isinstance(scene, vrml.Scene)
    messages = [str(w.message) for w in record if issubclass(w.category, vrml.VRMLWarning)]
    counts = {t: sum(_mentions(m, t) for m in messages) for t in types}
    assert counts == {t: 1 for t in types}, (
        f"VRMLWarnings naming each type: {counts}; the warnings were:\n" + "\n".join(messages))


@pytest.mark.corpus_role("extension")
def test_extension_lenient_round_trips(corpus_row, corpus_dir):
    scene = _load(corpus_dir / corpus_row["local_path"], strict=False)
    text = vrml.dumps(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vrml.VRMLWarning)
        again = vrml.loads(text, strict=False)
    assert again == scene, "loads(dumps(scene), strict=False) differs from the scene read"
    assert vrml.dumps(again) == text, "dumps is not a fixed point"
    kinds = Counter(n.type for n in scene)
    assert all(kinds[t] for t in corpus_row["_types"]), (
        f"the lenient scene lost a non-VRML97 node: {corpus_row['_types']} vs {sorted(kinds)}")


# -- the reader's own LALR loop against lark's, on every file --------------------------------

def test_every_file_reads_the_same_with_larks_loop(corpus_manifest, corpus_dir):
    """lark's own parse loop is the reference for the reader's faster one: on every
    corpus file, strict and lenient, both give equal scenes or the same error."""
    from mpeg4fba.vrml import reader

    def outcome(path, strict):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", vrml.VRMLWarning)
            try:
                return vrml.load(path, strict=strict)
            except vrml.VRMLError as e:
                return str(e)

    rows = [(corpus_dir / r["local_path"], strict) for r in corpus_manifest
            for strict in ((True, False) if r["_role"] == "extension" else (True,))]
    ours = [outcome(p, s) for p, s in rows]
    saved = reader._parse
    reader._parse = lambda parser, text: parser.parse(text)
    try:
        theirs = [outcome(p, s) for p, s in rows]
    finally:
        reader._parse = saved
    differ = [str(p) for (p, _), a, b in zip(rows, ours, theirs) if a != b]
    assert not differ, f"{len(differ)} of {len(rows)} files differ: {differ[:5]}"
    assert sum(isinstance(a, vrml.Scene) for a in ours) > len(rows) // 2
