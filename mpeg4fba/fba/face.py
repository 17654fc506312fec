"""FaceModel: a face's meshes in their transform tree, its feature points, FAPU and FAT;
and playback of FAP streams on it.

Playback compiles the FAT once into one linear operator per mesh (rows: the intervals
of every FaceDefMesh touching the mesh; columns: vertex coordinates), so a stream is a
product per mesh: ``vertices[frames, 3n] = neutral + W[frames, slots] @ B``, where W
holds each frame's interval weights.  Long streams use a blocked dense form of B (small
BLAS products written straight into one preallocated output, a chunk of frames at a
time), short ones the sparse B (see :class:`_MeshOperator`).  Transforms are composed
per frame with vectorised Rodrigues rotations.

Example
-------
>>> from mpeg4fba.fba import FapStream
>>> skin = FaceMesh("Skin", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
>>> fat = FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 1024], [2], [[0, -0.001, 0]])])])
>>> face = FaceModel([skin], fat=fat)
>>> frames = face.play(FapStream.from_values({"open_jaw": [0, 512, 1024]}))
>>> frames.vertices("Skin")[:, 2].round(6).tolist()
[[0.0, 1.0, 0.0], [0.0, 0.488, 0.0], [0.0, -0.024, 0.0]]
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Iterable, Mapping, Optional, Sequence

import numpy as np
import scipy.sparse as sp

from .appearance import is_closed, mesh_color
from .fapu import FAPU
from .fat import FAT, FaceDefTable, FaceDefMesh, interval_weights, rotation_matrices
from .featurepoints import FeaturePointSet
from .stream import FapStream
from .tables import N_FAPS

__all__ = ["FaceMesh", "FaceTransform", "FaceModel", "Playback", "table_values"]


@dataclass(eq=False)
class FaceMesh:
    """A mesh of the face: neutral ``vertices`` [n, 3] in its own (local) coordinates,
    ``triangles`` [m, 3], ``parent``, the name of the Transform it hangs under (None:
    the face's root), and ``color``, its own RGB colour (0-1, as displayed: a VRML
    Material's diffuseColor, a glTF material's base colour) or None for the one its
    name suggests (:func:`~mpeg4fba.fba.appearance.mesh_color`).  Colours per vertex,
    where a face has them, are in :attr:`FaceModel.colors` and take precedence.

    >>> FaceMesh("Tongue", np.eye(3), [[0, 1, 2]]).display_color()
    (0.8, 0.4, 0.42)
    >>> FaceMesh("Tongue", np.eye(3), [[0, 1, 2]], color=(1, 0, 0)).display_color()
    (1.0, 0.0, 0.0)
    """

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    parent: Optional[str] = None
    color: Optional[tuple] = None

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, dtype=np.float64).reshape(-1, 3)
        self.triangles = np.asarray(self.triangles, dtype=np.int64).reshape(-1, 3)
        if self.color is not None:
            c = np.asarray(self.color, dtype=np.float64).reshape(-1)
            if c.shape != (3,) or not (np.isfinite(c) & (c >= 0) & (c <= 1)).all():
                raise ValueError(f"mesh {self.name}: color is three numbers from 0 to 1 (RGB), "
                                 f"not {self.color!r}")
            self.color = tuple(float(x) for x in c)

    def display_color(self) -> tuple:
        """The mesh's colour: its own, else the one its name suggests."""
        return self.color if self.color is not None else mesh_color(self.name)

    def is_closed(self) -> bool:
        """True when the triangles enclose a volume, consistently wound, so that back
        faces are never meant to be seen (:func:`~mpeg4fba.fba.appearance.is_closed`):
        such a mesh is drawn single-sided, any other two-sided."""
        return is_closed(self.triangles)


@dataclass(eq=False)
class FaceTransform:
    """A Transform of the face scene graph with its neutral values (VRML97 semantics)."""

    name: str
    parent: Optional[str] = None
    translation: tuple = (0.0, 0.0, 0.0)
    rotation: tuple = (0.0, 0.0, 1.0, 0.0)
    scale: tuple = (1.0, 1.0, 1.0)
    center: tuple = (0.0, 0.0, 0.0)
    scale_orientation: tuple = (0.0, 0.0, 1.0, 0.0)

    def matrices(self, rotation: Optional[np.ndarray] = None, translation: Optional[np.ndarray] = None,
                 scale: Optional[np.ndarray] = None) -> np.ndarray:
        """Local 4x4 matrices [frames, 4, 4] (or [1, 4, 4] for the neutral), VRML97 order
        T C R SR S -SR -C, with per-frame rotation matrices / translations / scales."""
        R = rotation if rotation is not None else \
            rotation_matrices(self.rotation[:3], [self.rotation[3]])
        T = translation if translation is not None else np.asarray([self.translation], float)
        S = scale if scale is not None else np.asarray([self.scale], float)
        n = max(len(R), len(T), len(S))
        SR = rotation_matrices(self.scale_orientation[:3], [self.scale_orientation[3]])[0]
        c = np.asarray(self.center, dtype=float)
        M = np.tile(np.eye(4), (n, 1, 1))
        lin = np.einsum("ij,fjk,kl->fil", SR, S[:, :, None] * np.eye(3)[None], SR.T)
        lin = np.einsum("fij,fjk->fik", np.broadcast_to(R, (n, 3, 3)), np.broadcast_to(lin, (n, 3, 3)))
        M[:, :3, :3] = lin
        M[:, :3, 3] = np.broadcast_to(T, (n, 3)) + c - np.einsum("fij,j->fi", lin, c)
        return M


def table_values(table: FaceDefTable, held: np.ndarray, given: np.ndarray,
                 visemes: np.ndarray, expressions: np.ndarray) -> np.ndarray:
    """The value fed to ``table`` in each frame (see :mod:`mpeg4fba.fba.fat`)."""
    if table.fap > 2:
        return np.where(given[:, table.fap - 1], held[:, table.fap - 1], 0.0)
    if table.fap == 1:
        s1, s2, blend = visemes[:, 0], visemes[:, 1], visemes[:, 2].astype(float)
        p = np.where(s1 == table.select, blend, 0.0) + np.where(s2 == table.select, 63.0 - blend, 0.0)
        return np.where(given[:, 0], p, 0.0)
    s1, i1, s2, i2 = (expressions[:, k] for k in range(4))
    p = np.where(s1 == table.select, i1, 0.0) + np.where(s2 == table.select, i2, 0.0)
    return np.where(given[:, 1], p.astype(float), 0.0)


class _MeshOperator:
    """The FaceDefMesh entries of one mesh as one linear operator.

    Columns ("slots") are the intervals of every entry; ``BT`` [3n, slots] (CSR) maps
    interval weights to coordinate displacements.  For long streams the operator is also
    kept in a blocked dense form: the coordinates are cut into runs of ``3 x vb``
    consecutive ones, and each run keeps the dense rows of the few slots that touch it,
    plus the neutral coordinates as one more row.  A run of frames is then one small
    BLAS product per block, ``[W | 1][:, slots_b] @ D_b``, written straight into the
    output: no [3n, frames] temporary, no transposition, one pass over the output.  A
    mesh whose vertex order scatters the FAP regions (blocks would be mostly zeros)
    keeps the sparse product only.

    >>> t = FaceDefTable(3, [FaceDefMesh("M", [0, 10], [1, 3], [[0, 1, 0], [2, 0, 0]])])
    >>> op = _MeshOperator(FaceMesh("M", np.ones((4, 3)), [[0, 1, 2]]), [(t, t.meshes[0], 0)])
    >>> op.BT.shape, [(c0, c1, s.tolist(), D.shape) for c0, c1, s, D in op.blocks]
    ((12, 1), [(0, 12, [0, 1], (2, 12))])
    >>> op.displaced({id(t): np.array([0.0, 5.0])}, 2)[1].tolist()
    [[1.0, 1.0, 1.0], [1.0, 6.0, 1.0], [1.0, 1.0, 1.0], [11.0, 1.0, 1.0]]

    Long streams take the blocks, short ones the sparse product; both give the same:

    >>> values = {id(t): np.linspace(-5.0, 20.0, 40)}
    >>> blocked = op.displaced(values, 40)
    >>> op.MIN_BLOCKED_FRAMES = 10 ** 9          # force the sparse product
    >>> bool(np.allclose(blocked, op.displaced(values, 40), rtol=0, atol=1e-12))
    True
    >>> op.MIN_BLOCKED_FRAMES = 16
    >>> op.mesh.vertices += 1                      # edited in place: still followed
    >>> bool(np.allclose(op.displaced(values, 40), blocked + 1, rtol=0, atol=1e-12))
    True
    """

    #: Vertices per block tried at compile time, each twice the one before; the one of
    #: least estimated cost is kept.
    BLOCK_VERTICES = (8, 16, 32, 64, 128, 256)
    #: Per-block overhead in the cost model, as a number of dense entries.
    BLOCK_PENALTY = 700
    #: Blocks are used only when their dense entries stay within this factor of the
    #: sparse operator's (nonzeros + neutral coordinates).
    MAX_FILL = 4.0
    #: Streams shorter than this use the sparse product (block overheads would dominate).
    MIN_BLOCKED_FRAMES = 16
    #: Frames evaluated at a time (bounds the weight matrix and the gathers).
    FRAME_CHUNK = 2048
    #: Bytes of the [3n, frames] temporary of the sparse product, at most (about).
    SPARSE_TEMP_BYTES = 32 << 20

    def __init__(self, mesh: FaceMesh, entries: list):
        self.mesh = mesh
        self.entries = entries            # (table, FaceDefMesh, first slot)
        self.n_slots = sum(m.n_intervals for _, m, _ in entries)
        rows, cols, data = [], [], []
        n3 = 3 * len(mesh.vertices)
        for _, m, first in entries:
            k, j = np.meshgrid(np.arange(len(m.indices)), np.arange(m.n_intervals), indexing="ij")
            for c in range(3):
                rows.append((3 * m.indices[k] + c).ravel())
                cols.append((first + j).ravel())
                data.append(m.displacements[:, :, c].ravel())
        if rows:
            r, c, d = np.concatenate(rows), np.concatenate(cols), np.concatenate(data)
        else:
            r = c = np.zeros(0, np.int64)
            d = np.zeros(0)
        # B^T as CSR [3n, slots]: the product with W^T [slots, frames] is one sparse matmul.
        self.BT = sp.csr_matrix((d, (r, c)), shape=(n3, self.n_slots))
        self.BT.sum_duplicates()
        self.blocks = self._blocked()

    def _blocked(self) -> Optional[list]:
        """``[(first coordinate, end, slots, D)]`` with ``D`` [len(slots), end - first];
        the last slot is ``n_slots``, the column of ones whose row holds the neutral
        coordinates.  None when blocks would not pay (see the class docstring)."""
        BT, ns = self.BT, self.n_slots
        n3 = BT.shape[0]
        if ns == 0 or n3 == 0 or BT.nnz == 0:
            return None
        rows = np.repeat(np.arange(n3), np.diff(BT.indptr))
        # occ[b, s]: slot s touches block b, at the finest block size; coarser sizes
        # (each twice the one before) merge pairs of rows.
        finest = 3 * self.BLOCK_VERTICES[0]
        occ = np.zeros((-(-n3 // finest), ns), dtype=bool)
        occ[rows // finest, BT.indices] = True
        best = None
        for vb in self.BLOCK_VERTICES:
            width = 3 * vb
            n_blocks = -(-n3 // width)
            if width > finest:
                if len(occ) % 2:
                    occ = np.vstack([occ, np.zeros((1, ns), dtype=bool)])
                occ = occ.reshape(-1, 2, ns).any(axis=1)[:n_blocks]
            per_block = occ.sum(axis=1) + 1
            widths = np.minimum(width, n3 - np.arange(n_blocks) * width)
            entries = int((per_block * widths).sum())
            cost = entries + self.BLOCK_PENALTY * n_blocks
            if best is None or cost < best[0]:
                best = (cost, entries, width, n_blocks, occ, per_block, widths)
        _, entries, width, n_blocks, occ, per_block, widths = best
        if entries > self.MAX_FILL * (BT.nnz + n3):
            return None
        pairs = np.flatnonzero(occ)                  # block * ns + slot, sorted
        # One flat buffer: block b is [per_block[b], widths[b]] at offset[b], row-major.
        offset = np.concatenate([[0], np.cumsum(per_block * widths)])
        start = np.concatenate([[0], np.cumsum(per_block - 1)])    # block b's first pair
        block = rows // width
        rank = np.cumsum(occ.ravel()) - 1            # (block, slot) -> its pair number
        k = rank[block * ns + BT.indices] - start[block]
        flat = np.zeros(offset[-1])
        flat[offset[block] + k * widths[block] + rows % width] = BT.data
        c = np.arange(n3)                                          # the neutral row, last
        cb = c // width
        self._neutral_at = offset[cb] + (per_block[cb] - 1) * widths[cb] + c % width
        self._neutral = self.mesh.vertices.reshape(-1).copy()
        flat[self._neutral_at] = self._neutral
        self._flat = flat
        slots = np.split(pairs % ns, start[1:-1])
        out = []
        for b in range(n_blocks):
            D = flat[offset[b]:offset[b + 1]].reshape(per_block[b], widths[b])
            out.append((b * width, b * width + int(widths[b]), np.append(slots[b], ns), D))
        return out

    def frame_weights(self, values: dict, f0: int, f1: int) -> np.ndarray:
        """Interval weights of frames ``f0:f1`` as [frames, slots + 1]; the last column
        is 1 (it picks the neutral row of the blocks).  FAPs that stay at 0 are skipped."""
        W = np.zeros((f1 - f0, self.n_slots + 1))
        W[:, -1] = 1.0
        for table, m, first in self.entries:
            p = values[id(table)][f0:f1]
            if p.any():
                W[:, first:first + m.n_intervals] = interval_weights(m.borders, p)
        return W

    def weights(self, values: dict, n_frames: int) -> np.ndarray:
        """Interval weights [slots, frames] of the whole stream."""
        return self.frame_weights(values, 0, n_frames)[:, :-1].T

    def displaced(self, values: dict, n_frames: int) -> np.ndarray:
        """Vertex positions [frames, n, 3], into one preallocated array, a chunk of
        frames at a time."""
        base = self.mesh.vertices
        out = np.empty((n_frames,) + base.shape)
        if self.n_slots == 0 or n_frames == 0:
            out[...] = base
            return out
        flat = out.reshape(n_frames, -1)
        b = base.reshape(-1)
        blocked = self.blocks is not None and n_frames >= self.MIN_BLOCKED_FRAMES
        if blocked and not np.array_equal(self._neutral, b):
            # The neutral vertices were edited in place since compiling: take them up.
            self._neutral = b.copy()
            self._flat[self._neutral_at] = self._neutral
        step = max(1, self.SPARSE_TEMP_BYTES // (8 * max(len(b), 1)))
        for f0 in range(0, n_frames, self.FRAME_CHUNK):
            f1 = min(n_frames, f0 + self.FRAME_CHUNK)
            W = self.frame_weights(values, f0, f1)
            if blocked:
                active = W.any(axis=0)
                everything = active.all()
                for c0, c1, slots, D in self.blocks:
                    if not everything:          # drop the rows of FAPs at 0 throughout
                        keep = active[slots]
                        slots, D = slots[keep], D[keep]
                    np.matmul(W[:, slots], D, out=flat[f0:f1, c0:c1])
                continue
            WT = np.ascontiguousarray(W[:, :-1].T)                  # [slots, frames]
            for g0 in range(0, f1 - f0, step):
                g1 = min(f1 - f0, g0 + step)
                Y = self.BT @ WT[:, g0:g1]                            # [3n, frames]
                np.add(Y.T, b, out=flat[f0 + g0:f0 + g1])
        return out


class FaceModel:
    """A face: meshes, transform tree, feature points, FAPU and FAT.

    ``fapu`` defaults to the one computed from ``points`` when those have the points it
    needs.  ``play(stream)`` evaluates a FAP stream; ``compile()`` is done once and kept.
    Optional extras: ``colors`` (mesh name -> [n, 3] RGB per vertex, as displayed;
    stored in VRML as the IndexedFaceSet's Color, in glTF as COLOR_0) and ``regions``
    (name -> vertex indices of named areas, e.g. the lips; not stored in files), both
    empty by default.
    """

    def __init__(self, meshes: Iterable[FaceMesh] = (), transforms: Iterable[FaceTransform] = (),
                 points: Optional[FeaturePointSet] = None, fapu: Optional[FAPU] = None,
                 fat: Optional[FAT] = None, name: str = "face"):
        self.meshes: dict = {m.name: m for m in meshes}
        self.transforms: dict = {t.name: t for t in transforms}
        self.points = points if points is not None else FeaturePointSet()
        self.fat = fat if fat is not None else FAT()
        self.name = name
        self.colors: dict = {}
        self.regions: dict = {}
        self._fapu = fapu
        self._compiled = None
        for m in self.meshes.values():
            if m.parent is not None and m.parent not in self.transforms:
                raise ValueError(f"mesh {m.name} hangs under {m.parent!r}, which is not a "
                                 f"Transform of the face ({sorted(self.transforms)})")

    @property
    def fapu(self) -> Optional[FAPU]:
        if self._fapu is None and len(self.points):
            try:
                self._fapu = FAPU.from_feature_points(self.points)
            except ValueError:
                return None
        return self._fapu

    @fapu.setter
    def fapu(self, value: Optional[FAPU]) -> None:
        self._fapu = value

    def mesh_colors(self, mesh: str) -> tuple:
        """``(colour, colours per vertex or None)`` of a mesh as files store them: its
        entry of :attr:`colors` when that is an [n, 3] array (clipped to 0..1), else
        None; and its one colour, that entry when it is one RGB colour, else
        ``FaceMesh.display_color()``.  ValueError for an entry of another shape.

        >>> face = FaceModel([FaceMesh("Tongue", np.eye(3), [[0, 1, 2]])])
        >>> face.mesh_colors("Tongue")
        ((0.8, 0.4, 0.42), None)
        >>> face.colors["Tongue"] = np.full((3, 3), 0.5)
        >>> face.mesh_colors("Tongue")[1].shape
        (3, 3)
        """
        m = self.meshes[mesh]
        given = (getattr(self, "colors", None) or {}).get(mesh)
        if given is None:
            return m.display_color(), None
        a = np.asarray(given, dtype=np.float64)
        if a.shape == (3,) and np.isfinite(a).all():
            return tuple(float(c) for c in np.clip(a, 0.0, 1.0)), None
        if a.shape != (len(m.vertices), 3) or not np.isfinite(a).all():
            raise ValueError(f"face.colors[{mesh!r}] is one RGB colour or one per vertex "
                             f"([{len(m.vertices)}, 3], finite), not an array of shape {a.shape}")
        return m.display_color(), np.clip(a, 0.0, 1.0)

    def copy(self, share: bool = False) -> "FaceModel":
        """A copy whose meshes and transforms can be re-parented and edited without
        touching this face (vertex arrays are shared until replaced); ``share=True``
        shares the mesh and transform objects too, for a copy that only gets other
        points or another FAT.  Points, FAPU, FAT, colours, regions and the file
        attributes (``source``, ``initial_faps``...) are carried over.

        >>> face = FaceModel([FaceMesh("Skin", np.eye(3), [[0, 1, 2]])], name="f")
        >>> twin = face.copy()
        >>> twin.meshes["Skin"] is face.meshes["Skin"]
        False
        >>> np.shares_memory(twin.meshes["Skin"].vertices, face.meshes["Skin"].vertices)
        True
        >>> face.copy(share=True).meshes["Skin"] is face.meshes["Skin"]
        True
        """
        meshes = self.meshes.values() if share else [replace(m) for m in self.meshes.values()]
        transforms = self.transforms.values() if share else \
            [replace(t) for t in self.transforms.values()]
        out = FaceModel(meshes, transforms, points=self.points, fapu=self.fapu, fat=self.fat,
                        name=self.name)
        out.colors = dict(self.colors)
        out.regions = dict(self.regions)
        for attr in ("source", "initial_faps", "initial_viseme", "initial_expression"):
            if hasattr(self, attr):
                setattr(out, attr, getattr(self, attr))
        return out

    # -- the transform tree -------------------------------------------------------------------
    def chain(self, transform: Optional[str]) -> list:
        """Transform names from the root down to ``transform``."""
        out = []
        seen = set()
        while transform is not None:
            if transform in seen:
                raise ValueError(f"the transform tree loops at {transform}")
            seen.add(transform)
            out.append(transform)
            transform = self.transforms[transform].parent
        return out[::-1]

    def world_matrix(self, transform: Optional[str], local: Optional[Mapping] = None) -> np.ndarray:
        """World 4x4 matrices [frames, 4, 4] of a transform (or the root for None);
        ``local`` maps transform names to per-frame local matrices overriding the neutral."""
        local = local or {}
        M = np.eye(4)[None]
        for name in self.chain(transform):
            L = local.get(name)
            if L is None:
                L = self.transforms[name].matrices()
            M = np.einsum("fij,fjk->fik", np.broadcast_to(M, (max(len(M), len(L)), 4, 4)),
                          np.broadcast_to(L, (max(len(M), len(L)), 4, 4)))
        return M

    def world_vertices(self, mesh: str, vertices: Optional[np.ndarray] = None) -> np.ndarray:
        """Neutral (or given) vertices of ``mesh`` in world space."""
        m = self.meshes[mesh]
        v = m.vertices if vertices is None else vertices
        M = self.world_matrix(m.parent)[0]
        return v @ M[:3, :3].T + M[:3, 3]

    # -- playback ---------------------------------------------------------------------------
    def compile(self) -> "_Compiled":
        if self._compiled is None:
            self._compiled = _Compiled(self)
        return self._compiled

    def invalidate(self) -> None:
        """Forget the compiled operators (call after editing meshes or the FAT)."""
        self._compiled = None

    def play(self, stream: FapStream) -> "Playback":
        """Evaluate ``stream`` on the face: vertex positions and transform values per frame."""
        return Playback(self, stream)

    def pose(self, faps: Mapping, visemes: Optional[Sequence] = None,
             expressions: Optional[Sequence] = None) -> "Playback":
        """One frame from ``{fap: value}`` (and optional FAP 1 / FAP 2 fields)."""
        s = FapStream.from_values({k: [v] for k, v in faps.items()}, fps=1, n_frames=1,
                                  visemes=None if visemes is None else [visemes],
                                  expressions=None if expressions is None else [expressions])
        return self.play(s)

    def __repr__(self) -> str:
        return (f"<FaceModel {self.name}: {len(self.meshes)} meshes, {len(self.transforms)} "
                f"transforms, {len(self.points)} feature points, {self.fat!r}>")


class _Compiled:
    def __init__(self, face: FaceModel):
        self.face = face
        per_mesh: dict = {name: [] for name in face.meshes}
        self.transform_entries: dict = {}
        for table in sorted(face.fat, key=lambda t: t.key):
            for m in table.meshes:
                if m.mesh not in face.meshes:
                    raise ValueError(f"the FAT of FAP {table.fap} deforms mesh {m.mesh!r}, which "
                                     f"the face does not have ({sorted(face.meshes)})")
                problems = m.problems()
                if problems:
                    raise ValueError(f"FAP {table.fap} FaceDefMesh on {m.mesh}: {problems[0]}")
                n = len(face.meshes[m.mesh].vertices)
                if len(m.indices) and m.indices.max() >= n:
                    raise ValueError(f"FAP {table.fap} FaceDefMesh on {m.mesh}: vertex index "
                                     f"{int(m.indices.max())} out of range ({n} vertices)")
                entries = per_mesh[m.mesh]
                first = sum(e[1].n_intervals for e in entries)
                entries.append((table, m, first))
            for t in table.transforms:
                if t.transform not in face.transforms:
                    raise ValueError(f"the FAT of FAP {table.fap} drives Transform "
                                     f"{t.transform!r}, which the face does not have")
                self.transform_entries.setdefault(t.transform, []).append((table, t))
        self.meshes = {name: _MeshOperator(face.meshes[name], e) for name, e in per_mesh.items()}
        self.tables = list(face.fat)


class Playback:
    """The frames of a stream played on a face (computed on first access, then kept).

    ``vertices(mesh)`` -> [frames, n, 3] local positions; ``transform(name)`` -> dict of
    per-frame ``rotation`` matrices [frames, 3, 3], ``translation`` and ``scale``
    [frames, 3]; ``world_vertices(mesh)`` puts a mesh through its animated transform
    chain.
    """

    def __init__(self, face: FaceModel, stream: FapStream):
        self.face = face
        self.stream = stream
        self.compiled = face.compile()
        held, given, vis, exp = stream.held()
        self.n_frames = len(stream)
        self._values = {id(t): table_values(t, held, given, vis, exp) for t in self.compiled.tables}
        self._vertices: dict = {}
        self._transforms: dict = {}

    def __len__(self) -> int:
        return self.n_frames

    def vertices(self, mesh: str) -> np.ndarray:
        if mesh not in self._vertices:
            op = self.compiled.meshes[mesh]
            self._vertices[mesh] = op.displaced(self._values, self.n_frames)
        return self._vertices[mesh]

    def transform(self, name: str) -> dict:
        if name not in self._transforms:
            tr = self.face.transforms[name]
            n = self.n_frames
            R0 = rotation_matrices(tr.rotation[:3], [tr.rotation[3]])[0]
            R = np.broadcast_to(R0, (n, 3, 3)).copy()
            T = np.tile(np.asarray(tr.translation, float), (n, 1))
            S = np.tile(np.asarray(tr.scale, float), (n, 1))
            for table, entry in self.compiled.transform_entries.get(name, []):
                p = self._values[id(table)]
                if entry.field == "rotation":
                    R = np.einsum("fij,fjk->fik", rotation_matrices(entry.rotation[:3],
                                                                    entry.rotation[3] * p), R)
                elif entry.field == "translation":
                    T = T + p[:, None] * np.asarray(entry.translation)
                else:
                    S = S + p[:, None] * np.asarray(entry.scale)
            self._transforms[name] = {"rotation": R, "translation": T, "scale": S}
        return self._transforms[name]

    def local_matrices(self, name: str) -> np.ndarray:
        t = self.transform(name)
        return self.face.transforms[name].matrices(t["rotation"], t["translation"], t["scale"])

    def world_vertices(self, mesh: str) -> np.ndarray:
        """[frames, n, 3] positions of ``mesh`` in world space, transforms animated."""
        m = self.face.meshes[mesh]
        local = {name: self.local_matrices(name) for name in self.face.chain(m.parent)}
        M = self.face.world_matrix(m.parent, local)
        M = np.broadcast_to(M, (self.n_frames, 4, 4))
        v = self.vertices(mesh)
        return np.einsum("fij,fnj->fni", M[:, :3, :3], v) + M[:, None, :3, 3]
