"""How a mesh of a face looks: its colour when it carries none, and whether its back
faces can ever be seen.

* :func:`mesh_color`: a colour picked from a word in the mesh's name (skin, eyes,
  teeth, tongue, hair, mouth...), what every renderer and writer uses for a mesh that
  has neither a colour of its own (:attr:`FaceMesh.color <mpeg4fba.fba.face.FaceMesh>`)
  nor colours per vertex.
* :func:`is_closed`: whether triangles enclose a volume, consistently wound (each edge
  shared by exactly two triangles running it in opposite directions).  Such a mesh is
  *single-sided*: seen from outside only its front faces show, and a renderer must cull
  its back faces where the mesh is wound inward on purpose, as the reference head's
  mouth cavity is (drawn two-sided, its near wall hides the teeth and tongue).  An open
  surface (the skin, with its mouth slit and eye openings) stays two-sided.

Example
-------
>>> mesh_color("UpperTeeth"), mesh_color("Skin") == mesh_color("face")
((0.95, 0.93, 0.86), True)
>>> tetrahedron = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
>>> is_closed(tetrahedron), is_closed(tetrahedron[:3])
(True, False)
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["mesh_color", "is_closed", "NAMED_COLORS", "SKIN_COLOR"]

#: Colour (RGB 0-1, as displayed) of a mesh by a word in its name; the first match wins.
NAMED_COLORS = (
    ("pupil", (0.05, 0.05, 0.06)), ("iris", (0.27, 0.40, 0.52)), ("eye", (0.95, 0.94, 0.91)),
    ("teeth", (0.95, 0.93, 0.86)), ("tooth", (0.95, 0.93, 0.86)), ("tongue", (0.80, 0.40, 0.42)),
    ("mouth", (0.30, 0.07, 0.09)), ("cavity", (0.30, 0.07, 0.09)), ("lip", (0.76, 0.42, 0.42)),
    ("hair", (0.25, 0.17, 0.11)), ("brow", (0.25, 0.17, 0.11)), ("gum", (0.80, 0.45, 0.45)),
)
#: The colour of any other mesh.
SKIN_COLOR = (0.91, 0.74, 0.63)


def mesh_color(name: str) -> tuple:
    """The default RGB colour (0-1) of a mesh, from a word in its name.

    >>> mesh_color("LeftEyeball"), mesh_color("Spine") == SKIN_COLOR
    ((0.95, 0.94, 0.91), True)
    """
    low = name.lower()
    for word, rgb in NAMED_COLORS:
        if word in low:
            return rgb
    return SKIN_COLOR


def is_closed(triangles: ArrayLike) -> bool:
    """True when ``triangles`` [m, 3] enclose a volume, consistently wound: every
    directed edge occurs once and its reverse once.  False for an empty mesh.

    >>> is_closed([[0, 1, 2], [0, 2, 1]]), is_closed([[0, 1, 2], [0, 1, 2]])
    (True, False)
    """
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if not len(t):
        return False
    a = t.ravel()
    b = t[:, [1, 2, 0]].ravel()
    n = int(t.max()) + 1
    edges = a * n + b
    unique, counts = np.unique(edges, return_counts=True)
    if (counts != 1).any():              # an edge run twice the same way: not oriented
        return False
    return bool(np.isin(b * n + a, unique, assume_unique=False).all())
