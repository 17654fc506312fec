"""The detector's template: the reference head in the template frame (x the face's left,
y up, z forward; eye separations), with its points, openings and profile, and where the
landmark convention puts the points no geometry marks before the registration carries
them (:data:`TEMPLATE_SHIFT`).  Built once per process (:func:`reference_template`).

>>> tpl = reference_template()
>>> round(float(np.linalg.norm(tpl.points["3.5"] - tpl.points["3.6"])), 6), "mouth" in tpl.openings
(1.0, True)
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Optional

import numpy as np

from . import frontview, midline
from .registration import SPDFactoriser, register_surface
from .surface import boundary_vertices, closest_points, feature_warp

__all__ = ["TEMPLATE_SHIFT", "PAIRS", "MIRROR", "Template", "reference_template",
           "mirrored_template", "bend_template", "shift_anchors",
           "opening_boxes", "opening_landmarks"]

# left/right pairs (the face's left first): mirror partners of the shifts, and the
# symmetry part of the detector's confidence
PAIRS = (("2.4", "2.5"), ("2.6", "2.7"), ("2.8", "2.9"), ("2.11", "2.12"), ("2.13", "2.14"),
          ("3.1", "3.2"), ("3.3", "3.4"), ("3.5", "3.6"), ("3.7", "3.12"), ("3.11", "3.8"),
          ("3.9", "3.10"), ("3.13", "3.14"), ("4.1", "4.2"), ("4.3", "4.4"), ("4.5", "4.6"),
          ("5.1", "5.2"), ("5.3", "5.4"), ("8.3", "8.4"), ("8.5", "8.6"), ("8.7", "8.8"),
          ("8.10", "8.9"), ("9.1", "9.2"), ("9.5", "9.4"), ("9.7", "9.6"), ("9.13", "9.14"),
          ("10.1", "10.2"), ("10.3", "10.4"), ("10.5", "10.6"), ("10.7", "10.8"),
          ("10.9", "10.10"), ("11.2", "11.3"), ("6.3", "6.4"))
MIRROR = {a: b for a, b in PAIRS} | {b: a for a, b in PAIRS}


# -- the template --------------------------------------------------------------------------
@dataclass(frozen=True)
class Template:
    V: np.ndarray          # skin vertices, template frame, eye separations
    T: np.ndarray
    points: dict           # id -> position (template frame, ES units)
    skin_index: dict       # id -> skin vertex for skin points
    parts: dict            # kind -> (vertices, triangles) in the template frame
    sample: np.ndarray     # skin vertex indices for the rigid fit
    face: np.ndarray       # skin vertex indices of the face (brows to chin, ear to ear)
    openings: dict         # name -> (centre, {landmark: skin vertex}) of the mouth and eyes
    es: float              # metres
    profile: dict          # the mid-line points of its profile (:func:`~mpeg4fba.cloning.midline.profile_points`)
    eyes: dict             # its lid-margin points (:func:`~mpeg4fba.cloning.frontview.eye_points`)
    anchors: dict          # id -> (triangle, barycentric) of a point TEMPLATE_SHIFT moves


@lru_cache(maxsize=1)
def reference_template() -> Template:
    from ..models.reference_head import reference_head
    head = reference_head(resolution=1.0)
    es = float(np.linalg.norm(head.points["3.5"] - head.points["3.6"]))
    V = head.world_vertices("Skin") / es
    T = head.meshes["Skin"].triangles
    pts = {k: head.points[k] / es for k in head.points}
    skin_index = {k: v for k, (m, v) in head.points.vertices.items() if m == "Skin"}
    # the menton convention for 2.1 (module docstring), applied to the template too
    chin = midline.menton(V, T, pts)
    if chin is not None:           # (the reference head has one)
        pts["2.1"] = chin
    skin_index["2.1"] = int(np.argmin(np.linalg.norm(V - pts["2.1"], axis=1)))
    parts = {}
    for kind, names in (("eye", ("LeftEyeball", "RightEyeball")), ("teeth", ("UpperTeeth", "LowerTeeth")),
                        ("tongue", ("Tongue",))):
        for n in names:
            parts[n] = (head.world_vertices(n) / es, head.meshes[n].triangles)
    # an even sample of the skin for the rigid fit (the face counts double: it matters)
    rng = np.random.default_rng(0)
    face = np.flatnonzero(V[:, 2] > 0.3)
    rest = np.flatnonzero(V[:, 2] <= 0.3)
    sample = np.sort(np.concatenate([rng.choice(face, min(len(face), 900), replace=False),
                                     rng.choice(rest, min(len(rest), 500), replace=False)]))
    # the face: in front of the ears, from the brows' top to just under the chin
    chin, brow = pts["2.1"], pts["4.3"]
    face = np.flatnonzero((V[:, 2] > pts["3.7"][2] - 0.35) & (V[:, 1] < brow[1] + 0.35)
                          & (V[:, 1] > chin[1] - 0.1) & (np.abs(V[:, 0]) < 1.1))
    face = face[::max(1, len(face) // 1500)]
    openings = {}
    edge = boundary_vertices(T, len(V))
    for name, (c, half) in opening_boxes(pts).items():
        got = opening_landmarks(V, edge, c, half)
        if got is not None:
            openings[name] = (c, {k: int(v) for k, v in got.items()})
    anchors = shift_anchors(V, T, pts)
    prof = midline.profile_points(midline.profile(V, T, 0.6, -2.5), 0.0)
    eyes = {}
    for name, keys in frontview.EYE_KEYS.items():
        got = frontview.eye_opening(V, T, 0.5 * (pts[keys[0]] + pts[keys[1]]), name == "left eye")
        eyes.update({k: got[r] for k, r in zip(keys, ("out", "in", "top", "bottom")) if r in got})
    return Template(V, T, pts, skin_index, parts, sample, face, openings, es, prof, eyes,
                     anchors)



@lru_cache(maxsize=1)
def mirrored_template() -> Template:
    """:func:`reference_template` mirrored through its mid plane (x -> -x), each left point
    and part named as its right partner and back, so that its points are where the
    template's are.  Its mesh is the template's with the other handedness: the reference
    head's skin is sampled along a sunflower spiral, which turns one way, and a
    registration of that mesh onto a symmetric face carries the brows 0.6-1.1 % of the
    eye separation to the face's left; the mirrored mesh carries them as far to the right.
    Its skin's triangles keep the template's corner order, so they face inwards (which
    :func:`~mpeg4fba.cloning.registration.register_surface` takes as it comes) and its
    registration's system is the template's own to the bit: one factorisation serves
    both (:class:`~mpeg4fba.cloning.registration.SPDFactoriser`).

    >>> t, m = reference_template(), mirrored_template()
    >>> bool(np.allclose(m.points["4.1"], t.points["4.1"]) and np.allclose(m.V[:, 0], -t.V[:, 0]))
    True
    """
    t = reference_template()
    flip = np.array([-1.0, 1.0, 1.0])
    side = {"left": "right", "right": "left"}

    def swap(d: dict, f=lambda v: v) -> dict:
        return {MIRROR.get(k, k): f(v) for k, v in d.items()}

    openings = {{"left eye": "right eye", "right eye": "left eye"}.get(n, n):
                (c * flip, {side.get(k, k): v for k, v in lm.items()})
                for n, (c, lm) in t.openings.items()}
    parts = {{"LeftEyeball": "RightEyeball", "RightEyeball": "LeftEyeball"}.get(n, n):
             (v * flip, tr[:, ::-1].copy()) for n, (v, tr) in t.parts.items()}
    return Template(t.V * flip, t.T, swap(t.points, lambda p: p * flip),
                    swap(t.skin_index), parts, t.sample, t.face, openings, t.es,
                    swap(t.profile, lambda p: p * flip), swap(t.eyes, lambda p: p * flip),
                    swap(t.anchors))

#: Points no geometry marks, carried from the template by the registration: where on the
#: template each lies in the landmark convention, as a move of the template's own point
#: (template frame, eye separations; the face's left, the right mirrored).  The reference
#: head's brows and chin corners follow its modeller's idea of them; these moves put them
#: where annotators do.  Learned by ``python -m benchmarks.calibrate_points`` with
#: :data:`~mpeg4fba.cloning.convention.CONVENTION_SHIFT` (its docstring says on what).  Carried by the registration
#: they beat proportions of the crisp points found: over the training heads the spread
#: about the median was 1.8 / 1.8 / 2.1 / 2.0 % ES (4.1 / 4.3 / 4.5 / 2.11) carried,
#: against 2.3 / 2.8 / 4.5 / 2.5 placed in the eyes' (or chin's and mouth's) frame.
TEMPLATE_SHIFT: dict = {
    "2.11": (-0.0409, +0.0536, +0.1476),
    "4.1": (-0.0342, +0.0816, +0.0158),
    "4.3": (+0.0619, +0.0620, -0.0418),
    "4.5": (+0.0918, -0.0091, -0.1543),
}


def shift_anchors(V: np.ndarray, T: np.ndarray, pts: dict) -> dict:
    """{id: (triangle, barycentric)}: each :data:`TEMPLATE_SHIFT` point (and its mirror
    partner) moved by its shift onto the template's skin."""
    keys, moved = [], []
    for k, d in TEMPLATE_SHIFT.items():
        for kk, sign in ((k, 1.0), (MIRROR.get(k), -1.0)):
            if kk is not None and kk in pts:
                keys.append(kk)
                moved.append(pts[kk] + np.asarray(d, dtype=np.float64) * [sign, 1, 1])
    if not keys:
        return {}
    tri, bary, _ = closest_points(np.array(moved), V, T)
    return {k: (int(t), b) for k, t, b in zip(keys, tri, bary)}


# the template's opening widths (eye separations): an eye's, the mouth's (by box size)
_WIDTH = {False: 0.30, True: 0.64}


def opening_boxes(pts: dict) -> dict:
    """Opening name -> (centre, half sizes) of the box searched for it, template frame."""
    mouth = 0.5 * (pts["8.3"] + pts["8.4"])
    out = {"mouth": (mouth, np.array([0.9, 0.4, 0.8]))}
    for name, (a, b) in (("left eye", ("3.7", "3.11")), ("right eye", ("3.12", "3.8"))):
        out[name] = (0.5 * (pts[a] + pts[b]), np.array([0.32, 0.22, 0.5]))
    return out


def opening_landmarks(V: np.ndarray, edge: np.ndarray, centre: np.ndarray,
                       half: np.ndarray) -> Optional[dict]:
    """{"out", "in", "top", "bottom"} -> vertex of the opening (boundary vertices) in the
    box round ``centre`` (template frame): its lateral extremes, and its top and bottom
    near the middle; None without enough boundary there."""
    box = np.flatnonzero(edge & np.all(np.abs(V - centre) < half, axis=1))
    if len(box) < 6:
        return None
    x = V[box, 0]
    width = float(np.ptp(x))
    if width < 0.5 * half[0]:
        return None
    mid = box[np.abs(x - 0.5 * (x.max() + x.min())) < 0.15 * width]
    if not len(mid):
        return None
    out = {"left": box[np.argmax(x)], "right": box[np.argmin(x)],
           "top": mid[np.argmax(V[mid, 1])], "bottom": mid[np.argmin(V[mid, 1])]}
    # an opening is level and as wide as it is for the template (within a factor 1.6);
    # stray boundary edges (a decimated or torn mesh) are neither
    l, r = V[out["left"]], V[out["right"]]
    level = abs(l[1] - r[1]) < 0.12 and abs(l[2] - r[2]) < 0.15
    if not level or not _WIDTH[len(half) and (half[0] > 0.5)] / 1.6 <= width \
            <= 1.6 * _WIDTH[bool(half[0] > 0.5)]:
        return None
    return out


def bend_template(Vt: np.ndarray, ST: np.ndarray, pins: dict, keys: list) -> tuple:
    """(X, carried): the template's skin bent onto a head's (``Vt``, ``ST``, template
    frame; :func:`_bend`), held at the points ``pins`` found on it, and where the
    template's skin points ``keys`` are carried: half way between where the template and
    its mirror image (:func:`mirrored_template`) each carry them, the two bends sharing
    their factorisations.  ``X`` is the template's own bend."""
    tpl, mirrored = reference_template(), mirrored_template()
    factorise = SPDFactoriser()
    X = _bend(tpl, Vt, ST, pins, factorise)
    Xm = _bend(mirrored, Vt, ST, pins, factorise)
    return X, 0.5 * (_carried(tpl, X, keys) + _carried(mirrored, Xm, keys))


def _carried(tpl: Template, X: np.ndarray, keys: list) -> np.ndarray:
    """Where the template bent to ``X`` puts its skin points ``keys`` (its vertex, or the
    :data:`TEMPLATE_SHIFT` anchor's place)."""
    out = X[[tpl.skin_index[k] for k in keys]]
    for n, k in enumerate(keys):
        if k in tpl.anchors:
            a_tri, a_bary = tpl.anchors[k]
            out[n] = a_bary @ X[tpl.T[a_tri]]
    return out


def _bend(tpl: Template, Vt: np.ndarray, ST: np.ndarray, profile: dict,
          factorise: SPDFactoriser) -> np.ndarray:
    """The template's skin bent onto the target's (template frame): started from a warp
    taking the template's mid-line profile points (:func:`~mpeg4fba.cloning.midline.profile_points`, both
    profiles read by the same rules; the nose tip alone without them) and opening
    extremes (mouth, eyes; those both have) onto the target's, which then hold loosely
    through the non-rigid registration."""
    src, dst = [], []
    tip = tpl.skin_index["9.3"]
    for k, p in profile.items():
        # the template's point read by the same rule, else its own (the mouth's corners:
        # the reference head's lips barely crease where they meet)
        ref = tpl.profile.get(k, tpl.eyes.get(k, tpl.points.get(k)))
        if ref is not None and k not in ("2.3", "2.8", "2.9"):
            src.append(int(np.argmin(np.linalg.norm(tpl.V - ref, axis=1))))
            dst.append(p)
    if not src:
        src, dst = [tip], [tpl.V[tip]]
    edge = boundary_vertices(ST, len(Vt))
    for name, (c, lm) in tpl.openings.items():
        if any(k in profile for k in frontview.EYE_KEYS.get(name, ("8.3", "8.4"))):
            continue                 # the eye's lid margins (mouth's corners) held already
        got = opening_landmarks(Vt, edge, c, opening_boxes(tpl.points)[name][1])
        if got is None:
            continue
        for k, v in lm.items():
            src.append(v)
            dst.append(Vt[got[k]])
    src, keep = np.unique(np.array(src), return_index=True)
    dst = [dst[i] for i in keep]
    start = tpl.V.copy()
    # a thin-plate warp only when the landmarks surround the face (mouth and both eyes):
    # from fewer (an eye and the nose) it extrapolates wildly
    if len(keep) >= 1 + 4 * len(tpl.openings):
        start = feature_warp(tpl.V[src], np.array(dst), tpl.V)
    start[src] = np.array(dst)
    return register_surface(tpl.V, tpl.T, start, src, Vt, ST, factorise=factorise)
