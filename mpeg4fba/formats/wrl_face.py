"""The VRML FAT codec: MPEG-4 Face / FDP / FaceDefTables nodes <-> :class:`FaceModel`.

**Reading** (:func:`face_from_scene`, :func:`load_face`) finds the scene's Face node and
its FDP, and turns

* ``FDP.faceSceneGraph`` into meshes and a transform tree.  The graph is walked
  iteratively.  Each IndexedFaceSet (a ``Shape.geometry`` or a bare one) becomes a
  :class:`FaceMesh` named by its DEF name (``mesh_1``, ``mesh_2``... when it has none):
  its vertices are the Coordinate points (local coordinates), its triangles the fan
  triangulation of ``coordIndex`` (reversed when ``ccw`` is FALSE), its parent the
  nearest enclosing Transform.  Each Transform becomes a :class:`FaceTransform` (DEF name
  or ``transform_1``...) with its neutral fields.  Group, Anchor, Collision and
  Billboard are flattened (their children belong to the nearest Transform above);
  Switch follows its chosen child and LOD its first level; other nodes (lights,
  other geometry, PROTO instances) are not part of the model.  A node used in several
  places gives one mesh or transform per place, the later ones named ``<name>_2``...;
  the FAT entries that target it are repeated for each.  Mesh and transform names are
  unique together.  A Shape's ``Material.diffuseColor`` becomes the mesh's ``color``
  (none without a Material: the renderers then pick one from the mesh's name), and an
  IndexedFaceSet's Color node the face's colours per vertex (``face.colors``; colours
  per face or through a colorIndex are averaged at each vertex).  A colour outside
  0..1, or a Color index beyond the Color node, is a FormatError at the node's
  file:line.  ``solid`` is not read (a mesh is drawn single-sided where it is closed,
  :meth:`FaceMesh.is_closed`); texture coordinates and normals are not read.
* ``FDP.featurePointsCoord`` into feature points (:mod:`~mpeg4fba.formats.wrl_fdp`;
  none when the FDP has no featurePointsCoord).
* ``FDP.faceDefTables`` into the :class:`FAT`.  A FaceDefMesh whose
  ``faceSceneGraphNode`` is not an IndexedFaceSet of the face scene graph, a
  FaceDefTransform whose target is not a Transform of it, or a fieldId other than 1-3
  is a :class:`FormatError` naming the table's fapID, at the entry's file:line.  Other
  problems of an entry (borders, counts, vertex indices) are kept as read, for the
  validator (:mod:`mpeg4fba.fba.compliance`) to report; playing such a face raises.
* ``Face.fap`` (a FAP node, fields in the BIFS naming, -2147483648 meaning "not set")
  into ``face.initial_faps`` ({FAP number: value} for FAPs 3-68), and its Viseme and
  Expression nodes into ``face.initial_viseme`` / ``face.initial_expression`` (dicts of
  their fields, or None).

Instances of PROTOs named Face, FDP, FaceDefTables, FaceDefMesh, FaceDefTransform, FAP,
Viseme or Expression whose interface declares the catalogue's fields with the same
types are read as the MPEG-4 nodes (that is how :func:`scene_from_face` writes them for
VRML97 browsers); a PROTO of such a name with another interface is a FormatError.

**Where things came from.**  ``face.source`` is a dict::

    {"path": file or None, "face": the Face Node, "fdp": the FDP Node,
     "nodes": {id(obj): Node}}

where ``obj`` is each FaceDefTable (-> its FaceDefTables node), FaceDefMesh /
FaceDefTransform entry (-> its node), FaceMesh (-> its IndexedFaceSet), FaceTransform
(-> its Transform) and the FeaturePointSet (-> the featurePointsCoord Coordinate).
``node.location`` gives (path, line, column) for nodes read from text, so a validator
says ``file:line`` for each entry: :func:`where` does it.

**Writing** (:func:`scene_from_face`, :func:`save_face`) gives a Transform/Shape scene
graph (Transforms with their neutral values, IndexedFaceSets DEF'd with the mesh
names, coordIndex the triangles with -1 after each; each Shape's Material the mesh's
colour and a Color node of the face's colours per vertex where it has them, to 4
decimals (:meth:`FaceModel.mesh_colors`); ``solid TRUE`` for a closed mesh, whose back
faces are never to be seen, else ``solid FALSE``), the Face
with its FDP (featurePointsCoord, faceSceneGraph, faceDefTables) and, when the face has
initial FAP values, a FAP node.  DEF names are the model's names when they are valid
VRML97 names, else sanitised (bad characters become ``_``), and unique.

With ``protos=True`` (the default) the file opens in any VRML97 browser.  The MPEG-4
nodes are declared as PROTOs at the top with the catalogue's interfaces and an empty
``Group {}`` body, so they render nothing and bind nothing with IS; the face scene
graph is written once as a root ``DEF FaceSceneGraph Group``, which every browser
renders, and ``FDP.faceSceneGraph`` holds ``USE FaceSceneGraph``; FaceDefMesh and
FaceDefTransform point at the DEF'd IndexedFaceSets and Transforms with USE.  This is
plain VRML97: PROTO instances are allowed as root nodes (their type is their body's
first node, a Group) and in any SFNode/MFNode field of another PROTO instance, and
USE may name any node DEF'd earlier in the file.  No IS is used, because nothing
needs binding (and PyVRML97 loops forever on any PROTO instance that uses IS).
With ``protos=False`` the text is BIFS-style (the built-in MPEG-4 nodes, the graph
inline in ``faceSceneGraph``): our reader and MPEG-4 tools read it, VRML97 browsers
don't.

Example
-------
>>> from mpeg4fba import vrml
>>> from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform
>>> jaw = FaceTransform("Jaw", translation=(0, -1, 0))
>>> skin = FaceMesh("Skin", [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 3, 2]],
...                 parent="Jaw")
>>> fat = FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 1000], [0, 1], [[0, -1, 0], [0, -2, 0]])],
...                         [FaceDefTransform("Jaw", 1, rotation=(1, 0, 0, 1e-5))])])
>>> text = vrml.dumps(scene_from_face(FaceModel([skin], [jaw], fat=fat)))
>>> text.count("PROTO "), "DEF Skin IndexedFaceSet" in text
(5, True)
>>> face = face_from_scene(vrml.loads(text))
>>> face.meshes["Skin"].parent, face.transforms["Jaw"].translation
('Jaw', (0.0, -1.0, 0.0))
>>> face.fat[3].meshes[0].displacements.shape, face.fat[3].transforms[0].field
((2, 1, 3), 'rotation')
>>> face.pose({3: 500}).vertices("Skin")[0, :2].tolist()
[[0.0, -500.0, 0.0], [1.0, -1000.0, 0.0]]
"""
from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from ..fba.face import FaceMesh, FaceModel, FaceTransform
from ..fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform
from ..fba.featurepoints import FeaturePointSet
from ..fba.stream import EXPRESSION_FIELDS, VISEME_FIELDS
from ..fba.tables import FAP
from ..vrml.catalogue import NODE_TYPES, NodeType
from ..vrml.reader import VRMLWarning
from ..vrml.scene import ExternProto, Node, Proto, Scene, iter_nodes
from ..vrml.walk import fan_triangulate
from .errors import FormatError
# (the writing half, kept in its own module and named from here)
from .wrl_face_writer import (FACE_NODES, GRAPH_NAME, DefNamer, face_protos,  # noqa: F401
                              save_face, scene_from_face)
from .wrl_fdp import feature_points_from_fdp, find_face

__all__ = ["face_from_scene", "load_face", "scene_from_face", "save_face", "where",
           "face_protos", "FACE_NODES", "UNSET", "GRAPH_NAME"]

PathLike = Union[str, os.PathLike]

#: A FAP node field holding this is "not set" (the BIFS default +I, stored as INT32_MIN).
UNSET = -2147483648

_FLATTENED = frozenset({"Group", "Anchor", "Collision", "Billboard"})
_EXIT = object()


# -- locations ------------------------------------------------------------------------------

def _at(node: Any, path: Optional[str]) -> dict:
    """FormatError location keywords of a node (its file:line:column when read from text)."""
    loc = node.location if isinstance(node, Node) else None
    if loc is None:
        return {"path": path}
    return {"path": loc[0] if loc[0] is not None else path, "line": loc[1], "column": loc[2]}


def _label(node: Any) -> str:
    if node is None:
        return "NULL"
    if not isinstance(node, Node):
        return repr(node)
    return f"{node.type} {node.name!r}" if node.name else f"a {node.type}"


def where(face: FaceModel, obj: Any) -> str:
    """``file:line`` where ``obj`` (a table, FAT entry, mesh or transform of ``face``) was
    read; the file alone (or ``<face>``) when that is not known.

    >>> where(FaceModel(), object())
    '<face>'
    """
    src = getattr(face, "source", None) or {}
    node = (src.get("nodes") or {}).get(id(obj))
    text = src.get("path") or "<face>"
    loc = node.location if isinstance(node, Node) else None
    if loc is not None:
        file = loc[0] or src.get("path")
        text = f"{file}:{loc[1]}" if file else f"line {loc[1]}"
    return text


# -- MPEG-4 nodes, built in or as PROTOs ----------------------------------------------------

def _compatible(decl: Any, type_name: str) -> Optional[str]:
    """None if ``decl`` (a PROTO) declares the catalogue fields of ``type_name`` with
    their types, else what is wrong."""
    for d in NODE_TYPES[type_name].fields.values():
        mine = decl.field(d.name)
        if mine is None:
            return f"it declares no {d.name}"
        if mine.type is not d.type:
            return f"its {d.name} is {mine.type.name}, not {d.type.name}"
    return None


def _require(node: Any, type_name: str, what: str, path: Optional[str], at: Any) -> Node:
    """``node`` if it is an MPEG-4 ``type_name`` node (built in, or a PROTO instance with
    the catalogue's interface); FormatError otherwise (at ``at``'s location)."""
    if not isinstance(node, Node) or node.type != type_name:
        raise FormatError(f"{what} is {_label(node)}, not a {type_name} node",
                          **_at(node if isinstance(node, Node) else at, path))
    if isinstance(node.decl, NodeType):
        return node
    if isinstance(node.decl, (Proto, ExternProto)):
        problem = _compatible(node.decl, type_name)
        if problem is None:
            return node
        kind = "PROTO" if isinstance(node.decl, Proto) else "EXTERNPROTO"
        raise FormatError(f"{what}: {kind} {type_name} is not the MPEG-4 {type_name} node: "
                          f"{problem}", **_at(node, path))
    raise FormatError(f"{what}: {type_name} has no known interface", **_at(node, path))


def _nodes(value: Any) -> list:
    return value if isinstance(value, list) else []


# -- the face scene graph -------------------------------------------------------------------

class _GraphReader:
    """Meshes and transforms of a face scene graph, one per place of each node."""

    def __init__(self, roots: list, path: Optional[str]):
        self.path = path
        self.taken = {n.name for n in iter_nodes(roots) if n.name}
        self.used: set = set()
        self.meshes: list = []
        self.transforms: list = []
        self.mesh_names: dict = {}       # id(IFS node) -> [mesh names]
        self.transform_names: dict = {}  # id(Transform node) -> [transform names]
        self.nodes: dict = {}            # id(FaceMesh / FaceTransform) -> node
        self.colors: dict = {}           # mesh name -> [n, 3] colours per vertex
        self._serial = {"mesh": 0, "transform": 0}
        self.walk(roots)

    def claim(self, node: Node, kind: str) -> str:
        if node.name and node.name not in self.used:
            name = node.name
        elif node.name:
            k = 2
            while f"{node.name}_{k}" in self.used or f"{node.name}_{k}" in self.taken:
                k += 1
            name = f"{node.name}_{k}"
        else:
            while True:
                self._serial[kind] += 1
                name = f"{kind}_{self._serial[kind]}"
                if name not in self.used and name not in self.taken:
                    break
        self.used.add(name)
        return name

    def walk(self, roots: list) -> None:
        stack: list = [(n, None) for n in reversed(roots)]
        on_path: set = set()
        while stack:
            node, parent = stack.pop()
            if node is _EXIT:
                on_path.discard(parent)
                continue
            if not isinstance(node, Node) or not isinstance(node.decl, NodeType):
                continue  # PROTO instances and unknown nodes are not part of the model
            if id(node) in on_path:
                warnings.warn(f"{_label(node)} is its own ancestor in the face scene graph; "
                              "not entered again", VRMLWarning, stacklevel=4)
                continue
            t = node.type
            below = parent
            if t == "Transform":
                below = self.transform(node, parent)
                kids = _nodes(node["children"])
            elif t in _FLATTENED:
                kids = _nodes(node["children"])
            elif t == "Switch":
                choice, which = _nodes(node["choice"]), node["whichChoice"]
                kids = [choice[which]] if 0 <= which < len(choice) else []
            elif t == "LOD":
                kids = _nodes(node["level"])[:1]
            elif t == "Shape":
                geometry = node["geometry"]
                if isinstance(geometry, Node) and geometry.type == "IndexedFaceSet" \
                        and isinstance(geometry.decl, NodeType):
                    self.mesh(geometry, parent, node)
                continue
            elif t == "IndexedFaceSet":
                self.mesh(node, parent)
                continue
            else:
                continue
            on_path.add(id(node))
            stack.append((_EXIT, id(node)))
            stack.extend((k, below) for k in reversed(kids))

    def transform(self, node: Node, parent: Optional[str]) -> str:
        name = self.claim(node, "transform")
        t = FaceTransform(name, parent, translation=tuple(node["translation"]),
                          rotation=tuple(node["rotation"]), scale=tuple(node["scale"]),
                          center=tuple(node["center"]),
                          scale_orientation=tuple(node["scaleOrientation"]))
        self.transforms.append(t)
        self.transform_names.setdefault(id(node), []).append(name)
        self.nodes[id(t)] = node
        return name

    def mesh(self, ifs: Node, parent: Optional[str], shape: Optional[Node] = None) -> None:
        name = self.claim(ifs, "mesh")
        coord = ifs["coord"]
        points = coord.get("point") if isinstance(coord, Node) else None
        if isinstance(points, np.ndarray) and points.size:
            vertices = np.array(points, dtype=np.float64).reshape(-1, 3)
        else:
            vertices = np.empty((0, 3))
        idx = np.asarray(ifs["coordIndex"], dtype=np.int64).reshape(-1)
        bad = np.flatnonzero((idx < -1) | (idx >= len(vertices)))
        if bad.size:
            i = int(bad[0])
            raise FormatError(f"IndexedFaceSet {name!r}: coordIndex[{i}] is {int(idx[i])}, "
                              f"outside 0..{len(vertices) - 1} (the coord has {len(vertices)} "
                              "points)", **_at(ifs, self.path))
        triangles, _ = fan_triangulate(idx)
        if not ifs["ccw"]:
            triangles = triangles[:, [0, 2, 1]]
        m = FaceMesh(name, vertices, triangles, parent, _material_color(shape, name, self.path))
        colors = _vertex_colors(ifs, name, idx, len(vertices), m.display_color(), self.path)
        if colors is not None:
            self.colors[name] = colors
        self.meshes.append(m)
        self.mesh_names.setdefault(id(ifs), []).append(name)
        self.nodes[id(m)] = ifs


def _builtin(node: Any, type_name: str) -> bool:
    return isinstance(node, Node) and node.type == type_name and isinstance(node.decl, NodeType)


def _check_colors(values: np.ndarray, what: str, at: Node, path: Optional[str]) -> None:
    bad = ~(np.isfinite(values) & (values >= 0) & (values <= 1))
    if bad.any():
        i = int(np.flatnonzero(bad.reshape(-1))[0])
        raise FormatError(f"{what}: {float(values.reshape(-1)[i])!r} (item {i}) is not a colour "
                          "component; colours run from 0 to 1", **_at(at, path))


def _material_color(shape: Optional[Node], mesh: str, path: Optional[str]) -> Optional[tuple]:
    """A Shape's ``appearance.material.diffuseColor``, or None without a Material."""
    if shape is None:
        return None
    appearance = shape["appearance"]
    if not _builtin(appearance, "Appearance") or not _builtin(appearance["material"], "Material"):
        return None
    material = appearance["material"]
    color = np.asarray(material["diffuseColor"], dtype=np.float64)
    _check_colors(color, f"mesh {mesh!r}: Material.diffuseColor", material, path)
    return tuple(float(c) for c in color)


def _vertex_colors(ifs: Node, mesh: str, coord_index: np.ndarray, n: int, fill: tuple,
                   path: Optional[str]) -> Optional[np.ndarray]:
    """The colours [n, 3] per vertex of an IndexedFaceSet's Color node, or None without
    one.  Per vertex through coordIndex (the usual way, and the way :func:`save_face`
    writes them) the colours are taken as they are; per face, or through a colorIndex,
    a vertex gets the mean of its corners' colours.  Vertices on no polygon get
    ``fill``."""
    node = ifs["color"]
    if not _builtin(node, "Color"):
        return None
    table = np.asarray(node["color"], dtype=np.float64).reshape(-1, 3)
    what = f"IndexedFaceSet {mesh!r}"
    _check_colors(table, f"{what}: Color.color", node, path)
    idx = coord_index
    corners = np.flatnonzero(idx >= 0)                  # positions of polygon corners
    vertex = idx[corners]
    polygon = np.cumsum(idx == -1)[corners]             # the polygon of each corner
    per_vertex = bool(ifs["colorPerVertex"])
    cidx = np.asarray(ifs["colorIndex"], dtype=np.int64).reshape(-1)
    if per_vertex and not cidx.size:
        pick, field = vertex, "coordIndex"
    elif per_vertex:
        if len(cidx) < len(idx):
            raise FormatError(f"{what}: colorIndex has {len(cidx)} entries, fewer than "
                              f"coordIndex's {len(idx)}", **_at(ifs, path))
        pick, field = cidx[corners], "colorIndex"
    elif cidx.size:
        n_polygons = int(polygon.max()) + 1 if len(polygon) else 0
        if len(cidx) < n_polygons:
            raise FormatError(f"{what}: colorIndex has {len(cidx)} entries for {n_polygons} "
                              "faces (colorPerVertex FALSE)", **_at(ifs, path))
        pick, field = cidx[polygon], "colorIndex"
    else:
        pick, field = polygon, "the face number (colorPerVertex FALSE)"
    bad = np.flatnonzero((pick < 0) | (pick >= len(table)))
    if bad.size:
        raise FormatError(f"{what}: {field} picks colour {int(pick[bad[0]])}, but the Color "
                          f"node has {len(table)}", **_at(ifs, path))
    out = np.tile(np.asarray(fill, dtype=np.float64), (n, 1))
    if per_vertex and not cidx.size:
        used = np.unique(vertex)
        out[used] = table[used]                         # exactly as written
        return out
    count = np.bincount(vertex, minlength=n)
    for c in range(3):
        total = np.bincount(vertex, weights=table[pick, c], minlength=n)
        out[:, c] = np.where(count > 0, total / np.maximum(count, 1), out[:, c])
    return out


# -- reading --------------------------------------------------------------------------------

def _read_fat(fdp: Node, graph: _GraphReader, path: Optional[str], nodes: dict) -> FAT:
    fat = FAT()
    for tnode in _nodes(fdp["faceDefTables"]):
        tnode = _require(tnode, "FaceDefTables", "an entry of FDP.faceDefTables", path, fdp)
        fap, select = int(tnode["fapID"]), int(tnode["highLevelSelect"])
        table = FaceDefTable(fap, [], [], select)
        nodes[id(table)] = tnode
        head = f"FaceDefTables fapID {fap}"
        for mnode in _nodes(tnode["faceDefMesh"]):
            mnode = _require(mnode, "FaceDefMesh", f"{head}: a faceDefMesh entry", path, tnode)
            target = mnode["faceSceneGraphNode"]
            names = graph.mesh_names.get(id(target)) if isinstance(target, Node) else None
            if not names:
                hint = ""
                if isinstance(target, Node) and target.type == "Shape":
                    hint = " (point at the Shape's geometry, the IndexedFaceSet, with USE)"
                raise FormatError(f"{head}: FaceDefMesh.faceSceneGraphNode is {_label(target)}, "
                                  "not an IndexedFaceSet of the FDP's faceSceneGraph" + hint,
                                  **_at(mnode, path))
            borders = np.asarray(mnode["intervalBorders"])
            indices = np.asarray(mnode["coordIndex"])
            displacements = np.asarray(mnode["displacements"], dtype=np.float64)
            for name in names:
                entry = FaceDefMesh(name, borders, indices, displacements.copy())
                table.meshes.append(entry)
                nodes[id(entry)] = mnode
        for xnode in _nodes(tnode["faceDefTransform"]):
            xnode = _require(xnode, "FaceDefTransform", f"{head}: a faceDefTransform entry",
                             path, tnode)
            target = xnode["faceSceneGraphNode"]
            names = graph.transform_names.get(id(target)) if isinstance(target, Node) else None
            if not names:
                raise FormatError(f"{head}: FaceDefTransform.faceSceneGraphNode is "
                                  f"{_label(target)}, not a Transform of the FDP's "
                                  "faceSceneGraph", **_at(xnode, path))
            field_id = int(xnode["fieldId"])
            for name in names:
                try:
                    entry = FaceDefTransform(name, field_id, rotation=tuple(xnode["rotationDef"]),
                                             scale=tuple(xnode["scaleDef"]),
                                             translation=tuple(xnode["translationDef"]))
                except ValueError:
                    raise FormatError(f"{head}: FaceDefTransform.fieldId is {field_id}; it must "
                                      "be 1 (rotation), 2 (scale) or 3 (translation)",
                                      **_at(xnode, path)) from None
                table.transforms.append(entry)
                nodes[id(entry)] = xnode
        fat.add(table)
    return fat


def _read_fap(face_node: Node, path: Optional[str], nodes: dict) -> tuple:
    """(initial FAP values, viseme fields or None, expression fields or None)."""
    fap = face_node["fap"]
    if fap is None:
        return {}, None, None
    fap = _require(fap, "FAP", "Face.fap", path, face_node)
    values = {}
    for r in FAP.low_level:
        v = fap[r.bifs_name]
        if v != UNSET:
            values[r.number] = int(v)
    high = []
    for field, type_name, names in (("viseme", "Viseme", VISEME_FIELDS),
                                    ("expression", "Expression", EXPRESSION_FIELDS)):
        node = fap[field]
        if node is None:
            high.append(None)
            continue
        node = _require(node, type_name, f"FAP.{field}", path, fap)
        high.append({k: (bool(node[k]) if isinstance(node[k], bool) else int(node[k]))
                     for k in names})
    return values, high[0], high[1]


def face_from_scene(scene: Scene, path: Optional[str] = None, face: Optional[str] = None
                    ) -> FaceModel:
    """The :class:`FaceModel` of the scene's Face node (see the module doc).

    ``path`` names the file in errors (default: ``scene.path``); ``face`` is the DEF
    name of the Face to read, needed only when the scene has several.

    >>> from mpeg4fba import vrml
    >>> try:
    ...     face_from_scene(vrml.loads("#VRML V2.0 utf8\\nGroup {}"))
    ... except FormatError as e:
    ...     print(e.message)
    no MPEG-4 Face node in the scene (root nodes: Group); a face file holds Face { fdp FDP { ... } }
    """
    path = path if path is not None else getattr(scene, "path", None)
    face_node = find_face(scene, face, path)
    face_node = _require(face_node, "Face", "the Face node", path, face_node)
    fdp = face_node["fdp"]
    if fdp is None:
        raise FormatError(f"{_label(face_node)} has no fdp (FDP node), so no face model to "
                          "read", **_at(face_node, path))
    fdp = _require(fdp, "FDP", "Face.fdp", path, face_node)
    nodes: dict = {}
    graph = _GraphReader(_nodes(fdp["faceSceneGraph"]), path)
    nodes.update(graph.nodes)
    points = FeaturePointSet()
    coord = fdp["featurePointsCoord"]
    if coord is not None:
        points = feature_points_from_fdp(fdp, path)
        nodes[id(points)] = coord
    fat = _read_fat(fdp, graph, path, nodes)
    initial, viseme, expression = _read_fap(face_node, path, nodes)
    name = face_node.name or (Path(path).name.split(".")[0] if path else "face")
    model = FaceModel(graph.meshes, graph.transforms, points, fat=fat, name=name)
    model.colors = graph.colors
    model.initial_faps = initial
    model.initial_viseme = viseme
    model.initial_expression = expression
    model.source = {"path": path, "face": face_node, "fdp": fdp, "nodes": nodes}
    return model


# Validator rules (see ``mpeg4fba validate``) whose breach makes a face unplayable: a
# FAP table that can't be evaluated or indexes past its mesh.
UNPLAYABLE = ("FBA004", "FBA005", "FBA006", "FBA007", "FBA008", "FBA009", "FBA010")


def load_face(path: PathLike, strict: bool = True, *, max_inflated: Optional[int] = None,
              max_ratio: Optional[float] = None, check: bool = True) -> FaceModel:
    """Read a VRML face file (plain or gzipped) into a :class:`FaceModel`.

    ``strict=False`` reads the VRML leniently (unknown nodes and fields kept, with a
    warning; see :func:`mpeg4fba.vrml.load`).  ``max_inflated`` / ``max_ratio`` bound
    how far gzip data may inflate (see :func:`mpeg4fba.vrml.load`).  Raises VRMLError
    for VRML that can't be read and FormatError for a scene that is not a face (see
    :func:`face_from_scene`).  A face that loads is a face that plays: with ``check``
    (the default) a FAT that breaks one of the validator's rules in ``UNPLAYABLE``
    (fapID outside 1-68, interval borders without a 0, a vertex index past its mesh, a
    displacement count that does not match, ...) is a FormatError at the table's line;
    ``mpeg4fba validate`` lists every problem at once.
    """
    from ..vrml import load
    p = os.fspath(path)
    face = face_from_scene(load(p, strict=strict, max_inflated=max_inflated,
                                max_ratio=max_ratio), p)
    if check:
        from ..fba.compliance import check_fat
        for f in check_fat(face):
            if f.code in UNPLAYABLE:
                raise FormatError(f"{f.message} ({f.code}; `mpeg4fba validate` lists every "
                                  "problem of the face)", f.path or p, f.line, f.column)
    return face
