"""Walking a scene graph: transform matrices, paths to nodes, and triangle meshes.

The walk follows what VRML97 renders: grouping nodes' ``children``, the selected
``Switch`` choice, the first ``LOD`` level, and for the MPEG-4 ``Face`` node its
``renderedFace`` and the ``faceSceneGraph`` of its ``FDP``.  PROTO bodies are not
entered and PROTO instances are leaves.  Every loop here is iterative, so graphs of
any depth walk without recursion, and everything that touches vertices is numpy.

Example
-------
>>> from mpeg4fba import vrml
>>> scene = vrml.loads('''#VRML V2.0 utf8
... DEF T Transform { translation 0 0 5 children DEF S Shape { geometry IndexedFaceSet {
...   coord Coordinate { point [ 0 0 0, 1 0 0, 1 1 0, 0 1 0 ] } coordIndex [ 0 1 2 3 ] } } }''')
>>> [(node.type, len(path)) for node, path in iter_paths(scene)]
[('Transform', 0), ('Shape', 1)]
>>> mesh = next(iter_meshes(scene))
>>> mesh.triangles.tolist()
[[0, 1, 2], [0, 2, 3]]
>>> mesh.vertices[:, 2].tolist()
[5.0, 5.0, 5.0, 5.0]
>>> world_matrix(scene, scene.find("S"))[:3, 3].tolist()
[0.0, 0.0, 5.0]
"""
from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Iterable, Iterator, Optional, Union

import numpy as np

from .catalogue import NodeType
from .errors import VRMLError
from .errors import VRMLWarning
from .scene import Node, Scene

__all__ = ["transform_matrix", "rotation_matrix", "NodePath", "iter_paths", "world_matrix",
           "world_matrices", "Mesh", "iter_meshes", "fan_triangulate", "scene_bounds"]

#: Grouping nodes whose ``children`` field is rendered.
GROUPING_NODES = frozenset({"Group", "Transform", "Anchor", "Billboard", "Collision"})


# -- matrices ---------------------------------------------------------------------------

def rotation_matrix(rotation: Sequence) -> np.ndarray:
    """The 3x3 matrix of an SFRotation ``(x, y, z, angle)``; a zero axis is no rotation.

    >>> rotation_matrix((0, 0, 1, np.pi / 2)).round(6).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    x, y, z, angle = (float(v) for v in rotation)
    norm = np.sqrt(x * x + y * y + z * z)
    if norm == 0.0 or angle == 0.0:
        return np.eye(3)
    x, y, z = x / norm, y / norm, z / norm
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def transform_matrix(node: Node) -> np.ndarray:
    """The local 4x4 matrix of a node: ``T C R SR S -SR -C`` for a Transform, else identity.

    Points are column vectors: ``world = M @ [x, y, z, 1]``.

    >>> t = Node("Transform", translation=(1, 2, 3), scale=(2, 2, 2), center=(1, 0, 0))
    >>> (transform_matrix(t) @ [1, 0, 0, 1]).tolist()   # the centre stays put, then moves by T
    [2.0, 2.0, 3.0, 1.0]
    >>> transform_matrix(Node("Group")).tolist() == np.eye(4).tolist()
    True
    """
    m = np.eye(4)
    if node.type != "Transform" or not isinstance(node.decl, NodeType):
        return m
    r = rotation_matrix(node["rotation"])
    sr = rotation_matrix(node["scaleOrientation"])
    linear = r @ sr @ np.diag(np.asarray(node["scale"], dtype=np.float64)) @ sr.T
    c = np.asarray(node["center"], dtype=np.float64)
    m[:3, :3] = linear
    m[:3, 3] = np.asarray(node["translation"], dtype=np.float64) + c - linear @ c
    return m


# -- paths ------------------------------------------------------------------------------

class NodePath(Sequence):
    """The ancestors of a node, root first: a tuple-like sequence of Nodes.

    A path shares its beginning with its parent's path, so a walk makes each one in
    constant time however deep the graph is (real tuples would cost the square of
    the depth).  It supports ``len``, indexing, iteration, ``in`` and ``==`` with
    tuples and other paths; ``tuple(path)`` makes a real tuple.

    >>> g, s = Node("Group"), Node("Shape")
    >>> p = NodePath().child(g).child(s)
    >>> len(p), p[-1] is s, p == (g, s)
    (2, True, True)
    """

    __slots__ = ("_parent", "_node", "_len")

    def __init__(self) -> None:
        self._parent: Optional[NodePath] = None
        self._node: Optional[Node] = None
        self._len = 0

    def child(self, node: Node) -> "NodePath":
        """This path with ``node`` appended (this one is unchanged)."""
        p = NodePath.__new__(NodePath)
        p._parent, p._node, p._len = self, node, self._len + 1
        return p

    def __len__(self) -> int:
        return self._len

    def __reversed__(self) -> Iterator[Node]:
        p = self
        while p._len:
            yield p._node
            p = p._parent

    def __iter__(self) -> Iterator[Node]:
        return iter(self.as_tuple())

    def as_tuple(self) -> tuple:
        """The nodes as a real tuple, root first."""
        items = list(reversed(self))
        items.reverse()
        return tuple(items)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return self.as_tuple()[index]
        i = index + self._len if index < 0 else index
        if not 0 <= i < self._len:
            raise IndexError("NodePath index out of range")
        p = self
        for _ in range(self._len - 1 - i):
            p = p._parent
        return p._node

    def __contains__(self, node: object) -> bool:
        return any(n is node for n in reversed(self))

    def __eq__(self, other: object) -> bool:
        if isinstance(other, NodePath):
            if other._len != self._len:
                return False
            a, b = self, other
            while a is not b and a._len:
                if a._node is not b._node:
                    return False
                a, b = a._parent, b._parent
            return True
        if isinstance(other, tuple):
            return len(other) == self._len and self.as_tuple() == other
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self.as_tuple())

    def __repr__(self) -> str:
        return "NodePath(" + ", ".join(_label(n) for n in self) + ")"


def _label(node: Node) -> str:
    return f"{node.type} {node.name!r}" if node.name else node.type


def _children(node: Node) -> list:
    """The nodes a renderer visits below ``node``, in order."""
    if not isinstance(node.decl, NodeType):
        return []  # PROTO instances and generic (unknown) nodes are leaves
    t = node.type
    if t in GROUPING_NODES:
        kids = node["children"]
    elif t == "Switch":
        choice, which = node["choice"], node["whichChoice"]
        kids = [choice[which]] if isinstance(choice, list) and 0 <= which < len(choice) else []
    elif t == "LOD":
        kids = node["level"][:1]
    elif t == "Face":
        kids = list(node["renderedFace"])
        fdp = node["fdp"]
        if isinstance(fdp, Node):
            kids.append(fdp)
    elif t == "FDP":
        kids = node["faceSceneGraph"]
    else:
        return []
    return kids if isinstance(kids, list) else []


def _roots(scene_or_roots: Union[Scene, Node, Iterable[Node]]) -> list:
    if isinstance(scene_or_roots, Scene):
        return scene_or_roots.nodes
    if isinstance(scene_or_roots, Node):
        return [scene_or_roots]
    return [n for n in scene_or_roots if isinstance(n, Node)]


_EXIT = object()


def _walk(roots: list, matrices: bool) -> Iterator[tuple]:
    """(node, path, matrix of the parent's frame) for every place of every node.

    Depth-first, pre-order, with a work stack.  A node that is its own ancestor (only
    a lenient read can make one) is skipped with a warning instead of looping.
    """
    identity = np.eye(4)
    top = NodePath()
    stack: list = [(n, top, identity) for n in reversed(roots)]
    on_path: set = set()
    while stack:
        node, path, parent_m = stack.pop()
        if node is _EXIT:
            on_path.discard(path)
            continue
        if id(node) in on_path:
            warnings.warn(f"{_label(node)} is its own ancestor; not entered again",
                          VRMLWarning, stacklevel=3)
            continue
        yield node, path, parent_m
        kids = _children(node)
        if kids:
            m = parent_m
            if matrices and node.type == "Transform":
                m = parent_m @ transform_matrix(node)
            on_path.add(id(node))
            stack.append((_EXIT, id(node), None))
            sub = path.child(node)
            stack.extend((k, sub, m) for k in reversed(kids))


def iter_paths(scene_or_roots: Union[Scene, Node, Iterable[Node]]) -> Iterator[tuple]:
    """``(node, path)`` for every place of every rendered node, depth-first, parents first.

    ``path`` is a :class:`NodePath` of the node's ancestors from the root (empty for a
    root node).  A node used in two places (DEF/USE) comes twice, with each path.

    >>> s = Node("Shape")
    >>> g = Node("Group", children=[s, Node("Transform", children=[s])])
    >>> [(n.type, [a.type for a in p]) for n, p in iter_paths(g)]
    [('Group', []), ('Shape', ['Group']), ('Transform', ['Group']), ('Shape', ['Group', 'Transform'])]
    """
    for node, path, _ in _walk(_roots(scene_or_roots), matrices=False):
        yield node, path


def world_matrices(scene: Union[Scene, Node, Iterable[Node]], node: Node) -> list:
    """World matrix of ``node`` at each place it occurs, in walk order.

    The node's own transform is included when it is a Transform.  KeyError if the
    node is not in the rendered scene graph.

    >>> s = Node("Shape")
    >>> g = Node("Group", children=[s, Node("Transform", translation=(1, 0, 0), children=[s])])
    >>> [float(m[0, 3]) for m in world_matrices(g, s)]
    [0.0, 1.0]
    """
    out = [m @ transform_matrix(n) if n.type == "Transform" else m
           for n, _, m in _walk(_roots(scene), matrices=True) if n is node]
    if not out:
        raise KeyError(_not_found(node))
    return out


def world_matrix(scene: Union[Scene, Node, Iterable[Node]], node: Node) -> np.ndarray:
    """World matrix of the first place ``node`` occurs; KeyError if it is not in the graph.

    >>> t = Node("Transform", scale=(2, 2, 2))
    >>> world_matrix(Node("Group", children=[t]), t).diagonal().tolist()
    [2.0, 2.0, 2.0, 1.0]
    """
    for n, _, m in _walk(_roots(scene), matrices=True):
        if n is node:
            return m @ transform_matrix(n) if n.type == "Transform" else m
    raise KeyError(_not_found(node))


def _not_found(node: Node) -> str:
    return (f"{_label(node)} is not in the scene graph (PROTO bodies, unselected Switch "
            f"choices and LOD levels after the first are not part of it)")


# -- meshes ----------------------------------------------------------------------------

def fan_triangulate(coord_index: np.ndarray) -> tuple:
    """Fan triangles of polygons written as a VRML coordIndex (``-1`` ends a polygon).

    Returns ``(triangles, faces)``: an int64 (m, 3) array of vertex indices and, for
    each triangle, the index of its polygon (counted over all polygons, degenerate
    ones too, as per-face colours and normals count them).  The last ``-1`` is
    optional; polygons of fewer than 3 vertices give no triangles.

    >>> tris, faces = fan_triangulate(np.array([0, 1, 2, 3, -1, 4, 5, -1, 6, 7, 8]))
    >>> tris.tolist(), faces.tolist()
    ([[0, 1, 2], [0, 2, 3], [6, 7, 8]], [0, 0, 2])
    """
    idx = np.asarray(coord_index).reshape(-1)
    if idx.size and idx[-1] != -1:
        idx = np.append(idx, -1)
    ends = np.flatnonzero(idx == -1)
    n = len(ends)
    k = int(ends[0]) if n else 0
    if n and len(idx) == n * (k + 1) and (idx[k::k + 1] == -1).all():
        # every polygon has k vertices (all triangles, say): a reshape, no bookkeeping
        # arrays per triangle, which on a big mesh cost more memory than the mesh
        if k < 3:
            return np.empty((0, 3), np.int64), np.empty(0, np.int64)
        polys = idx.reshape(n, k + 1)
        tris = np.empty((n, k - 2, 3), np.int64)
        tris[:, :, 0] = polys[:, :1]
        tris[:, :, 1] = polys[:, 1:k - 1]
        tris[:, :, 2] = polys[:, 2:k]
        return tris.reshape(-1, 3), np.repeat(np.arange(n, dtype=np.int64), k - 2)
    idx = idx.astype(np.int64, copy=False)
    starts = np.concatenate(([0], ends[:-1] + 1)).astype(np.int64)
    per_poly = np.maximum(ends - starts - 2, 0)     # triangles of each polygon
    total = int(per_poly.sum())
    if total == 0:
        return np.empty((0, 3), np.int64), np.empty(0, np.int64)
    faces = np.repeat(np.arange(len(starts), dtype=np.int64), per_poly)
    first_tri = np.cumsum(per_poly) - per_poly      # index of each polygon's first triangle
    k = np.arange(total, dtype=np.int64) - first_tri[faces]  # triangle number in its polygon
    s = starts[faces]
    tris = np.stack([idx[s], idx[s + k + 1], idx[s + k + 2]], axis=1)
    return tris, faces


@dataclass(eq=False)
class Mesh:
    """One IndexedFaceSet at one place in the scene, triangulated, in world space.

    ``path`` holds the ancestors of ``shape`` (of ``geometry`` when there is no
    Shape), root first; ``matrix`` maps local to world coordinates; ``triangles``
    index ``vertices`` (all points of the ``coord`` node, in order) and
    ``faces_of_triangles`` gives each triangle's polygon in ``coordIndex``.

    >>> ifs = Node("IndexedFaceSet", coord=Node("Coordinate", point=[[0, 0, 0], [2, 0, 0], [0, 3, 0]]),
    ...            coordIndex=[0, 1, 2])
    >>> mesh = next(iter_meshes(Scene([Node("Shape", geometry=ifs)])))
    >>> [b.tolist() for b in mesh.bounds]
    [[0.0, 0.0, 0.0], [2.0, 3.0, 0.0]]
    """

    shape: Optional[Node]
    geometry: Node
    path: tuple
    matrix: np.ndarray
    vertices: np.ndarray
    local_vertices: np.ndarray
    triangles: np.ndarray
    faces_of_triangles: np.ndarray = field(repr=False)

    @property
    def bounds(self) -> Optional[tuple]:
        """``(min xyz, max xyz)`` of the world-space vertices, or None if there are none."""
        if len(self.vertices) == 0:
            return None
        return self.vertices.min(axis=0), self.vertices.max(axis=0)


def _points(ifs: Node) -> np.ndarray:
    coord = ifs["coord"]
    if not isinstance(coord, Node):
        return np.empty((0, 3))
    pts = coord.get("point")
    if not isinstance(pts, np.ndarray):
        return np.empty((0, 3))
    return np.asarray(pts, dtype=np.float64).reshape(-1, 3)


def _mesh_error(ifs: Node, message: str, scene_path: Optional[str]) -> VRMLError:
    loc = ifs.location
    what = f"IndexedFaceSet {ifs.name!r}" if ifs.name else "IndexedFaceSet"
    if loc is None:
        return VRMLError(f"{what}: {message}", scene_path)
    return VRMLError(f"{what}: {message}", loc[0] if loc[0] is not None else scene_path,
                     loc[1], loc[2])


def _triangulate(ifs: Node, n_points: int, scene_path: Optional[str]) -> tuple:
    idx = np.asarray(ifs["coordIndex"]).reshape(-1)     # as read (int32): no copy
    bad = np.flatnonzero((idx < -1) | (idx >= n_points))
    if bad.size:
        i = int(bad[0])
        raise _mesh_error(ifs, f"coordIndex[{i}] is {int(idx[i])}, outside 0..{n_points - 1} "
                          f"(the coord has {n_points} points)", scene_path)
    tris, faces = fan_triangulate(idx)
    if not ifs["ccw"]:
        tris = tris[:, [0, 2, 1]]
    return tris, faces


def _make_mesh(shape: Optional[Node], ifs: Node, path: NodePath, matrix: np.ndarray,
               scene_path: Optional[str]) -> Mesh:
    local = _points(ifs)
    tris, faces = _triangulate(ifs, len(local), scene_path)
    world = local @ matrix[:3, :3].T + matrix[:3, 3]
    return Mesh(shape, ifs, path.as_tuple(), matrix, world, local, tris, faces)


def _is_ifs(node: object) -> bool:
    return isinstance(node, Node) and node.type == "IndexedFaceSet" \
        and isinstance(node.decl, NodeType)


def iter_meshes(scene: Union[Scene, Node, Iterable[Node]]) -> Iterator[Mesh]:
    """A :class:`Mesh` for each place of each IndexedFaceSet in the rendered graph.

    IndexedFaceSets are found as ``Shape.geometry``, or as nodes reached directly by
    the walk (a face scene graph may hold one bare).  Geometry referred to only from
    FaceDefMesh nodes is not visited.  VRMLError (naming the node and where it was
    read) if a coordIndex entry is out of range.

    >>> cube = Node("IndexedFaceSet", coordIndex=[0, 1, 2, 3, -1],
    ...             coord=Node("Coordinate", point=np.eye(4, 3)))
    >>> [len(m.triangles) for m in iter_meshes(Node("Shape", geometry=cube))]
    [2]
    """
    scene_path = scene.path if isinstance(scene, Scene) else None
    for node, path, m in _walk(_roots(scene), matrices=True):
        if node.type == "Shape" and isinstance(node.decl, NodeType):
            geometry = node["geometry"]
            if _is_ifs(geometry):
                yield _make_mesh(node, geometry, path, m, scene_path)
        elif _is_ifs(node):
            yield _make_mesh(None, node, path, m, scene_path)


def scene_bounds(scene: Union[Scene, Node, Iterable[Node]]) -> Optional[tuple]:
    """``(min xyz, max xyz)`` over all meshes in world space, or None if there are none.

    >>> tri = Node("IndexedFaceSet", coordIndex=[0, 1, 2],
    ...            coord=Node("Coordinate", point=[[0, 0, 0], [1, 0, 0], [0, 1, 0]]))
    >>> moved = Node("Transform", translation=(0, 0, -2), children=[Node("Shape", geometry=tri)])
    >>> [b.tolist() for b in scene_bounds(Scene([Node("Shape", geometry=tri), moved]))]
    [[0.0, 0.0, -2.0], [1.0, 1.0, 0.0]]
    """
    lows, highs = [], []
    for mesh in iter_meshes(scene):
        b = mesh.bounds
        if b is not None:
            lows.append(b[0])
            highs.append(b[1])
    if not lows:
        return None
    return np.min(lows, axis=0), np.max(highs, axis=0)
