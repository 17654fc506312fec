"""Where the 68-landmark convention puts points the detector's geometric rules place
otherwise: the points no geometry marks placed by the convention's proportions
(:data:`CONVENTION`), and each found point moved by what the rules miss of the
convention (:data:`CONVENTION_SHIFT`), both in the template frame (x the face's left,
y up, z forward; eye separations).

>>> sorted(CONVENTION)
['8.10', '8.5', '8.7', '9.5']
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from . import frontview
from .surface import onto_same_sheet
from .template import MIRROR

__all__ = ["CONVENTION", "CONVENTION_RIGHT", "CONVENTION_SHIFT", "convention_points",
           "shift_to_convention"]


#: Points along a contour the crisp points bound (the outer lips' intermediate points, the
#: nostril base's ends), placed by the proportions of the Multi-PIE / iBUG 68-landmark
#: convention (the one ICT-FaceKit's landmarks and users' face trackers follow) relative
#: to the crisp points found, then dropped along z onto the skin's front.  (The brows and
#: the chin's corners were placed so too, from the eyes' and the mouth's frames; carried
#: by the registration they are better:
#: :data:`~mpeg4fba.cloning.template.TEMPLATE_SHIFT`.)  Each entry: ``id -> (frame, a,
#: b)``; the frames (:func:`convention_points`):
#:
#: - ``lip``: ``x = x(mid) + a (x(corner) - x(mid))``, ``y = y(corner) + b (y(mid) -
#:   y(corner))``, mid 8.1 (upper) or 8.2 (lower), corner 8.3/8.4;
#: - ``nose``: ``x = a`` half the outer canthi's distance (3.7-3.12) to that side,
#:   ``y = y(9.15) + b`` that distance.
#:
#: The proportions are the means over 20 random ICT-FaceKit identities (seeds 101-120 of
#: ``benchmarks/ict.py``'s identity draw, none of them used to judge the detector); in
#: brackets the standard deviation of ``a`` and ``b`` over them.
CONVENTION = {
    "8.5": ("lip", 0.618, 0.776),      # upper lip, half way  [0.017, 0.049]
    "8.10": ("lip", 0.288, 1.069),     # Cupid's bow peak     [0.012, 0.027]
    "8.7": ("lip", 0.589, 0.766),      # lower lip, half way  [0.020, 0.061]
    "9.5": ("nose", 0.276, 0.009),     # nostril base's end   [0.016, 0.005]
}
#: The mirror partners (the face's right side) of :data:`CONVENTION`.
CONVENTION_RIGHT = {"8.6": "8.5", "8.9": "8.10", "8.8": "8.7", "9.4": "9.5"}


def convention_points(Vt: np.ndarray, T: np.ndarray, pos: dict, crisp: set) -> dict:
    """The :data:`CONVENTION` points (and their mirror partners) from the crisp points in
    ``pos`` (template frame; only those in ``crisp`` are used), on the skin's front."""
    want = {**{k: (k, 1.0) for k in CONVENTION}, **{k: (m, -1.0) for k, m in CONVENTION_RIGHT.items()}}
    corner = {1.0: "8.3", -1.0: "8.4"}
    xy = {}
    for k, (rule, side) in want.items():
        frame, a, b = CONVENTION[rule]
        if frame == "lip":
            mid = "8.1" if rule in ("8.5", "8.10") else "8.2"
            c = corner[side]
            if mid not in crisp or c not in crisp:
                continue
            xy[k] = np.array([pos[mid][0] + a * (pos[c][0] - pos[mid][0]),
                              pos[c][1] + b * (pos[mid][1] - pos[c][1])])
        elif frame == "nose":
            if not {"3.7", "3.12", "9.15"} <= crisp:
                continue
            half = 0.5 * abs(pos["3.7"][0] - pos["3.12"][0])
            xy[k] = np.array([side * a * half, pos["9.15"][1] + b * 2 * half])
    if not xy:
        return {}
    keys = list(xy)
    z = frontview.front_at(Vt, T, np.array([xy[k] for k in keys]))
    # on the face's front, not far behind where the registration put the point (one
    # dropped into an opening would find the inside of the head, an eye separation or
    # more behind)
    return {k: np.array([*xy[k], zk]) for k, zk in zip(keys, z)
            if np.isfinite(zk) and (k not in pos or zk > pos[k][2] - 0.6)}


#: What the geometric rules miss of the landmark convention, per point: the median over
#: training heads of (landmark point - found point) in the template frame (x the face's
#: left, y up, z forward; eye separations), the face's right side mirrored onto its left
#: (``template.MIRROR``).  Learned by ``python -m benchmarks.calibrate_points`` on identities
#: of its own seeds (101-120; none of them the benchmark's regression draw or a fresh
#: one), full and decimated, three rounds; each found point is moved by its shift and
#: dropped back onto the skin (:func:`shift_to_convention`).  They are where a rule's
#: geometric mark and the annotators' habit part: a lid's margin point sits on the lid's
#: rim behind its front edge; an inner lip corner deeper in the contact groove; the
#: commissure and the nose tip a little above where the geometry marks them.
CONVENTION_SHIFT: dict = {
    "2.1": (+0.0000, -0.0186, -0.0157),
    "2.2": (+0.0000, -0.0037, -0.0080),
    "2.3": (+0.0000, +0.0033, -0.0049),
    "2.4": (+0.0002, +0.0100, -0.0187),
    "2.6": (-0.0063, -0.0092, -0.0259),
    "2.8": (-0.0053, +0.0139, -0.0190),
    "3.1": (+0.0110, -0.0028, -0.0049),
    "3.3": (+0.0120, -0.0050, -0.0181),
    "3.7": (+0.0056, -0.0064, -0.0129),
    "3.11": (+0.0126, -0.0120, -0.0158),
    "8.1": (-0.0000, +0.0077, +0.0036),
    "8.2": (-0.0000, -0.0030, +0.0055),
    "8.3": (+0.0002, +0.0185, +0.0042),
    "8.5": (+0.0020, +0.0118, +0.0059),
    "8.7": (+0.0030, +0.0023, +0.0041),
    "8.10": (+0.0010, +0.0061, +0.0048),
    "9.3": (+0.0001, +0.0134, +0.0011),
    "9.5": (-0.0049, +0.0060, -0.0121),
    "9.15": (-0.0000, +0.0064, -0.0029),
}


def shift_to_convention(Vt: np.ndarray, T: np.ndarray, pos: dict, tie: dict,
                         skin_ids: np.ndarray) -> None:
    """Move each point of ``pos`` with a :data:`CONVENTION_SHIFT` (its mirror partner's,
    x negated, on the right side) by it, onto the skin's closest point (in place)."""
    keys, moved = [], []
    for k in list(pos):
        if k in CONVENTION_SHIFT:
            d = np.asarray(CONVENTION_SHIFT[k], dtype=np.float64)
        elif MIRROR.get(k) in CONVENTION_SHIFT:
            d = np.asarray(CONVENTION_SHIFT[MIRROR[k]], dtype=np.float64) * [-1, 1, 1]
        else:
            continue
        keys.append(k)
        moved.append(pos[k] + d)
    if not keys:
        return
    # back onto the sheet the point was on (a surface facing away counts 0.1 ES further)
    tri, bary = onto_same_sheet(np.array([pos[k] for k in keys]), np.array(moved), Vt, T, 0.1)
    on = np.einsum("nk,nkc->nc", bary, Vt[T[tri]])
    near = cKDTree(Vt).query(on)[1]
    for k, p, v in zip(keys, on, near):
        pos[k], tie[k] = p, skin_ids[v]
