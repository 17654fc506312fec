"""The skin seen from the front: depth maps of the detector's template frame (x the
face's left, y up, z forward; units of the eye separation), and the openings read off
them: each eye's lid margins (corners and lid middles) and the lips' contact groove with
the mouth's corners and inner-lip points (steps 5 and 6 of
:mod:`mpeg4fba.cloning.detect`).

>>> V = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.5], [-1.0, 1.0, 0.5]])
>>> T = np.array([[0, 1, 2], [0, 2, 3]])
>>> front_at(V, T, np.array([[0.0, 0.0], [0.0, 0.5], [3.0, 0.0]])).round(3).tolist()
[0.25, 0.375, nan]
"""
from __future__ import annotations

from typing import Optional

import numpy as np

__all__ = ["depth_map", "front_at", "groove", "mouth", "mouth_points", "eye_points",
           "eye_opening", "DEPTH_CELL", "INNER_CORNER", "EYE_KEYS", "PUPIL_OPENINGS",
           "INNER_CANTHAL_RATIO",
           "INNER_CANTHAL_BAND", "front_samples", "MOUTH_PHASES", "EYE_PHASES", "EYE_GAP",
           "EYE_SHUT_RATIO", "shut_eyes", "eye_findings"]


#: Cell size (eye separations) of the front-view depth maps of the eyes: 0.01 ES.
DEPTH_CELL = 0.01


def depth_map(Vt: np.ndarray, T: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              cell: float = DEPTH_CELL, samples: Optional[np.ndarray] = None) -> np.ndarray:
    """The skin seen from the front (+z) in the box ``lo``..``hi`` (template frame):
    (nx, ny) grid of the most forward z of the triangles over each cell centre, NaN where
    no triangle is.  Each triangle in the box is sampled on a barycentric lattice fine
    enough for the cell size (its longest edge over half a cell), so a decimated mesh's
    large triangles leave no gaps.  ``samples``: those of a box holding this one
    (:func:`front_samples`), when several maps are read there."""
    nx = int(np.ceil((hi[0] - lo[0]) / cell))
    ny = int(np.ceil((hi[1] - lo[1]) / cell))
    Q = front_samples(Vt, T, lo, hi, cell) if samples is None else samples
    out = np.full((nx, ny), -np.inf)
    ix = np.floor((Q[:, 0] - lo[0]) / cell).astype(int)
    iy = np.floor((Q[:, 1] - lo[1]) / cell).astype(int)
    ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny) & (Q[:, 2] >= lo[2])
    np.maximum.at(out, (ix[ok], iy[ok]), Q[ok, 2])
    out[~np.isfinite(out)] = np.nan
    return out


def front_samples(Vt: np.ndarray, T: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  cell: float = DEPTH_CELL) -> np.ndarray:
    """(k, 3) points sampling the triangles that meet the box ``lo``..``hi`` (see
    :func:`depth_map`; ``samples=`` takes them, so that several depth maps within one box
    share them)."""
    P = Vt[T]                                             # (m, 3, 3)
    inb = ((P[:, :, 0].max(1) >= lo[0]) & (P[:, :, 0].min(1) <= hi[0])
           & (P[:, :, 1].max(1) >= lo[1]) & (P[:, :, 1].min(1) <= hi[1])
           & (P[:, :, 2].max(1) >= lo[2]))
    P = P[inb]
    if not len(P):
        return np.empty((0, 3))
    edge = np.linalg.norm(P - P[:, [1, 2, 0]], axis=2).max(1)
    nsub = np.clip(np.ceil(edge / (0.5 * cell)).astype(int), 1, 64)
    out = []
    for n in np.unique(nsub):
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = i + j <= n
        a, b = i[keep] / n, j[keep] / n
        w = np.c_[1 - a - b, a, b]                        # (k, 3)
        out.append(np.einsum("kv,mvc->mkc", w, P[nsub == n]).reshape(-1, 3))
    return np.concatenate(out)


def front_at(Vt: np.ndarray, T: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(k,) the most forward z of the skin over each point ``xy`` (k, 2) (template frame),
    NaN where no triangle is over it."""
    P = Vt[T]
    out = np.full(len(xy), np.nan)
    lo, hi = P[:, :, :2].min(1), P[:, :, :2].max(1)
    for n, q in enumerate(xy):
        m = np.flatnonzero(np.all((lo <= q) & (hi >= q), axis=1))
        if not len(m):
            continue
        a, b, c = P[m, 0], P[m, 1], P[m, 2]
        v0, v1, v2 = b[:, :2] - a[:, :2], c[:, :2] - a[:, :2], q - a[:, :2]
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        ok = np.abs(den) > 1e-15
        den = np.where(ok, den, 1.0)
        u = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        v = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        inside = ok & (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9)
        if inside.any():
            z = (a[:, 2] + u * (b[:, 2] - a[:, 2]) + v * (c[:, 2] - a[:, 2]))[inside]
            out[n] = z.max()
    return out


#: Where Multi-PIE's inner lip corners (landmarks 60/64, MPEG-4 2.4/2.5) lie on a closed
#: mouth, as a fraction of the way from the mid line to the commissure along the lips'
#: contact groove: 0.875 (the inner corners sit an eighth of the mouth's half width
#: inside the commissures: 0.86-0.89 on ICT-FaceKit identities, measured on the mean
#: face and four random identities; a closed mouth's contact line has no geometric mark
#: there, and a slit between the lips seen from the front ends anywhere from a third to
#: two thirds of the way out, so it marks nothing either).
INNER_CORNER = 0.875


def _rows_near(D: np.ndarray, i: int, j: int, reach: int) -> Optional[np.ndarray]:
    """The rows a groove walk weighs in column ``i`` of the depth map ``D``: within two
    of the last cell's row ``j`` and ``reach`` or more from the map's top and bottom (a
    cell's neighbours ``reach`` above and below must exist); None past the map's side
    or with no such row."""
    if not 0 <= i < D.shape[0]:
        return None
    js = np.arange(max(j - 2, reach), min(j + 3, D.shape[1] - reach))
    return js if len(js) else None


def groove(D: np.ndarray, i: int, j: int, step: int, reach: int = 3,
           depth: float = 0.01, slack: int = 3, contrast: bool = False) -> list:
    """The cells (i, j) of the groove of the depth map ``D`` (front-view z, -inf where
    empty) followed from (i, j) along x (``step`` = +-1): at each column the deepest cell
    within two cells of the last one's height (an empty cell is deepest: an opening), or
    with ``contrast`` the one lying deepest behind the mean of the cells ``reach`` rows
    above and below it (an empty cell most of all).  A
    column is strong where that cell lies ``depth`` (0.01 ES, 0.6 mm) or more behind the
    mean of the cells ``reach`` rows above and below it, faint where less than half that
    (the smooth skin beyond the groove's end).  The groove is followed through columns
    between the two (a lip line that runs shallow for a stretch: a smooth model's lips
    meet 0.009-0.010 ES deep near the mid line) and across up to ``slack`` faint ones in a
    row (a decimated mesh's facets make a shallow groove flicker); it ends at its last
    strong cell, and is [] unless half its columns or more are strong."""
    out, pending, faint, strong = [], [], 0, 0
    for _ in range(D.shape[0]):
        i += step
        js = _rows_near(D, i, j, reach)
        if js is None:
            break
        # each candidate's depth behind the mean of its rows ``reach`` above and below
        # (an empty cell: infinitely deep; a neighbour missing: not a groove)
        z, up, dn = D[i, js], D[i, js + reach], D[i, js - reach]
        with np.errstate(invalid="ignore"):
            cs = np.where(~np.isfinite(z), np.inf,
                          np.where(np.isfinite(up) & np.isfinite(dn), 0.5 * (up + dn) - z, -np.inf))
        k = int(np.argmax(cs)) if contrast else int(np.argmin(z))
        jb, c = int(js[k]), float(cs[k])
        if c >= depth:
            out.extend(pending)
            out.append((i, jb))
            pending, faint = [], 0
            strong += 1
        else:
            pending.append((i, jb))
            faint = faint + 1 if c < 0.5 * depth else 0
            if faint > slack:
                break
        j = jb
    return out if 2 * strong >= len(out) else []


def mouth_points(Vt: np.ndarray, T: np.ndarray, stomion: np.ndarray,
                 phases: Optional[int] = None) -> dict:
    """The mouth's points of :func:`mouth` (without the lips' edges)."""
    return mouth(Vt, T, stomion, phases=phases)[0]


#: On how many phases of the depth map's grid :func:`mouth` reads the mouth (the grid
#: shifted by fractions of a cell along x and y), each point the median of its readings.
#: One grid's cells put a point where the groove's cells happen to fall: the same heads
#: in a head frame a hair different moved mouth points by up to 9 % of the eye distance.
#: Five phases, on the regression draw's 80 heads (points only): all points' median / p95
#: 1.49 / 4.68 -> 1.44 / 4.56 % ES0, the full heads' inner lips' p95 2.3-2.7 -> 1.5-1.9; on
#: a fresh draw (seed 4701) 1.43 / 4.87 -> 1.39 / 4.69; three phases gave 1.46 / 4.61 on the
#: regression draw.  The phases share one sampling of the skin (:func:`front_samples`);
#: each costs a binning of it and a groove.
MOUTH_PHASES = 5


def _grid_shifts(n: int) -> list:
    """``n`` sub-cell shifts of the depth map's grid (template frame), the first none:
    evenly along x, by steps of 0.618 of a cell (the golden ratio's) along y."""
    return [np.array([DEPTH_CELL * k / n, DEPTH_CELL * ((k * 0.618) % 1.0), 0.0])
            for k in range(n)]


def _phase_median(first: dict, read, n: int) -> dict:
    """Each point of ``first`` (``read(0)``, a reading on the depth map's own grid) as the
    median of its readings ``read(d)`` on ``n`` phases ``d`` of the grid
    (:func:`_grid_shifts`), where half of them or more found it; else as first read."""
    if n <= 1 or not first:
        return first
    runs = [first]
    for d in _grid_shifts(n)[1:]:
        runs.append(read(d))
    out = {}
    for k in first:
        P = np.array([r[k] for r in runs if k in r])
        out[k] = np.median(P, axis=0) if 2 * len(P) > n else first[k]
    return out


def mouth(Vt: np.ndarray, T: np.ndarray, stomion: np.ndarray, gap: float = 0.0,
          phases: Optional[int] = None) -> tuple:
    """(points, lip edges) read on :data:`MOUTH_PHASES` (or ``phases``) phases of the
    depth map's grid, each point the median of the phases that found it (those of half of
    them or more; else the first phase's), the lip edges the first phase's: see
    :func:`_mouth_once`."""
    n = MOUTH_PHASES if phases is None else max(1, int(phases))
    lo, hi = _mouth_box(stomion, gap)
    # (one sampling of the skin for every phase, in a box a cell wider)
    Q = front_samples(Vt, T, lo - DEPTH_CELL, hi + DEPTH_CELL)
    points, edges = _mouth_once(Vt, T, stomion, gap, samples=Q)
    return _phase_median(points, lambda d: _mouth_once(Vt, T, stomion, gap, d, Q)[0], n), edges


def _mouth_box(stomion: np.ndarray, gap: float, mid: float = 0.0) -> tuple:
    """(lo, hi) of the mouth's depth map: the mouth's width either side of the mid line
    (at x = ``mid``), both lips (``gap`` apart there) and a margin above and below."""
    half = max(0.2, 0.5 * gap + 0.1)
    return (np.array([mid - 0.75, stomion[1] - half, stomion[2] - 0.6]),
            np.array([mid + 0.75, stomion[1] + half]))


def _mouth_once(Vt: np.ndarray, T: np.ndarray, stomion: np.ndarray, gap: float = 0.0,
                shift: Optional[np.ndarray] = None, samples: Optional[np.ndarray] = None) -> tuple:
    """(points, lip edges): the mouth's corners from the lips' contact groove seen from the front (template
    frame): the groove (:func:`groove`) of the skin's depth map followed from the
    stomion (the profile's lips' meeting) to each side; its ends are the commissures
    (8.3, 8.4: the outer corners); the inner corners (2.4, 2.5) are the groove's points
    :data:`INNER_CORNER` of the way out; 2.6-2.9 (the inner lips'
    midpoints) on the groove half way to the inner corners: its edges above and below
    where it is open there, a cell (0.01 ES) above and below its bottom where closed.
    The lip edges, "upper lip" and "lower lip", are the (k, 3) polylines so taken at
    every column of the groove, from the right corner to the left: where each lip meets
    the other or ends at the opening, seen from the front.  ({}, {}) without a groove a
    mouth's width (0.45 to 1.4 ES) whose ends lie symmetrically about the mid line
    (within 15 % of its width).  ``gap``: how far apart the lips are at the mid line
    (an open mouth's), so that the map reaches both.  ``shift``: read on the grid moved
    by ``-shift`` (the stomion and the mid line with it: as if the skin were moved by
    ``shift``, the points moved back); ``samples``: :func:`front_samples` of the box."""
    d = np.zeros(3) if shift is None else np.asarray(shift, dtype=np.float64)
    stomion, mid = stomion - d, -d[0]     # (mid: the mid line's x)
    lo, hi = _mouth_box(stomion, gap, mid)
    D = depth_map(Vt, T, lo, hi, samples=samples)
    F = np.where(np.isnan(D), -np.inf, D)
    i0 = int((mid - lo[0]) / DEPTH_CELL)
    j0 = int((stomion[1] - lo[1]) / DEPTH_CELL)
    # the deepest cells followed; where that gives no mouth, the cells deepest against
    # their neighbours above and below (a coarse lower lip's facet sloping back below
    # the groove can lead the deepest-cell walk off it: a fresh ICT draw, seed 2045, had
    # its mouth read in the lower lip's fold so).  Not first: on the regression draw's
    # decimated heads it puts the corners further off (mouth corners' max 6.1 -> 12.8).
    for contrast in (False, True):
        sides = {}
        for name, step in (("left", 1), ("right", -1)):
            g = groove(F, i0, j0, step, contrast=contrast)
            if g:
                sides[name] = g
        if len(sides) < 2:
            continue
        width = (sides["left"][-1][0] - sides["right"][-1][0]) * DEPTH_CELL
        skew = (sides["left"][-1][0] + sides["right"][-1][0] - 2 * i0) * DEPTH_CELL
        if 0.45 <= width <= 1.4 and abs(skew) <= 0.15 * width:
            break
    else:
        return {}, {}
    cx = lambda i: lo[0] + (i + 0.5) * DEPTH_CELL
    cy = lambda j: lo[1] + (j + 0.5) * DEPTH_CELL

    def at(i, j, dj=0):
        # the surface point at cell (i, j): its depth, or the first filled cell in dj
        while not np.isfinite(F[i, j]) and dj and 0 <= j + dj < F.shape[1]:
            j += dj
        return np.array([cx(i), cy(j), F[i, j]]) if np.isfinite(F[i, j]) else None

    out = {}
    for name, (outer, inner, up, dn) in (("left", ("8.3", "2.4", "2.6", "2.8")),
                                         ("right", ("8.4", "2.5", "2.7", "2.9"))):
        g = sides[name]
        ie, je = g[-1]
        p = at(ie, je)
        if p is not None:
            out[outer] = p
        # (not the end of an opening seen from the front: lips modelled as two sheets
        # leave a slit a third to two thirds of the way out, and ICT's inner corners stay
        # 0.045-0.055 ES inside the commissures whether or not it is there)
        k = int(np.argmin([abs(abs(cx(i) - mid) - INNER_CORNER * abs(cx(ie) - mid))
                           for i, _ in g]))
        ic, jc = g[k]
        if np.isfinite(F[ic, jc]):
            p = at(ic, jc)
        else:
            # open there: between the lips' edges above and below
            pu, pd = at(ic, jc, 1), at(ic, jc, -1)
            p = None if pu is None or pd is None else 0.5 * (pu + pd)
        if p is not None:
            out[inner] = p
        # half way along the groove (arc length, in 3D) to the inner corner
        pts = [at(i, j, 1) for i, j in g[:k + 1]]
        ok = [q is not None for q in pts]
        Q = np.array([q for q in pts if q is not None])
        if len(Q) < 2:
            continue
        arc = np.r_[0, np.cumsum(np.linalg.norm(np.diff(Q, axis=0), axis=1))]
        h = int(np.flatnonzero(ok)[np.argmin(np.abs(arc - 0.5 * arc[-1]))])
        ih, jh = g[h]
        if np.isfinite(F[ih, jh]):
            # closed there: a cell off the groove's bottom, on each lip (the bottom itself
            # is where both lips touch, and a point there belongs to neither)
            pu, pd = at(ih, jh + 1), at(ih, jh - 1)
        else:
            pu, pd = at(ih, jh, 1), at(ih, jh, -1)
        if pu is not None and pd is not None:
            out[up], out[dn] = pu, pd
    edges: dict = {"upper lip": [], "lower lip": []}
    for i, j in sides["right"][::-1] + sides["left"]:
        closed = np.isfinite(F[i, j])
        for name, dj in (("upper lip", 1), ("lower lip", -1)):
            p = at(i, j + dj) if closed else at(i, j, dj)
            if p is not None:
                edges[name].append(p)
    return out, {k: np.array(v) for k, v in edges.items() if len(v) >= 2}


#: Each eye's lid-margin points: outer corner, inner corner, upper and lower lid middles.
EYE_KEYS = {"left eye": ("3.7", "3.11", "3.1", "3.3"), "right eye": ("3.12", "3.8", "3.2", "3.4")}
#: Each pupil's eye opening: its corners and lid middles.
PUPIL_OPENINGS = {"3.5": EYE_KEYS["left eye"], "3.6": EYE_KEYS["right eye"]}


#: The inner canthi's distance over the outer canthi's (3.11-3.8 over 3.7-3.12): 0.412 on
#: 40 random ICT-FaceKit identities (sd 0.023, range 0.36-0.45); adult anthropometry
#: gives 0.35-0.37 (about 32 mm between the inner canthi, 90 mm between the outer).
INNER_CANTHAL_RATIO = 0.41
#: An eye opening that ends further from the mid line than a fraction of its outer corner's
#: distance in this band is less and less likely the whole eye: a coarse mesh's triangles
#: bridge the lids near the inner corner, and the opening seen from the front stops up to
#: 0.15 eye separations short of it.  Over the band the inner corner is moved from the
#: opening's end to :data:`INNER_CANTHAL_RATIO` of the way, in proportion (all the way
#: beyond it).  The band straddles 0.5, 4 sd above the ICT mean (300 random identities,
#: 600 eyes: 0.412, sd 0.023, largest 0.49; people's are lower still), where a switch
#: was until 2026-12-07: a reading either side of it put the corner 6 % of the eye
#: distance apart, and the eye's grid phases (:data:`EYE_PHASES`) moved readings across
#: it.  Regression draw, points only: the decimated heads' inner corners' p95 / max
#: 7.86 / 9.92 -> 7.35 / 7.75 % ES0, no point worse; fresh draw (seed 4701): their median
#: 2.15 -> 2.04 (p95 and max as before), 17 points better, 6 worse (by up to 1.2).
INNER_CANTHAL_BAND = (0.45, 0.55)


def eye_points(Vt: np.ndarray, T: np.ndarray, tpl) -> dict:
    """The lid-margin points of both eyes (:func:`eye_opening`), each eye searched round
    where the template's eye lies after the rigid fit; an eye without an opening of an
    eye's size there gives none.  An inner corner too far out for an eye
    (:data:`INNER_CANTHAL_BAND`) is moved towards where the canthi's proportion puts it, on the
    skin's front at the opening's end's height."""
    out = {}
    for name, keys in EYE_KEYS.items():
        c = 0.5 * (tpl.points[keys[0]] + tpl.points[keys[1]])
        got = eye_opening(Vt, T, c, name == "left eye")
        w = 0.0
        if "in" in got:
            lo, hi = INNER_CANTHAL_BAND
            w = np.clip((abs(got["in"][0]) / abs(got["out"][0]) - lo) / (hi - lo), 0.0, 1.0)
        if w > 0:
            x = np.sign(got["out"][0]) * INNER_CANTHAL_RATIO * abs(got["out"][0])
            xy = np.array([(1 - w) * got["in"][0] + w * x, got["in"][1]])
            # on the skin's front there; a point barely moved can still be over the
            # opening, where the first skin seen is the inside of the head (2.6 eye
            # separations behind on a fresh decimated head), and keeps the end's depth
            z = front_at(Vt, T, xy[None])[0]
            if not (np.isfinite(z) and z > got["in"][2] - 0.6):
                z = got["in"][2]
            got["in"] = np.array([*xy, z])
        out.update({k: got[r] for k, r in zip(keys, ("out", "in", "top", "bottom")) if r in got})
    return out


def shut_eyes(points: dict) -> dict:
    """{eye name: height over width} of the eyes read (:func:`eye_points`) whose lids'
    middles are less than :data:`EYE_SHUT_RATIO` of the corners' width apart.

    >>> p = {"3.7": np.array([0.6, 0, 0]), "3.11": np.array([0.3, 0, 0]),
    ...      "3.1": np.array([0.45, 0.02, 0]), "3.3": np.array([0.45, -0.01, 0])}
    >>> {k: round(v, 2) for k, v in shut_eyes(p).items()}
    {'left eye': 0.1}
    """
    out = {}
    for name, (outer, inner, top, bottom) in EYE_KEYS.items():
        if all(k in points for k in (outer, inner, top, bottom)):
            width = abs(points[outer][0] - points[inner][0])
            ratio = float((points[top][1] - points[bottom][1]) / width) if width > 0 else 0.0
            if ratio < EYE_SHUT_RATIO:
                out[name] = ratio
    return out


def eye_findings(points: dict) -> tuple:
    """(eyes with no opening seen, notes, id -> reason) for the eyes read
    (:func:`eye_points`): an eye with no opening seen from the front (closed lids, as scans
    are often taken, or an eyeball joined to them; its lid points are then the fitted
    template's open lids: a closed ICT eye's upper lid 10 % of the eye distance high), and
    one read nearly shut (:func:`shut_eyes`), each said in a note and on its points.

    >>> unseen, notes, reasons = eye_findings({})
    >>> unseen, notes[0][:40], reasons["3.1"][:25]
    (['left eye', 'right eye'], 'no eye opening seen at the left eye and ', 'no eye opening seen here:')
    """
    unseen = [eye for eye, keys in EYE_KEYS.items() if keys[2] not in points]
    notes, reasons = [], {}
    if unseen:
        notes.append(f"no eye opening seen at the {' and the '.join(unseen)} (closed lids, "
                     "or an eyeball joined to them): the lid points there are the fitted "
                     "template's open lids, not read off the geometry; MPEG-4's neutral face "
                     "has its eyes open, and eyelid FAPs move the lids from where they are")
        why = "no eye opening seen here: where the fitted template puts its open lids"
        reasons.update({k: why for eye in unseen for k in EYE_KEYS[eye]})
    shut = shut_eyes(points)
    if shut:
        notes.append(f"the {' and the '.join(shut)} {'is' if len(shut) == 1 else 'are'} nearly "
                     f"shut (lids {', '.join(f'{r:.2f}' for r in shut.values())} of the eye's "
                     "width apart): the lid points are read where the lids are; MPEG-4's neutral "
                     "face has its eyes open, the upper lid touching the iris, and eyelid FAPs "
                     "move the lids from where they are: open the eyes in the head for the "
                     "standard's neutral")
        why = "a nearly shut eye's lid, read where it is (MPEG-4's neutral has it open)"
        reasons.update({k: why for eye in shut for k in EYE_KEYS[eye][2:]})
    return unseen, notes, reasons


def _groove_end(D: np.ndarray, i: int, j: int, step: int, reach: int = 3,
                depth: float = 0.01) -> Optional[tuple]:
    """Following the groove of the depth map ``D`` (front-view z, -inf where empty) from
    the opening's extreme cell (i, j) outward along x (``step`` = +-1): at each column the
    deepest cell within two cells of the last one's height, kept while it lies ``depth``
    (0.01 ES, 0.6 mm) or more behind the mean of the cells ``reach`` rows above and below
    it (a groove, not the smooth skin beyond the corner), for 0.07 ES at most (a
    caruncle's pocket reaches 0.04-0.06 ES; on a coarse mesh the side of the nose can
    look like a groove going on); the last groove cell, or None."""
    last = None
    for _ in range(int(0.07 / DEPTH_CELL)):
        i += step
        js = _rows_near(D, i, j, reach)
        if js is None:
            break
        col = D[i, js]
        if not np.isfinite(col).any():
            continue                      # still in the opening
        jb = int(js[np.argmax(np.where(np.isfinite(col), -col, -np.inf))])
        z, up, dn = D[i, jb], D[i, jb + reach], D[i, jb - reach]
        if not (np.isfinite(up) and np.isfinite(dn)) or 0.5 * (up + dn) - z < depth:
            break
        last, j = (i, jb), jb
    return last


#: (width, thinness): an opening narrower than this (eye separations) and less tall than
#: this fraction of its width is what an eye shut but for a gap leaves open, not the eye's
#: opening: ICT's eyeBlink at 1 left 0.15-0.17 wide, 0.02-0.03 tall at one end of the eye
#: on three of six people of a fresh draw (seed 4949), whose ends were then read as the
#: corners (one 19 % of the eye distance off, nothing said).  An open eye's opening seen
#: from the front is 0.24-0.37 wide on the 160 heads of the regression draw, full and
#: decimated (median 0.33); where a coarse mesh bridges its ends it can be 0.18-0.19 (fresh
#: draw 4901, decimated), but then half as tall as wide.  A gap counts as a shut eye (the
#: template's lids, said).
EYE_GAP = (0.2, 1 / 3)

#: Below this height of the lids' middles apart for the corners' width (3.1 - 3.3 over 3.7
#: - 3.11), an eye read is said to be nearly shut: 0.28-0.45 on the regression draw's 160
#: open eyes (median 0.38), 0.09-0.17 with ICT's eyeBlink at 0.8 (five of six people of a
#: fresh draw, seed 4949; the sixth's eyes then show no opening).
EYE_SHUT_RATIO = 0.2


#: On how many phases of the depth map's grid :func:`eye_opening` reads an eye (as
#: :data:`MOUTH_PHASES` for the mouth): one grid moved an inner eye corner from 0.6 to 6.2 %
#: of the eye distance off when the head frame moved a hair.  Five phases, points only: the
#: eye points' median / p95 / max 1.34 / 5.31 / 9.89 -> 1.17 / 5.01 / 9.92 % ES0 on the
#: regression draw's 80 heads (all points' 1.44 / 4.56 -> 1.42 / 4.50), on a fresh draw
#: (seed 4701) full heads' 0.90 / 2.55 -> 0.83 / 2.28, decimated 1.70 / 5.79 -> 1.57 /
#: 5.54.  The phases share one sampling of the skin (:func:`front_samples`).
EYE_PHASES = 5


def eye_opening(Vt: np.ndarray, T: np.ndarray, centre: np.ndarray, left: bool,
                phases: Optional[int] = None) -> dict:
    """:func:`_eye_opening_once` read on :data:`EYE_PHASES` (or ``phases``) phases of the
    depth map's grid, each point the median of the phases that found it."""
    n = EYE_PHASES if phases is None else max(1, int(phases))
    lo, hi = _eye_box(centre)
    Q = front_samples(Vt, T, lo - DEPTH_CELL, hi + DEPTH_CELL)
    return _phase_median(_eye_opening_once(Vt, T, centre, left, samples=Q),
                         lambda d: _eye_opening_once(Vt, T, centre, left, d, Q), n)


def _eye_box(centre: np.ndarray) -> tuple:
    """(lo, hi) of an eye's depth map round ``centre``: tall, as after the rigid fit a
    long face's eyes can sit a third of an eye separation below the template's."""
    half = np.array([0.4, 0.45])
    return (np.array([centre[0] - half[0], centre[1] - half[1], centre[2] - 0.45]),
            np.array([centre[0] + half[0], centre[1] + half[1]]))


def _eye_opening_once(Vt: np.ndarray, T: np.ndarray, centre: np.ndarray, left: bool,
                      shift: Optional[np.ndarray] = None,
                      samples: Optional[np.ndarray] = None) -> dict:
    """The lid margins of the eye round ``centre`` (template frame) from the opening the
    skin leaves as seen from the front: {"out", "in", "top", "bottom"} -> point on the
    skin's front edge, or {} when no opening of an eye's size is there.

    The opening is the connected empty part of the front-view depth map
    (:func:`depth_map`, skin only: an eyeball is another piece) nearest the centre, 0.15
    to 0.6 ES wide and less tall than wide, and not a shut eye's gap (:data:`EYE_GAP`);
    its corners are its lateral extremes, its lid middles the top and bottom of its
    column half way between them, each taken on the
    skin just outside the opening (the most forward surface there: the lid margin's front
    edge, not the hole's boundary, which can lie a fifth of an eye separation deeper).
    ``shift`` and ``samples`` as :func:`_mouth_once`'s."""
    from scipy import ndimage
    if shift is not None:
        centre = centre - np.asarray(shift, dtype=np.float64)
    lo, hi = _eye_box(centre)
    D = depth_map(Vt, T, lo, hi, samples=samples)
    empty = np.isnan(D)
    lab, n = ndimage.label(empty)
    if not n:
        return {}
    ci = int((centre[0] - lo[0]) / DEPTH_CELL)
    cj = int((centre[1] - lo[1]) / DEPTH_CELL)
    best, best_d = None, np.inf
    border = set(np.unique(np.r_[lab[0], lab[-1], lab[:, 0], lab[:, -1]]).tolist())
    for k in range(1, n + 1):
        if k in border:
            continue
        ii, jj = np.nonzero(lab == k)
        w = (ii.max() - ii.min() + 1) * DEPTH_CELL
        h = (jj.max() - jj.min() + 1) * DEPTH_CELL
        if not (0.15 <= w <= 0.6 and h < w):
            continue
        if w < EYE_GAP[0] and h < EYE_GAP[1] * w:      # a shut eye's gap
            continue
        dd = np.hypot(ii.mean() - ci, jj.mean() - cj)
        if dd < best_d:
            best, best_d = (ii, jj), dd
    if best is None:
        return {}
    ii, jj = best
    filled = np.where(np.isnan(D), -np.inf, D)

    def front(i, j, di, dj):
        # the first filled cell outward from (i, j), its centre at the front surface
        for _ in range(6):
            i, j = i + di, j + dj
            if not (0 <= i < D.shape[0] and 0 <= j < D.shape[1]):
                break
            if np.isfinite(filled[i, j]):
                return np.array([lo[0] + (i + 0.5) * DEPTH_CELL, lo[1] + (j + 0.5) * DEPTH_CELL,
                                 filled[i, j]])
        return None

    out = {}
    imax, imin = ii.max(), ii.min()
    jr = int(np.round(jj[ii == imax].mean()))
    jl = int(np.round(jj[ii == imin].mean()))
    pr, pl = front(imax, jr, 1, 0), front(imin, jl, -1, 0)
    # the inner corner: the lids meet medially beyond the opening, over a groove (a
    # caruncle's pocket) that can reach a twentieth of an eye separation further; the
    # corner is where that groove ends
    med = -1 if left else 1
    ic, jc = (imin, jl) if left else (imax, jr)
    groove = _groove_end(filled, ic, jc, med)
    if groove is not None:
        g = np.array([lo[0] + (groove[0] + 0.5) * DEPTH_CELL,
                      lo[1] + (groove[1] + 0.5) * DEPTH_CELL, filled[groove]])
        if left:
            pl = g
        else:
            pr = g
    icol = int(np.round(0.5 * (imax + imin)))
    col = jj[ii == icol]
    if not len(col) or pr is None or pl is None:
        return {}
    pt, pb = front(icol, col.max(), 0, 1), front(icol, col.min(), 0, -1)
    if pt is None or pb is None:
        return {}
    out["out"], out["in"] = (pr, pl) if left else (pl, pr)
    out["top"], out["bottom"] = pt, pb
    return out
