"""Reading a face from whatever file holds it, with its feature points from a sidecar.

:func:`read_face` takes a VRML face (``.wrl``, ``.wrz``, ``.gz``: meshes, FDP and FAT)
or a neutral mesh file (``.obj``, ``.glb``, ``.gltf``, and scans as ``.ply``, ``.stl``,
``.off``: meshes only) and, when given a
feature point file (our JSON sidecar, :mod:`~mpeg4fba.formats.fpjson`, or an Xface
``.fdp``, :mod:`~mpeg4fba.formats.xface_fdp`), puts those points on it: points tied to
a vertex take its position in the face frame; the sidecar's FAPU, if any, is used.

>>> import os, tempfile
>>> from mpeg4fba.models import reference_head
>>> from mpeg4fba.formats.wrl_face import save_face
>>> p = os.path.join(tempfile.mkdtemp(), "head.wrl")
>>> save_face(reference_head(resolution=0.5), p)
>>> face = read_face(p)
>>> len(face.meshes), len(face.points)
(9, 84)
"""
from __future__ import annotations

import os
from typing import Optional, Union

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointSet
from .errors import FormatError

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["read_face", "read_points", "VRML_SUFFIXES", "MESH_SUFFIXES"]

VRML_SUFFIXES = (".wrl", ".wrz", ".wrl.gz", ".gz")
MESH_SUFFIXES = (".obj", ".glb", ".gltf", ".ply", ".stl", ".off")


def read_points(path: PathLike, face: FaceModel) -> tuple:
    """(FeaturePointSet with positions in the face frame, FAPU or None) from a sidecar."""
    p = os.fspath(path)
    low = p.lower()
    if low.endswith(".json"):
        from .fpjson import read_feature_points_json
        points, fapu = read_feature_points_json(p)
    elif low.endswith(".fdp"):
        from .xface_fdp import read_xface_fdp
        fdp = read_xface_fdp(p)
        points, fapu = fdp.points, fdp.fapu
        if len(face.meshes) == 1:
            # Xface names a mesh by its file; a face of one mesh takes them all
            only = next(iter(face.meshes))
            points = FeaturePointSet({}, {k: (only, v) for k, (_, v) in points.vertices.items()})
    else:
        raise FormatError("feature points come in a .json sidecar or an Xface .fdp file", p)
    world = {name: face.world_vertices(name) for name in face.meshes}
    try:
        points = points.resolve(world)
    except ValueError as e:
        raise FormatError(str(e), p) from None
    return points, fapu


def read_face(path: PathLike, points: Optional[PathLike] = None, *, lenient: bool = False,
              max_inflated: Optional[int] = None, max_ratio: Optional[float] = None) -> FaceModel:
    """A FaceModel from a VRML face or a neutral mesh file, with feature points from
    ``points`` (they replace the file's own; its FAPU too when the sidecar has one).
    ``max_inflated`` / ``max_ratio`` bound a gzipped VRML face's inflation (see
    :func:`mpeg4fba.vrml.load`)."""
    p = os.fspath(path)
    low = p.lower()
    if low.endswith(MESH_SUFFIXES):
        from .morph_targets import read_morph_face
        face = read_morph_face(p, lenient=lenient)
    elif low.endswith(VRML_SUFFIXES):
        from .wrl_face import load_face
        face = load_face(p, strict=not lenient, max_inflated=max_inflated, max_ratio=max_ratio)
    else:
        raise FormatError(f"a face is read from VRML ({', '.join(VRML_SUFFIXES)}) or a "
                          f"mesh file ({', '.join(MESH_SUFFIXES)})", p)
    if points is not None:
        pts, fapu = read_points(points, face)
        face.points = pts
        face.fapu = fapu
    return face
