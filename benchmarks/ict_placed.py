"""ICT-FaceKit heads as users give them (:mod:`benchmarks.ict`, which names these too):
:class:`Placement` / :func:`random_placement` (up +Y or +Z, facing any horizontal axis,
tilted up to 20 degrees, scale 0.1, 1 or 10), :func:`placed_face` (moved, eyeballs dropped
on request, points stripped), :func:`cut_at_seams` and :func:`jaw_fat`."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable
from mpeg4fba.fba.featurepoints import FeaturePointSet

from .ict import split_deltas

__all__ = ["Placement", "random_placement", "placed_face", "cut_at_seams", "jaw_fat",
           "axis_vector", "UP_AXES", "FACING_AXES", "SCALES", "MAX_TILT", "EYEBALLS"]

#: The two supported up axes and, for each, the horizontal axes a face may look along.
UP_AXES = {"+Y": (0, 1, 0), "+Z": (0, 0, 1)}
FACING_AXES = {"+Y": ("+X", "-X", "+Z", "-Z"), "+Z": ("+X", "-X", "+Y", "-Y")}
#: The scales a head is given (ICT is in cm: 0.1 looks like dm, 10 like mm).
SCALES = (0.1, 1.0, 10.0)
#: Largest tilt (degrees) off the supported orientations.
MAX_TILT = 20.0
#: The eyeball meshes dropped from a head "without eyes".
EYEBALLS = ("LeftEyeball", "RightEyeball")


def cut_at_seams(face: FaceModel, mesh: str = "Skin") -> tuple:
    """``face`` with ``mesh`` cut into texture islands as a glTF exporter stores a
    textured head: front, back left and back right, every vertex on an island's border
    given once per island (the copies after the mesh's own vertices); (cut face, without
    a FAT, the original vertex of each of the cut mesh's vertices).

    >>> from mpeg4fba.models import reference_head
    >>> head = reference_head(resolution=0.5)
    >>> cut, origin = cut_at_seams(head)
    >>> n = len(head.meshes["Skin"].vertices)
    >>> len(origin) > n, bool((origin[:n] == range(n)).all())
    (True, True)
    """
    m = face.meshes[mesh]
    V, T = m.vertices, m.triangles
    c = V[T].mean(1)
    mid = np.median(V[:, 2])
    island = np.where(c[:, 2] > mid, 0, np.where(c[:, 0] > 0, 1, 2))
    corner = np.repeat(island, 3)
    # the first island to use a vertex keeps it; the others get a copy
    owner = np.full(len(V), -1)
    for k in (0, 1, 2):
        free = (owner[T.ravel()] == -1) & (corner == k)
        owner[T.ravel()[free]] = k
    owner[owner < 0] = 0
    flat = T.ravel()
    key = flat * 3 + corner
    other = corner != owner[flat]
    copies = np.unique(key[other])
    flat = np.where(other, len(V) + np.searchsorted(copies, key), flat)
    origin = np.r_[np.arange(len(V)), copies // 3]
    out = face.copy()
    out.meshes[mesh] = FaceMesh(mesh, V[origin], flat.reshape(-1, 3), m.parent, m.color)
    out.points = FeaturePointSet({k: face.points[k] for k in face.points}, dict(face.points.vertices))
    out.fat = FAT()
    if mesh in face.colors and np.ndim(face.colors[mesh]) == 2:
        out.colors[mesh] = np.asarray(face.colors[mesh])[origin]
    return out, origin


def axis_vector(name: str) -> np.ndarray:
    v = np.zeros(3)
    v["XYZ".index(name[1])] = 1.0 if name[0] == "+" else -1.0
    return v


@dataclass(frozen=True)
class Placement:
    """Where a head is put: ``world = scale * rotation @ head + offset``.  The head frame
    is ICT's (cm, +y up, +z the way the face looks, +x its left); ``up`` and ``facing``
    name the world axes the head's +y and +z go to before the ``tilt`` (degrees, about
    ``tilt_axis``, a unit vector) is applied.  Rotations are proper (no mirror image)."""

    up: str
    facing: str
    tilt: float
    tilt_axis: tuple
    scale: float
    offset: tuple

    @property
    def rotation(self) -> np.ndarray:
        up, fwd = axis_vector(self.up), axis_vector(self.facing)
        R0 = np.c_[np.cross(up, fwd), up, fwd]          # columns: head x, y, z in the world
        a = np.asarray(self.tilt_axis, dtype=np.float64)
        th = np.radians(self.tilt)
        K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        Rt = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
        return Rt @ R0

    def apply(self, P: np.ndarray) -> np.ndarray:
        """Head-frame points (..., 3) -> world."""
        return self.scale * np.asarray(P, dtype=np.float64) @ self.rotation.T + np.asarray(self.offset)

    def undo(self, P: np.ndarray) -> np.ndarray:
        """World points (..., 3) -> the head frame (scale undone)."""
        return (np.asarray(P, dtype=np.float64) - np.asarray(self.offset)) @ self.rotation / self.scale

    @property
    def label(self) -> str:
        return f"up {self.up}, facing {self.facing}, tilt {self.tilt:.0f} deg, x{self.scale:g}"


def random_placement(rng: np.random.Generator) -> Placement:
    """A supported placement: up +Y or +Z (equally likely), facing one of the four
    horizontal axes (equally likely), tilted by U(0, :data:`MAX_TILT`) degrees about a
    uniformly random axis, scaled by one of :data:`SCALES` (equally likely), moved by
    U(-20, 20) cm per axis times the scale.

    >>> p = random_placement(np.random.default_rng(0))
    >>> P = np.array([[1.0, 2, 3]])
    >>> bool(np.allclose(p.undo(p.apply(P)), P)), bool(np.isclose(np.linalg.det(p.rotation), 1))
    (True, True)
    """
    up = str(rng.choice(list(UP_AXES)))
    facing = str(rng.choice(FACING_AXES[up]))
    tilt = float(rng.uniform(0, MAX_TILT))
    a = rng.standard_normal(3)
    a /= np.linalg.norm(a)
    scale = float(rng.choice(SCALES))
    offset = rng.uniform(-20, 20, 3) * scale
    return Placement(up, facing, tilt, tuple(a.tolist()), scale, tuple(offset.tolist()))


def placed_face(face: FaceModel, placement: Optional[Placement] = None, *, eyes: bool = True,
                points: Optional[FeaturePointSet] = None, name: Optional[str] = None) -> FaceModel:
    """A head as a user has it: ``face``'s meshes moved by ``placement`` (default none),
    without the eyeball meshes (:data:`EYEBALLS`) unless ``eyes``, with ``points``
    (moved likewise; default none: a dumb mesh) and no regions, colours or FAT.  The
    meshes keep their names and vertex order (so results map back by index)."""
    meshes = []
    for m in face.meshes.values():
        if not eyes and m.name in EYEBALLS:
            continue
        v = m.vertices if placement is None else placement.apply(m.vertices)
        meshes.append(FaceMesh(m.name, v, m.triangles))
    pts = None
    if points is not None:
        pos = {k: points[k] if placement is None else placement.apply(points[k]) for k in points}
        ties = {k: t for k, t in points.vertices.items() if eyes or t[0] not in EYEBALLS}
        pts = FeaturePointSet(pos, ties)
    return FaceModel(meshes, points=pts, name=name or face.name)


def jaw_fat(data, source: FaceModel) -> FAT:
    """jawOpen of ``data`` as a FAP 3 (open_jaw) table on ``source``, its motion at 1024
    the expression: how the benchmarks see a cloned jaw's rotation."""
    meshes = []
    for mesh, d in split_deltas(source, data.expressions["jawOpen"]).items():
        moving = np.flatnonzero(np.abs(d).max(axis=1) > 0)
        if len(moving):
            meshes.append(FaceDefMesh(mesh, [0, 1024], moving, d[moving][:, None, :] / 1024))
    return FAT([FaceDefTable(3, meshes)])
