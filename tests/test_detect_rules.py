"""The geometric rules of :mod:`mpeg4fba.cloning.detect` on small synthetic meshes whose
answers are known by construction: the mid-plane cut and profile (nose tip, lips, menton),
the mid plane, the eye opening seen from the front, the lips' groove, the points placed by
the landmark convention's proportions.  Units are the template's (eye separations, ES)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpeg4fba.cloning import convention as C
from mpeg4fba.cloning import detect as D
from mpeg4fba.cloning import frontview as F
from mpeg4fba.cloning import headframe as H
from mpeg4fba.cloning import midline as M


def _grid(x: np.ndarray, y: np.ndarray, z) -> tuple:
    """A triangulated height field z(x, y) over the grid ``x`` by ``y``: (V, T)."""
    X, Y = np.meshgrid(x, y, indexing="ij")
    V = np.c_[X.ravel(), Y.ravel(), z(X, Y).ravel()]
    nx, ny = len(x), len(y)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    b, c, d = a + ny, a + 1, a + ny + 1
    T = np.r_[np.c_[a, b, d], np.c_[a, d, c]]
    return V, T


def _bump(y, c, h, w):
    return h * np.exp(-0.5 * ((y - c) / w) ** 2)


def _face_profile(y, lip=0.10):
    """A face's mid-line profile z(y) (template frame): nose tip at y = -0.55, upper lip's
    front at -0.95 (height ``lip``), lips meeting at -1.05, lower lip at -1.15, chin at
    -1.5, its underside turning 45 degrees at about -1.66."""
    z = 1.0 + _bump(y, -0.55, 0.5, 0.1)
    z = z + _bump(y, -0.95, lip, 0.05) + _bump(y, -1.15, 0.08, 0.05)
    z = z + _bump(y, -1.5, 0.06, 0.12)
    z = z - 1.0 / (1.0 + np.exp((y + 1.70) / 0.03))        # under the chin
    return z


def _face(lip=0.10, resolution=0.01, extra=None):
    """:func:`_face_profile` (plus ``extra(Y)``, if given) on the mid line, its features
    narrowing away from it."""
    x = np.arange(-1.0, 1.0 + 1e-9, 0.05)
    y = np.arange(-2.4, 0.6 + 1e-9, resolution)

    def z(X, Y):
        relief = _face_profile(Y, lip) - 1.0 + (0.0 if extra is None else extra(Y))
        return 1.0 + relief * np.exp(-0.5 * (X / 0.25) ** 2) - 0.3 * X ** 2
    return _grid(x, y, z)


def _menton_y(lip=0.10) -> float:
    """Where the profile's fall (-dz/dy) first reaches 1 going up from under the chin."""
    y = np.arange(-1.9, -1.45, 1e-4)
    fall = np.gradient(_face_profile(y, lip), y)        # z falls as y falls: dz/dy > 0
    under = np.flatnonzero(fall >= 1.0)
    return float(y[under[-1]])


def test_plane_cut_lies_on_the_plane_and_counts_mid_line_vertices():
    V, T = _grid(np.linspace(-1, 1, 9), np.linspace(0, 1, 5), lambda X, Y: X * 0 + Y)
    for x0 in (0.3, 0.0):                     # 0.0: a column of vertices on the plane
        A, B = M.plane_cut(V, T, x0)
        assert len(A) > 0
        assert np.allclose(A[:, 0], x0) and np.allclose(B[:, 0], x0)
        # the cut covers the mesh's whole height
        ys = np.r_[A[:, 1], B[:, 1]]
        assert ys.min() == pytest.approx(0.0) and ys.max() == pytest.approx(1.0)


def test_profile_points_of_a_synthetic_face():
    V, T = _face()
    prof = M.profile(V, T, 0.6, -2.4)
    pts = M.profile_points(prof, 0.0)
    y = {k: p[1] for k, p in pts.items()}
    assert y["9.3"] == pytest.approx(-0.55, abs=0.04)
    assert -1.0 < y["8.1"] < -0.9
    assert y["2.2"] == y["2.3"] and -1.1 < y["2.2"] < -1.0          # lips closed
    assert -1.3 < y["8.2"] < y["2.3"]                              # below the meeting
    assert y["8.1"] < y["9.15"] < y["9.3"]                         # between nose and lip
    assert y["2.1"] == pytest.approx(_menton_y(), abs=0.03)          # the 45-degree turn
    # every point lies on the profile's front
    for k, p in pts.items():
        assert p[2] == pytest.approx(_face_profile(p[1]), abs=0.02), k


def test_mid_plane_search_keeps_the_frame_of_a_face_too_flat_across():
    # a ridge with no relief across: any plane square to x fits as well; the search
    # must not run away
    V, T = _grid(np.arange(-1, 1, 0.05), np.arange(-2, 0.6, 0.02),
                 lambda X, Y: _face_profile(Y) + 0 * X)
    A, b = H.mid_plane(V, T)
    assert np.degrees(np.arccos(np.clip(A[0, 0], -1, 1))) < 10.5


def test_an_upper_lip_as_forward_as_the_nose_is_not_the_nose_tip():
    # the lip stands within 0.05 ES of the tip's height: the tip is still the first
    # peak below the eye line that falls like a nose
    V, T = _face(lip=0.45)
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0)
    assert pts["9.3"][1] == pytest.approx(-0.55, abs=0.04)
    assert -1.0 < pts["8.1"][1] < -0.9


def test_parted_lips_give_two_inner_lip_points_either_side_of_the_gap():
    V, T = _face(resolution=0.005)
    # cut the lips apart: drop the triangles between y = -1.07 and -1.03 (a slit), and
    # let what shows through it lie deep inside (a mouth socket's back)
    c = V[T].mean(1)
    slit = (c[:, 1] > -1.07) & (c[:, 1] < -1.03)
    T = T[~slit]
    x = np.arange(-1.0, 1.0 + 1e-9, 0.05)
    Vb, Tb = _grid(x, np.arange(-1.2, -0.9, 0.01), lambda X, Y: X * 0 + 0.3)
    V2, T2 = np.vstack([V, Vb]), np.vstack([T, Tb + len(V)])
    pts = M.profile_points(M.profile(V2, T2, 0.6, -2.4), 0.0)
    assert pts["2.2"][1] > pts["2.3"][1]
    assert -1.04 < pts["2.2"][1] < -1.0 and -1.11 < pts["2.3"][1] < -1.06


def test_an_open_mouth_gives_inner_lip_points_either_side_of_its_opening():
    # the jaw dropped: a gap 0.17 ES tall (taller than a slit, SLIT_LIMIT) and the lower
    # lip below it 0.15 ES further back than it stands on a closed mouth, behind the
    # upper lip's front by more than a parting's depth (ICT's jawOpen at 0.3 does both:
    # read as closed lips, 2.3 went 17-21 % of the eye separation off)
    drop = lambda Y: np.where((Y < -1.2) & (Y > -1.65), -0.15 + _bump(Y, -1.27, 0.08, 0.04), 0.0)
    V, T = _face(resolution=0.005, extra=drop)
    c = V[T].mean(1)
    T = T[~((c[:, 1] > -1.2) & (c[:, 1] < -1.03))]
    Vb, Tb = _grid(np.arange(-1.0, 1.0 + 1e-9, 0.05), np.arange(-1.3, -0.9, 0.01),
                   lambda X, Y: X * 0 + 0.3)
    V2, T2 = np.vstack([V, Vb]), np.vstack([T, Tb + len(V)])
    pts = M.profile_points(M.profile(V2, T2, 0.6, -2.4), 0.0)
    assert -1.04 < pts["2.2"][1] < -1.0 and -1.23 < pts["2.3"][1] < -1.19
    assert pts["2.3"][2] > 0.8                                 # on the lip, not inside
    assert -1.4 < pts["8.2"][1] < pts["2.3"][1]


def test_the_fall_under_a_lower_lip_is_no_parting():
    # the lower lip's underside falls steeply (5 ES per ES) from y = -1.26, behind the
    # lips' front by more than a parting's depth within reach of the upper lip, and
    # stays back to the end of the search: no lower lip comes back below it, so it is no
    # gap between the lips, and the lips meet at the crease (a head of a fresh ICT draw,
    # seed 2041, had its underside read as the parting)
    V, T = _face(extra=lambda Y: -5.0 * np.clip(-1.26 - Y, 0, 0.12) * (Y > -1.6))
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0)
    assert pts["2.2"][1] == pts["2.3"][1] and -1.1 < pts["2.2"][1] < -1.0


def test_a_philtrum_crease_is_the_mouth_only_when_the_lips_crease_is_not():
    # a crease in the philtrum, above the upper lip's bump: taken for the lips' meeting
    # only when no groove runs the mouth's width from the crease below the bump
    V, T = _face(extra=lambda Y: _bump(Y, -0.88, -0.012, 0.012))
    prof = M.profile(V, T, 0.6, -2.4)
    everywhere = M.profile_points(prof, 0.0, lambda p: True)
    assert -1.1 < everywhere["2.2"][1] < -1.0                  # the lips' crease kept
    only_above = M.profile_points(prof, 0.0, lambda p: p[1] > -0.93)
    assert -0.93 < only_above["2.2"][1] < -0.84                # an upper lip with no bump


def test_a_flat_upper_lip_has_its_front_at_its_knee():
    # no upper-lip bump: a hollow under the nose, the lip flat down to a knee at -0.95
    # where it rolls in to the lips' meeting; the lower lip's bump is the first below
    # the nose, so the meeting is looked for above it, and the lip's front is the knee,
    # not where the nose's fall ends (a fresh ICT draw, seed 2043, put it there)
    def flat(Y):
        return 0.05 / (1 + np.exp(-(Y + 0.97) / 0.012)) - _bump(Y, -0.95, 0.10, 0.05)
    V, T = _face(extra=flat)
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0, lambda p: -1.1 < p[1] < -1.0)
    assert -1.1 < pts["2.2"][1] < -1.0
    assert -0.97 < pts["8.1"][1] < -0.91
    assert pts["8.1"][1] < pts["9.15"][1] < pts["9.3"][1]


def test_a_lower_lip_behind_the_chins_rise_is_still_the_lower_lip():
    # the chin stands 0.07 ES further forward than the lower lip, rising 0.2 ES below
    # the lips' meeting: 8.2 is on the lower lip's bump, not on the chin
    V, T = _face(extra=lambda Y: 0.15 / (1 + np.exp((Y + 1.24) / 0.015)) * (Y > -1.69))
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0)
    assert -1.22 < pts["8.2"][1] < -1.1


def test_a_shelf_under_the_chin_does_not_take_the_menton_down_the_throat():
    # the chin's underside falls 0.3 ES, stands on a shelf, then falls to the throat:
    # 2.1 is the chin's own 45-degree turn, not the top of the second fall (walking up
    # from under the chin stopped at the shelf: a fresh ICT draw, seed 7777, had 2.1
    # 55 % of the eye distance down the throat)
    shelf = lambda Y: 0.7 / (1 + np.exp((Y + 1.70) / 0.02)) - 0.7 / (1 + np.exp((Y + 1.95) / 0.02))
    V, T = _face(extra=shelf)
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0)
    assert -1.72 < pts["2.1"][1] < -1.6


def test_a_chin_with_no_front_of_its_own_turns_below_the_lower_lips_underside():
    # no chin bump: the lower lip's underside falls steeply past 0.25 ES below the lips'
    # meeting, then the chin slopes gently back to its turn under the chin; the chin's
    # front is where the lip's fall ends, and 2.1 the turn below it, not the lip's fall
    def retreating(Y):
        return (-_bump(Y, -1.5, 0.06, 0.12) - 0.08 / (1 + np.exp((Y + 1.31) / 0.012))
                - 0.3 * np.clip(-1.34 - Y, 0, 0.36))
    V, T = _face(extra=retreating)
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0)
    y = np.arange(-1.9, -1.4, 1e-4)[::-1]
    z = _face_profile(y) + retreating(y)
    turn = y[np.flatnonzero(np.gradient(z, y) >= 1.0)[0]]     # the first 45 degrees down
    assert pts["2.1"][1] == pytest.approx(turn, abs=0.03)


def test_menton_keeps_to_the_chin_above_the_hollow_where_the_throat_meets_it():
    # the chin falls 0.3 ES to a throat standing straight down: the hollow where they
    # meet turns through 45 degrees too, lower down (a jaw opened wide, ICT jawOpen 1.0,
    # had 2.1 put there, 30 % of the eye distance behind the chin)
    def shallow(Y):
        return 1.0 / (1 + np.exp((Y + 1.70) / 0.03)) - 0.3 / (1 + np.exp((Y + 1.70) / 0.015))
    V, T = _face(extra=shallow)
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0)
    assert "2.1" not in pts                             # no fall deep enough to be a chin's
    m = M.menton(V, T, pts)
    assert -1.70 < m[1] < -1.6                          # above the fall's steepest, -1.70


def test_a_lower_lip_with_no_fold_below_it_keeps_its_rim_off_the_chins_edge():
    # no labiomental fold: below the lower lip the profile falls all the way to the
    # chin's edge, 0.3 ES down, where it drops away (a jaw opened wide takes the chin
    # back under the lip); the edge bends more sharply than the lip's rim but is not it
    def no_fold(Y):
        return (-_bump(Y, -1.5, 0.06, 0.12) - 0.1 * np.clip(-1.15 - Y, 0, None)
                + 1.0 / (1 + np.exp((Y + 1.70) / 0.03)) - 1.0 / (1 + np.exp((Y + 1.45) / 0.02)))
    V, T = _face(extra=no_fold)
    pts = M.profile_points(M.profile(V, T, 0.6, -2.4), 0.0)
    assert -1.25 < pts["8.2"][1] < pts["2.3"][1]


def test_mid_plane_found_for_a_turned_shifted_symmetric_face():
    V, T = _face(resolution=0.02)
    turn = H.rotation(np.array([0.0, 1.0, 0.0]), np.radians(4.0))
    W = V @ turn.T + [0.04, 0.0, 0.0]
    A, b = H.mid_plane(W, T)
    back = W @ A.T + b
    # the nose tip, off the plane by 0.04 + 2 * sin(4 deg) before, is on it after
    tip = back[np.argmax(back[:, 2])]
    assert abs(tip[0]) < 0.01


def test_eye_opening_seen_from_the_front():
    # a flat skin (z = 1) with an elliptical hole: half width 0.17, half height 0.06
    V, T = _grid(np.arange(-0.2, 1.2, 0.01), np.arange(-0.5, 0.5, 0.01), lambda X, Y: X * 0 + 1.0)
    c = V[T].mean(1)
    hole = ((c[:, 0] - 0.5) / 0.17) ** 2 + (c[:, 1] / 0.06) ** 2 < 1.0
    T = T[~hole]
    got = F.eye_opening(V, T, np.array([0.5, 0.0, 1.0]), left=True)
    assert set(got) == {"out", "in", "top", "bottom"}
    assert got["out"][0] == pytest.approx(0.67, abs=0.02)
    assert got["in"][0] == pytest.approx(0.33, abs=0.02)
    assert got["top"][1] == pytest.approx(0.06, abs=0.02)
    assert got["bottom"][1] == pytest.approx(-0.06, abs=0.02)
    assert all(p[2] == pytest.approx(1.0) for p in got.values())
    # the right eye's corners the other way round
    got = F.eye_opening(V, T, np.array([0.5, 0.0, 1.0]), left=False)
    assert got["out"][0] < got["in"][0]
    # no opening: nothing
    V2, T2 = _grid(np.arange(-0.2, 1.2, 0.02), np.arange(-0.5, 0.5, 0.02), lambda X, Y: X * 0)
    assert F.eye_opening(V2, T2, np.array([0.5, 0.0, 0.0]), left=True) == {}


def test_the_eye_corners_do_not_follow_the_depth_grids_phase():
    """As the mouth's (below): an eye's opening shifted by sixths of a cell under the
    same search centre read its corners a cell apart on one grid; on EYE_PHASES phases,
    each point the median, within a quarter of that."""
    V, T = _grid(np.arange(-0.2, 1.2, 0.01), np.arange(-0.5, 0.5, 0.01),
                 lambda X, Y: 1.0 - 0.2 * (X - 0.5) ** 2)
    c = V[T].mean(1)
    T = T[((c[:, 0] - 0.5) / 0.17) ** 2 + (c[:, 1] / 0.06) ** 2 >= 1.0]
    spread = {}
    for phases in (1, F.EYE_PHASES):
        xs = []
        for s in np.linspace(0.0, F.DEPTH_CELL, 7)[:-1]:
            got = F.eye_opening(V + [s, 0.37 * s, 0.0], T, np.array([0.5, 0.0, 1.0]), left=True,
                                phases=phases)
            xs.append([got[k][0] - s for k in ("out", "in")])
        spread[phases] = np.ptp(np.array(xs), axis=0)
    assert (spread[1] > 0.5 * F.DEPTH_CELL).all()
    assert (spread[F.EYE_PHASES] < 0.5 * spread[1]).all()


def _two_eyes(inner: float, outer: float, y0: float = 0.0, height: float = 0.1):
    """A flat skin (z = 1) with a rectangular opening per eye from |x| = ``inner`` to
    ``outer``, ``height`` tall round y = ``y0``, and the template's eyes at y = 0."""
    V, T = _grid(np.arange(-1.0, 1.0, 0.01), np.arange(-0.7, 0.5, 0.01), lambda X, Y: X * 0 + 1.0)
    c = V[T].mean(1)
    hole = (np.abs(c[:, 0]) > inner) & (np.abs(c[:, 0]) < outer) & (np.abs(c[:, 1] - y0) < height / 2)
    tpl = SimpleNamespace(points={"3.7": np.array([0.65, 0, 1.0]), "3.11": np.array([0.27, 0, 1.0]),
                                  "3.12": np.array([-0.65, 0, 1.0]), "3.8": np.array([-0.27, 0, 1.0])})
    return V, T[~hole], tpl


def test_an_eye_opening_cut_short_gets_its_inner_corner_by_proportion():
    # an eye's opening: both corners where it ends
    V, T, tpl = _two_eyes(0.25, 0.65)
    got = F.eye_points(V, T, tpl)
    assert got["3.11"][0] == pytest.approx(0.25, abs=0.02)
    assert got["3.8"][0] == pytest.approx(-0.25, abs=0.02)
    # a coarse mesh's triangles bridge the lids at the inner corners: the openings end
    # 0.15 further out, too far for an eye (60 % of the outer corner's distance)
    V, T, tpl = _two_eyes(0.40, 0.65)
    got = F.eye_points(V, T, tpl)
    assert got["3.7"][0] == pytest.approx(0.65, abs=0.02)
    assert got["3.11"][0] == pytest.approx(F.INNER_CANTHAL_RATIO * got["3.7"][0], abs=0.005)
    assert got["3.8"][0] == pytest.approx(-F.INNER_CANTHAL_RATIO * got["3.7"][0], abs=0.02)
    assert got["3.11"][1] == pytest.approx(0.0, abs=0.06) and got["3.11"][2] == pytest.approx(1.0)


def test_an_inner_corner_moves_to_the_proportion_by_degrees():
    """Over INNER_CANTHAL_BAND the inner corner goes from the opening's end to the canthi's
    proportion in proportion: openings ending a hundredth further out each time move it by
    no more than that (a switch at one ratio moved it 6 % of the eye distance at once)."""
    xs = []
    for inner in np.arange(0.27, 0.39, 0.01):
        V, T, tpl = _two_eyes(inner, 0.65)
        xs.append(F.eye_points(V, T, tpl)["3.11"][0])
    steps = np.diff(xs)
    assert np.abs(steps).max() < 0.02
    assert xs[0] == pytest.approx(0.27, abs=0.01)                 # below the band: as read
    assert xs[-1] == pytest.approx(F.INNER_CANTHAL_RATIO * 0.65, abs=0.01)  # above: proportion


def test_an_inner_corner_moved_a_little_stays_on_the_face():
    """Moved only a little, an inner corner can still be over the opening, where the first
    skin seen from the front is the inside of the head: it keeps the opening end's depth
    (a fresh decimated ICT head had 3.8 put 2.6 eye separations behind its face so, and
    the whole head misread)."""
    back = _grid(np.arange(-1.0, 1.0, 0.05), np.arange(-0.7, 0.5, 0.05), lambda X, Y: X * 0 - 1.0)
    for inner in np.arange(0.28, 0.37, 0.0025):
        V, T, tpl = _two_eyes(inner, 0.65)
        got = F.eye_points(np.vstack([V, back[0]]), np.vstack([T, back[1] + len(V)]), tpl)
        assert got["3.11"][2] == pytest.approx(1.0) and got["3.8"][2] == pytest.approx(1.0), inner


def test_eyes_lower_than_the_templates_are_found():
    # the rigid fit leaves a long face's eyes up to a third of an eye separation below
    # the template's: the opening is searched that far
    V, T, tpl = _two_eyes(0.25, 0.65, y0=-0.3)
    got = F.eye_points(V, T, tpl)
    assert set(got) == {"3.7", "3.11", "3.1", "3.3", "3.12", "3.8", "3.2", "3.4"}
    assert got["3.1"][1] == pytest.approx(-0.25, abs=0.02)
    assert got["3.3"][1] == pytest.approx(-0.35, abs=0.02)


def _lip_groove_face(step: float) -> tuple:
    """(V, T): a face front (z = 1 - 0.3 x^2) with a groove 0.03 ES deep along y = -1.05
    for |x| < 0.35, fading over 0.02 ES beyond; columns ``step`` apart."""
    def z(X, Y):
        depth = 0.03 * np.clip((0.37 - np.abs(X)) / 0.02, 0, 1)
        return 1.0 - 0.3 * X ** 2 - depth * np.exp(-0.5 * ((Y + 1.05) / 0.015) ** 2)
    return _grid(np.arange(-0.8, 0.8 + 1e-9, step), np.arange(-1.3, -0.8, 0.005), z)


def test_lips_groove_ends_at_the_commissures():
    V, T = _lip_groove_face(0.01)
    got = F.mouth_points(V, T, np.array([0.0, -1.05, 1.0]))
    assert got["8.3"][0] == pytest.approx(0.36, abs=0.02)
    assert got["8.4"][0] == pytest.approx(-0.36, abs=0.02)
    assert got["2.4"][0] == pytest.approx(F.INNER_CORNER * got["8.3"][0], abs=0.015)
    assert 0.0 < got["2.6"][0] < got["2.4"][0]
    # no groove: no mouth
    V2, T2 = _grid(np.arange(-0.8, 0.8, 0.02), np.arange(-1.3, -0.8, 0.01),
                   lambda X, Y: 1.0 - 0.3 * X ** 2)
    assert F.mouth_points(V2, T2, np.array([0.0, -1.05, 1.0])) == {}


def test_the_mouth_corners_do_not_follow_the_depth_grids_phase():
    """One depth grid puts a groove's end on whichever cell it happens to fall in: the
    same face shifted by fractions of a cell read its commissures up to a cell apart.
    Read on several phases of the grid (MOUTH_PHASES), each point the median, they keep
    to a quarter of that."""
    V, T = _lip_groove_face(0.01)
    spread = {}
    for phases in (1, F.MOUTH_PHASES):
        xs = []
        for s in np.linspace(0.0, F.DEPTH_CELL, 7)[:-1]:
            d = np.array([s, 0.37 * s, 0.0])
            got = F.mouth_points(V + d, T, np.array([0.0, -1.05, 1.0]) + d, phases=phases)
            xs.append([got[k][0] - s for k in ("8.3", "8.4")])
        spread[phases] = np.ptp(np.array(xs), axis=0)
    assert (spread[1] > 0.5 * F.DEPTH_CELL).all()
    assert (spread[F.MOUTH_PHASES] < 0.5 * spread[1]).all()


def test_an_open_mouths_inner_corners_lie_between_its_lips():
    # the lips' groove of the test above, opened into a lens 0.16 ES tall at the mid
    # line that closes at the commissures: still 0.04 ES tall where the inner corners
    # go, which lie between the lips there, not on the upper lip's edge
    V, T = _lip_groove_face(0.005)
    c = V[T].mean(1)
    half = 0.08 * np.clip(1 - (c[:, 0] / 0.36) ** 2, 0, None)
    T = T[~(np.abs(c[:, 1] + 1.05) < half)]
    got = F.mouth_points(V, T, np.array([0.0, -1.05, 1.0]))
    assert got["8.3"][0] == pytest.approx(0.36, abs=0.02)
    assert got["2.4"][0] == pytest.approx(F.INNER_CORNER * got["8.3"][0], abs=0.015)
    for k in ("2.4", "2.5"):
        assert got[k][1] == pytest.approx(-1.05, abs=0.01), k
    assert got["2.6"][1] > -1.05 + 0.03 and got["2.8"][1] < -1.05 - 0.03


def test_convention_points_follow_their_proportions_on_a_flat_face():
    V, T = _grid(np.arange(-1.5, 1.5, 0.05), np.arange(-2.0, 1.0, 0.05), lambda X, Y: X * 0 + 1.0)
    pos = {"3.7": [0.7, 0, 1], "3.11": [0.3, 0, 1], "3.1": [0.5, 0.08, 1], "3.3": [0.5, -0.08, 1],
           "3.12": [-0.7, 0, 1], "3.8": [-0.3, 0, 1], "3.2": [-0.5, 0.08, 1],
           "3.4": [-0.5, -0.08, 1], "2.1": [0, -1.7, 1], "8.3": [0.35, -1.05, 1],
           "8.4": [-0.35, -1.05, 1], "8.1": [0, -0.95, 1], "8.2": [0, -1.2, 1],
           "9.15": [0, -0.75, 1]}
    pos = {k: np.array(v, dtype=float) for k, v in pos.items()}
    got = C.convention_points(V, T, pos, set(pos))
    assert set(got) == set(C.CONVENTION) | set(C.CONVENTION_RIGHT)
    _, a, b = C.CONVENTION["8.5"]                     # mid 8.1, corner 8.3
    assert got["8.5"][:2] == pytest.approx([a * 0.35, -1.05 + b * 0.1])
    _, a, b = C.CONVENTION["9.5"]                     # half the canthi's distance 0.7
    assert got["9.5"][:2] == pytest.approx([a * 0.7, -0.75 + b * 1.4])
    # left and right mirror each other, and all lie on the skin
    for k, m in C.CONVENTION_RIGHT.items():
        assert got[k] == pytest.approx(got[m] * [-1, 1, 1])
    assert all(p[2] == pytest.approx(1.0) for p in got.values())


def test_front_at_takes_the_most_forward_layer():
    V1, T1 = _grid(np.linspace(0, 1, 5), np.linspace(0, 1, 5), lambda X, Y: X * 0 + 0.2)
    V2, T2 = _grid(np.linspace(0, 1, 5), np.linspace(0, 1, 5), lambda X, Y: 0.5 + 0.1 * X)
    V, T = np.vstack([V1, V2]), np.vstack([T1, T2 + len(V1)])
    z = F.front_at(V, T, np.array([[0.5, 0.5], [2.0, 2.0]]))
    assert z[0] == pytest.approx(0.55) and np.isnan(z[1])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.integers(0, 4).map(float), st.floats(-3, 3), st.just(float("nan"))),
                max_size=40),
       st.sampled_from([0.0, 0.0005, 0.5, 1.0, 2.5]))
def test_the_profiles_peaks_are_scipys(values, prominence):
    """midline.find_peaks stands in for scipy.signal.find_peaks (whose import costs more
    than half a detection): the same peaks, plateaus, NaNs and prominences included."""
    from scipy.signal import find_peaks
    x = np.array(values, dtype=np.float64)
    want = find_peaks(x, prominence=prominence or None)[0]
    assert M.find_peaks(x, prominence).tolist() == want.tolist()


def test_no_module_imports_scipy_signal():
    """The import is what the stand-in saves (0.6 s of a first detection): no module of
    the package imports scipy.signal, at its top or inside a function."""
    import ast
    from pathlib import Path

    import mpeg4fba
    found = []
    for path in Path(mpeg4fba.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            if isinstance(node, ast.ImportFrom) and node.module == "scipy":
                names = [f"scipy.{a.name}" for a in node.names]
            found += [f"{path.name}:{node.lineno}" for n in names if n.startswith("scipy.signal")]
    assert found == []


def test_an_eye_shut_but_for_a_gap_at_one_end_is_no_eye_opening():
    """What a shut eye leaves open at one end (a fresh ICT draw's eyeBlink at 1: 0.15-0.17
    eye separations wide, 0.02-0.03 tall) is not read as the eye's opening, whose ends
    would be taken for its corners; an open eye's is 0.24 wide or more, or, where a coarse
    mesh bridges its ends, narrower but half as tall as wide."""
    every = {"3.7", "3.11", "3.1", "3.3", "3.12", "3.8", "3.2", "3.4"}
    V, T, tpl = _two_eyes(0.55 - 0.16, 0.55, height=0.03)
    assert F.eye_points(V, T, tpl) == {}
    V, T, tpl = _two_eyes(0.55 - 0.25, 0.55, height=0.03)
    assert set(F.eye_points(V, T, tpl)) == every
    V, T, tpl = _two_eyes(0.55 - 0.18, 0.55, height=0.09)
    assert set(F.eye_points(V, T, tpl)) == every


def test_nearly_shut_eyes_are_told_from_open_ones():
    V, T, tpl = _two_eyes(0.3, 0.62)                   # 0.1 tall, 0.32 wide: open
    assert F.shut_eyes(F.eye_points(V, T, tpl)) == {}
    V, T = _grid(np.arange(-1.0, 1.0, 0.01), np.arange(-0.7, 0.5, 0.01), lambda X, Y: X * 0 + 1.0)
    c = V[T].mean(1)
    slit = (np.abs(c[:, 0]) > 0.3) & (np.abs(c[:, 0]) < 0.62) & (np.abs(c[:, 1]) < 0.02)
    got = F.shut_eyes(F.eye_points(V, T[~slit], tpl))
    assert set(got) == {"left eye", "right eye"}
    assert all(r < F.EYE_SHUT_RATIO for r in got.values())
