"""The motion itself: the source's skin motion of every table, scaled into the target's
units, mapped through the weights, and written back as FaceDefMesh entries.

Pandzic's Facial Motion Cloning, "Computing facial motion" and "Mapping facial
motion": the motion is the difference between the animated and the neutral source,
taken in the normalised facial space (divided by the regional FAPU factors), mapped,
and denormalised by the target's factors.  Here the "animated source" is each table at
each of its interval borders (:func:`source_skin_motion`, with skin that a Transform
other than a part's moves, a jaw carrying a chin mesh, played in full:
``_play_table``), all tables at once as one sparse matrix ``S``; the target's motion is
``W @ S`` (:func:`map_skin`).  The paper's normalisation and denormalisation are one
factor per source vertex (:func:`motion_scale`), and we depart from the paper in
which region's factor the target side uses: the source vertex's, not the target
vertex's (see :func:`motion_scale`).  The target's motion at the borders, differenced,
gives the per-interval displacements of FaceDefMesh (:func:`mesh_entries`), a step the
paper, which clones one animated pose, does not have.

>>> import numpy as np
>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> face = FaceModel([FaceMesh("Skin", np.eye(3), [[0, 1, 2]])])
>>> motion = np.array([[[0.0, 0, 0], [0, 2, 0]], [[0, 1, 0], [0, 0, 0]], [[0, 0, 0]] * 2])
>>> [(e.mesh, e.indices.tolist(), e.displacements[0].tolist())
...  for e in mesh_entries(face, {"Skin": (0, 3)}, np.array([0.0, 1.0, 2.0]), motion)]
[('Skin', [0, 1], [[0.0, 0.0, 0.0], [0.0, 2.0, 0.0]])]
"""
from __future__ import annotations

from typing import Optional, Union

import numpy as np
import scipy.sparse as sp

from ..fba.face import FaceModel
from ..fba.fat import FAT, FaceDefMesh, FaceDefTable, interval_weights
from ..fba.stream import FapStream
from .skin import Skin, linear_part

__all__ = ["motion_scale", "map_skin", "source_skin_motion", "mesh_entries"]


def motion_scale(source: Skin, target: Skin) -> np.ndarray:
    """(Ns, 3) factor taking each source vertex's motion to the target's units.

    A source vertex's motion is normalised by the FAPU of its region (its closest
    feature point) and denormalised by the target's FAPU *for the same region*, so
    the FAP units carry over exactly (a FAP moving a feature point by v x FAPU on the
    source does so on the target) and a target vertex between regions does not get
    its neighbours' motion in another region's unit (which, where the eyes' IRISD
    meets the brows' ENS, is four times off).  The target's own region is used only
    for a point the target lacks.
    """
    src = source.space.normaliser
    tgt = target.space.normaliser
    regions = src.regions(source.vertices)
    index = {fp: k for k, fp in enumerate(tgt.ids)}
    to_t = np.array([index.get(fp, -1) for fp in src.ids])
    t = to_t[regions]
    target_units = np.where((t >= 0)[:, None], tgt.point_factors[np.maximum(t, 0)], np.nan)
    missing = t < 0
    if missing.any():
        # a region the target has no point for: the target's nearest region there
        near = tgt.factors(source.space.map_point_array(source.vertices[missing], target.space))
        target_units[missing] = near
    return target_units / source.space.motion_factors


def map_skin(weights: sp.spmatrix, motion: Union[np.ndarray, sp.spmatrix],
             scale: Optional[np.ndarray] = None) -> Union[np.ndarray, sp.csr_matrix]:
    """Target skin motions ``weights @ (scale * motion)``.

    ``motion`` is (Ns, 3) or (Ns, 3K) (K motions side by side, x y z each), ``scale``
    (Ns, 3) from :func:`motion_scale` or None (motion copied as is); sparse in, sparse
    out.

    >>> W = sp.csr_matrix([[0.5, 0.5]])
    >>> map_skin(W, np.array([[1.0, 0, 0], [3, 0, 0]]), np.full((2, 3), 2.0)).tolist()
    [[4.0, 0.0, 0.0]]
    """
    if sp.issparse(motion):
        s = motion.tocoo(copy=True)
        if scale is not None:
            s.data = s.data * scale[s.row, s.col % 3]
        return (weights @ s.tocsr()).tocsr()
    s = np.asarray(motion, dtype=np.float64)
    if scale is not None:
        k = s.shape[1] // 3
        s = (s.reshape(len(s), k, 3) * scale[:, None, :]).reshape(s.shape)
    return np.asarray(weights @ s)


def source_skin_motion(source: Skin, part_transforms: set, tables: list,
                       borders: list) -> sp.csr_matrix:
    """Source skin motion of every table at every non-zero border of ``borders`` (one
    array per table, :func:`~mpeg4fba.fba.fat.table_borders`): (Ns, 3K) sparse, in the
    face frame.  Motion of Transforms other than ``part_transforms`` (those the part
    step carries over) that move skin is included."""
    rows, cols, vals = [], [], []
    col = 0
    for table, b in zip(tables, borders):
        nz = b[b != 0]
        for m in table.meshes:
            if m.mesh not in source.offsets:
                continue
            first, _ = source.offsets[m.mesh]
            R = source.linear[m.mesh]
            w = interval_weights(m.borders, nz)                       # (nb, intervals)
            d = np.einsum("bj,kjc->kbc", w, m.displacements) @ R.T    # (k, nb, 3)
            k = len(m.indices)
            rows.append(np.repeat(first + m.indices, 3 * len(nz)))
            cols.append(np.tile(col + np.arange(3 * len(nz)), k))
            vals.append(d.reshape(-1))
        extra = _transform_skin_motion(source, part_transforms, table, nz)
        if extra is not None:
            r, c, v = extra
            rows.append(r)
            cols.append(col + c)
            vals.append(v)
        col += 3 * len(nz)
    n = len(source.vertices)
    if not rows:
        return sp.csr_matrix((n, col))
    s = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, col)).tocsr()
    s.sum_duplicates()
    return s


def _transform_skin_motion(source: Skin, part_transforms: set, table: FaceDefTable,
                           nz: np.ndarray):
    """Skin motion from a Transform that is not a part's (a jaw carrying a chin mesh)."""
    face = source.face
    movers = [t.transform for t in table.transforms if t.transform not in part_transforms]
    if not movers:
        return None
    affected = [m for m in source.offsets
                if set(movers) & set(face.chain(face.meshes[m].parent))]
    if not affected:
        return None
    rows, cols, vals = [], [], []
    for j, value in enumerate(nz):
        play = _play_table(face, table, value)
        for m in affected:
            first, n = source.offsets[m]
            moved = play.world_vertices(m)[0] - face.world_vertices(m)
            rows.append(np.repeat(first + np.arange(n), 3))
            cols.append(np.tile(3 * j + np.arange(3), n))
            vals.append(moved.reshape(-1))
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)


def _play_table(face: FaceModel, table: FaceDefTable, value: float):
    solo = face.copy(share=True)
    solo.fat = FAT([table])
    if table.fap == 1:
        s = FapStream.from_values({}, fps=1, n_frames=1,
                                  visemes=[(table.select, 0, int(value), 0)])
    elif table.fap == 2:
        s = FapStream.from_values({}, fps=1, n_frames=1,
                                  expressions=[(table.select, int(value), 0, 0, 0, 0)])
    else:
        s = FapStream.from_values({table.fap: [value]}, fps=1, n_frames=1)
    return solo.play(s)


def mesh_entries(face: FaceModel, offsets: dict, borders: np.ndarray, motion: np.ndarray,
                 min_motion: float = 1e-3) -> list:
    """FaceDefMesh entries of ``face``, one per mesh of ``offsets`` (name -> (first row,
    count)), from world motion [rows, non-zero borders, 3] at the non-zero ``borders``;
    vertices moving less than ``min_motion`` of the largest motion are left out."""
    if motion.shape[1] == 0 or not len(motion):
        return []
    norm = np.linalg.norm(motion, axis=2).max(axis=1)
    top = norm.max()
    if top <= 0:
        return []
    keep = norm > min_motion * top
    entries = []
    for name, (first, n) in offsets.items():
        sel = np.flatnonzero(keep[first:first + n])
        if not len(sel):
            continue
        R = linear_part(face, face.meshes[name].parent)
        local = motion[first + sel] @ np.linalg.inv(R).T
        entries.append(FaceDefMesh(name, borders, sel, _intervals(borders, local)))
    return entries


def _intervals(borders: np.ndarray, at_borders: np.ndarray) -> np.ndarray:
    """Per-interval displacements [k, intervals, 3] from displacements at the non-zero
    borders [k, nb, 3] (the displacement at 0 is 0)."""
    zero = int(np.flatnonzero(borders == 0)[0])
    full = np.insert(at_borders, zero, 0.0, axis=1)
    width = np.diff(borders)
    return np.diff(full, axis=1) / width[None, :, None]
