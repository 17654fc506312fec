"""Surfaces cut at seams, joined for the detector and the cloner.

A glTF file stores a vertex once per texture island and per hard edge it lies on (its
attributes are per vertex), so the skin of a textured head comes in pieces that touch
without sharing a vertex; OBJ and VRML writers that do not share coordinates do the
same, and an STL file (or a mesh converted from one) gives every triangle its own three
vertices.  What the detector and the cloner read off the mesh's connections (its pieces,
the eye and mouth openings as boundaries, the neck's cut, the registration's stiffness)
would see cuts that are not there: on an ICT head cut into three texture islands the
detector found no face at all, and the cloner's mean error rose by 60 %.

So both work on the face with its triangles joined: each triangle corner at a vertex
that has an earlier copy (the same position exactly, both on an open edge, as seams
leave them; parts welded into one mesh that touch keep their own vertices) moved onto
that copy, triangles so collapsed or doubled dropped.  Vertices keep their rows (the
later copies are then in no triangle), so every per-vertex result still has the face's
own rows; the cloner gives each copy its first copy's motion (and holds a feature
point at a vertex in some triangle: :class:`~mpeg4fba.cloning.skin.Skin`), and the face
it writes has the triangles it was given.  On an ICT head as triangle soup, the cloner's
errors are the whole head's (mean 0.046 % of the eye distance, max 4.45).  Coincident
vertices that a face's FAT moves differently (lips modelled touching, whose tables part
them) are distinct points of the surface and stay apart.

>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
>>> w = weld_seams(FaceModel([FaceMesh("Skin", V, [[0, 1, 2], [3, 5, 4]])]))
>>> w.count, w.face.meshes["Skin"].triangles.tolist(), w.first["Skin"].tolist()
(2, [[0, 1, 2], [1, 5, 2]], [0, 1, 2, 1, 2, 5])
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..fba.face import FaceModel
from .surface import boundary_vertices

__all__ = ["Welding", "weld_seams"]


@dataclass(frozen=True)
class Welding:
    """A face with its seams joined (:func:`weld_seams`).

    Attributes
    ----------
    face : FaceModel
        The face with its triangles joined (the face itself when it has no seam).
    original : FaceModel
        The face as given.
    first : dict
        Mesh name -> (n,) the first copy of each vertex (itself when it has no earlier
        copy), for the meshes with seams.
    count : int
        How many vertices are later copies.
    """

    face: FaceModel
    original: FaceModel
    first: dict = field(default_factory=dict)
    count: int = 0

    def rows(self, offsets: dict, n: int) -> np.ndarray:
        """(n,) for stacked per-vertex rows (``offsets``: mesh -> (first row, count), as
        :class:`~mpeg4fba.cloning.skin.Skin` has them) the row of each vertex's first
        copy."""
        out = np.arange(n)
        for name, (r0, k) in offsets.items():
            f = self.first.get(name)
            if f is not None and len(f) == k:
                out[r0:r0 + k] = r0 + f
        return out

    def face_back(self, out: FaceModel) -> FaceModel:
        """``out``, a face made from the joined one, with the triangles as given (for the
        meshes it still has as they were; parts split off keep the joined ones)."""
        if not self.count:
            return out
        back = out.copy(share=False)
        for name in self.first:
            m, o = back.meshes.get(name), self.original.meshes[name]
            if m is not None and len(m.vertices) == len(o.vertices):
                back.meshes[name] = replace(m, triangles=o.triangles)
        back.invalidate()
        return back


def _moves_alike(face: FaceModel, name: str, first: np.ndarray) -> np.ndarray:
    """(n,) whether the face's FAT moves each vertex of mesh ``name`` exactly as its
    first copy."""
    ok = np.ones(len(first), dtype=bool)
    for t in face.fat:
        for m in t.meshes:
            if m.mesh != name or not len(m.indices):
                continue
            D = np.zeros((len(first), m.displacements[0].size))
            D[m.indices] = m.displacements.reshape(len(m.indices), -1)
            ok &= (D == D[first]).all(axis=1)
    return ok


def weld_seams(face: FaceModel) -> Welding:
    """The face with each triangle corner at a later copy of a vertex (a vertex of the
    same mesh at exactly the same position) moved onto the first copy, as
    :class:`Welding`; a face without such copies is returned as it is."""
    first_of, meshes, count = {}, {}, 0
    for name, mesh in face.meshes.items():
        V = mesh.vertices
        if len(V) < 2 or not len(mesh.triangles):
            continue
        _, lead, inv = np.unique(V, axis=0, return_index=True, return_inverse=True)
        first = lead[inv.ravel()]
        # a seam leaves both copies on an open edge; parts touching inside a mesh (a
        # closed tooth against the gum) have theirs inside closed surfaces
        edge = boundary_vertices(mesh.triangles, len(V))
        first = np.where(edge & edge[first], first, np.arange(len(V)))
        if len(face.fat):
            first = np.where(_moves_alike(face, name, first), first, np.arange(len(V)))
        later = int((first != np.arange(len(V))).sum())
        if not later:
            continue
        T = first[mesh.triangles]
        T = T[(T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 2] != T[:, 0])]
        _, once = np.unique(np.sort(T, axis=1), axis=0, return_index=True)
        meshes[name] = replace(mesh, triangles=T[np.sort(once)])
        first_of[name] = first
        count += later
    if not count:
        return Welding(face, face)
    out = face.copy()
    out.meshes.update(meshes)
    out.invalidate()
    return Welding(out, face, first_of, count)
