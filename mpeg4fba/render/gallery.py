"""A face's visemes and expressions in one picture.

:func:`shape_gallery` renders the neutral face, expressions 1-6 (FAP 2) and visemes
1-14 (FAP 1) of a face at full intensity, labelled, in a grid; run as a module it
writes the reference head's gallery (``docs/images/reference_head.png``)::

    python -m mpeg4fba.render.gallery docs/images/reference_head.png

Example
-------
>>> from mpeg4fba.models import reference_head
>>> image = shape_gallery(reference_head(resolution=0.5), size=(60, 70), shapes=[("neutral", None)])
>>> image.shape[1]
60
"""
from __future__ import annotations

import sys
from typing import Optional, Sequence

import numpy as np

from ..fba.tables import EXPRESSIONS, VISEMES
from .preview import render_face, render_grid, save_png

__all__ = ["shape_gallery", "gallery_shapes", "main"]


def gallery_shapes(face) -> list:
    """(label, pose) for the neutral face, each expression and each viseme the face's
    FAT defines; a pose is None (neutral) or a one-frame playback."""
    out = [("neutral", None)]
    for n in face.fat.expressions:
        out.append((f"{n} {EXPRESSIONS[n].name}", face.pose({}, expressions=[n, 63, 0, 0, 0, 0])))
    for n in face.fat.visemes:
        v = VISEMES[n]
        sounds = " ".join(v.phonemes[:3])
        out.append((f"{n} {v.name} ({sounds})", face.pose({}, visemes=[n, 0, 63, 0])))
    return out


def shape_gallery(face, *, size: Sequence[int] = (300, 330), cols: int = 7,
                  view="front", shapes: Optional[list] = None, fit=None) -> np.ndarray:
    """The gallery as an RGB image: one tile per (label, pose) of ``shapes`` (default
    :func:`gallery_shapes`), framed on the face (forehead to chin) when ``fit`` is None."""
    shapes = gallery_shapes(face) if shapes is None else shapes
    if fit is None and all(k in face.points for k in ("11.1", "2.1", "9.3", "3.7", "3.12")):
        p = face.points
        top, chin = p["11.1"], p["2.1"]
        height = top[1] - chin[1]
        half_w = 0.5 * abs(p["3.7"][0] - p["3.12"][0]) + 0.16 * height
        lo = np.array([-half_w, chin[1] - 0.04 * height, p["9.3"][2] - 0.45 * height])
        hi = np.array([half_w, top[1] + 0.02 * height, p["9.3"][2]])
        fit = (lo, hi)
    images = [render_face(face, pose, size=size, view=view, fit=fit) for _, pose in shapes]
    return render_grid(images, [label for label, _ in shapes], cols=cols, label_size=13)


def main(argv: Optional[list] = None) -> int:
    """Write the reference head's gallery to the path given (a PNG)."""
    from ..models import reference_head

    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python -m mpeg4fba.render.gallery OUT.png", file=sys.stderr)
        return 2
    save_png(argv[0], shape_gallery(reference_head()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
