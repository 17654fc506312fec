"""Automatic feature points on ICT-FaceKit heads (the cases behind
``benchmarks/bench_find_points.py``), and the landmark -> feature point table they are
measured against.

Needs ``../shared/data/ict-facekit`` (skips without it), read in place.  The detector
tests also need ``mpeg4fba.cloning.detect`` (branch i18-detect) and skip without it.
Bounds are in % of the eye distance ES0, measured in the head's own frame.
"""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from benchmarks import ict
from benchmarks.ict_pick_points import PAIRS
from mpeg4fba.fba.tables import FEATURE_POINTS


@pytest.fixture(scope="module")
def data(ict_data):
    return ict_data


# -- the landmark table ---------------------------------------------------------------------------
def spec_side(fp: str) -> str:
    """"left", "right" or "mid" from the standard's description of ``fp`` (the face's
    own left): the side of the eye, lid or brow named, else of the end of a midpoint
    that is off the midline, else the first left/right word."""
    desc = FEATURE_POINTS[fp].description
    m = re.search(r"\b(left|right) (eye|eyebrow|eyelid)\b", desc)
    if m:
        return m.group(1)
    m = re.search(r"midpoint between (\d+\.\d+) and (\d+\.\d+)", desc)
    if m:
        sides = {spec_side(m.group(1)), spec_side(m.group(2))} - {"mid"}
        return sides.pop() if len(sides) == 1 else "mid"
    m = re.search(r"\b(left|right)\b", desc)
    return m.group(1) if m else "mid"


def test_spec_side_reads_the_descriptions():
    assert [spec_side(k) for k in ("3.8", "3.12", "4.1", "2.6", "8.5", "8.9", "3.1", "9.15")] == \
        ["right", "right", "left", "left", "left", "right", "left", "mid"]


def test_every_table_point_is_on_the_side_the_standard_says(data):
    """The face's own left is +x (ICT: +z toward the viewer); the generic head is
    symmetric, so a midline point is at x = 0."""
    pts = ict.landmark_points(data)
    es = float(np.linalg.norm(data.neutral[21458] - data.neutral[23028]))   # the pupils
    for fp, p in pts.items():
        side = spec_side(fp)
        if side == "left":
            assert p[0] > 0.01 * es, (fp, FEATURE_POINTS[fp].description, p)
        elif side == "right":
            assert p[0] < -0.01 * es, (fp, FEATURE_POINTS[fp].description, p)
        else:
            assert abs(p[0]) < 0.01 * es, (fp, FEATURE_POINTS[fp].description, p)


def test_table_points_lie_near_our_picked_points(data):
    """Each landmark point against our picked point (spec_fixtures/ict/feature_points.json)
    on the generic head, within LANDMARK_PICKED_TOLERANCE (cm): 0 where the picked point
    is the landmark; 1.0 to 3.2 mm where the rules differ (9.3: landmark 30 is 3 mm above
    the front-most vertex; lids: the lid landmarks' midpoint, not the pupil's slab)."""
    pts = ict.landmark_points(data)
    picked = ict.feature_point_ids()
    assert set(pts) == set(ict.LANDMARK_POINTS) <= set(picked)
    for fp, p in pts.items():
        d = float(np.linalg.norm(p - data.neutral[picked[fp]]))
        assert d <= ict.LANDMARK_PICKED_TOLERANCE[fp], (fp, d)


def test_table_points_mirror_in_pairs(data):
    pts = ict.landmark_points(data)
    for left, right in PAIRS:
        if left in pts and right in pts:
            assert np.allclose(pts[left], pts[right] * [-1, 1, 1], atol=0.005), (left, right)


def test_table_lip_and_lid_points_lie_on_the_right_sheet(data):
    """Upper-lip points barely move under jawOpen, lower-lip ones go down with the jaw;
    upper-lid points close under eyeBlink, lower-lid ones don't (the closed lips and the
    lids touch: a point between two landmarks could land on the other sheet)."""
    from mpeg4fba.cloning.surface import closest_points
    V = data.neutral
    lay = ict.mesh_layout(data)
    tris = lay.ids["Skin"][lay.triangles["Skin"]]
    pts = ict.landmark_points(data)
    ids = list(pts)
    t, b, d = closest_points(np.array([pts[k] for k in ids]), V, tris, k=16)
    assert d.max() < 1e-6                         # on the surface
    jaw = np.einsum("ij,ijc->ic", b, data.expressions["jawOpen"][tris[t]])[:, 1]
    blink_l = np.einsum("ij,ijc->ic", b, data.expressions["eyeBlink_L"][tris[t]])[:, 1]
    blink_r = np.einsum("ij,ijc->ic", b, data.expressions["eyeBlink_R"][tris[t]])[:, 1]
    move = dict(zip(ids, zip(jaw, blink_l, blink_r)))
    for fp in ("2.2", "2.6", "2.7", "8.1", "8.5", "8.6", "8.9", "8.10"):
        assert move[fp][0] > -1.0, (fp, move[fp])
    for fp in ("2.3", "2.8", "2.9", "8.2", "8.7", "8.8"):
        assert move[fp][0] < -2.0, (fp, move[fp])
    assert move["3.1"][1] < -0.5 and move["3.2"][2] < -0.5
    assert move["3.3"][1] > -0.2 and move["3.4"][2] > -0.2


def test_landmark_truth_is_the_table_where_it_defines_a_point(data):
    V = ict.identity(data, 5)
    given = ict.landmark_truth(data, V)
    pts = ict.landmark_points(data, V)
    picked = ict.feature_point_ids()
    for fp in given:
        want = pts[fp] if fp in pts else (V[picked[fp]] if fp in picked else None)
        if want is not None:
            assert np.allclose(given[fp], want), fp
    assert "7.1" in given and not given.vertices


# -- placements -----------------------------------------------------------------------------
def test_placements_are_supported_and_undone():
    rng = np.random.default_rng(3)
    P = np.random.default_rng(4).normal(size=(5, 3))
    for _ in range(50):
        pl = ict.random_placement(rng)
        R = pl.rotation
        assert np.allclose(R @ R.T, np.eye(3)) and np.isclose(np.linalg.det(R), 1.0)
        assert np.allclose(pl.undo(pl.apply(P)), P)
        up = np.degrees(np.arccos(np.clip(R[:, 1] @ ict.axis_vector(pl.up), -1, 1)))
        fwd = np.degrees(np.arccos(np.clip(R[:, 2] @ ict.axis_vector(pl.facing), -1, 1)))
        assert up <= ict.MAX_TILT + 1e-9 and fwd <= ict.MAX_TILT + 1e-9
        assert pl.scale in ict.SCALES


def test_placed_face_is_a_dumb_mesh(data):
    face = ict.ict_face(data)
    pl = ict.Placement("+Z", "-Y", 12.0, (0.0, 0.6, 0.8), 10.0, (1.0, 2.0, 3.0))
    out = ict.placed_face(face, pl, eyes=False)
    assert not len(out.points) and not out.regions and not len(out.fat.tables)
    assert set(out.meshes) == set(face.meshes) - set(ict.EYEBALLS)
    assert np.allclose(pl.undo(out.meshes["Skin"].vertices), face.meshes["Skin"].vertices)


# -- the detector on ICT heads ---------------------------------------------------------------------
#: (identity seed, variant (mesh, eyes), placement): three identities of the regression
#: draw, each full and decimated, with and without eyeballs, upright and lying, three
#: scales, tilted 0 to 20 degrees.
CASES = [
    (7301, ("full", True), ict.Placement("+Y", "+Z", 0.0, (1.0, 0.0, 0.0), 1.0, (0.0, 0.0, 0.0))),
    (7301, ("decimated", False), ict.Placement("+Z", "-X", 17.0, (0.6, 0.0, 0.8), 10.0, (50.0, -80.0, 20.0))),
    (7302, ("full", False), ict.Placement("+Z", "+Y", 9.0, (0.0, 0.8, 0.6), 0.1, (1.0, 1.0, -2.0))),
    (7302, ("decimated", True), ict.Placement("+Y", "-X", 20.0, (0.0, 0.0, 1.0), 10.0, (0.0, 30.0, 0.0))),
    (7303, ("full", True), ict.Placement("+Z", "-Y", 5.0, (0.0, 1.0, 0.0), 1.0, (-4.0, 2.0, 9.0))),
    (7303, ("decimated", False), ict.Placement("+Y", "+X", 14.0, (0.8, 0.6, 0.0), 0.1, (0.5, 0.0, 0.0))),
]
_FRACTION = 0.3


@pytest.fixture(scope="module")
def detect():
    return pytest.importorskip("mpeg4fba.cloning.detect",
                               reason="mpeg4fba.cloning.detect (branch i18-detect) is not merged")


@pytest.fixture(scope="module")
def detections(data, detect):
    """Per case: (identity vertices, truth face, the placed head, what the detector gave:
    its points in the placed head's frame, or the exception)."""
    out = []
    for seed, (mesh, eyes), pl in CASES:
        V = ict.identity(data, seed)
        truth = (ict.ict_face(data, V) if mesh == "full"
                 else ict.ict_face_decimated(data, V, _FRACTION, keep_ids=data.landmarks))
        world = ict.placed_face(truth, pl, eyes=eyes)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = detect.find_feature_points(world)
        except Exception as e:                               # noqa: BLE001 (asserted below)
            res = e
        out.append((V, truth, world, res))
    return out


@pytest.fixture(scope="module")
def found(data, detections):
    """Per case: (identity vertices, truth face, eyes, found points in the head frame or
    the exception, landmark errors % ES0)."""
    from mpeg4fba.fba.featurepoints import FeaturePointSet
    out = []
    for (_, (_, eyes), pl), (V, truth, _, res) in zip(CASES, detections):
        if isinstance(res, Exception):
            out.append((V, truth, eyes, res, {}))
            continue
        head = FeaturePointSet({k: pl.undo(res.points[k]) for k in res.points}, res.points.vertices)
        lm = ict.landmark_points(data, V)
        es = float(np.linalg.norm(truth.points["3.5"] - truth.points["3.6"]))
        err = {k: float(np.linalg.norm(head[k] - lm[k]) / es * 100) for k in lm if k in head}
        out.append((V, truth, eyes, head, err))
    return out


def test_every_head_gets_its_landmark_points(found):
    for (seed, variant, pl), (_, _, _, head, err) in zip(CASES, found):
        assert not isinstance(head, Exception), (seed, variant, pl.label, head)
        missing = sorted(set(ict.LANDMARK_POINTS) - set(err))
        assert not missing, (seed, variant, pl.label, missing)


def _all_errors(found) -> np.ndarray:
    return np.array([e for *_, err in found for e in err.values()])


def _worst(found) -> tuple:
    return max((v, k, CASES[i][0], CASES[i][1]) for i, (*_, err) in enumerate(found)
               for k, v in err.items())


#: Issue 18's goals for the found points against the landmark points (% ES0) and for
#: cloning with them against cloning with the landmark points (ratio, mean and max).
GOAL = {"median": 1.5, "p95": 4.0, "max": 8.0, "clone_mean": 1.25, "clone_max": 1.25}
#: What the detector meets today on CASES (measured, rounded up; the convention shifts of
#: detect and matched_points, after commit 238cd92: median 1.53, p95 4.19, max 9.9 % ES0
#: (9.4 of a decimated head); clone ratio 1.89 mean, 1.71 max; the mouth read on five
#: phases of the depth grid (frontview.MOUTH_PHASES): median 1.47 (the goal, met on
#: these heads), p95 4.06, max 9.85).  One head's max ratio
#: swings (1.05, 1.9, 1.8, 1.1, 0.77, 0.80, 1.71 over seven detect commits): the
#: benchmark's distribution over 40 pairs is the measure (median 1.77).  A regression
#: fails the plain tests; the goal tests are strict xfails while a goal is not met, so
#: they XPASS (and fail) once it is: then move MEETS.
MEETS = {"median": 1.5, "p95": 5.5, "max": 12.0, "clone_mean": 2.5, "clone_max": 2.5}
_NOT_YET = "the detector does not meet issue 18's goal yet (MEETS is what it meets)"


def _goal_params(keys):
    return [pytest.param(k, marks=pytest.mark.xfail(strict=True, reason=_NOT_YET))
            if MEETS[k] > GOAL[k] else k for k in keys]


def _stat(found, stat: str) -> float:
    e = _all_errors(found)
    return float({"median": np.median, "p95": lambda x: np.percentile(x, 95),
                  "max": np.max}[stat](e))


@pytest.mark.parametrize("stat", ["median", "p95", "max"])
def test_found_points_within_what_the_detector_meets(found, stat):
    assert _stat(found, stat) <= MEETS[stat], _worst(found)


@pytest.mark.parametrize("stat", _goal_params(["median", "p95", "max"]))
def test_found_points_within_the_goal(found, stat):
    """Issue 18: median <= 1.5 %, p95 <= 4 %, none over 8 % ES0."""
    assert _stat(found, stat) <= GOAL[stat], _worst(found)


@pytest.fixture(scope="module")
def cloned(data, detections, detect):
    """CASES[3] (ICT-7302, decimated, with eyeballs, lying, x10), cloned from ICT-1 in
    the head frame (eight expressions, scaling off) with the found points (in the
    source's convention, as ``clone`` puts them) and with the landmark points: (auto,
    landmark) results of bench_find_points.clone_error."""
    from benchmarks.bench_find_points import SOURCE_SEED, clone_error
    from mpeg4fba.cloning.autopoints import matched_points
    from mpeg4fba.fba.featurepoints import FeaturePointSet
    V, truth, world, got = detections[3]
    assert not isinstance(got, Exception), got
    eyes, pl = CASES[3][1][1], CASES[3][2]
    source = ict.ict_face(data, ict.identity(data, SOURCE_SEED))
    # as `mpeg4fba clone` does: the found points put in the source's convention
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        on_source = detect.find_feature_points(ict.placed_face(source, None))
    m = matched_points(world, got, source, source_found=on_source)
    auto = FeaturePointSet({k: pl.undo(m[k]) for k in m})
    return (clone_error(data, source, truth, auto, eyes),
            clone_error(data, source, truth, ict.landmark_truth(data, V), eyes))


def _ratio(cloned, which: str) -> float:
    auto, given = cloned
    assert "raised" not in auto and "raised" not in given, (auto, given)
    key = which.split("_")[1]
    return auto[key] / given[key]


@pytest.mark.parametrize("which", ["clone_mean", "clone_max"])
def test_cloning_with_found_points_within_what_the_detector_meets(cloned, which):
    assert _ratio(cloned, which) <= MEETS[which], cloned


@pytest.mark.parametrize("which", _goal_params(["clone_mean", "clone_max"]))
def test_cloning_with_found_points_within_the_goal(cloned, which):
    """Issue 18: cloning with found points within 1.25x of cloning with landmark points."""
    assert _ratio(cloned, which) <= GOAL[which], cloned


def test_a_head_without_eyeballs_says_where_its_pupils_are_or_that_they_are_missing(detections):
    assert not CASES[2][1][1]                                # ICT-7302, full, no eyeballs
    res = detections[2][3]
    assert not isinstance(res, Exception), res
    for fp in ("3.5", "3.6"):
        assert fp in res.points or (fp in res.missing and fp in res.reasons), fp


def test_the_benchmark_measures_given_points_as_exact(data):
    """The harness's own zero check: a stand-in "detector" that gives back the landmark
    points (placed like the head) scores 0 on every landmark point, on every surface, on
    the right side, for a head lying on its back at scale 10 without eyeballs."""
    from benchmarks import bench_find_points as bench
    det = bench.Detector("stand-in", None, lambda f, p, ids=(): (p, {}), (), False)
    ident = bench.draw_identity(data, 0, bench.REGRESSION_SEEDS[0])
    ident.placements[3] = CASES[1][2]
    res, head = bench.run_case(det, ident, 3)
    assert "raised" not in res and not res["landmark_missing"]
    assert max(res["errors"].values()) < 1e-9
    checks = res["plausibility"]["points"].values()
    assert all(r["on_surface"] and r["in_box"] and r.get("side_ok", True) for r in checks)


def test_teeth_points_lie_on_the_mid_line(found):
    """ICT's teeth have roots the template's lack, and its lower incisors sit behind the
    upper ones: every tooth is taken, each to its row, and the teeth points (midline
    points of the standard) are the incisors', not a molar's far to one side."""
    for (seed, variant, pl), (_, truth, _, head, _) in zip(CASES, found):
        es = float(np.linalg.norm(truth.points["3.5"] - truth.points["3.6"]))
        for k in ("9.8", "9.9", "9.10", "9.11"):
            assert k in head, (seed, variant, k)
            assert abs(head[k][0]) < 0.05 * es, (seed, variant, k, head[k][0] / es)
        # the upper row's points above the lower row's
        assert head["9.10"][1] > head["9.9"][1] and head["9.8"][1] > head["9.11"][1]


#: Heads of fresh benchmark draws (``bench_find_points --seed S``: the draw's case index
#: and head variant) the detector once misread as a whole: a lower lip's underside taken
#: for the lips' parting (2041/9 full), a philtrum's crease for the lips' meeting
#: (2041/15), the head frame upside down (2043/3, refused for want of a nose; 2046/14,
#: every point 1-3 eye separations off), the lips' groove walked off on a coarse lower
#: lip (2045/14), a retruded lower lip's 8.2 put on the chin (2043/1 with eyeballs) and
#: a flat upper lip's 8.1 at the nose's fall (2043/1 without), a ripple under the nose
#: taken for the upper lip's bump (2049/0).  Each is now read like the rest of its draw.
MISREAD = [(2041, 9, 0), (2041, 15, 3), (2043, 3, 1), (2046, 14, 3), (2045, 14, 1),
           (2043, 1, 1), (2043, 1, 3), (2049, 0, 1)]
#: No landmark point of these heads further than this (% ES0) from its landmark: the
#: misreadings put them 20-330 % off; the rest of their draws' heads stay under 14.
MISREAD_BOUND = 15.0


@pytest.mark.parametrize("draw,index,variant", MISREAD,
                         ids=[f"{d}-{i}-{v}" for d, i, v in MISREAD])
def test_heads_once_misread_are_read(data, detect, draw, index, variant):
    from benchmarks import bench_find_points as bench
    ident = bench.draw_identity(data, index, bench.fresh_seeds(draw, 20)[index])
    det = bench.load_detector()
    res, _ = bench.run_case(det, ident, variant)
    assert "raised" not in res, res["raised"]
    worst = max(res["errors"], key=res["errors"].get)
    assert res["errors"][worst] < MISREAD_BOUND, (worst, res["errors"][worst], res["placement"])


#: Open mouths: ICT's jawOpen added to a random person's neutral (the lips 0.1-0.6 eye
#: separations apart).  Read as closed lips, 2.3 went 17-21 % ES0 off at 0.3, and at 0.5
#: 8.2 went onto the back of the mouth (250 % off).
OPEN_MOUTHS = [(5353, 0.3), (6161, 0.6)]


def _posed(data, detect, seed: int, pose: dict) -> tuple:
    """(found points, id -> error against the landmarks in % ES0, landmarks) of person
    ``seed`` with ICT's expressions ``pose`` (name -> weight) added, unplaced."""
    V = ict.identity(data, seed) + sum(w * data.expressions[k] for k, w in pose.items())
    face = ict.ict_face(data, V)
    es = float(np.linalg.norm(face.points["3.5"] - face.points["3.6"]))
    lm = ict.landmark_points(data, V)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = detect.find_feature_points(ict.placed_face(face, None))
    return found, {k: float(np.linalg.norm(found.points[k] - lm[k]) / es * 100) for k in lm}, lm


@pytest.mark.parametrize("seed,jaw", OPEN_MOUTHS, ids=[f"{s}-jaw{j}" for s, j in OPEN_MOUTHS])
def test_an_open_mouth_is_read_and_said_to_be_open(data, detect, seed, jaw):
    from mpeg4fba.cli.points import describe_found
    found, err, lm = _posed(data, detect, seed, {"jawOpen": jaw})
    assert err["2.2"] < 5 and err["2.3"] < 5, err
    assert max(err.values()) < 10, max(err.items(), key=lambda kv: kv[1])
    gap = lm["2.2"][1] - lm["2.3"][1]
    assert found.points["2.2"][1] - found.points["2.3"][1] == pytest.approx(gap, rel=0.25)
    assert any("mouth is open" in n for n in found.notes)
    assert "note: the mouth is open" in describe_found(found, "the head")
    assert "open mouth" in found.reasons["2.3"]          # the editor shows it on the point
    # a closed mouth says nothing of the kind
    closed = detect.find_feature_points(ict.placed_face(ict.ict_face(data, ict.identity(data, seed)), None))
    assert closed.notes == ()


#: Chins read down the throat before their rule took the first 45-degree turn below the
#: chin's front (and the lower lip's rim the one above its underside's steepest fall):
#: jaws opened as wide as ICT's jawOpen goes (2.1 50-62 %, 8.2 44 % of the eye distance
#: off), and a closed mouth over a chin whose underside stands on a shelf (fresh draw
#: 7777's person 671399744: 2.1 55 % off).
CHINS = [(318855079, 1.0), (1829395269, 1.0), (671399744, 0.0)]


@pytest.mark.parametrize("seed,jaw", CHINS, ids=[f"{s}-jaw{j}" for s, j in CHINS])
def test_the_chin_is_read_on_the_chin(data, detect, seed, jaw):
    _, err, _ = _posed(data, detect, seed, {"jawOpen": jaw})
    assert err["2.1"] < 8 and err["8.2"] < 8, (err["2.1"], err["8.2"])


def test_closed_eyes_are_said(data, detect):
    # ICT's eyeBlink at full weight on both eyes: no opening is seen, and the lid points
    # (the fitted template's open lids, the upper ones 10 % of the eye distance high) are
    # flagged rather than given at the confidence of points read off the geometry
    found, _, _ = _posed(data, detect, 612987514, {"eyeBlink_L": 1.0, "eyeBlink_R": 1.0})
    assert any("no eye opening seen" in n for n in found.notes)
    assert max(found.confidence[k] for k in ("3.1", "3.2", "3.3", "3.4")) <= 0.2


#: Shut eyes that leave a gap: ICT's eyeBlink at 1 left the right eye of person
#: 1851174760 (fresh draw 4949) open at one end only, 0.16 eye separations wide, read as
#: the eye's opening (3.12 19 % of the eye distance off, nothing said).  (Eyes nearly
#: shut all along, read and said: test_find_points.py, on the reference head.)
SHUT_EYES = [(1851174760, "no eye opening seen at the left eye and the right eye")]


@pytest.mark.parametrize("seed,said", SHUT_EYES, ids=[str(s) for s, _ in SHUT_EYES])
def test_eyes_shut_but_for_a_gap_are_said(data, detect, seed, said):
    found, _, _ = _posed(data, detect, seed, {"eyeBlink_L": 1.0, "eyeBlink_R": 1.0})
    assert any(said in n for n in found.notes), found.notes
