"""Facial Motion Cloning on random ICT identity pairs (``benchmarks/bench_clone_pairs.py``):
the first pairs of the benchmark's regression draw, onto the full target and onto a copy
decimated by quadric edge collapse, scaling off.

Needs ``../shared/data/ict-facekit`` (skips without it), read in place.  The guards are
the figures these pairs give today with some room; issue 19's goals, not met yet, are
strict xfails, so meeting one fails the suite until the goal becomes a guard.
"""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import bench_clone_pairs as bp

#: How many pairs of the regression draw the suite clones (each onto two targets).
PAIRS = 2


@pytest.fixture(scope="module")
def results(ict_data) -> list:
    return [bp.measure(ict_data, a, b, kind, fraction, {})
            for a, b, fraction in bp.draw_pairs(bp.REGRESSION_SEED, PAIRS) for kind in bp.KINDS]


def test_the_draw_is_fixed_and_distinct():
    draw = bp.draw_pairs(bp.REGRESSION_SEED, 20)
    assert draw[:PAIRS] == bp.draw_pairs(bp.REGRESSION_SEED, PAIRS)
    seeds = [s for a, b, _ in draw for s in (a, b)]
    assert len(set(seeds)) == len(seeds)
    assert all(bp.FRACTION[0] <= f <= bp.FRACTION[1] for _, _, f in draw)
    assert bp.draw_pairs(bp.REGRESSION_SEED + 1, 3) != draw[:3]


def test_the_decimated_targets_are_another_topology_at_the_asked_fraction(ict_data):
    from benchmarks import ict
    vertices = ict.identity(ict_data, 5)
    full = ict.ict_face(ict_data, vertices)
    face, truth = bp.quadric_target(ict_data, vertices, 0.3, "decimated")
    n, n0 = len(face.meshes["Skin"].vertices), len(full.meshes["Skin"].vertices)
    assert 0.25 <= n / n0 <= 0.35
    assert truth.shape == (n, n0)
    assert np.allclose(np.asarray(truth.sum(axis=1)).ravel(), 1.0)
    # the feature points sit on vertices of the new skin, where the original ones were
    for k, (mesh, i) in face.points.vertices.items():
        if mesh == "Skin":
            assert np.allclose(face.meshes["Skin"].vertices[i], full.points[k])
    # the truth of a vertex is a point of the original skin near it
    near = truth @ full.meshes["Skin"].vertices
    iod = np.linalg.norm(full.points["3.5"] - full.points["3.6"])
    assert np.linalg.norm(near - face.meshes["Skin"].vertices, axis=1).max() < 0.05 * iod


def test_random_pairs_hold_todays_figures(results):
    """Guards: what the regression pairs give today, with some room (means 0.048 / 0.069
    % of the eye distance full, 0.043 / 0.058 decimated; largest errors 5.1 / 12.2 full,
    4.1 / 5.8 decimated, at the lips or the throat under jawOpen; at most 16 flips beyond
    the truth; lower teeth within 1.23 degrees)."""
    for r in results:
        assert r.mean <= 0.08, r
        assert r.max <= 15.0, r
        assert r.flipped <= 25, r
        assert r.teeth_deg <= 1.5, r
        assert r.region_max["brows"] <= 0.5, r


def _unmet(reason: str) -> pytest.MarkDecorator:
    return pytest.mark.xfail(strict=True, reason=f"issue 19's goal is not met: {reason}")


@pytest.mark.parametrize("goal, measure", [
    pytest.param("max_worst", "max", marks=_unmet(
        "largest error <= 4 % of the eye distance on every pair (lip corners under jawOpen)")),
    pytest.param("flipped", "flipped", marks=_unmet(
        "no more than 2 flipped triangles beyond the truth (full targets)")),
    pytest.param("teeth_deg", "teeth_deg", marks=_unmet(
        "lower teeth within 1 degree (one of the pairs: 1.23 degrees)")),
    pytest.param("mean", "mean", marks=_unmet(
        "mean <= 0.06 % of the eye distance on every pair (one full target: 0.070)")),
])
def test_goal(results, goal, measure):
    assert max(getattr(r, measure) for r in results) <= bp.GOALS[goal]
