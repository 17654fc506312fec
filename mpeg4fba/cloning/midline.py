"""The face's mid line, read off the skin's cut by its mid plane: nose tip, subnasale,
the upper lip's front, the lips' meeting, the lower lip's vermilion edge and the menton
(step 4 of :mod:`mpeg4fba.cloning.detect`).

Everything here works on a skin already turned into the detector's template frame (x
the face's left, y up, z forward; units of the eye separation), with its mid plane at
x = 0.

>>> V = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
>>> a, b = plane_cut(V, np.array([[0, 1, 2]]))      # the plane x = 0 cuts two edges
>>> sorted(np.vstack([a, b]).round(2).tolist())
[[0.0, 0.0, 0.0], [0.0, 0.5, 0.0]]
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .surface import vertex_normals

__all__ = ["Profile", "profile", "profile_points", "plane_cut", "menton", "PROFILE_STEP",
           "PARTING_REACH", "SLIT_LIMIT", "PARTING_LIMIT",
           "NOSE_FALL"]


def menton(V: np.ndarray, T: np.ndarray, pts: dict) -> Optional[np.ndarray]:
    """2.1 by the menton rule on a skin in the head frame (x left, y up, z forward, eye
    separations): on the mid-plane profile below the lower lip (8.2 in ``pts``), the
    lowest point of the first run down the chin of points whose normal points within
    about 20 degrees of 45 degrees between forward and down, and no more than 0.6
    behind the chin's most forward point (so the chin, not the lower lip's underside
    above it nor the throat behind it).  None where the skin has no such chin."""
    N = vertex_normals(V, T)
    lip = pts["8.2"]
    band = np.flatnonzero((np.abs(V[:, 0] - lip[0]) < 0.05) & (V[:, 1] < lip[1] - 0.2)
                          & (V[:, 1] > lip[1] - 1.2) & (V[:, 2] > lip[2] - 1.0))
    if not len(band):
        return None
    front = V[band, 2].max()
    want = np.array([0.0, -np.sqrt(0.5), np.sqrt(0.5)])
    good = (N[band] @ want > 0.93) & (V[band, 2] > front - 0.6)
    if not good.any():
        return None
    # the lowest of the first run of such points down the chin: where the throat meets
    # the chin in a hollow its surface turns through 45 degrees too, and under a jaw
    # opened wide that hollow stands high enough to count (2.1 went 30 % of the eye
    # distance behind the chin)
    order = np.argsort(-V[band, 1], kind="stable")
    g = good[order]
    i0 = int(np.argmax(g))
    after = np.flatnonzero(~g[i0:])
    i1 = i0 + (int(after[0]) if len(after) else len(g) - i0)
    return V[band[order[i1 - 1]]]


#: Step (eye separations) of the mid-plane profile's height grid: 0.01 ES (about 0.6 mm),
#: finer than any ICT or reference-head edge that crosses the mid plane at the lips.
PROFILE_STEP = 0.01
#: How far (eye separations) the mid-plane profile must fall below a peak, before rising
#: as high again, for the peak to be the nose tip: 0.1.  ICT noses fall 0.14-0.35 to the
#: subnasale (the least where the upper lip stands almost as far forward as the tip); a
#: glabella falls 0.02-0.08 to the nasion, a dorsal hump less.  The nose is the first
#: such peak below the eye line, so an upper lip that falls as far to the stomion, below
#: it, is never taken for it.
NOSE_FALL = 0.1
#: The lips' parting on the mid-plane profile (:func:`profile_points`): a run of the raw
#: front 0.12 ES or more behind the upper lip's, within this far (eye separations) below
#: the upper lip's front (8.1): 1.0, room for a mouth open as wide as ICT's jawOpen at
#: full weight (a 0.6 ES gap).
PARTING_REACH = 1.0
#: A run no taller than this (eye separations) is a slit between lips that nearly meet,
#: and ends where the front comes back within 0.12 ES of the upper lip's: 0.12 (a closed
#: mouth's slit is 0.01-0.03).  A taller one is an open mouth, which ends at the first
#: step forward onto a lip, however far back that lip stands (an open jaw takes the
#: lower lip back with it, 0.1-0.2 ES behind the upper lip's front on ICT's jawOpen at
#: 0.3-0.5, so it never comes back within 0.12: read as closed lips, 2.3 went 17-21 %
#: of the eye separation off, and at jawOpen 0.5, 8.2 onto the back of the mouth).  An
#: open mouth is entered by a step back of 0.12 ES or more in one step and left by such
#: a step forward (a lower lip's underside falls steeply but smoothly).
SLIT_LIMIT = 0.12
#: The tallest opening read as parted lips (eye separations): 0.8.  MPEG-4's neutral face
#: has its lips closed, but heads as people model or scan them often have the mouth a
#: little open; a wide-open one (jawOpen 1.0 on ICT: 0.6 ES) is still read.
PARTING_LIMIT = 0.8


def plane_cut(V: np.ndarray, T: np.ndarray, x0: float = 0.0) -> tuple:
    """(a, b): the segments (k, 3) x 2 where the triangles cross the plane x = ``x0``.  A
    vertex counts as on the plane's negative side when x < x0, else on its positive side
    (half-open), so a triangle is cut by two of its edges or none, and a symmetric mesh's
    mid-line vertices (x = x0 exactly) are cut points too."""
    side = V[:, 0] < x0
    s = side[T]
    cut = s.any(1) & ~s.all(1)
    Tc = T[cut]
    sc = s[cut]
    # the odd vertex out, then the two edges from it
    odd = np.where(sc.sum(1) == 1, np.argmax(sc, 1), np.argmin(sc, 1))
    r = np.arange(len(Tc))
    o, p, q = Tc[r, odd], Tc[r, (odd + 1) % 3], Tc[r, (odd + 2) % 3]

    def cross(i, j):
        ai, aj = V[i, 0] - x0, V[j, 0] - x0
        w = ai / (ai - aj)
        return V[i] + w[:, None] * (V[j] - V[i])

    return cross(o, p), cross(o, q)


@dataclass(frozen=True)
class Profile:
    """The front of the mid-plane profile: ``z[i]``, the most forward point of the cut at
    height ``y[i]`` (template frame, eye separations), smoothed; ``raw`` unsmoothed (NaN
    where nothing was cut)."""
    y: np.ndarray
    z: np.ndarray
    raw: np.ndarray

    def at(self, i: int) -> np.ndarray:
        return np.array([0.0, self.y[i], self.z[i]])


def profile(Vt: np.ndarray, T: np.ndarray, top: float, bottom: float) -> Profile:
    """The front envelope of the skin's mid-plane cut between heights ``bottom`` and
    ``top`` (template frame), on a :data:`PROFILE_STEP` grid, gaps filled linearly and
    smoothed by a Gaussian of 1.5 steps (a decimated mesh's facets, not its shape)."""
    A, B = plane_cut(Vt, T)
    y = np.arange(bottom, top + PROFILE_STEP / 2, PROFILE_STEP)
    raw = np.full(len(y), -np.inf)
    if len(A):
        # each segment rasterised onto the grid (the heights it spans), the most forward kept
        lo, hi = np.minimum(A[:, 1], B[:, 1]), np.maximum(A[:, 1], B[:, 1])
        i0 = np.ceil((lo - bottom) / PROFILE_STEP).astype(int)
        i1 = np.floor((hi - bottom) / PROFILE_STEP).astype(int)
        i0, i1 = np.maximum(i0, 0), np.minimum(i1, len(y) - 1)
        n = np.maximum(i1 - i0 + 1, 0)
        seg = np.repeat(np.arange(len(A)), n)
        idx = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + i0[seg]
        dy = B[seg, 1] - A[seg, 1]
        w = np.where(np.abs(dy) > 1e-12, (y[idx] - A[seg, 1]) / np.where(dy == 0, 1, dy), 0.5)
        zz = A[seg, 2] + np.clip(w, 0, 1) * (B[seg, 2] - A[seg, 2])
        np.maximum.at(raw, idx, zz)
    have = np.isfinite(raw)
    if have.sum() < 2:
        return Profile(y, np.zeros_like(y), np.where(have, raw, np.nan))
    z = np.interp(y, y[have], raw[have])
    k = np.arange(-4, 5)
    g = np.exp(-0.5 * (k / 1.5) ** 2)
    zs = np.convolve(np.pad(z, 4, mode="edge"), g / g.sum(), mode="valid")
    return Profile(y, zs, np.where(have, raw, np.nan))


def _farthest(yy: np.ndarray, zz: np.ndarray, i: int, j: int) -> int:
    """The index in [i, j] of the profile point furthest in front of (+z side of) the chord
    from point i to point j: where the profile's tangent is parallel to the chord."""
    a, b = np.array([yy[i], zz[i]]), np.array([yy[j], zz[j]])
    d = b - a
    n = np.array([-d[1], d[0]])
    if n[1] < 0:
        n = -n
    seg = np.c_[yy[i:j + 1], zz[i:j + 1]]
    return i + int(np.argmax((seg - a) @ n))


def find_peaks(x: np.ndarray, prominence: float = 0.0) -> np.ndarray:
    """Indices of the local maxima of ``x`` (1-D) whose prominence is at least
    ``prominence``: what ``scipy.signal.find_peaks(x, prominence=...)[0]`` gives (a
    plateau's peak at its middle, rounded down; the prominence the peak's height above
    the higher of the lowest points on either side before the signal rises above it),
    written here because importing ``scipy.signal`` takes 0.6 s, a quarter of a head's
    whole detection (it loads ``scipy.stats``).  A NaN ends a run as it does there.

    >>> find_peaks(np.array([0.0, 2, 1, 3, 3, 3, 0, 0.5, 0.4])).tolist()
    [1, 4, 7]
    >>> find_peaks(np.array([0.0, 2, 1, 3, 3, 3, 0, 0.5, 0.4]), prominence=1.0).tolist()
    [1, 4]
    """
    x = np.asarray(x, dtype=np.float64).ravel()
    n = len(x)
    if n < 3:
        return np.zeros(0, dtype=np.intp)
    # a peak starts where the signal rises and ends where the run of equal values after
    # that falls (a run reaching the last sample is no peak)
    rise = np.flatnonzero(x[:-2] < x[1:-1]) + 1
    change = np.flatnonzero(x[1:] != x[:-1]) + 1
    nxt = np.searchsorted(change, rise, side="right")
    ahead = np.full(len(rise), n - 1)
    inside = nxt < len(change)
    ahead[inside] = np.minimum(change[nxt[inside]], n - 1)
    keep = x[ahead] < x[rise]
    peaks = (rise[keep] + ahead[keep] - 1) // 2
    if prominence <= 0 or not len(peaks):
        return peaks.astype(np.intp)
    out = []
    for p in peaks:             # a few peaks per profile
        h = x[p]
        blocked = ~(x <= h)     # higher, or NaN
        left = np.flatnonzero(blocked[:p])
        right = np.flatnonzero(blocked[p + 1:])
        lo = left[-1] + 1 if len(left) else 0
        hi = p + 1 + right[0] if len(right) else n
        base = max(x[lo:p + 1].min(), x[p:hi].min())
        if h - base >= prominence:
            out.append(p)
    return np.asarray(out, dtype=np.intp)


def profile_points(prof: Profile, eye_y: float, lips_ok=None) -> dict:
    """Mid-line points read off the profile (template frame), walking down from the eye
    line ``eye_y``: {"9.3", "9.15", "8.1", "2.2", "2.3", "8.2"} where found.

    - the nose: the first peak below the eye line that the profile then falls from by
      0.15 ES or more before rising as high again (an upper lip standing as far forward as
      the nose does not qualify: its fall to the stomion is about 0.1 ES; nor the
      glabella, whose fall to the nasion is smaller still);
    - 8.1 (labrale superius): the upper lip's most forward point, the first peak below
      the nose's fall (an upper lip with no bump: its knee, the point furthest in front
      of the chord from the corner under the nose to the lips' meeting); 8.2 (labrale
      inferius): the lower lip's, its first bump within 0.2 ES below the meeting (else
      its most forward point there), then moved down to where the lower lip's bulge
      turns towards the labiomental fold (the most convex point between them: Multi-PIE's
      landmark 57 lies on the vermilion's lower edge, not on the bulge's front);
    - 2.2 and 2.3 (the inner lips' middles): where the lips meet, the deepest point
      between 8.1 and 8.2 when the lips touch; when they part (the profile steps back
      more than 0.12 ES into the mouth between them, and comes forward again below: a
      fall that does not is the lower lip's underside; a slit or an open mouth,
      :data:`SLIT_LIMIT`), the upper lip's lowest and the lower lip's highest front
      points, either side of the gap.  When no groove runs the
      mouth's width from that meeting, a crease above the first bump from which one does
      is taken (an upper lip with no bump: the first bump was the lower lip's);
    - 9.15 (subnasale): the point furthest behind the chord from the nose tip to 8.1
      (the corner where the columella meets the lip);
    - 9.3 (pronasale): the point furthest in front of the chord from the sellion (the
      deepest point between the eye line and the nose) to the subnasale: the tip as
      seen square to the nose's own axis, so it does not slide with the head's pitch.
    """
    y, z = prof.y, prof.z
    order = np.argsort(-y)          # top down
    yy, zz = y[order], z[order]
    start = int(np.searchsorted(-yy, -eye_y))
    out = {}
    peaks = find_peaks(zz, prominence=0.005)
    peaks = peaks[peaks >= start]
    # the upper lip's front can be all but flat (a philtrum hardly hollow): any bump
    # standing out of a decimated mesh's facets (0.002 ES, 0.13 mm: a fresh ICT draw,
    # seed 2049, had a 0.001 ripple under the nose taken for the lip, 23 % ES0 off); a
    # lip with no bump at all is read from its knee below
    lip_peaks = find_peaks(zz, prominence=0.002)
    tip = None
    for p in peaks:
        after = zz[p:]
        higher = np.flatnonzero(after > zz[p])
        seg = after[:higher[0]] if len(higher) else after
        if zz[p] - seg.min() >= NOSE_FALL:
            tip = p
            break
    if tip is None:
        return out
    out["9.3"] = np.array([0.0, yy[tip], zz[tip]])
    fallen = np.flatnonzero(zz[tip:] < zz[tip] - NOSE_FALL)
    if not len(fallen):
        return out
    below = lip_peaks[lip_peaks > tip + fallen[0]]
    if not len(below):
        return out
    ul = below[0]
    out["8.1"] = np.array([0.0, yy[ul], zz[ul]])
    # curvature (second difference over 2 steps, + concave: a crease; - convex: a rim)
    d2 = np.zeros_like(zz)
    d2[2:-2] = zz[:-4] - 2 * zz[2:-2] + zz[4:]
    win = int(0.35 / PROFILE_STEP)
    rz = prof.raw[order]
    # the lips' meeting: a gap where the raw front steps back into the mouth, else the
    # first crease at least a fifth as sharp as the sharpest within 0.35 ES below 8.1
    ref = zz[ul]
    span = slice(ul, min(ul + win, len(zz) - 1) + 1)
    reach = rz[ul:min(ul + int(PARTING_REACH / PROFILE_STEP), len(zz) - 1) + 1]
    deep = ~(reach > ref - 0.12)
    if deep.any():
        g0 = int(np.argmax(deep))                       # the first run of deep bins
        back = np.flatnonzero(~deep[g0:])
        # a slit ends where the front is back near the upper lip's; an open mouth at the
        # first step forward onto a lip (SLIT_LIMIT)
        g1 = g0 + int(back[0]) - 1 if len(back) else None
        if g1 is None or g1 - g0 + 2 > SLIT_LIMIT / PROFILE_STEP:
            with np.errstate(invalid="ignore"):
                onto = np.isfinite(reach[1:]) & ~(reach[:-1] > reach[1:] - 0.12)
                into = ~(reach[1:] > reach[:-1] - 0.12)
            ends = np.flatnonzero(~deep[g0 + 1:] | onto[g0:])
            # an open mouth is entered by a step back too (a lower lip's underside
            # falling steeply to the labiomental fold is no opening)
            g1 = g0 + int(ends[0]) if len(ends) and into[max(g0 - 1, 0):g0 + 1].any() else None
        if g1 is None:
            # no lower lip below it within reach: the fall under the lower lip, or the
            # chin's, not a parting
            deep[:] = False
        else:
            up, lo = ul + g0 - 1, ul + g1 + 1
    if deep.any():
        # the lips part where the front steps back (a jump of 0.04 ES in one step, or no
        # cut at all); a smooth fall (the labiomental fold of a retruded lower lip), or a
        # "gap" taller than PARTING_LIMIT, is no parting
        r = rz[up:lo + 1]
        jump = ~np.isfinite(r).all() or np.nanmax(np.abs(np.diff(r))) > 0.04
        if not jump or lo - up > PARTING_LIMIT / PROFILE_STEP:
            deep[:] = False
    if not deep.any():
        c = d2[span]
        strong = np.flatnonzero((c >= 0.2 * c.max()) & (c > 0))
        peaks_c = find_peaks(c)
        firsts = [p for p in peaks_c if p in set(strong.tolist())]
        up = lo = ul + (firsts[0] if firsts else int(np.argmax(c)))
    if lips_ok is not None and not lips_ok(np.array([0.0, yy[up], zz[up]])):
        # an upper lip that does not bulge gives no bump: its first bump was then the
        # lower lip's, and the lips' contact lies above it: a crease between 0.3 ES below
        # the tip (the tip to the stomion is 0.4 ES or more: nose below the tip, then
        # philtrum; a philtrum's crease lies higher) and that bump from which a groove
        # runs the mouth's width.  Only when no groove runs from the meeting found below
        # the bump: a short nose's philtrum can hold a crease with a groove-like fold
        # beside it, above a mouth that is where the bumps say
        f = tip + int(fallen[0])
        a0 = tip + int(0.3 / PROFILE_STEP)
        if ul > a0 + 2:
            pk = find_peaks(d2[a0:ul])
            for p in pk:
                if d2[a0 + p] > 0 and lips_ok(np.array([0.0, yy[a0 + p], zz[a0 + p]])):
                    up = lo = a0 + p
                    # the lip's front from the corner under the nose (the point furthest
                    # behind the chord from the nose's fall to the meeting): a flat lip
                    # below a hollow under the nose has its knee low, not at the fall
                    # (a fresh ICT draw, seed 2043: 8.1 36 % ES0 off at the fall)
                    ul = _farthest(yy, zz, _farthest(yy, -zz, f, up), up)
                    out["8.1"] = np.array([0.0, yy[ul], zz[ul]])
                    break
    def front(i):
        # the raw front at bin i, or the nearest bin's within two (the smoothed one dips
        # into a parting's gap), unless that is the inside of the mouth or head seen
        # through the gap
        for o in (0, -1, 1, -2, 2):
            if 0 <= i + o < len(rz) and np.isfinite(rz[i + o]) and rz[i + o] > zz[i] - 0.15:
                return rz[i + o]
        return zz[i]

    out["2.2"] = np.array([0.0, yy[up], front(up)])
    out["2.3"] = np.array([0.0, yy[lo], front(lo)])
    # 8.2: the lower lip's rim, the most convex point between the lower lip's front and
    # the labiomental fold (the deepest point within 0.35 ES below it)
    # (from the lower lip's front, the most forward point within 0.2 ES below the lips'
    # meeting: the smoothed profile just below a parting still dips into the gap)
    # (its first bump there, else its most forward point: a retruded lower lip can stand
    # behind the chin's rise 0.2 ES below, which a fresh ICT draw, seed 2043, read as
    # the lower lip)
    below = zz[lo:min(lo + int(0.2 / PROFILE_STEP), len(zz) - 1) + 1]
    bumps = find_peaks(below, prominence=0.0005)
    ll = lo + (int(bumps[0]) if len(bumps) else int(np.argmax(below)))
    end = min(ll + int(0.35 / PROFILE_STEP), len(zz) - 1)
    fold = ll + int(np.argmin(zz[ll:end + 1]))
    if fold == end:
        # still falling at the window's end: no fold within reach.  A jaw opened wide
        # takes the chin back under the lower lip, and the chin's edge, more convex than
        # the lip's rim, is then within the window (ICT jawOpen 1.0: 8.2 on it, 35-45 %
        # of the eye distance low).  The rim is then sought above the lip's underside's
        # steepest fall (its first, of 0.002 ES a step or more above what flanks it):
        # the rim bends over into it, and a chin's edge comes after
        fall = zz[ll:end] - zz[ll + 1:end + 1]
        steepest = find_peaks(np.nan_to_num(fall), prominence=0.002)
        if len(steepest):
            fold = ll + int(steepest[0]) + 1
    if fold > ll + 2:
        i8 = ll + int(np.argmin(d2[ll:fold]))
        out["8.2"] = np.array([0.0, yy[i8], zz[i8]])
    # 2.1 (menton; the module docstring's convention): under the chin (where the profile
    # has fallen 0.4 ES behind the chin's front, 0.25 ES or more below the lips' meeting:
    # the lower lip's underside can be as steep, so the chin is known by its fall), the
    # chin's underside's first turn 45 degrees from facing forward to facing down below
    # the chin's front (not the last above that fall: a throat can stand on a shelf
    # between, and did, 55 % of the eye distance below a fresh ICT head's chin, and
    # under a jaw opened wide).  The chin's front is the most forward point after any
    # stretch of the lower lip's underside still falling at 45 degrees or more.
    a0 = lo + int(0.25 / PROFILE_STEP)
    if a0 < len(zz) - 2:
        front = np.maximum.accumulate(zz[a0:])
        under = np.flatnonzero(zz[a0:] < front - 0.4)
        if len(under):
            u = a0 + int(under[0])
            i = np.arange(a0, u + 1)
            steep = (zz[i - 1] - zz[np.minimum(i + 1, len(zz) - 1)]) / (2 * PROFILE_STEP) >= 1.0
            k = a0 + (int(np.argmax(~steep)) if (~steep).any() else u - a0)
            c = k + int(np.argmax(zz[k:u + 1]))
            j = np.arange(c + 1, u + 1)
            turn = (zz[j - 2] - zz[j]) / (2 * PROFILE_STEP) >= 1.0
            m = int(j[np.argmax(turn)]) - 1 if turn.any() else u
            out["2.1"] = np.array([0.0, yy[m], zz[m]])
    # subnasale: furthest behind the chord tip -> upper lip
    a, b = np.array([yy[tip], zz[tip]]), np.array([yy[ul], zz[ul]])
    d = b - a
    n = np.array([-d[1], d[0]])
    if n[1] > 0:
        n = -n
    sn = tip + int(np.argmax((np.c_[yy[tip:ul + 1], zz[tip:ul + 1]] - a) @ n))
    out["9.15"] = np.array([0.0, yy[sn], zz[sn]])
    # the tip square to the nose's axis (sellion -> subnasale)
    top = max(start - int(0.3 / PROFILE_STEP), 0)
    se = top + int(np.argmin(zz[top:tip + 1]))
    t2 = _farthest(yy, zz, se, sn)
    out["9.3"] = np.array([0.0, yy[t2], zz[t2]])
    return out
