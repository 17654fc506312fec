"""Feature point sets: where the standard's points are on one face.

Example
-------
>>> pts = FeaturePointSet({"3.5": (3, 4.5, 0), "3.6": (-3, 4.5, 0)})
>>> pts["3.5"].tolist(), len(pts), "2.1" in pts
([3.0, 4.5, 0.0], 2, False)
>>> pts.missing(["3.5", "9.15", "2.1"])
['2.1', '9.15']
"""
from __future__ import annotations

from typing import Iterable, Iterator, Mapping, Optional

import numpy as np

from .tables import FEATURE_POINTS

__all__ = ["FeaturePointSet", "FeaturePointError", "point_order", "normalise_id"]

_ORDER = {fp.id: i for i, fp in enumerate(FEATURE_POINTS)}


class FeaturePointError(ValueError):
    """Feature points that are missing or unknown; ``ids`` lists them."""

    def __init__(self, message: str, ids: Iterable[str] = ()):
        super().__init__(message)
        self.ids = list(ids)


def normalise_id(fp) -> str:
    """A feature point id as "group.index": accepts "3.5", (3, 5), and "3.05"-free forms.

    >>> normalise_id((2, 10)), normalise_id(" 9.15 ")
    ('2.10', '9.15')
    """
    if isinstance(fp, tuple) and len(fp) == 2:
        text = f"{int(fp[0])}.{int(fp[1])}"
    else:
        text = str(fp).strip()
    if text not in _ORDER:
        import difflib
        close = difflib.get_close_matches(text, list(_ORDER), n=3)
        raise FeaturePointError(f"{text!r} is not a feature point of the standard (groups 2-11)"
                                + (f"; did you mean {', '.join(close)}?" if close else ""), [text])
    return text


def point_order(ids: Iterable[str]) -> list:
    """Ids sorted in the standard's order (by group, then index)."""
    return sorted(ids, key=_ORDER.__getitem__)


class FeaturePointSet(Mapping):
    """Feature point id -> position (x, y, z); optionally each tied to a mesh vertex.

    ``vertices`` maps ids to ``(mesh_name, vertex_index)``; positions may come from it
    later with :meth:`resolve`.  Iteration is in the standard's order.
    """

    def __init__(self, positions: Optional[Mapping] = None, vertices: Optional[Mapping] = None):
        self._pos: dict = {}
        self._vert: dict = {}
        for k, v in (positions or {}).items():
            p = np.asarray(v, dtype=np.float64).reshape(-1)
            if p.shape != (3,) or not np.isfinite(p).all():
                raise FeaturePointError(f"feature point {k}: a position is 3 finite numbers, "
                                        f"not {v!r}", [str(k)])
            self._pos[normalise_id(k)] = p
        for k, v in (vertices or {}).items():
            mesh, index = v
            if int(index) < 0:
                raise FeaturePointError(f"feature point {k}: vertex index {index} is negative", [k])
            self._vert[normalise_id(k)] = (str(mesh) if mesh is not None else None, int(index))

    # -- Mapping ---------------------------------------------------------------------------
    def __getitem__(self, fp) -> np.ndarray:
        key = fp if fp in self._pos else normalise_id(fp)
        if key not in self._pos:
            where = f" (it is tied to vertex {self._vert[key][1]} of {self._vert[key][0]}; " \
                    "call resolve() with the meshes)" if key in self._vert else ""
            raise KeyError(f"feature point {key} has no position{where}")
        return self._pos[key]

    def __iter__(self) -> Iterator[str]:
        return iter(point_order(self._pos))

    def __len__(self) -> int:
        return len(self._pos)

    def __contains__(self, fp) -> bool:
        try:
            key = normalise_id(fp)
        except FeaturePointError:
            return False
        return key in self._pos

    # -- more ------------------------------------------------------------------------------
    @property
    def ids(self) -> list:
        """Ids with a position or a vertex, in the standard's order."""
        return point_order(set(self._pos) | set(self._vert))

    @property
    def positions(self) -> np.ndarray:
        """Positions as an (n, 3) array, rows in the order of ``list(self)``."""
        keys = list(self)
        return np.array([self._pos[k] for k in keys]).reshape(len(keys), 3)

    def vertex(self, fp) -> Optional[tuple]:
        """(mesh name, vertex index) of a point, or None."""
        return self._vert.get(normalise_id(fp))

    @property
    def vertices(self) -> dict:
        return dict(self._vert)

    def missing(self, required: Iterable) -> list:
        """Which of ``required`` have no position, in the standard's order."""
        return point_order(k for k in map(normalise_id, required) if k not in self._pos)

    def require(self, required: Iterable, purpose: str = "") -> None:
        """Raise FeaturePointError listing the missing ones of ``required``."""
        missing = self.missing(required)
        if missing:
            what = f" for {purpose}" if purpose else ""
            raise FeaturePointError(f"feature point{'s' if len(missing) > 1 else ''} "
                                    f"{', '.join(missing)} missing{what}", missing)

    def resolve(self, meshes: Mapping) -> "FeaturePointSet":
        """A copy whose vertex-tied points take their positions from ``meshes``.

        ``meshes`` maps mesh names to (n, 3) vertex arrays; a point tied to mesh None
        uses the only mesh given.
        """
        pos = dict(self._pos)
        for k, (mesh, index) in self._vert.items():
            if mesh is None:
                if len(meshes) != 1:
                    raise FeaturePointError(f"feature point {k} names no mesh and "
                                            f"{len(meshes)} meshes were given", [k])
                verts = next(iter(meshes.values()))
            elif mesh not in meshes:
                raise FeaturePointError(f"feature point {k} is on mesh {mesh!r}, which is not "
                                        f"among {sorted(meshes)}", [k])
            else:
                verts = meshes[mesh]
            verts = np.asarray(verts)
            if index >= len(verts):
                raise FeaturePointError(f"feature point {k}: vertex {index} is out of range for "
                                        f"{mesh or 'the mesh'} ({len(verts)} vertices)", [k])
            pos[k] = verts[index]
        return FeaturePointSet(pos, self._vert)

    def positions_only(self) -> "FeaturePointSet":
        """A copy with the positions and no vertex ties (for a sidecar whose positions
        are exact: a reader moves a tied point onto its vertex).

        >>> FeaturePointSet({"9.3": (0, 0, 1)}, {"9.3": ("Skin", 4)}).positions_only().vertices
        {}
        """
        return FeaturePointSet(self._pos)

    def transformed(self, matrix: np.ndarray) -> "FeaturePointSet":
        """A copy with positions moved by a 4x4 matrix."""
        keys = list(self._pos)
        if not keys:
            return FeaturePointSet({}, self._vert)
        p = np.array([self._pos[k] for k in keys])
        q = p @ np.asarray(matrix)[:3, :3].T + np.asarray(matrix)[:3, 3]
        return FeaturePointSet(dict(zip(keys, q)), self._vert)

    def __eq__(self, other) -> bool:
        if not isinstance(other, FeaturePointSet):
            return NotImplemented
        return (self._vert == other._vert and list(self) == list(other)
                and all(np.array_equal(self._pos[k], other._pos[k]) for k in self._pos))

    def __repr__(self) -> str:
        return f"<FeaturePointSet {len(self._pos)} positions, {len(self._vert)} vertices>"
