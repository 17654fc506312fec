"""Cloning grids, as in Pandzic's *Facial Motion Cloning* (Figs. 11-13).

Each face is cloned onto every other one; row ``i`` shows face ``i``'s motion on every
face (column ``j``: cloned from ``i`` onto ``j``), so the diagonal holds the source
faces showing their own motion, a row shows one source on all targets and a column one
target from all sources.

>>> from mpeg4fba.models import reference_head
>>> faces = [reference_head(resolution=0.5), reference_head(resolution=0.5, face_width=1.2, seed=1)]
>>> grid = cloning_grid(faces, {"expressions": (6, 63, 0, 0, 0, 0)}, size=(64, 72))
>>> grid.shape[:2]
(184, 128)
"""
from __future__ import annotations

import warnings
from typing import Mapping, Optional, Sequence

import numpy as np

from .preview import render_face, render_grid

__all__ = ["cloning_grid", "clone_all"]


def clone_all(faces: Sequence, **options) -> list:
    """``out[i][j]``: face ``j`` with the motion of face ``i`` (``out[i][i]`` is face ``i``)."""
    from ..cloning import CloneWarning, FacialMotionCloner

    out = []
    for i, src in enumerate(faces):
        row = []
        for j, tgt in enumerate(faces):
            if i == j:
                row.append(src)
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", CloneWarning)
                row.append(FacialMotionCloner(src, tgt, **options).clone())
        out.append(row)
    return out


def cloning_grid(faces: Sequence, pose: Mapping, *, names: Optional[Sequence[str]] = None,
                 size: Sequence[int] = (240, 280), view="front", hide: Sequence[str] = (),
                 cloned: Optional[list] = None, **options) -> np.ndarray:
    """An RGB image: the grid of ``faces`` cloned onto each other, each in ``pose``.

    ``pose`` holds the arguments of :meth:`FaceModel.pose`: ``faps`` ({fap: value}),
    ``visemes`` and/or ``expressions`` (the FAP 1 / FAP 2 fields).  ``names`` label the
    faces ("source -> target" under each picture); ``cloned`` reuses the result of
    :func:`clone_all`; ``options`` go to the cloner.
    """
    names = list(names) if names is not None else [f.name for f in faces]
    grid = cloned if cloned is not None else clone_all(faces, **options)
    images, labels = [], []
    for i, row in enumerate(grid):
        for j, face in enumerate(row):
            frames = face.pose(dict(pose.get("faps", {})), pose.get("visemes"), pose.get("expressions"))
            images.append(render_face(face, frames, size=size, view=view,
                                      hide=[h for h in hide if h in face.meshes]))
            labels.append(names[i] if i == j else f"{names[i]} \u2192 {names[j]}")
    return render_grid(images, labels, cols=len(faces))
