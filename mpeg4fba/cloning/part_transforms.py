"""Which Transform moves each part of a face (:mod:`~mpeg4fba.cloning.parts`):

* in a **source** face, the part's transform is the lowest Transform that encloses all
  its meshes *and carries motion* (is driven by some FaceDefTransform of the FAT);
* in a **target** face, the lowest Transform enclosing all its meshes, provided it holds
  nothing else (the lower teeth and the tongue may share one, a jaw); otherwise the
  cloner installs a new one (:class:`mpeg4fba.cloning.part_motion.TransformInstaller`).

>>> from mpeg4fba.models import reference_head
>>> from mpeg4fba.cloning.parts import find_parts
>>> face = reference_head(resolution=0.5)
>>> found = find_parts(face)
>>> source_transform(face, found["lower teeth"]), target_transform(face, "lower teeth", found)
('Jaw', 'Jaw')
"""
from __future__ import annotations

from typing import Iterable, Optional

from ..fba.face import FaceModel
from .parts import HEAD, PART_SPECS

__all__ = ["lowest_common_transform", "moving_transforms", "source_transform",
           "target_transform", "enclosed_meshes"]


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
    for rider in PART_SPECS[part].riders:
        allowed |= set(parts.get(rider, ()))
    return t if set(enclosed_meshes(face, t)) <= allowed else None
