"""Finding the eyes, teeth, tongue and head of a face ("Treating eyes, teeth, tongue and
global motion").

A part's meshes are found from its feature points: the mesh holding one of them (the
point's (mesh, vertex) tie, else the mesh with the vertex nearest the point), plus the
meshes connected to it (sharing a vertex position, within ``weld`` of the face's eye
separation), leaving out meshes that hold another part's or the skin's feature points
- so teeth modelled clenched, upper and lower touching, are still told apart by their
own points.  The head is every mesh of the face.

Transforms:

* in a **source** face, the part's transform is the lowest Transform that encloses all
  its meshes *and carries motion* (is driven by some FaceDefTransform of the FAT);
* in a **target** face, the lowest Transform enclosing all its meshes, provided it holds
  nothing else (the lower teeth and the tongue may share one, a jaw); otherwise the
  cloner installs a new one (:mod:`mpeg4fba.cloning.fmc`).

>>> from mpeg4fba.models import reference_head
>>> face = reference_head(resolution=0.5)
>>> found = find_parts(face)
>>> found["lower teeth"], found["left eye"], len(found["head"]) == len(face.meshes)
(['LowerTeeth'], ['LeftEyeball'], True)
>>> source_transform(face, found["lower teeth"]), target_transform(face, "lower teeth", found)
('Jaw', 'Jaw')
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Optional

import numpy as np
from scipy.spatial import cKDTree

from ..fba.face import FaceModel

__all__ = ["PartSpec", "PARTS", "find_parts", "mesh_holding", "connected_meshes",
           "lowest_common_transform", "moving_transforms", "source_transform",
           "target_transform", "enclosed_meshes", "HEAD"]


@dataclass(frozen=True)
class PartSpec:
    """A rigid part of the face: ``kind`` is eye, teeth or tongue; ``points`` the feature
    points that identify its meshes (in order of preference); ``riders`` the parts that
    may share its transform."""

    name: str
    kind: str
    points: tuple
    riders: tuple = ()


PARTS = (
    PartSpec("left eye", "eye", ("3.5",)),
    PartSpec("right eye", "eye", ("3.6",)),
    PartSpec("upper teeth", "teeth", ("9.10", "9.8")),
    PartSpec("lower teeth", "teeth", ("9.11", "9.9"), riders=("tongue",)),
    PartSpec("tongue", "tongue", ("6.1", "6.2", "6.3", "6.4"), riders=("lower teeth",)),
)
_SPEC = {p.name: p for p in PARTS}
#: Name of the whole-head part in :func:`find_parts`'s answer.
HEAD = "head"


def _scale(face: FaceModel) -> float:
    fapu = face.fapu
    if fapu is not None and fapu.ES0 > 0:
        return float(fapu.ES0)
    ext = [np.ptp(face.world_vertices(n), axis=0).max() for n in face.meshes
           if len(face.meshes[n].vertices)]
    return float(max(ext)) / 3 if ext else 1.0


def mesh_holding(face: FaceModel, fp: str, tolerance: Optional[float] = None) -> Optional[str]:
    """The mesh a feature point lies on: its vertex tie, else the mesh with the vertex
    nearest to it (within ``tolerance``, default 5 % of ES0); None if none is near."""
    if fp not in face.points:
        return None
    tie = face.points.vertex(fp)
    if tie is not None and tie[0] in face.meshes:
        return tie[0]
    tol = 0.05 * _scale(face) if tolerance is None else tolerance
    p = face.points[fp]
    best, best_d = None, np.inf
    for name, mesh in face.meshes.items():
        if not len(mesh.vertices):
            continue
        d = float(np.min(np.linalg.norm(face.world_vertices(name) - p, axis=1)))
        if d < best_d:
            best, best_d = name, d
    return best if best_d <= tol else None


def connected_meshes(face: FaceModel, seeds: Iterable[str], exclude: Iterable[str] = (),
                     weld: float = 1e-4) -> list:
    """``seeds`` and every mesh reachable from them through shared vertex positions
    (within ``weld`` x ES0), never entering ``exclude``."""
    tol = weld * _scale(face)
    excluded = set(exclude)
    names = [n for n in face.meshes if len(face.meshes[n].vertices)]
    trees = {n: cKDTree(face.world_vertices(n)) for n in names}
    found = [s for s in seeds if s in face.meshes]
    todo = list(found)
    while todo:
        a = todo.pop()
        for b in names:
            if b in found or b in excluded:
                continue
            if trees[a].sparse_distance_matrix(trees[b], tol, output_type="coo_matrix").nnz:
                found.append(b)
                todo.append(b)
    return [n for n in face.meshes if n in found]


def find_parts(face: FaceModel) -> dict:
    """Part name -> list of mesh names, for each part of :data:`PARTS` found, and
    :data:`HEAD` -> every mesh."""
    holders = {}
    for spec in PARTS:
        for fp in spec.points:
            m = mesh_holding(face, fp)
            if m is not None:
                holders[spec.name] = m
                break
    # meshes holding a feature point that belongs to no part: the skin (and hair...)
    part_points = {fp for s in PARTS for fp in s.points}
    skin = {mesh_holding(face, fp, 0.0) for fp in face.points if fp not in part_points}
    skin.discard(None)
    out = {}
    for name, seed in holders.items():
        others = {m for n, m in holders.items() if n != name} | skin
        others.discard(seed)
        out[name] = connected_meshes(face, [seed], exclude=others)
    out[HEAD] = list(face.meshes)
    return out


def lowest_common_transform(face: FaceModel, meshes: Iterable[str]) -> Optional[str]:
    """The deepest Transform enclosing all ``meshes`` (None: only the root does)."""
    chains = [face.chain(face.meshes[m].parent) for m in meshes]
    if not chains:
        return None
    common = None
    for level in zip(*chains):
        if all(t == level[0] for t in level):
            common = level[0]
        else:
            break
    return common


def moving_transforms(face: FaceModel) -> set:
    """Transforms driven by some FaceDefTransform of the face's FAT."""
    return {t.transform for table in face.fat for t in table.transforms}


def enclosed_meshes(face: FaceModel, transform: Optional[str]) -> list:
    """Meshes under ``transform`` (all of them for None)."""
    if transform is None:
        return list(face.meshes)
    return [m for m in face.meshes if transform in face.chain(face.meshes[m].parent)]


def source_transform(face: FaceModel, meshes: Iterable[str]) -> Optional[str]:
    """The lowest Transform carrying motion that encloses ``meshes`` (None: no such)."""
    moving = moving_transforms(face)
    t = lowest_common_transform(face, list(meshes))
    while t is not None and t not in moving:
        t = face.transforms[t].parent
    return t


def target_transform(face: FaceModel, part: str, parts: dict) -> Optional[str]:
    """The lowest Transform enclosing the part's meshes and nothing else (but its
    riders); None when there is none and one must be installed."""
    meshes = parts.get(part)
    if not meshes:
        return None
    t = lowest_common_transform(face, meshes)
    if t is None:
        return None
    if part == HEAD:
        return t
    allowed = set(meshes)
    for rider in _SPEC[part].riders:
        allowed |= set(parts.get(rider, ()))
    return t if set(enclosed_meshes(face, t)) <= allowed else None
