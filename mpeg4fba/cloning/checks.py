"""Checks of a face's feature points against its meshes, before any cloning work: the
points must lie on the mesh, in the mesh's units.

A point file made for another face, or written in millimetres for a mesh in
centimetres, used to be accepted silently and cloned into garbage.  Now:

* the points that should lie on a surface (all but :data:`~mpeg4fba.fba.requirements.
  NOT_SURFACE` and the pupils, which float in the eye opening of a head without
  eyeballs) are measured against every mesh of the face; those further than
  :data:`PLACEMENT_TOLERANCE` of the face size (the extent of those points) are an
  error naming each point and its distance in % of the face size;
* when most of them are off, and the points scaled by a power of ten (10, 100, 1000 or
  their inverses) about the origin do lie on the mesh, the error says it is a unit
  mismatch and by how much to scale ("the points look like millimetres while the mesh
  is in centimetres: scale them by 0.1?"); otherwise that the points look like another
  face's.

>>> from mpeg4fba.models import reference_head
>>> face = reference_head(resolution=0.5)
>>> check_placement(face)                  # the reference head's own points: no error
>>> from mpeg4fba.fba.featurepoints import FeaturePointSet
>>> face.points = FeaturePointSet({k: face.points[k] * 1000 for k in face.points})
>>> check_placement(face)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
mpeg4fba.cloning.checks.PlacementError: ... look like millimetres while the mesh is in metres ...
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointError, point_order
from ..fba.requirements import NOT_SURFACE
from .surface import closest_points

__all__ = ["PLACEMENT_TOLERANCE", "PlacementError", "check_placement", "surface_distances",
           "face_size", "UNITS"]

#: How far a feature point may lie from the mesh's surface, as a fraction of the face
#: size (the largest side of the bounding box of the points that should lie on it, ear
#: to ear or brow to chin): 0.02 is 3 to 4 mm on a human face.  Points written from the
#: mesh's vertices or picked on its surface are at 0; a point placed by eye on a coarse
#: mesh, between its facets, is well under this.  Too small: a hand-placed point just
#: off a coarse mesh is refused; too large: a point on the wrong side of a lip (a few mm
#: off through the mouth) passes.
PLACEMENT_TOLERANCE = 0.02

#: Length units a face may be modelled in, in millimetres (for the unit-mismatch error).
UNITS = {"millimetres": 1.0, "centimetres": 10.0, "decimetres": 100.0, "metres": 1000.0}

#: A human's eye separation in millimetres, to name the points' unit from their ES.
_HUMAN_EYES_MM = 62.0


class PlacementError(FeaturePointError):
    """Feature points that do not lie on their face's mesh (off it, in other units, or
    another face's); ``ids`` names the points off the surface."""


def face_size(points: np.ndarray) -> float:
    """The largest side of the bounding box of ``points`` (n, 3).

    >>> face_size(np.array([[0, 0, 0], [2.0, 1, 0]]))
    2.0
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return float(np.ptp(p, axis=0).max()) if len(p) else 0.0


def _surface(face: FaceModel) -> tuple:
    verts, tris, first = [], [], 0
    for name, mesh in face.meshes.items():
        if not len(mesh.vertices) or not len(mesh.triangles):
            continue
        verts.append(face.world_vertices(name))
        tris.append(mesh.triangles + first)
        first += len(mesh.vertices)
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.vstack(verts), np.vstack(tris)


def surface_distances(face: FaceModel, points: np.ndarray) -> np.ndarray:
    """(n,) distance of each of ``points`` from the nearest surface of the face's meshes
    (inf when the face has no triangles)."""
    V, T = _surface(face)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(T):
        return np.full(len(p), np.inf)
    return closest_points(p, V, T, k=16)[2]


def _checked(face: FaceModel) -> list:
    """The points that should lie on a surface: not inside the head, not the pupils."""
    return [k for k in face.points if k not in NOT_SURFACE and k not in ("3.5", "3.6")]


def _unit_name(mm: float) -> Optional[str]:
    for name, size in UNITS.items():
        if abs(np.log10(mm / size)) < 0.3:
            return name
    return None


def check_placement(face: FaceModel, which: str = "", *,
                    tolerance: float = PLACEMENT_TOLERANCE) -> None:
    """Raise :class:`PlacementError` when the face's feature points do not lie on its
    meshes (see the module docstring); ``which`` names the face in the message
    ("target"); ``tolerance`` is a fraction of the face size."""
    ids = _checked(face)
    if len(ids) < 3:
        return
    p = np.array([face.points[k] for k in ids])
    size = face_size(p)
    if not size > 0:
        return
    d = surface_distances(face, p)
    off = d > tolerance * size
    if not off.any():
        return
    who = f"the {which} face's ({face.name})" if which else "the face's"
    if off.mean() > 0.5:
        scale = _unit_scale(face, p, tolerance)
        if scale is not None:
            raise PlacementError(_unit_message(who, face, scale), point_order(ids))
    bad = [(k, dist) for k, dist, o in zip(ids, d, off) if o]
    shown = bad if len(bad) <= _LISTED else sorted(bad, key=lambda b: -b[1])[:_LISTED]
    listed = ", ".join(f"{k} ({dist / size * 100:.1f} %)" for k, dist in shown)
    if len(shown) < len(bad):
        listed += f" and {len(bad) - len(shown)} more"
    where = (f"(distance from the surface in % of the face size, {size:.4g}; at most "
             f"{tolerance * 100:g} % is allowed)")
    if off.mean() >= 0.25:
        raise PlacementError(
            f"{who} feature points do not fit its mesh: {len(bad)} of {len(ids)} lie off the "
            f"surface, {listed} {where}: a point file made for another face, or for this "
            "one moved or turned?", [k for k, _ in bad])
    raise PlacementError(
        f"{who} feature point{'s' if len(bad) > 1 else ''} {listed} "
        f"lie{'' if len(bad) > 1 else 's'} off its mesh {where}: "
        f"move {'them' if len(bad) > 1 else 'it'} onto the surface",
        [k for k, _ in bad])


#: Points named one by one in an error before "and N more".
_LISTED = 12


def _unit_scale(face: FaceModel, p: np.ndarray, tolerance: float) -> Optional[float]:
    """The power of ten that puts most of the points ``p`` on the mesh, if one does."""
    for k in (1, 2, 3):
        for scale in (10.0 ** -k, 10.0 ** k):
            q = p * scale
            d = surface_distances(face, q)
            if np.mean(d <= tolerance * face_size(q)) > 0.5:
                return scale
    return None


def _unit_message(who: str, face: FaceModel, scale: float) -> str:
    """"the points look like millimetres while the mesh is in centimetres ..."."""
    points_unit = mesh_unit = None
    if "3.5" in face.points and "3.6" in face.points:
        es = float(np.linalg.norm(face.points["3.5"] - face.points["3.6"]))
        if es > 0:
            # the unit that makes the points' eye separation a human one
            per_unit = _HUMAN_EYES_MM / es
            points_unit = _unit_name(per_unit)
            mesh_unit = _unit_name(per_unit / scale)
    factor = f"{scale:g}"
    if points_unit and mesh_unit and points_unit != mesh_unit:
        return (f"{who} feature points look like {points_unit} while the mesh is in "
                f"{mesh_unit} (the points lie on the mesh when scaled by {factor}): scale "
                f"them by {factor}?")
    return (f"{who} feature points are in other units than the mesh: they lie on it when "
            f"scaled by {factor}; scale them by {factor}?")
