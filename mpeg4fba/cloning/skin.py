"""A face's skin as the cloning sees it: every mesh that is not an eye, teeth or tongue,
stacked, in the normalised facial space and the 2D alignment space.

Pandzic's Facial Motion Cloning works on "the face", one mesh: it normalises it
("Normalizing the face": each vertex scaled by the FAPU of its closest feature point's
region about the face centre, :mod:`~mpeg4fba.cloning.normalise`) and projects it
cylindrically ("Aligning source and target face", :mod:`~mpeg4fba.cloning.projection`),
both held by :class:`~mpeg4fba.cloning.alignment.FaceSpace`.  Real faces come in several
meshes (skin, eyelashes, hair, a beard), so here the skin is every mesh that is not a
part (:func:`~mpeg4fba.cloning.parts.find_parts`) stacked into one array, rows in the
order of the face's meshes; :func:`mesh_groups` keeps each target mesh to its source
counterpart, where the paper has one mesh to map from.  The 3D steps of the surface
alignment measure the meshes here too (:func:`mean_edge`, :func:`coarseness`).

>>> import numpy as np
>>> square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
>>> mean_edge(square, np.array([[0, 1, 2], [0, 2, 3]])).round(3).tolist()
[1.207, 1.0, 1.207, 1.0]
"""
from __future__ import annotations

from functools import cached_property
from typing import Optional, Sequence

import numpy as np
from scipy.spatial import cKDTree

from ..fba.face import FaceModel
from .alignment import FaceSpace
from .parts import HEAD
from .surface import triangle_edges

__all__ = ["Skin", "linear_part", "stack_meshes", "mesh_groups", "mean_edge", "coarseness"]


def linear_part(face: FaceModel, transform: Optional[str]) -> np.ndarray:
    """(3, 3) linear part of the world matrix of ``transform`` (the root for None)."""
    return face.world_matrix(transform)[0][:3, :3]


class Skin:
    """A face's skin meshes stacked: world vertices, triangles, alignment space.

    ``parts`` is :func:`~mpeg4fba.cloning.parts.find_parts`'s answer (their meshes are
    left out, the head's kept); ``positions`` and ``mouth_angle`` go to the
    :class:`~mpeg4fba.cloning.alignment.FaceSpace`.  Attributes: ``face``, ``offsets``
    (mesh name -> (first row, vertex count)), ``linear`` (mesh name -> the linear part
    of its world matrix), ``mesh_index`` (row -> index into ``offsets``), ``main`` (the
    mesh holding most feature points), ``vertices``, ``triangles`` (rows), ``space``.
    """

    def __init__(self, face: FaceModel, parts: dict, positions: str, mouth_angle: float):
        rigid = {m for p, ms in parts.items() if p != HEAD for m in ms}
        names = [n for n, m in face.meshes.items() if n not in rigid and len(m.vertices)]
        self.offsets: dict = {}
        self.linear: dict = {}
        verts, tris = [], []
        first = 0
        for n in names:
            m = face.meshes[n]
            self.offsets[n] = (first, len(m.vertices))
            self.linear[n] = linear_part(face, m.parent)
            verts.append(face.world_vertices(n))
            tris.append(m.triangles + first)
            first += len(m.vertices)
        self.mesh_index = np.repeat(np.arange(len(names)),
                                    [len(face.meshes[n].vertices) for n in names])
        counts = {}
        for fp in face.points:
            tie = face.points.vertex(fp)
            if tie is not None and tie[0] in self.offsets:
                counts[tie[0]] = counts.get(tie[0], 0) + 1
        self.main = max(counts, key=counts.get) if counts else (names[0] if names else None)
        self.vertices = np.vstack(verts) if verts else np.zeros((0, 3))
        self.triangles = np.vstack(tris) if tris else np.zeros((0, 3), dtype=np.int64)
        self.space = FaceSpace(self.vertices, face.points, face.fapu, positions=positions,
                               mouth_angle=mouth_angle)
        self.face = face

    @cached_property
    def normalised(self) -> np.ndarray:
        """The skin vertices in this face's normalised space (FAPU0 units)."""
        return self.space.normalise(self.vertices)

    def main_point_rows(self) -> np.ndarray:
        """:meth:`point_vertices` of the main skin mesh, as rows of that mesh."""
        first, n = self.offsets[self.main]
        rows = self.point_vertices()
        return rows[(rows >= first) & (rows < first + n)] - first

    def point_vertices(self) -> np.ndarray:
        """Rows of the skin vertices that are feature points: a point's vertex tie, else
        the skin vertex nearest to it when that is within 1 % of ES0."""
        return self._point_rows

    @cached_property
    def _point_rows(self) -> np.ndarray:
        rows = set()
        if not len(self.vertices):
            return np.zeros(0, dtype=np.int64)
        # (vertices in some triangle: a seam's later copy is in none, cloning.seams)
        on = np.unique(self.triangles) if len(self.triangles) else np.arange(len(self.vertices))
        tree = cKDTree(self.vertices[on])
        tol = 0.01 * float(self.face.fapu.ES0)
        for fp in self.face.points:
            tie = self.face.points.vertex(fp)
            if tie is not None and tie[0] in self.offsets:
                r = self.offsets[tie[0]][0] + int(tie[1])
                if r < len(self.vertices):
                    i = np.searchsorted(on, r)
                    rows.add(r if i < len(on) and on[i] == r
                             else int(on[tree.query(self.vertices[r])[1]]))
                continue
            d, i = tree.query(self.face.points[fp])
            if d <= tol:
                rows.add(int(on[i]))
        return np.array(sorted(rows), dtype=np.int64)

    @cached_property
    def edges(self) -> tuple:
        """(mean edge length round each skin vertex, the rows in some triangle, their
        k-d tree) in the normalised space: what :func:`coarseness` measures against."""
        on = np.unique(self.triangles)
        return mean_edge(self.normalised, self.triangles), on, cKDTree(self.normalised[on])


def stack_meshes(face: FaceModel, meshes: Sequence[str]) -> tuple:
    """((n, 3) world vertices of ``meshes`` stacked, mesh name -> (first row, count))."""
    offsets, verts, first = {}, [], 0
    for n in meshes:
        v = face.world_vertices(n)
        offsets[n] = (first, len(v))
        verts.append(v)
        first += len(v)
    return (np.vstack(verts) if verts else np.zeros((0, 3))), offsets


def mesh_groups(source: Skin, target: Skin, by_mesh: bool = True) -> list:
    """(target skin rows, source skin mesh indices they take motion from) per target mesh.

    A target mesh takes its motion from the source mesh of the same name when there
    is one; the target's main skin (the mesh holding most feature points) from the
    source's main skin; any other mesh from all the source's skin meshes.  So the
    face is not moved by what lies over it in 2D (eyelashes, hair, a beard mesh) and
    vice versa.  ``by_mesh=False``: every target mesh from all the source's, the
    paper's single face mesh.
    """
    src_names = list(source.offsets)
    out = []
    for k, (name, (first, n)) in enumerate(target.offsets.items()):
        if not by_mesh:
            meshes = list(range(len(src_names)))
        elif name in source.offsets:
            meshes = [src_names.index(name)]
        elif name == target.main and source.main is not None:
            meshes = [src_names.index(source.main)]
        else:
            meshes = list(range(len(src_names)))
        out.append((np.arange(first, first + n), meshes))
    return out


def mean_edge(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(n,) mean length of the edges at each vertex, each edge counted once per triangle
    it belongs to (0 for a vertex in no triangle)."""
    i, j, length = triangle_edges(vertices, triangles)
    n = len(vertices)
    total = np.bincount(i, length, n) + np.bincount(j, length, n)
    count = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    return total / np.maximum(count, 1)


def coarseness(source: Skin, edges: np.ndarray, places: np.ndarray) -> tuple:
    """(ratio, near): for target vertices whose edges have the mean lengths ``edges``
    (normalised space, :func:`mean_edge`), those over the mean edge round ``near``,
    the source skin vertex nearest each one's place on the source (``places``, in the
    source's normalised space).  Above 1 the target is the coarser there."""
    edge, on, tree = source.edges
    _, k = tree.query(places)
    near = on[k]
    return edges / np.maximum(edge[near], 1e-300), near
