"""The ICT-FaceKit skin decimated (:mod:`benchmarks.ict`, which names these too): vertex
clustering whose clusters are represented by one *original* vertex, so a decimated
vertex's ground truth is exactly its original's delta (:func:`decimate`), and the head with
its Skin so decimated, the other meshes kept (:func:`ict_face_decimated`)."""
from __future__ import annotations

from typing import Mapping, Optional, Sequence

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.cloning.surface import vertex_normals
from mpeg4fba.fba.featurepoints import FeaturePointSet

from .ict import IDS_PREFIX, SKIN_FRONT, IctData, triangle_cross, ict_face

__all__ = ["decimate", "decimation_report", "ict_face_decimated"]


def _clusters(V: np.ndarray, cell: float, origin: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Cluster label per vertex: the connected pieces of each grid cell."""
    key = np.floor((V - origin) / cell).astype(np.int64)
    _, cell_id = np.unique(key, axis=0, return_inverse=True)
    cell_id = cell_id.ravel()
    e = edges[cell_id[edges[:, 0]] == cell_id[edges[:, 1]]]
    n = len(V)
    A = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return connected_components(A, directed=False)[1]


def decimate(vertices: np.ndarray, triangles: np.ndarray, target_fraction: float = 0.25, *,
             keep: Sequence[int] = (), tolerance: float = 0.01) -> tuple:
    """Vertex-clustering decimation in which each cluster is one ORIGINAL vertex.

    The vertices are binned in a uniform grid whose cell size is found by bisection (on a
    log scale) so that about ``target_fraction`` of them remain (within ``tolerance``
    relative, or the closest found).  A cluster is a connected piece of a cell (vertices
    of one cell joined by mesh edges inside it), so surfaces that touch without sharing
    edges (closed lips, eyelids) are not welded.  Its representative is the member
    nearest to the cluster's centroid, or the member listed in ``keep`` (a cluster with
    several ``keep`` members is split between them, each member going to the nearest).
    Triangles are mapped to representatives; degenerate (repeated vertex or zero area)
    and duplicate ones (same vertex set) are dropped, and representatives left in no
    triangle are dropped unless kept.

    Returns ``(kept_ids, triangles)``: sorted ids into ``vertices`` and (m', 3)
    triangles numbered into ``kept_ids``.

    >>> g = np.stack(np.meshgrid(np.arange(20.0), np.arange(20.0)), -1).reshape(-1, 2)
    >>> V = np.c_[g, np.zeros(len(g))]
    >>> q = (np.arange(19)[:, None] * 20 + np.arange(19)).ravel()
    >>> T = np.r_[np.c_[q, q + 1, q + 21], np.c_[q, q + 21, q + 20]]
    >>> kept, tris = decimate(V, T, 0.25, keep=[0, 1])
    >>> abs(len(kept) / 400 - 0.25) < 0.05, {0, 1} <= set(kept.tolist()), len(tris) > 0
    (True, True, True)
    >>> bool((np.cross(V[kept][tris[:, 1]] - V[kept][tris[:, 0]],
    ...                V[kept][tris[:, 2]] - V[kept][tris[:, 0]])[:, 2] > 0).all())
    True
    """
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    n = len(V)
    keep = np.unique(np.asarray(keep, dtype=np.int64))
    edges = np.unique(np.sort(np.r_[T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]], axis=1), axis=0)
    target = max(1, int(round(target_fraction * n)))
    origin = V.min(axis=0)
    mean_edge = float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
    lo, hi = 0.05 * mean_edge, float(np.ptp(V, axis=0).max()) + 1e-9
    best = None
    for _ in range(40):
        cell = float(np.sqrt(lo * hi))
        label = _clusters(V, cell, origin, edges)
        count = int(label.max()) + 1
        if best is None or abs(count - target) < abs(best[1] - target):
            best = (label, count)
        if abs(count - target) <= tolerance * target:
            break
        if count > target:
            lo = cell
        else:
            hi = cell
    label = best[0]

    # clusters holding several kept vertices: split them between those vertices
    is_keep = np.zeros(n, dtype=bool)
    is_keep[keep] = True
    nkeep = np.bincount(label, weights=is_keep, minlength=label.max() + 1)
    multi = np.flatnonzero(nkeep[label] >= 2)
    if len(multi):
        K = keep[nkeep[label[keep]] >= 2]
        d = np.linalg.norm(V[multi, None, :] - V[None, K, :], axis=2)
        d[label[multi][:, None] != label[K][None, :]] = np.inf
        label = label.copy()
        label[multi] = label.max() + 1 + np.argmin(d, axis=1)
        _, label = np.unique(label, return_inverse=True)
        label = label.ravel()

    # representative: the kept member, else the member nearest the centroid
    k = label.max() + 1
    size = np.bincount(label, minlength=k)
    centroid = np.stack([np.bincount(label, weights=V[:, c], minlength=k) for c in range(3)], 1)
    centroid /= size[:, None]
    score = np.linalg.norm(V - centroid[label], axis=1)
    score[is_keep] = -1.0
    order = np.lexsort((np.arange(n), score, label))
    first = order[np.r_[True, label[order][1:] != label[order][:-1]]]
    rep = np.empty(k, dtype=np.int64)
    rep[label[first]] = first

    # triangles on the representatives: no degenerate, no duplicate
    R = rep[label][T]
    ok = (R[:, 0] != R[:, 1]) & (R[:, 1] != R[:, 2]) & (R[:, 2] != R[:, 0])
    R = R[ok]
    area2 = np.linalg.norm(triangle_cross(V, R), axis=1)
    R = R[area2 > 1e-12 * max(mean_edge, 1e-300) ** 2]
    _, first_of = np.unique(np.sort(R, axis=1), axis=0, return_index=True)
    R = R[np.sort(first_of)]
    used = np.zeros(n, dtype=bool)
    used[R.ravel()] = True
    used[keep] = True
    kept = np.flatnonzero(used)                   # every used vertex is a representative
    new = np.full(n, -1, dtype=np.int64)
    new[kept] = np.arange(len(kept))
    return kept, new[R]


def decimation_report(vertices: np.ndarray, triangles: np.ndarray, kept: np.ndarray,
                      new_triangles: np.ndarray) -> dict:
    """Counts describing a :func:`decimate` result: vertices and triangles before and
    after, how many decimated triangles are also original triangles, how many face away
    from the original surface (normal against the mean original vertex normal of their
    corners), zero-area ones, and edges with more than two triangles (non-manifold)."""
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    kept = np.asarray(kept)
    R = kept[np.asarray(new_triangles)]
    N = vertex_normals(V, T)
    fn = triangle_cross(V, R)
    flipped = int(np.count_nonzero(np.einsum("ij,ij->i", fn, N[R].sum(axis=1)) < 0))
    n = np.int64(len(V))

    def code(t):
        s = np.sort(t, axis=1).astype(np.int64)
        return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]
    shared = np.count_nonzero(np.isin(code(R), code(T)))
    e = np.sort(np.r_[R[:, [0, 1]], R[:, [1, 2]], R[:, [2, 0]]], axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    return {"vertices": len(V), "triangles": len(T), "kept_vertices": len(kept),
            "kept_triangles": len(R), "vertex_fraction": len(kept) / max(len(V), 1),
            "triangles_also_original": int(shared), "flipped_vs_original_normals": flipped,
            "zero_area": int(np.count_nonzero(np.linalg.norm(fn, axis=1) == 0)),
            "nonmanifold_edges": int(np.count_nonzero(cnt > 2)),
            "boundary_edges": int(np.count_nonzero(cnt == 1))}


def ict_face_decimated(data: IctData, vertices: Optional[np.ndarray] = None,
                       fraction: float = 0.25, *, name: str = "ict_decimated",
                       fp_ids: Optional[Mapping] = None, tongue_tip: bool = False,
                       keep_ids: Sequence[int] = ()) -> FaceModel:
    """:func:`ict_face` with its Skin decimated to about ``fraction`` of its vertices
    (:func:`decimate` on ``vertices``, feature point vertices kept, their ties renumbered;
    the other meshes unchanged).  ``face.regions["ict_ids:Skin"]`` holds the original ids
    of the kept Skin vertices, so ground truth is ``split_deltas(face, delta)``.
    ``keep_ids``: more original (ICT) vertex ids to keep, where on the Skin (e.g. the
    landmarks, ``data.landmarks``)."""
    face = ict_face(data, vertices, name=name, fp_ids=fp_ids, tongue_tip=tongue_tip)
    skin = face.meshes["Skin"]
    ties = face.points.vertices
    on_skin = {k: i for k, (m, i) in ties.items() if m == "Skin"}
    ids = face.regions[IDS_PREFIX + "Skin"]
    extra = np.searchsorted(ids, np.asarray(keep_ids, dtype=np.int64))
    extra = extra[(extra < len(ids)) & (ids[np.minimum(extra, len(ids) - 1)] == np.asarray(keep_ids, dtype=np.int64))]
    kept, tris = decimate(skin.vertices, skin.triangles, fraction,
                          keep=list(on_skin.values()) + extra.tolist())
    face.meshes["Skin"] = FaceMesh("Skin", skin.vertices[kept], tris, skin.parent)
    ids = face.regions[IDS_PREFIX + "Skin"]
    front = np.zeros(len(ids), dtype=bool)
    front[face.regions[SKIN_FRONT]] = True
    face.regions[IDS_PREFIX + "Skin"] = ids[kept]
    face.regions[SKIN_FRONT] = np.flatnonzero(front[kept])
    where = np.searchsorted(kept, list(on_skin.values()))
    ties.update({k: ("Skin", int(w)) for k, w in zip(on_skin, where)})
    pos = {k: face.points[k] for k in face.points}
    face.points = FeaturePointSet(pos, ties)
    face.invalidate()
    return face
