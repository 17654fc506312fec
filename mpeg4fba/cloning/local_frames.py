"""Local-frame expression cloning for faces that share a mesh (Kong, Kang and Yin,
*Cloning of Facial Expressions Using Spatial Information*).

The face is split into five **spaces**, :data:`SPACES`: mouth (with the teeth and the
tongue), eyes, nose, brows and the rest of the face.  Each space has a local frame made
of four **base points**: ``bp1`` the origin, ``bp2`` and ``bp3`` giving the X and Y
directions ``a = (bp2 - bp1) / |bp2 - bp1|`` and ``b = (bp3 - bp1) / |bp3 - bp1|`` -
deliberately not orthogonal: the angle between them carries the shape, e.g. the mouth's
width - and ``c = a x b / |a x b|``; ``bp4``, the **w-point**, whose local coordinates
measure the space.

A point ``p`` has the local coordinates ``e = ((p - o).a, (p - o).b, (p - o).c)`` (the
feet of the perpendiculars from ``p`` to the three axes, the paper's eqs. 1-3).  The
source's expression is the change of local coordinates ``T = e_key - e_base``, divided
component-wise by the source w-point's local coordinates ``w`` (eq. 4) and multiplied by
the target's ``s`` (eq. 5): ``e_target_key = e_target_base + (s / w) * T``.  Back in
world coordinates each space solves ``D p = e + D o`` (``D`` the rows a, b, c; eqs. 6-8)
for all its points at once.

Where the paper is silent:

* **Vertex to space**: each vertex goes to the space of its closest feature point
  (:data:`SPACE_POINTS`; the regions of :mod:`~mpeg4fba.cloning.normalise` work the same
  way), eyeball meshes to the eyes and teeth and tongue meshes to the mouth
  (:func:`~mpeg4fba.cloning.parts.find_parts`); or from a map the caller gives.
* **Base points** (the paper's Table 1 is not in the text we have): :data:`BASE_POINTS`,
  chosen so that ``bp4`` lies well off the plane of the other three (a w-point near that
  plane makes ``w_z`` tiny and the division blow up).  A w-point coordinate below
  ``min_w`` (10 %) of the w-point's distance on either face is not used: that component takes
  the mean ratio of the others, with a :class:`LocalFrameWarning`.

>>> import numpy as np
>>> f = LocalFrame.from_points([0, 0, 0], [1, 0, 0], [1, 1, 0], [0.5, 0.5, 1.0])
>>> e = f.local(np.array([[0.3, 0.2, 0.4]]))
>>> np.round(f.world(e), 12).tolist()
[[0.3, 0.2, 0.4]]
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Mapping, Optional, Sequence, Union

import numpy as np
from scipy.spatial import cKDTree

from ..fba.face import FaceModel
from ..fba.fat import FaceDefTable, interval_weights, table_borders
from ..fba.featurepoints import FeaturePointError, FeaturePointSet
from ..fba.morph import FULL_SHAPE, MorphTarget, TargetKey, fat_from_morph_targets
from .errors import CloneWarning, LocalFrameWarning, TopologyError
from .parts import find_parts

__all__ = ["SPACES", "SPACE_POINTS", "BASE_POINTS", "LocalFrame", "LocalFrameWarning",
           "TopologyError", "assign_spaces", "LocalFrameCloner", "local_frame_clone"]

SPACES = ("mouth", "eyes", "nose", "brows", "rest")

#: Feature points whose nearest vertices go to each space.
SPACE_POINTS = {
    "mouth": ("2.1", "2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9", "2.10", "2.11",
              "2.12", "6.1", "6.2", "6.3", "6.4", "8.1", "8.2", "8.3", "8.4", "8.5", "8.6",
              "8.7", "8.8", "8.9", "8.10", "9.8", "9.9", "9.10", "9.11"),
    "eyes": ("3.1", "3.2", "3.3", "3.4", "3.5", "3.6", "3.7", "3.8", "3.9", "3.10", "3.11",
             "3.12", "3.13", "3.14"),
    "nose": ("9.1", "9.2", "9.3", "9.4", "9.5", "9.6", "9.7", "9.12", "9.13", "9.14", "9.15"),
    "brows": ("4.1", "4.2", "4.3", "4.4", "4.5", "4.6"),
    "rest": ("2.13", "2.14", "5.1", "5.2", "5.3", "5.4", "7.1", "10.1", "10.2", "10.3", "10.4",
             "10.5", "10.6", "10.7", "10.8", "10.9", "10.10", "11.1", "11.2", "11.3", "11.4",
             "11.5", "11.6"),
}

#: Base points (bp1 origin, bp2 X, bp3 Y, bp4 w-point) of each space.  The mouth follows
#: the paper's description (a point on the nose, the two lip corners, the middle of the
#: mouth); the others are built the same way round their features, each with its w-point
#: well off the plane of the other three on every face we measured (ICT identities and
#: the reference head: each local coordinate of bp4 at least a third of its length), so
#: that no component of the w-point ratio divides by a near-zero.
BASE_POINTS = {
    "mouth": ("9.15", "8.3", "8.4", "8.2"),
    "eyes": ("2.1", "3.7", "3.12", "9.3"),
    "nose": ("2.2", "3.11", "3.8", "9.3"),
    "brows": ("2.1", "4.5", "4.6", "9.3"),
    "rest": ("11.1", "2.13", "2.14", "9.3"),
}


@dataclass
class LocalFrame:
    """One space's frame: origin ``o``, unit axes ``a``, ``b`` (not orthogonal) and
    ``c = a x b / |a x b|``, and the w-point's local coordinates ``w``."""

    origin: np.ndarray
    axes: np.ndarray        # rows a, b, c
    w: np.ndarray

    @classmethod
    def from_points(cls, bp1, bp2, bp3, bp4) -> "LocalFrame":
        o, p2, p3, p4 = (np.asarray(p, dtype=np.float64).reshape(3) for p in (bp1, bp2, bp3, bp4))
        a, b = p2 - o, p3 - o
        na, nb = np.linalg.norm(a), np.linalg.norm(b)
        if na == 0 or nb == 0:
            raise ValueError("a base point coincides with the origin bp1")
        a, b = a / na, b / nb
        c = np.cross(a, b)
        nc = np.linalg.norm(c)
        if nc < 1e-9:
            raise ValueError("bp1, bp2 and bp3 are on one line: no frame")
        axes = np.vstack([a, b, c / nc])
        frame = cls(o, axes, np.zeros(3))
        frame.w = frame.local(p4[None])[0]
        return frame

    @property
    def size(self) -> float:
        return float(np.linalg.norm(self.w))

    def local(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) local coordinates: projections of ``p - o`` on a, b and c."""
        return (np.asarray(points, dtype=np.float64).reshape(-1, 3) - self.origin) @ self.axes.T

    def world(self, local: np.ndarray) -> np.ndarray:
        """Points from local coordinates: ``D p = e + D o`` solved for every row at once."""
        e = np.asarray(local, dtype=np.float64).reshape(-1, 3)
        rhs = e + self.axes @ self.origin
        return np.linalg.solve(self.axes, rhs.T).T


def assign_spaces(face: FaceModel, vertices: Mapping[str, np.ndarray],
                  spaces: Optional[Mapping] = None) -> dict:
    """Mesh name -> (n,) index into :data:`SPACES` of each vertex.

    ``spaces`` may give, per mesh, an array of space names or indices (the user's map);
    meshes it leaves out are assigned from the feature points.
    """
    given = dict(spaces or {})
    ids, owner = [], []
    for k, name in enumerate(SPACES):
        for fp in SPACE_POINTS[name]:
            if fp in face.points:
                ids.append(fp)
                owner.append(k)
    if not ids:
        raise FeaturePointError("assigning vertices to spaces needs feature points")
    tree = cKDTree(np.array([face.points[i] for i in ids]))
    owner = np.asarray(owner)
    whole = {}
    try:
        parts = find_parts(face)
    except Exception:  # noqa: BLE001 - parts only refine the default
        parts = {}
    for part, meshes in parts.items():
        if part in ("left eye", "right eye"):
            whole.update({m: SPACES.index("eyes") for m in meshes})
        elif part in ("upper teeth", "lower teeth", "tongue"):
            whole.update({m: SPACES.index("mouth") for m in meshes})
    out = {}
    for mesh, v in vertices.items():
        if mesh in given:
            s = np.asarray(given[mesh])
            if s.dtype.kind in "US":
                bad = set(s.tolist()) - set(SPACES)
                if bad:
                    raise ValueError(f"mesh {mesh}: unknown space(s) {sorted(bad)}; the spaces "
                                     f"are {', '.join(SPACES)}")
                s = np.array([SPACES.index(x) for x in s])
            if s.shape != (len(v),):
                raise ValueError(f"mesh {mesh}: the space map has {s.shape} entries for "
                                 f"{len(v)} vertices")
            out[mesh] = s.astype(np.int64)
        elif mesh in whole:
            out[mesh] = np.full(len(v), whole[mesh], dtype=np.int64)
        else:
            out[mesh] = owner[tree.query(v)[1]] if len(v) else np.zeros(0, dtype=np.int64)
    return out


def _frames(points: FeaturePointSet, base_points: Mapping, which: str) -> dict:
    need = sorted({p for bp in base_points.values() for p in bp})
    missing = points.missing(need)
    if missing:
        raise FeaturePointError(f"the {which} face lacks base point"
                                f"{'s' if len(missing) > 1 else ''} {', '.join(missing)} of the "
                                f"local frames", missing)
    out = {}
    for space, bp in base_points.items():
        try:
            out[space] = LocalFrame.from_points(*(points[p] for p in bp))
        except ValueError as e:
            raise ValueError(f"{which} face, {space} space (base points {', '.join(bp)}): {e}") from None
    return out


class LocalFrameCloner:
    """Local-frame cloning between two faces with the same meshes (same names, vertex
    counts and triangles).

    ``spaces`` optionally maps mesh names to per-vertex space names / indices;
    ``base_points`` overrides :data:`BASE_POINTS` per space (four feature point ids);
    ``scale=False`` copies the local displacement without the w-point ratio.
    """

    def __init__(self, source: FaceModel, target: FaceModel, *, spaces: Optional[Mapping] = None,
                 base_points: Optional[Mapping] = None, scale: bool = True, min_w: float = 0.1):
        _check_topology(source, target)
        self.source, self.target = source, target
        bps = dict(BASE_POINTS)
        for k, v in (base_points or {}).items():
            if k not in SPACES:
                raise ValueError(f"unknown space {k!r}; the spaces are {', '.join(SPACES)}")
            if len(v) != 4:
                raise ValueError(f"{k}: give four base points (bp1 origin, bp2 X, bp3 Y, bp4 w-point)")
            bps[k] = tuple(str(p) for p in v)
        self.base_points = bps
        self.meshes = [m for m in source.meshes if len(source.meshes[m].vertices)]
        self.src_world = {m: source.world_vertices(m) for m in self.meshes}
        self.tgt_world = {m: target.world_vertices(m) for m in self.meshes}
        self.spaces = assign_spaces(source, self.src_world, spaces)
        self.src_frames = _frames(source.points, bps, "source")
        self.tgt_frames = _frames(target.points, bps, "target")
        self.ratio = {}
        for space in SPACES:
            self.ratio[space] = self._ratio(space, scale, min_w) if scale else np.ones(3)
        # per mesh, per space: the rows and the target base's local coordinates
        self._rows = {m: [(k, np.flatnonzero(self.spaces[m] == k)) for k in range(len(SPACES))]
                      for m in self.meshes}

    def _ratio(self, space: str, scale: bool, min_w: float) -> np.ndarray:
        fs, ft = self.src_frames[space], self.tgt_frames[space]
        ok = (np.abs(fs.w) > min_w * fs.size) & (np.abs(ft.w) > min_w * ft.size)
        r = np.ones(3)
        r[ok] = ft.w[ok] / fs.w[ok]
        if not ok.all():
            fill = float(np.mean(r[ok])) if ok.any() else 1.0
            r[~ok] = fill
            axes = ", ".join("xyz"[k] for k in np.flatnonzero(~ok))
            warnings.warn(f"{space} space: the w-point {self.base_points[space][3]} has a "
                          f"local {axes} coordinate too small to scale by; using {fill:.3g}",
                          LocalFrameWarning, stacklevel=3)
        return r

    def clone_keys(self, keys: Union[Mapping, Sequence], mix: Optional[Mapping] = None) -> list:
        """Target key shapes (world vertices per mesh) from source key shapes.

        ``keys`` is a list of source key models, each a dict mesh -> (n, 3) world
        vertices (or (K, n, 3) arrays per mesh for K keys).  ``mix`` takes each named
        space from another key: ``{"mouth": 3, "brows": 7}`` gives one output whose mouth
        is key 3's and brows key 7's (other spaces stay neutral).
        """
        if isinstance(keys, Mapping):
            stacked = {m: np.asarray(keys[m], dtype=np.float64).reshape(-1, *self.src_world[m].shape)
                       for m in self.meshes if m in keys}
            n_keys = len(next(iter(stacked.values()))) if stacked else 0
        else:
            n_keys = len(keys)
            stacked = {m: np.stack([np.asarray(k.get(m, self.src_world[m]), dtype=np.float64)
                                    for k in keys]) if n_keys else np.zeros((0,) + self.src_world[m].shape)
                       for m in self.meshes}
        for m, arr in stacked.items():
            if arr.shape[1:] != self.src_world[m].shape:
                raise ValueError(f"key shapes of mesh {m} have shape {arr.shape[1:]}, the mesh "
                                 f"{self.src_world[m].shape}")
        if mix is not None:
            return [self._mixed(stacked, mix, n_keys)]
        out = {m: np.empty_like(stacked.get(m, np.zeros((n_keys,) + self.src_world[m].shape)))
               for m in self.meshes}
        for m in self.meshes:
            src = stacked.get(m)
            if src is None:
                out[m] = np.broadcast_to(self.tgt_world[m], (n_keys,) + self.tgt_world[m].shape).copy()
                continue
            for k, rows in self._rows[m]:
                if len(rows):
                    out[m][:, rows] = self._space(SPACES[k], self.src_world[m][rows], src[:, rows],
                                                  self.tgt_world[m][rows])
        return [{m: out[m][i] for m in self.meshes} for i in range(n_keys)]

    def _mixed(self, stacked: dict, mix: Mapping, n_keys: int) -> dict:
        for space, key in mix.items():
            if space not in SPACES:
                raise ValueError(f"unknown space {space!r}; the spaces are {', '.join(SPACES)}")
            if not 0 <= int(key) < n_keys:
                raise ValueError(f"{space}: key {key} out of range ({n_keys} keys)")
        out = {m: self.tgt_world[m].copy() for m in self.meshes}
        for m in self.meshes:
            if m not in stacked:
                continue
            for k, rows in self._rows[m]:
                space = SPACES[k]
                if space in mix and len(rows):
                    key = int(mix[space])
                    out[m][rows] = self._space(space, self.src_world[m][rows],
                                               stacked[m][key:key + 1, rows],
                                               self.tgt_world[m][rows])[0]
        return out

    def _space(self, space: str, src_base: np.ndarray, src_keys: np.ndarray,
               tgt_base: np.ndarray) -> np.ndarray:
        fs, ft = self.src_frames[space], self.tgt_frames[space]
        T = fs.local(src_keys.reshape(-1, 3)).reshape(src_keys.shape) - fs.local(src_base)[None]
        e = ft.local(tgt_base)[None] + T * self.ratio[space]
        return ft.world(e.reshape(-1, 3)).reshape(e.shape)

    def morph_targets(self) -> list:
        """The target's morph targets (:class:`~mpeg4fba.fba.morph.MorphTarget`, vertices
        in each mesh's own frame), one per source table and non-zero interval border (the
        full shape, at 63, for a viseme or expression)."""

        to_local = {}         # mesh -> (inverse linear part, translation) of its world matrix
        for m in self.meshes:
            M = self.target.world_matrix(self.target.meshes[m].parent)[0]
            to_local[m] = (np.linalg.inv(M[:3, :3]), M[:3, 3])
        targets = []
        for table in sorted(self.source.fat, key=lambda t: t.key):
            high = table.fap <= 2
            b = table_borders(table)
            values = np.array([FULL_SHAPE]) if high else b[b != 0]
            keys = {m: np.broadcast_to(self.src_world[m], (len(values),) + self.src_world[m].shape).copy()
                    for m in self.meshes}
            for entry in table.meshes:
                if entry.mesh not in keys:
                    continue
                R = self.source.world_matrix(self.source.meshes[entry.mesh].parent)[0][:3, :3]
                w = interval_weights(entry.borders, values)
                keys[entry.mesh][:, entry.indices] += np.einsum("bj,kjc->bkc", w, entry.displacements) @ R.T
            shapes = self.clone_keys(keys)
            key = TargetKey(table.fap, table.select if high else 0)
            for value, shape in zip(values, shapes):
                local = {m: (shape[m] - t) @ inv.T for m, (inv, t) in to_local.items()}
                targets.append(MorphTarget(key, None if high else float(value), local))
        return targets

    def clone(self) -> FaceModel:
        """The target with a FAT made, through the morph-target path
        (:func:`~mpeg4fba.fba.morph.fat_from_morph_targets`), from :meth:`morph_targets`.
        The source's Transform motions are kept for Transforms the target has too."""
        out = self.target.copy()
        neutral = {m: self.target.meshes[m].vertices for m in self.meshes}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")      # a table that moves no mesh is fine here
            fat = fat_from_morph_targets(neutral, self.morph_targets(), order_check=None)
        dropped = set()
        for table in self.source.fat:
            kept = [t for t in table.transforms if t.transform in out.transforms]
            dropped |= {t.transform for t in table.transforms if t.transform not in out.transforms}
            if kept:
                if table.key not in fat:
                    fat.add(FaceDefTable(table.fap, [], [], table.select))
                fat[table.key].transforms.extend(kept)
        if dropped:
            warnings.warn(f"the target has no Transform {', '.join(sorted(dropped))}: their "
                          f"motion is not cloned", CloneWarning, stacklevel=2)
        out.fat = fat
        out.invalidate()
        return out


def _check_topology(source: FaceModel, target: FaceModel) -> None:
    advice = ("; local-frame cloning needs faces that share a mesh - use the motion cloning "
              "(method='fmc', `mpeg4fba clone` without --method) for faces meshed differently")
    sm, tm = set(source.meshes), set(target.meshes)
    if sm != tm:
        raise TopologyError(f"the faces have different meshes (only in the source: "
                            f"{sorted(sm - tm)}, only in the target: {sorted(tm - sm)})" + advice)
    for name in source.meshes:
        a, b = source.meshes[name], target.meshes[name]
        if len(a.vertices) != len(b.vertices):
            raise TopologyError(f"mesh {name} has {len(a.vertices)} vertices in the source and "
                                f"{len(b.vertices)} in the target" + advice)
        if a.triangles.shape != b.triangles.shape or not np.array_equal(a.triangles, b.triangles):
            raise TopologyError(f"mesh {name} is connected differently in the two faces" + advice)


def local_frame_clone(source: FaceModel, target: FaceModel, **options) -> FaceModel:
    """The target face with the source's FAT cloned by local frames (same-mesh faces)."""
    return LocalFrameCloner(source, target, **options).clone()
