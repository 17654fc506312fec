"""Facial Motion Cloning on ICT-FaceKit identities (the cases behind the figures of
``benchmarks/bench_clone_ict.py``), kept as checks so the figures can't slip back.

Needs ``../shared/data/ict-facekit`` (skips without it), read in place.  ICT's
expressions are the same deltas on every identity, so with ``scale_motion=False`` the
truth of every target vertex is its own original's delta.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from benchmarks import ict
from benchmarks.bench_clone_ict import EXPRESSIONS, evaluate
from mpeg4fba.cloning import LOWER, UPPER, FacialMotionCloner


@pytest.fixture(scope="module")
def data(ict_data):
    return ict_data


def _clone(data, a: int, b: int) -> tuple:
    source = ict.ict_face(data, ict.identity(data, a), name=f"ICT-{a}")
    target = ict.ict_face_decimated(data, ict.identity(data, b), 0.25, name=f"ICT-{b}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return source, target, FacialMotionCloner(source, target, scale_motion=False)


def _row(face, skin: dict, ict_id: int) -> int:
    """The cloner's row (``skin``: its source_skin or target_skin) of an original vertex."""
    first, _ = skin["Skin"]
    ids = face.regions[ict.IDS_PREFIX + "Skin"]
    return first + int(np.flatnonzero(ids == ict_id)[0])


def test_a_sliver_off_the_lip_corner_stays_on_its_lip(data):
    """Decimated 7 -> 8: vertex 6072 of the upper lip, 2 mm inside the mouth, hangs off
    the lip corner 2.4 by one sliver.  Settled through the corner it went to the lower
    lip and took its motion under jawOpen, 24 % of the eye distance off."""
    source, target, c = _clone(data, 7, 8)
    assert c.source_regions[_row(source, c.source_skin, 6072)] == UPPER
    assert c.target_regions[_row(target, c.target_skin, 6072)] == UPPER
    res = evaluate(c, source, target, ["jawOpen"], data)["jawOpen"]
    assert res["all"][2] < 2.5, res["all"]          # was 24.05 % IOD; now 2.11
    assert res["flipped"][0] <= res["flipped"][1]


def test_decimated_pair_meets_the_mean_and_flip_goals(data):
    """ICT 1 -> 2, decimated target, scaling off (the issue's table): mean <= 0.10 %
    IOD and no more flipped triangles than the truth over the eight expressions.  The
    largest error, 2.36 % against a goal of 2.0, is held under 2.5 so it can't slip
    back."""
    source, target, c = _clone(data, 1, 2)
    res = evaluate(c, source, target, list(EXPRESSIONS), data)
    means = [row["all"][0] for row in res.values()]
    assert np.mean(means) <= 0.10
    assert max(row["flipped"][0] - row["flipped"][1] for row in res.values()) <= 0
    assert max(row["all"][2] for row in res.values()) < 2.5
    # the lip regions of the two lips are both present on the target
    first, n = c.target_skin["Skin"]
    labels = c.target_regions[first:first + n]
    assert (labels == UPPER).sum() > 20 and (labels == LOWER).sum() > 20
