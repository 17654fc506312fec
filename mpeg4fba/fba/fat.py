"""Facial Animation Tables (FATs): how each FAP deforms one particular face model.

A FAT is a list of :class:`FaceDefTable` (the BIFS FaceDefTables node), one per FAP, or
per viseme / expression for FAPs 1 and 2.  Each holds :class:`FaceDefMesh` entries
(piecewise-linear vertex displacements) and :class:`FaceDefTransform` entries (FAP-driven
rotation, scale or translation of a Transform).

Evaluation (ISO/IEC 14496-1 FaceDefMesh / FaceDefTransform semantics, as
``spec/bifs_nodes.md`` sections 4-5 recall them), for a FAP value P:

* **Mesh**: borders I0 < ... < I(n-1) with one border 0 make n-1 intervals.  For P > 0
  the intervals above 0 are walked upward, each fully covered one adding its width
  times its displacement and the one containing P adding (P - I_j) times it; P < 0 is the
  mirror image.  The displacements of all FAPs are added (superposition).
* **Beyond the outer borders** the outermost interval continues linearly (the sum left
  open-ended), rather than clamping: a one-interval table [0, v] is then exactly a
  morph target whose weight is P, extrapolated like any blend shape.  A FAP value on
  the side of 0 that has no interval (e.g. negative P for borders [0, v]) moves nothing.
* **Transform** (fieldId 1 rotation, 2 scale, 3 translation): the FAP adds to the
  Transform's neutral value: rotation = R(axis, angle * P) applied after the neutral
  rotation, in the parent's frame (R_fap . R0, so the axis is in the face frame);
  scale = neutral + scaleDef * P; translation = neutral + translationDef * P.  Several
  FAPs on one Transform compose in FAP-number order (rotations) or add (scale,
  translation).  These two choices are ours: the recalled text says only "the field is
  set".
* **High-level FAPs** feed their tables with a value on the 0-63 scale: viseme tables
  get P = viseme_blend for viseme_select1 and 63 - viseme_blend for viseme_select2 (so
  the shape is viseme1 * blend/63 + viseme2 * (1 - blend/63)); expression tables get
  P = expression_intensity1 and expression_intensity2 (each intensity/63 of its shape,
  added).  A table for a viseme or expression is thus usually borders [0, 63] holding
  the full shape / 63.  They add to the low-level FAPs of the same frame.

Example (the worked example of the standard's FaceDefMesh semantics)
--------------------------------------------------------------------
>>> m = FaceDefMesh("Skin", [-1000, 0, 500, 1000], [50, 51],
...                 [[1, 0, 0], [0.9, 0, 0], [1.5, 0, 4], [0.8, 0, 0], [0.7, 0, 0], [2, 0, 0]])
>>> m.displacement(600)[0].tolist()
[600.0, 0.0, 400.0]
>>> m.displacement(-200)[1].tolist()
[-160.0, 0.0, 0.0]
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Iterator, Optional, Sequence

import numpy as np

__all__ = ["FaceDefMesh", "FaceDefTransform", "FaceDefTable", "FAT", "interval_weights",
           "table_borders", "rotation_matrices", "TRANSFORM_FIELDS"]

#: fieldId of a FaceDefTransform -> the Transform field it drives.
TRANSFORM_FIELDS = {1: "rotation", 2: "scale", 3: "translation"}


def interval_weights(borders: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Weights [len(values), intervals]: a displacement is ``weights @ D``.

    >>> interval_weights(np.array([-1000, 0, 500, 1000]), np.array([600, -200, 1500])).tolist()
    [[0.0, 500.0, 100.0], [-200.0, 0.0, 0.0], [0.0, 500.0, 1000.0]]
    """
    b = np.asarray(borders, dtype=np.float64)
    p = np.asarray(values, dtype=np.float64).reshape(-1, 1)
    lo, hi = b[:-1], b[1:]
    above = lo >= 0                      # intervals walked for P > 0
    top = np.minimum(p, hi)
    if above.any():
        top[:, -1] = p[:, 0]              # the outermost interval is open-ended
    w_pos = np.where(above, np.clip(top - lo, 0.0, None), 0.0)
    bottom = np.maximum(p, lo)
    if (~above).any():
        bottom[:, 0] = p[:, 0]
    w_neg = np.where(~above, np.clip(bottom - hi, None, 0.0), 0.0)
    return np.where(p > 0, w_pos, np.where(p < 0, w_neg, 0.0))


def rotation_matrices(axis: Sequence, angles: np.ndarray) -> np.ndarray:
    """Rotation matrices [len(angles), 3, 3] about one axis (Rodrigues), vectorised."""
    a = np.asarray(axis, dtype=np.float64)
    norm = np.linalg.norm(a)
    angles = np.asarray(angles, dtype=np.float64).reshape(-1)
    out = np.tile(np.eye(3), (len(angles), 1, 1))
    if norm == 0:
        return out
    x, y, z = a / norm
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return out + s * k + (1 - c) * (k @ k)


@dataclass(eq=False)
class FaceDefMesh:
    """Piecewise-linear displacement of some vertices of one mesh by one FAP.

    ``mesh`` names the mesh (an IndexedFaceSet of the face); ``borders`` are the
    interval borders (strictly increasing, one of them 0); ``indices`` the vertex
    indices; ``displacements`` an array [vertices, intervals, 3] (the file order is
    vertex-major, which is what a reshape of the flat list gives).
    """

    mesh: str
    borders: np.ndarray
    indices: np.ndarray
    displacements: np.ndarray

    def __post_init__(self):
        self.borders = np.asarray(self.borders, dtype=np.float64).reshape(-1)
        self.indices = np.asarray(self.indices, dtype=np.int64).reshape(-1)
        d = np.asarray(self.displacements, dtype=np.float64)
        n_int = max(len(self.borders) - 1, 0)
        if d.ndim == 2 and n_int and d.shape[1] == 3 and len(d) == len(self.indices) * n_int:
            d = d.reshape(len(self.indices), n_int, 3)
        self.displacements = d

    @property
    def n_intervals(self) -> int:
        return max(len(self.borders) - 1, 0)

    def problems(self) -> list:
        """What makes this entry unusable (empty when it is well formed)."""
        out = []
        b = self.borders
        if len(b) < 2:
            out.append("needs at least two interval borders")
        elif not (np.diff(b) > 0).all():
            out.append(f"interval borders {b.tolist()} are not strictly increasing")
        elif not (b == 0).any():
            out.append(f"interval borders {b.tolist()} have no 0")
        if self.displacements.shape != (len(self.indices), self.n_intervals, 3):
            out.append(f"{self.displacements.size // 3 if self.displacements.size % 3 == 0 else self.displacements.size / 3} "
                       f"displacements for {len(self.indices)} vertices x {self.n_intervals} "
                       f"intervals (expected {len(self.indices) * self.n_intervals})")
        if (self.indices < 0).any():
            out.append("negative vertex index")
        return out

    def displacement(self, value: float) -> np.ndarray:
        """Displacements [vertices, 3] at FAP value ``value``."""
        w = interval_weights(self.borders, np.array([value]))[0]
        return np.einsum("j,kjc->kc", w, self.displacements)


@dataclass(eq=False)
class FaceDefTransform:
    """A FAP-driven rotation (``field`` "rotation"), scale or translation of a Transform.

    ``rotation`` is (x, y, z, angle per FAP unit); ``scale`` and ``translation`` are
    per-FAP-unit increments.  Only the one named by ``field`` is used.
    """

    transform: str
    field: str = "rotation"
    rotation: tuple = (0.0, 0.0, 1.0, 0.0)
    scale: tuple = (1.0, 1.0, 1.0)
    translation: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        if isinstance(self.field, int) or str(self.field).isdigit():
            fid = int(self.field)
            if fid not in TRANSFORM_FIELDS:
                raise ValueError(f"fieldId {fid} is not 1 (rotation), 2 (scale) or 3 (translation)")
            self.field = TRANSFORM_FIELDS[fid]
        if self.field not in TRANSFORM_FIELDS.values():
            raise ValueError(f"a FaceDefTransform drives rotation, scale or translation, "
                             f"not {self.field!r}")
        self.rotation = tuple(float(v) for v in self.rotation)
        self.scale = tuple(float(v) for v in self.scale)
        self.translation = tuple(float(v) for v in self.translation)

    @property
    def field_id(self) -> int:
        return {v: k for k, v in TRANSFORM_FIELDS.items()}[self.field]


@dataclass(eq=False)
class FaceDefTable:
    """How one FAP (or one viseme / expression of FAP 1 / 2) deforms the face.

    ``select`` is the BIFS highLevelSelect: the viseme (1-14) or expression (1-6) a
    table for FAP 1 or 2 defines; ignored (kept as given, default 1) for FAPs 3-68.
    """

    fap: int
    meshes: list = field(default_factory=list)
    transforms: list = field(default_factory=list)
    select: int = 1

    @property
    def key(self) -> tuple:
        """(fap, select) for FAPs 1 and 2, (fap, 0) for the others."""
        return (self.fap, self.select if self.fap <= 2 else 0)


def table_borders(table: FaceDefTable) -> np.ndarray:
    """The union of a table's interval borders, 0 included ([0, 1] when it has no mesh
    entry): where a cloner samples the table's motion.

    >>> table_borders(FaceDefTable(3, [FaceDefMesh("Skin", [0, 512, 1024], [0], [[0, 1, 0]] * 2),
    ...                                FaceDefMesh("Jaw", [-100, 100], [0], [[1, 0, 0]])])).tolist()
    [-100.0, 0.0, 100.0, 512.0, 1024.0]
    >>> table_borders(FaceDefTable(48)).tolist()
    [0.0, 1.0]
    """
    b = [m.borders for m in table.meshes]
    if not b:
        return np.array([0.0, 1.0])
    return np.union1d(np.concatenate(b), [0.0])


class FAT:
    """A face's tables, looked up by FAP (``fat[3]``) or by (FAP, select) for visemes and
    expressions (``fat[1, 4]`` is viseme 4's table).

    >>> fat = FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 1024], [0], [[0, -1, 0]])])])
    >>> 3 in fat, (1, 4) in fat, len(fat)
    (True, False, 1)
    """

    def __init__(self, tables: Iterable[FaceDefTable] = ()):
        self.tables: list = list(tables)

    def _find(self, key) -> Optional[FaceDefTable]:
        if isinstance(key, tuple):
            fap, select = key
            key = (fap, select if fap <= 2 else 0)
        else:
            key = (int(key), 0)
        for t in self.tables:
            if t.key == key:
                return t
        return None

    def __getitem__(self, key) -> FaceDefTable:
        t = self._find(key)
        if t is None:
            raise KeyError(f"no table for FAP {key}")
        return t

    def __contains__(self, key) -> bool:
        return self._find(key) is not None

    def __iter__(self) -> Iterator[FaceDefTable]:
        return iter(self.tables)

    def __len__(self) -> int:
        return len(self.tables)

    def add(self, table: FaceDefTable) -> None:
        self.tables.append(table)

    @property
    def faps(self) -> list:
        """Low-level FAP numbers with a table, sorted."""
        return sorted({t.fap for t in self.tables if t.fap > 2})

    @property
    def visemes(self) -> list:
        return sorted({t.select for t in self.tables if t.fap == 1})

    @property
    def expressions(self) -> list:
        return sorted({t.select for t in self.tables if t.fap == 2})

    def __repr__(self) -> str:
        return (f"<FAT {len(self.faps)} FAPs, {len(self.visemes)} visemes, "
                f"{len(self.expressions)} expressions>")
