"""Faces the detector would misread, said rather than guessed (:mod:`~mpeg4fba.cloning.detect`).

The detector reads a face's parts off one another: the nose off the mid-plane profile,
the frame off the nose, the mouth and eyes off the frame.  Where the geometry breaks
that chain (a scan's hole where the nose is) every point after it can come out a feature
off, at confidences that do not say so; these checks stop it with the reason.

>>> eyes_round_their_eyeballs({"3.5": np.array([0.5, 0.0, 1.0])})   # no lids: nothing to check
"""
from __future__ import annotations

import numpy as np

from . import midline
from .frontview import PUPIL_OPENINGS
from .headframe import FaceNotFoundError

__all__ = ["NOSE_SPAN", "NOSE_GAP", "EYE_LAYOUT_LIMIT", "MISREAD", "no_hole_on_the_nose",
           "eyes_round_their_eyeballs"]

#: What a misread layout's error goes on to say.
MISREAD = ("so the nose, mouth and eyes were placed wrong (holes in the skin where the nose "
           "or eyes are can do this); give the points (mpeg4fba points HEAD --edit)")


#: The stretch of the mid line (template frame, eye separations below the eye line) whose
#: front must be the face's all along: the nose, from below its root to above the upper
#: lip.  A scan's hole there (a shiny nose tip) shows the mid-plane cut the back of the
#: head or nothing; the profile then has no nose, and the rest of the face was read off
#: the wrong bumps (the reference head with its tip cut out: mouth corners 40 % of the eye
#: distance off, 2.1 80 %, at confidences up to 0.8).
NOSE_SPAN = (-0.9, -0.1)
#: The longest gap (eye separations) allowed there: 0.03 (a coarse mesh's sliver can
#: leave a bin or two uncut); a bin is a gap when nothing is cut there or its front lies
#: more than 0.8 ES behind the span's most forward (a nose stands out 0.15-0.55 ES).
NOSE_GAP = 0.03


def no_hole_on_the_nose(prof: midline.Profile) -> None:
    """FaceNotFoundError when the mid-plane profile has a gap longer than
    :data:`NOSE_GAP` within :data:`NOSE_SPAN`: a hole in the skin on the nose."""
    sel = (prof.y >= NOSE_SPAN[0]) & (prof.y <= NOSE_SPAN[1])
    raw = prof.raw[sel]
    if not np.isfinite(raw).any():
        return
    with np.errstate(invalid="ignore"):
        gap = ~(raw >= np.nanmax(raw) - 0.8)
    if not gap.any():
        return
    # the longest run of uncut bins
    edges = np.flatnonzero(np.diff(np.r_[0, gap.astype(int), 0]))
    runs = edges[1::2] - edges[::2]
    longest = float(runs.max() * midline.PROFILE_STEP)
    if longest > NOSE_GAP:
        raise FaceNotFoundError(
            f"the skin has a hole on its mid line where the nose is ({longest:.2f} eye "
            "separations of it not there): the nose, and from it the mouth and chin, can't "
            "be read; close the hole in the mesh, or give the points (mpeg4fba points HEAD "
            "--edit)")


#: How far (eye separations, seen from the front) the middle of an eye's lid points may
#: lie from the pupil of an eyeball under it: 0.3.  On ICT heads they are within 0.05; a
#: head whose frame was misread (holes where the nose is, taken for eye openings, put
#: the eyes on the forehead: 0.4 ES and more off) has every point off, and says so.
EYE_LAYOUT_LIMIT = 0.3


def eyes_round_their_eyeballs(pos: dict) -> None:
    """FaceNotFoundError when an eye's points found on the skin do not lie round the
    pupil of the eyeball under them (:data:`EYE_LAYOUT_LIMIT`): the rest was misread."""
    for fp, eye in PUPIL_OPENINGS.items():
        if fp not in pos or not all(k in pos for k in eye):
            continue
        d = float(np.linalg.norm(np.mean([pos[k] for k in eye], axis=0)[:2] - pos[fp][:2]))
        if d > EYE_LAYOUT_LIMIT:
            raise FaceNotFoundError(
                f"the face was misread: the lids found round eye {fp} lie {d:.2f} eye "
                f"separations from its eyeball's pupil (at most {EYE_LAYOUT_LIMIT}), {MISREAD}")
