"""Finding the MPEG-4 feature points on a head mesh that has none, from its geometry alone
(no model weights, no network).

Route (each step a function below), the face's structure found in order:

Steps 1-3 are :mod:`~mpeg4fba.cloning.headframe`'s, 4 :mod:`~mpeg4fba.cloning.midline`'s,
5 and 6 :mod:`~mpeg4fba.cloning.frontview`'s.

1. **Pieces** (:func:`~mpeg4fba.cloning.headframe.pieces`): every mesh cut into
   connected components, its texture seams joined first (:mod:`~mpeg4fba.cloning.seams`);
   the skin is the component of the largest area, the others are candidate parts
   (eyeballs, teeth, tongue, lashes...).
2. **Head frame** (:func:`~mpeg4fba.cloning.headframe.head_frame`): the reference head's
   skin (:func:`mpeg4fba.models.reference_head`, the template, which carries all 84 points) is
   fitted to the target's skin by a trimmed, two-way similarity ICP (rotation, translation,
   one scale) from each of the 24 axis-aligned up/forward hypotheses; the best fit is
   kept, which also tilts it into place (faces up to 20 degrees off an axis).  The nose
   tip read off the mid-plane profile (step 4) then sets the translation.
3. **Is it a face** (:func:`~mpeg4fba.cloning.headframe.face_checks`): the fit must be
   close, the skin bilaterally symmetric about the fitted mid plane, and a nose must
   stand out; else :class:`FaceNotFoundError` says which was missing.  **Mid plane**
   (:func:`~mpeg4fba.cloning.headframe.mid_plane`): the plane of the skin's mirror
   symmetry, by a point-to-plane mirror fit, turned to x = 0.
4. **Mid line** (:func:`~mpeg4fba.cloning.midline.profile`,
   :func:`~mpeg4fba.cloning.midline.profile_points`): the front of the skin's cut by
   the mid plane, read from the eye line down: the nose tip (the first peak that falls
   like a nose: an upper lip as forward as the nose is never taken for it), subnasale,
   the upper lip's front, the lips' meeting (a crease, a slit or an open mouth's parting;
   the crease from which a groove runs the mouth's width), the lower lip's vermilion
   edge, the menton.  A hole in the skin where the nose is is refused
   (:data:`~mpeg4fba.cloning.misread.NOSE_SPAN`): read, it put everything below it
   wrong.
5. **Eyes** (:func:`~mpeg4fba.cloning.frontview.eye_opening`): each eye's opening seen
   from the front (a depth map of the skin, :func:`~mpeg4fba.cloning.frontview.depth_map`:
   a hole, or the skin's edge round an eyeball that is another piece): corners at its lateral ends (the inner one where the groove beyond it
   ends), lid middles at its top and bottom, on the lid margin's front edge.  An eye
   with no opening seen (closed lids, as scans are often taken, or an eyeball joined to
   them), or only a shut eye's gap (:data:`~mpeg4fba.cloning.frontview.EYE_GAP`),
   keeps the fitted template's lids, said in a note and on each point, at a
   confidence of at most :data:`GUESSED_CONFIDENCE`; an eye whose lids are nearly shut
   (:data:`~mpeg4fba.cloning.frontview.EYE_SHUT_RATIO`) is read and said to be.
6. **Mouth** (:func:`~mpeg4fba.cloning.frontview.mouth_points`): the lips' contact
   groove seen from the front, followed from the stomion: commissures at its ends, inner corners and inner-lip
   midpoints along it.
7. **Registration**: the template's skin is bent onto the target's
   (:func:`~mpeg4fba.cloning.registration.register_surface`, coarse to fine), held at the
   points of steps 4-6, and every template point is carried to the closest point of the
   target's surface; the points of steps 4-6 then replace the carried ones.  The
   template's mesh turns one way (a sunflower spiral's sampling), which carried points
   follow by 0.5-1 % of the eye separation; so its mirror image is bent onto the target
   too, and each point is carried half way between the two
   (:func:`~mpeg4fba.cloning.template.bend_template`).
8. **Convention points** (:mod:`~mpeg4fba.cloning.convention`): the points no geometry
   marks (the outer lips' intermediate points, the nostril base's ends) placed by the
   68-landmark convention's proportions relative to the points found, dropped onto the
   skin; the brows and chin corners carried from the template
   (:mod:`~mpeg4fba.cloning.template`) where the convention puts them; every found point
   moved by what the geometric rules miss of the convention.
9. **Parts**: eyeballs (the pupil: the most forward point of a closed round component in
   the eye), teeth and tongue (components where the template's are), when present.
   Eyeballs found elsewhere than the eyes, or lids found away from their eyeball
   (:data:`~mpeg4fba.cloning.misread.EYE_LAYOUT_LIMIT`), mean the face was misread, and
   say so (:mod:`~mpeg4fba.cloning.misread`).

Units: the work is done in the template's frame (x the face's left, y up, z forward) in
units of the template's eye separation; results are returned in the face's own units and
frame.  ``FoundPoints.scale`` is model units per millimetre (taking the template's eye
separation, 64 mm, for the target's), so ``scale`` is 0.001 for a head in metres, 0.1 in
centimetres, 1 in millimetres.

Chin convention: 2.1 ("bottom of the chin") is the *menton*, the lowest point of the chin
on the mid line as seen from the front (the lowest point of the jaw line of a face photo,
Multi-PIE landmark 8), where the chin's profile turns from facing forward to facing down:
on the mid-plane profile, below the chin's front, the first point where the profile falls
45 degrees (:func:`~mpeg4fba.cloning.midline.profile_points`; the chin known by its fall
of 0.4 eye separations below, its front taken after any stretch of the lower lip's
underside still falling as steeply;
:func:`~mpeg4fba.cloning.midline.menton`, the
same by the surface normals, when the profile has no chin).  The reference head's own 2.1
lies further back, under the jaw; the landmark convention is what users (and ICT-FaceKit)
mean and what they can see.

Accuracy today (the issue's goals are median 1.5 / p95 4 / max 8 % ES0), on the 39
ICT-FaceKit points its 68 landmarks define, on the benchmark's regression draw of 20
random identities (seeds 7301-7320 of the identity modes), each full and decimated to
25-35 %, with and without eyeballs, randomly turned, tilted and scaled
(``benchmarks/results/find_points.md``, 2026-12-08): median 1.39, p95 4.53, max 11.45
% ES0; fresh draws (seeds 5050, 5353, 5454) 1.30-1.42 / 4.47-4.67 / 10.3-12.9, none
refused.  By group (median / p95): inner lips 1.02 / 3.30, outer lips 1.28 / 3.68, nose
1.27 / 4.14, eyes 1.20 / 5.03, brows 2.04 / 5.28, chin 2.51 / 8.79.  Worst: the chin's
2.1, 2.11 and 2.12 (up to 11.5: ICT's jaw-contour landmarks are fixed vertices whose
place on the chin's curve differs between people by more than any rule on the geometry
follows; the error is the same on all four heads of a person), the decimated heads'
eye corners (the coarse triangles bridge the opening's ends) and the brows (up to 8:
brows are hair, not shape).  About 1.7 s for a 29,000-vertex head on 2026-12-08's
machine.

Example
-------
>>> from mpeg4fba.models import reference_head
>>> head = reference_head(resolution=0.5, seed=3)
>>> found = find_feature_points(head)
>>> es = np.linalg.norm(head.points["3.5"] - head.points["3.6"])
>>> bool(np.linalg.norm(found.points["9.3"] - head.points["9.3"]) < 0.03 * es)
True
>>> round(found.scale, 4), (found.up.round(1) + 0.0).tolist(), (found.forward.round(1) + 0.0).tolist()
(0.001, [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Optional

import numpy as np
from scipy.spatial import cKDTree

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointSet, normalise_id, point_order
from ..fba.requirements import FAPU_POINTS, PART_POINTS, required_points
from . import frontview, headframe, midline, misread
from .frontview import PUPIL_OPENINGS
from .convention import convention_points, shift_to_convention
from .template import MIRROR, Template, bend_template, reference_template
from .headframe import FIT_LIMIT, SYMMETRY_LIMIT, FaceNotFoundError
from .alignment import REQUIRED_POINTS
from .parts import is_eyeball
from .seams import weld_seams
from .surface import boundary_vertices, closest_points

__all__ = ["FaceNotFoundError", "FoundPoints", "find_feature_points", "PART_OF",
           "CRISP_POINTS", "TEMPLATE_ES_MM", "FIT_LIMIT",
           "SYMMETRY_LIMIT"]


#: The points the geometry defines crisply, which :func:`_refine` (and
#: :func:`~mpeg4fba.cloning.snapping.snap_points`)
#: move onto that geometry: nose tip, chin, mouth corners and mid lips, eye corners and
#: lid middles.
CRISP_POINTS = ("2.1", "2.2", "2.3", "2.4", "2.5", "3.1", "3.2", "3.3", "3.4", "3.7", "3.8",
                "3.11", "3.12", "8.1", "8.2", "8.3", "8.4", "9.3")


#: The confidence, at most, of a point the geometry should mark and does not (an eye's
#: lid points with no eye opening seen): 0.2, among the points a review looks at first.
GUESSED_CONFIDENCE = 0.2


#: The template's eye separation in millimetres (the reference head's ES0): what
#: ``FoundPoints.scale`` takes the target's to be.
TEMPLATE_ES_MM = 64.0


#: Points the template carries that belong to parts, and which part.
PART_OF = {"3.5": "eye", "3.6": "eye", "9.8": "teeth", "9.9": "teeth", "9.10": "teeth",
            "9.11": "teeth", "6.1": "tongue", "6.2": "tongue", "6.3": "tongue", "6.4": "tongue"}


@dataclass(frozen=True)
class FoundPoints:
    """The feature points found on a face.

    Attributes
    ----------
    points : FeaturePointSet
        Positions in the face's own units and frame, each tied to the nearest vertex
        ``(mesh, vertex)`` of the mesh it lies on (7.1, inside the neck, has no tie).
    confidence : dict
        Point id -> confidence in [0, 1] (see :func:`_confidence`).
    missing : tuple
        Required ids (:func:`mpeg4fba.fba.requirements.required_points`) the geometry
        does not have (no eyeballs, no tongue...), in the standard's order.
    reasons : dict
        Id -> why it is missing, why its confidence is low, or what to know about it (the
        inner lips' middles of an open mouth).
    up, forward : numpy.ndarray
        Unit vectors of the head frame found, in model coordinates.
    scale : float
        Model units per millimetre (the target's eye separation taken as 64 mm).
    fit : dict
        The head frame found, ``s``, ``R``, ``t`` (template frame = s R p + t, eye
        separations), its ``score``, the template bent onto the skin (``deformed``), and
        ``opening_pupils``: the pupils put at their eye opening's centre for want of an
        eyeball (:func:`_pupils_in_openings`).
    curves : dict
        Name -> (k, 3) polyline in model coordinates: "upper lip" and "lower lip", each
        lip's edge along the mouth's slit seen from the front, from the right corner to
        the left, when the geometry has a contact groove
        (:func:`~mpeg4fba.cloning.snapping.snap_points`).
    notes : tuple
        What the user should know about the head as found (an open mouth, an eye with no
        opening seen: MPEG-4's neutral face has its lips closed and its eyes open).
    """

    points: FeaturePointSet
    confidence: dict
    missing: tuple
    reasons: dict
    up: np.ndarray
    forward: np.ndarray
    scale: float
    fit: dict = field(default_factory=dict, compare=False)
    curves: dict = field(default_factory=dict, compare=False)
    notes: tuple = ()

    def lowest(self) -> tuple:
        """(id, confidence) of the least confident point found."""
        if not self.confidence:
            return (None, 0.0)
        k = min(self.confidence, key=lambda i: (self.confidence[i], i))
        return k, float(self.confidence[k])


# -- the whole step --------------------------------------------------------------------------
def find_feature_points(face: FaceModel, *, ids: Optional[Iterable[str]] = None) -> FoundPoints:
    """The feature points of ``face`` (which needs none), found from its geometry.

    ``ids``: the points wanted (default: every point the template has where the face's
    geometry has it: all skin points, plus the eyeballs', teeth's and tongue's when those
    are present).  ``missing`` lists the required points
    (:func:`~mpeg4fba.fba.requirements.required_points` for every FAP, the FAPU and
    cloning's :data:`~mpeg4fba.cloning.REQUIRED_POINTS`) the face's geometry lacks.

    Raises :class:`FaceNotFoundError` when the face is too unlike a face.
    """
    want = None if ids is None else {normalise_id(k) for k in ids}
    tpl = reference_template()
    # a surface cut at texture seams is one surface (cloning.seams)
    pieces = headframe.pieces(weld_seams(face).face)
    skin_mask = pieces.comp == pieces.skin
    skin_mask[np.setdiff1d(np.arange(len(skin_mask)), pieces.T.ravel())] = False  # seam copies
    skin_ids = np.flatnonzero(skin_mask)
    # skin triangles, renumbered
    tri_skin = skin_mask[pieces.T[:, 0]]
    remap = np.full(len(pieces.V), -1)
    remap[skin_ids] = np.arange(len(skin_ids))
    ST = remap[pieces.T[tri_skin]]
    SV = pieces.V[skin_ids]
    if len(ST) < 50:
        raise FaceNotFoundError(f"no face found: the largest piece of the mesh has only "
                                f"{len(ST)} triangles")
    s, R, t, score = headframe.head_frame(SV, tpl, ST)
    Vt = s * SV @ R.T + t                      # target skin in the template frame
    # the mid plane at x = 0 (before the symmetry check: the rigid fit alone can leave a
    # straight face a few degrees turned, and its mirror then misses it)
    A, b = headframe.mid_plane(Vt, ST)
    R, t = A @ R, A @ t + b
    Vt = s * SV @ R.T + t
    headframe.face_checks(Vt, ST, score)
    # the mid-line profile's points (nose, lips), then the template's skin bent onto the
    # target's, held at them
    prof = midline.profile(Vt, ST, 0.6, -2.5)
    misread.no_hole_on_the_nose(prof)
    # (whether there is a mouth at p: one phase of the grid says as much as five)
    prof_pts = midline.profile_points(
        prof, 0.0, lambda p: bool(frontview.mouth_points(Vt, ST, p, phases=1)))
    eye_pts = frontview.eye_points(Vt, ST, tpl)
    unseen, notes, reasons = frontview.eye_findings(eye_pts)
    open_mouth = "2.2" in prof_pts and prof_pts["2.2"][1] - prof_pts["2.3"][1] > midline.SLIT_LIMIT
    if open_mouth:
        gap = float(prof_pts["2.2"][1] - prof_pts["2.3"][1])
        notes.append(f"the mouth is open (lips {gap:.2f} eye separations, about "
                     f"{gap * TEMPLATE_ES_MM:.0f} mm, apart): MPEG-4's neutral face has the "
                     "lips closed, so lip and jaw FAPs move them from where they are; close "
                     "the mouth in the head for the standard's neutral")
    lip_edges: dict = {}
    if "2.2" in prof_pts:
        mouth_pts, lip_edges = frontview.mouth(Vt, ST, 0.5 * (prof_pts["2.2"] + prof_pts["2.3"]),
                                               prof_pts["2.2"][1] - prof_pts["2.3"][1])
        eye_pts.update(mouth_pts)
    skin_points = list(tpl.skin_index)
    X, carried = bend_template(Vt, ST, {**prof_pts, **eye_pts}, skin_points)
    if open_mouth:               # (shown on its points in the editor)
        for k in ("2.2", "2.3"):
            reasons[k] = "the lips are apart here: an open mouth (MPEG-4's neutral has them closed)"
    guessed = [k for eye in unseen for k in frontview.EYE_KEYS[eye]]
    pos: dict = {}       # id -> template-frame position on the target
    tie: dict = {}       # id -> stacked vertex index
    resid: dict = {}
    idx = np.array([tpl.skin_index[k] for k in skin_points])
    tri, bary, dist = closest_points(carried, Vt, ST)
    q = np.einsum("nk,nkc->nc", bary, Vt[ST[tri]])
    corner = cKDTree(Vt).query(q)[1]
    # registration residual near each point: the mean distance of the deformed template's
    # vertices within 0.1 ES of it to the target
    near_d = cKDTree(Vt).query(X)[0]
    tpl_tree = cKDTree(tpl.V)
    for k, p, v, i in zip(skin_points, q, corner, idx):
        pos[k], tie[k] = p, skin_ids[v]
        around = tpl_tree.query_ball_point(tpl.V[i], 0.1)
        resid[k] = float(near_d[around].mean())
    if prof_pts:
        near = cKDTree(Vt).query(np.array(list(prof_pts.values())))[1]
        for (k, p), v in zip(prof_pts.items(), near):
            pos[k], tie[k] = p, skin_ids[v]
    if eye_pts:
        tri, bary, _ = closest_points(np.array(list(eye_pts.values())), Vt, ST)
        on = np.einsum("nk,nkc->nc", bary, Vt[ST[tri]])
        near = cKDTree(Vt).query(on)[1]
        for k, p, v in zip(eye_pts, on, near):
            pos[k], tie[k] = p, skin_ids[v]
    crisp_ok = (_refine(Vt, ST, pos, tie, skin_ids, reasons, "9.3" in prof_pts,
                        "2.1" in prof_pts)
                | set(prof_pts) | set(eye_pts))
    # from the crisp points, or where the registration put them when the geometry had
    # no mark (a mouth without a groove keeps the template's corners)
    conv = convention_points(Vt, ST, pos, set(pos))
    if conv:
        near = cKDTree(Vt).query(np.array(list(conv.values())))[1]
        for (k, p), v in zip(conv.items(), near):
            pos[k], tie[k] = p, skin_ids[v]
    shift_to_convention(Vt, ST, pos, tie, skin_ids)
    # 7.1 and other off-surface points: moved with the registration's displacement nearby
    for k, p in tpl.points.items():
        if k in pos or k in PART_OF:
            continue
        _, nn = tpl_tree.query(p, k=8)
        pos[k] = p + (X[nn] - tpl.V[nn]).mean(0)
        resid[k] = float(near_d[nn].mean())
    _parts(pieces, s, R, t, X, tpl, pos, tie, reasons)
    misread.eyes_round_their_eyeballs(pos)
    opening_pupils = _pupils_in_openings(pos, resid, reasons)
    # results in model coordinates
    inv = lambda p: (np.asarray(p) - t) @ R / s
    conf = _confidence(pos, resid, crisp_ok, reasons)
    conf.update({k: min(conf[k], GUESSED_CONFIDENCE) for k in guessed if k in conf})
    present = sorted({PART_OF[k] for k in pos if k in PART_OF})
    need = set(required_points(range(3, 69), parts=present, fapu=True, base=REQUIRED_POINTS))
    for kind in ("eye", "teeth", "tongue"):
        need |= set(PART_POINTS[kind])
    need |= set(FAPU_POINTS)
    if want is not None:
        need &= want
    missing = tuple(point_order(k for k in need if k not in pos))
    for k in missing:
        reasons.setdefault(k, "not found")
    keep = [k for k in pos if want is None or k in want]
    positions = {k: inv(pos[k]) for k in keep}
    ties = {k: (pieces.names[pieces.mesh_of[tie[k]]], int(pieces.local[tie[k]]))
            for k in keep if k in tie}
    up = R[1] / np.linalg.norm(R[1])
    fwd = R[2] / np.linalg.norm(R[2])
    scale = 1.0 / (s * TEMPLATE_ES_MM)
    return FoundPoints(FeaturePointSet(positions, ties), {k: conf[k] for k in keep}, missing,
                       {k: v for k, v in reasons.items() if k in keep or k in missing},
                       up, fwd, float(scale),
                       fit={"score": score, "s": s, "R": R, "t": t, "deformed": X,
                            "opening_pupils": opening_pupils},
                       curves={k: inv(c) for k, c in lip_edges.items()}, notes=tuple(notes))


def _refine(Vt, ST, pos, tie, skin_ids, reasons, prof_has_tip: bool = False,
            prof_has_chin: bool = False) -> set:
    """Move the crisp points onto the crisp geometry near them (template frame); the ids
    moved.  Nose tip 9.3: the most forward vertex within 0.25 ES of where the registration
    put it; chin 2.1: the menton rule (module docstring) on the target's skin."""
    done = set()
    near = np.flatnonzero(np.linalg.norm(Vt - pos["9.3"], axis=1) < 0.25)
    if len(near) and not prof_has_tip:
        v = near[np.argmax(Vt[near, 2])]
        pos["9.3"], tie["9.3"] = Vt[v], skin_ids[v]
        done.add("9.3")
    if "8.2" in pos and not prof_has_chin:
        m = midline.menton(Vt, ST, {"8.2": pos["8.2"], "2.1": pos["2.1"]})
        if m is not None and np.linalg.norm(m - pos["2.1"]) < 0.5:
            v = int(np.argmin(np.linalg.norm(Vt - m, axis=1)))
            pos["2.1"], tie["2.1"] = Vt[v], skin_ids[v]
            done.add("2.1")
        else:
            reasons["2.1"] = "no clear chin (menton) below the lower lip: left where the fit put it"
    return done


def _parts(pieces: headframe.Pieces, s, R, t, X, tpl: Template, pos, tie, reasons) -> set:
    """Eyeball, teeth and tongue points from the components where the template has those
    parts (template frame); the kinds found."""
    found = set()
    Vt = s * pieces.V @ R.T + t
    others = np.unique(pieces.comp[pieces.comp != pieces.skin])
    if not len(others):
        for k in PART_OF:
            reasons[k] = f"no {PART_OF[k]} mesh: the face is one piece (its skin)"
        return found
    # the template's parts moved by the registration's displacement nearby
    tree = cKDTree(tpl.V)

    def moved(P):
        _, nn = tree.query(P, k=8)
        return P + (X[nn] - tpl.V[nn]).mean(1)

    order = np.argsort(pieces.comp, kind="stable")
    bounds = np.searchsorted(pieces.comp[order], np.arange(pieces.comp.max() + 2))
    members = {int(c): order[bounds[c]:bounds[c + 1]] for c in others}
    cent = {c: Vt[m].mean(0) for c, m in members.items()}
    ext = {c: float(np.ptp(Vt[m], axis=0).max()) for c, m in members.items()}
    # closed: no edge on the boundary (an eyeball is; a socket or an open shell is not)
    open_set = set(np.unique(pieces.comp[boundary_vertices(pieces.T, len(pieces.V))]).tolist())
    closed = {int(c): int(c) not in open_set for c in others}
    used = set()
    # eyes
    for fp, name in (("3.5", "LeftEyeball"), ("3.6", "RightEyeball")):
        ev, _ = tpl.parts[name]
        centre = moved(ev.mean(0)[None])[0]
        radius = np.ptp(ev, axis=0).max() / 2
        cand = [c for c in members if np.linalg.norm(cent[c] - centre) < 0.6 * radius * 2
                and ext[c] < 4 * radius and closed[c]]
        balls = [c for c in cand if is_eyeball(Vt[members[c]], 1.0)
                 and ext[c] > 0.8 * radius]
        if not balls:
            elsewhere = [c for c in members if closed[c] and radius < ext[c] < 4 * radius
                         and is_eyeball(Vt[members[c]], 1.0)]
            if len(elsewhere) >= 2:
                raise FaceNotFoundError(
                    f"the face was misread: it has eyeballs (closed round pieces), none where "
                    f"its eye {fp} was placed, {misread.MISREAD}")
            reasons[fp] = "no eyeball: no closed round piece in the eye" if not cand else \
                "no eyeball: the pieces in the eye are not round"
            continue
        ball = min(balls, key=lambda c: np.linalg.norm(cent[c] - centre))
        bc, br = cent[ball], ext[ball] / 2
        allv = np.concatenate([members[c] for c in cand
                               if np.linalg.norm(cent[c] - bc) < br])
        v = allv[np.argmax(Vt[allv, 2])]
        pos[fp], tie[fp] = Vt[v], v
        used.update(c for c in cand if np.linalg.norm(cent[c] - bc) < br)
        found.add("eye")
    # teeth and tongue: each remaining piece goes to the template part (moved with the
    # registration) it lies closest to, when it lies near it (median within TEETH_REACH
    # of the teeth, 0.06 ES of the tongue) and is no bigger than it (a mouth cavity or
    # gums-and-palate piece is bigger); a tooth to the row above or below the bite where
    # it stands (_teeth_row)
    names = ("UpperTeeth", "LowerTeeth", "Tongue")
    moved_parts = {n: moved(tpl.parts[n][0]) for n in names}
    trees = {n: cKDTree(v) for n, v in moved_parts.items()}
    extent = {n: np.ptp(v, axis=0) for n, v in moved_parts.items()}
    take = {n: [] for n in names}
    up_v, low_v = moved_parts["UpperTeeth"], moved_parts["LowerTeeth"]
    for c in members:
        if c in used:
            continue
        d = {n: float(np.median(trees[n].query(Vt[members[c]])[0])) for n in names}
        n = min(d, key=d.get)
        # (no deeper than it either: a mouth's lining can be as wide as a row of teeth
        # stretched by the registration, but is twice as deep)
        if d[n] < (0.06 if n == "Tongue" else TEETH_REACH) and ext[c] <= 1.3 * extent[n].max() \
                and np.ptp(Vt[members[c], 2]) <= 1.3 * extent[n][2]:
            if n != "Tongue":
                n = _teeth_row(cent[c], up_v, low_v) or n
            take[n].append(c)
    for name, pts in (("UpperTeeth", ("9.8", "9.10")), ("LowerTeeth", ("9.11", "9.9")),
                      ("Tongue", ("6.1", "6.2", "6.3", "6.4"))):
        kind = "tongue" if name == "Tongue" else "teeth"
        if not take[name]:
            for k in pts:
                reasons[k] = f"no {kind} mesh where the {name} would be"
            continue
        allv = np.concatenate([members[c] for c in take[name]])
        P = Vt[allv]
        # the incisors (or the tongue's middle): within 0.04 ES of the mid plane, or of
        # the nearest the part comes to it (never a molar's top far to one side)
        ax = np.abs(P[:, 0])
        mid = allv[ax < ax.min() + 0.04]
        if kind == "teeth":
            hi, lo = mid[np.argmax(Vt[mid, 1])], mid[np.argmin(Vt[mid, 1])]
            pos[pts[0]], tie[pts[0]] = Vt[hi], hi
            pos[pts[1]], tie[pts[1]] = Vt[lo], lo
        else:
            tip = mid[np.argmax(Vt[mid, 2])]
            pos["6.1"], tie["6.1"] = Vt[tip], tip
            body = mid[np.argmax(Vt[mid, 1])]
            pos["6.2"], tie["6.2"] = Vt[body], body
            l, r = allv[np.argmax(P[:, 0])], allv[np.argmin(P[:, 0])]
            pos["6.3"], tie["6.3"] = Vt[l], l
            pos["6.4"], tie["6.4"] = Vt[r], r
        found.add(kind)
    return found


#: How near (median distance, eye separations) a piece must lie to the template's teeth
#: or tongue, moved with the registration, to be taken for them.  ICT-FaceKit's teeth
#: have roots the template's lack: on 12 ICT heads 249 of 384 teeth lay further than
#: 0.06 (up to 0.25), so 0.06 lost the lower incisors and put 9.9 / 9.11 on a molar,
#: 15-38 % of the eye distance off the mid line.  Nothing but size tells teeth from the
#: gums-and-palate or mouth-socket pieces there (0.11-0.13, but a whole mouth wide), and
#: the size test does.  (The tongue keeps 0.06: a mouth's inner lining fits the size.)
TEETH_REACH = 0.3


def _teeth_row(centre: np.ndarray, upper: np.ndarray, lower: np.ndarray,
               reach: float = 0.1) -> Optional[str]:
    """Which row a tooth whose centre is ``centre`` belongs to: above the bite there
    (half way between the template's upper teeth's lowest and lower teeth's highest
    point within ``reach`` ES across), the upper; below it, the lower; None where the
    template has no teeth nearby.  (The nearer template row is no answer at the
    incisors: in a closed bite the lower ones sit right behind the upper ones.)"""
    def near(P):
        return P[np.hypot(P[:, 0] - centre[0], P[:, 2] - centre[2]) < reach, 1]
    u, lo = near(upper), near(lower)
    if not len(u) or not len(lo):
        return None
    return "UpperTeeth" if centre[1] > 0.5 * (u.min() + lo.max()) else "LowerTeeth"


def _pupils_in_openings(pos, resid, reasons) -> tuple:
    """Without an eyeball, a pupil (3.5, 3.6) is put at the centre of its eye opening:
    the mean of the eye's corners and lid middles (:data:`PUPIL_OPENINGS`); the ids so
    placed.  The FAPU ES0 and cloning's alignment need both pupils on every face (the
    standard places them with the eyes looking ahead); with no eyeball to move, no
    eyeball FAP is cloned (see :mod:`mpeg4fba.fba.requirements`), so the pupil's only use
    is as this landmark."""
    placed = []
    for fp, eye in PUPIL_OPENINGS.items():
        if fp in pos or not all(k in pos for k in eye):
            continue
        placed.append(fp)
        pos[fp] = np.mean([pos[k] for k in eye], axis=0)
        resid[fp] = float(max(resid.get(k, 0.0) for k in eye))
        reasons[fp] = (reasons.get(fp, "no eyeball") + "; put at the centre of the eye "
                       "opening (the mean of its corners and lid middles)")
    return tuple(placed)


def _confidence(pos, resid, crisp_ok, reasons) -> dict:
    """Point id -> confidence in [0, 1]: ``fit * symmetry``, where fit =
    ``exp(-(residual / 0.05)^2)`` with the registration residual near the point in eye
    separations (0.05 ES, about 3 mm, halves it roughly), raised half way to 1 when a crisp
    refinement succeeded, and symmetry = ``exp(-(mismatch / 0.08)^2)`` with the mismatch
    of a left/right pair mirrored in the mid plane (1 for points on the mid line)."""
    out = {}
    for k, p in pos.items():
        r = resid.get(k, 0.0)
        fit = float(np.exp(-(r / 0.05) ** 2))
        if k in crisp_ok:
            fit = 0.5 * (1 + fit)
        sym = 1.0
        m = MIRROR.get(k)
        if m in pos:
            mis = float(np.linalg.norm(np.asarray(pos[k]) - np.asarray(pos[m]) * [-1, 1, 1]))
            sym = float(np.exp(-(mis / 0.08) ** 2))
        c = float(np.clip(fit * sym, 0.0, 1.0))
        out[k] = c
        if c < 0.5 and k not in reasons:
            reasons[k] = (f"registration residual {r:.3f} ES near it" if fit < 0.7 else
                          "its left/right partner does not mirror it")
    return out
