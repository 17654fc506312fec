"""Writing the VRML FAT codec (:mod:`mpeg4fba.formats.wrl_face`, whose module doc
describes the layout): :class:`FaceModel` -> MPEG-4 Face / FDP / FaceDefTables nodes.
Imported from there (``from mpeg4fba.formats.wrl_face import save_face``)."""
from __future__ import annotations

import os
import re
from typing import Optional, Union

import numpy as np

from ..fba.face import FaceMesh, FaceModel, FaceTransform
from ..fba.tables import FAP
from ..vrml.catalogue import NODE_TYPES, FieldDecl
from ..vrml.reader import is_name
from ..vrml.scene import Node, Proto, Scene
from ..vrml.writer import dump
from .wrl_fdp import fdp_coordinate

__all__ = ["scene_from_face", "save_face", "face_protos", "DefNamer", "FACE_NODES",
           "GRAPH_NAME"]

PathLike = Union[str, os.PathLike]

#: The MPEG-4 face node types this codec reads and writes (FIT is not read).
FACE_NODES = ("Face", "FDP", "FaceDefTables", "FaceDefMesh", "FaceDefTransform", "FAP",
              "Viseme", "Expression")
#: DEF name (made unique) of the root Group holding the face scene graph with protos=True.
GRAPH_NAME = "FaceSceneGraph"

_BAD_CHARS = re.compile(r"[\x00-\x20\"#',.\[\\\]{}\x7f]")


def _sanitize(name: str) -> str:
    """A valid VRML97 name close to ``name``.

    >>> _sanitize("Skin"), _sanitize("left eye"), _sanitize("3d.mesh"), _sanitize("TRUE")
    ('Skin', 'left_eye', '_3d_mesh', 'TRUE_')
    """
    if is_name(name):
        return name
    s = _BAD_CHARS.sub("_", name)
    if not s or s[0] in "0123456789+-":
        s = "_" + s
    if not is_name(s):
        s += "_"
    return s if is_name(s) else "_"


class DefNamer:
    """Unique valid DEF names, the wanted ones first come first served."""

    def __init__(self):
        self.used: set = set()

    def claim(self, wanted: str, fallback: str) -> str:
        base = _sanitize(wanted) if wanted else fallback
        name, k = base, 2
        while name in self.used:
            name, k = f"{base}_{k}", k + 1
        self.used.add(name)
        return name


def face_protos(types: tuple = FACE_NODES) -> dict:
    """PROTO declarations of MPEG-4 face nodes for VRML97 browsers: the catalogue's
    interface and an empty ``Group {}`` body (they render nothing, bind nothing).

    >>> p = face_protos(("FaceDefMesh",))["FaceDefMesh"]
    >>> [d.name for d in p.interface], p.body[0].type
    (['faceSceneGraphNode', 'intervalBorders', 'coordIndex', 'displacements'], 'Group')
    """
    out = {}
    for t in types:
        interface = [FieldDecl(d.kind, d.type, d.name, d.default)
                     for d in NODE_TYPES[t].fields.values()]
        out[t] = Proto(t, interface, [Node("Group")])
    return out


def _changed(value: tuple, default: tuple) -> bool:
    return tuple(float(v) for v in value) != tuple(default)


def _transform_fields(t: FaceTransform) -> dict:
    decl = NODE_TYPES["Transform"].fields
    out = {}
    for field, value in (("translation", t.translation), ("rotation", t.rotation),
                         ("scale", t.scale), ("center", t.center),
                         ("scaleOrientation", t.scale_orientation)):
        if _changed(value, decl[field].default):
            out[field] = tuple(value)
    return out


def _check_tree(face: FaceModel) -> None:
    for name, t in face.transforms.items():
        if t.parent is not None and t.parent not in face.transforms:
            raise ValueError(f"transform {name} hangs under {t.parent!r}, which is not a "
                             "Transform of the face")
        face.chain(name)  # ValueError if the tree loops


def _first_meshes(face: FaceModel) -> dict:
    """Transform name -> index of the first mesh (in the model's order) below it; those
    without meshes come after all meshes, in the model's order of transforms."""
    n = len(face.meshes)
    first = {t: n + k for k, t in enumerate(face.transforms)}
    for i, m in enumerate(face.meshes.values()):
        p = m.parent
        while p is not None and first[p] > i:
            first[p] = i
            p = face.transforms[p].parent
    return first


def _integers(values: np.ndarray, what: str) -> np.ndarray:
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if not (np.isfinite(v).all() and (v == np.round(v)).all()
            and (np.abs(v) <= 2147483647).all()):
        raise ValueError(f"{what} must be 32-bit integers to be written, not {v.tolist()}")
    return v.astype(np.int64)


def scene_from_face(face: FaceModel, *, protos: bool = True) -> Scene:
    """The VRML scene of a :class:`FaceModel` (see the module doc for the layout).

    ``protos=True`` declares the MPEG-4 nodes as PROTOs so that VRML97 browsers open
    the file; ``protos=False`` writes BIFS-style text.  ValueError for a model that
    can't be written (a transform tree that loops, a FAT entry naming a mesh or
    Transform the face does not have, non-integral interval borders).
    """
    _check_tree(face)
    names = DefNamer()
    tnames = {n: names.claim(n, "transform") for n in face.transforms}
    mnames = {n: names.claim(n, "mesh") for n in face.meshes}
    initial = dict(getattr(face, "initial_faps", None) or {})
    viseme = getattr(face, "initial_viseme", None)
    expression = getattr(face, "initial_expression", None)
    used = ["Face", "FDP", "FaceDefTables", "FaceDefMesh", "FaceDefTransform"]
    if initial or viseme or expression:
        used.append("FAP")
    used += [t for t, v in (("Viseme", viseme), ("Expression", expression)) if v]
    decls = face_protos(tuple(used)) if protos else {}

    def make(type_name: str, name: Optional[str] = None, **fields) -> Node:
        return Node(type_name, decl=decls.get(type_name), name=name, **fields)

    # The scene graph.  Under each Transform (and at the top) the children go in the
    # order of the first mesh of the model each holds, so that a reader finds the
    # meshes in the model's order whenever the tree allows it.
    tnodes = {n: Node("Transform", name=tnames[n], **_transform_fields(t))
              for n, t in face.transforms.items()}
    kids: dict = {n: [] for n in face.transforms}
    roots: list = []
    ifs_nodes = {}
    for i, (n, m) in enumerate(face.meshes.items()):
        if m.parent is not None and m.parent not in face.transforms:
            raise ValueError(f"mesh {n} hangs under {m.parent!r}, which is not a Transform of "
                             "the face")
        tris = np.asarray(m.triangles, dtype=np.int64).reshape(-1, 3)
        if tris.size and (tris.min() < 0 or tris.max() >= len(m.vertices)):
            raise ValueError(f"mesh {n}: a triangle names a vertex outside "
                             f"0..{len(m.vertices) - 1}")
        coord_index = np.column_stack([tris, np.full(len(tris), -1)]).reshape(-1)
        coord = Node("Coordinate", point=m.vertices.copy())
        color, per_vertex = face.mesh_colors(n)
        # 4 decimals: well below a display's 1/255 step, and a third of the text
        fields = {} if per_vertex is None else \
            {"color": Node("Color", color=np.round(per_vertex, 4))}
        # solid TRUE where back faces are never to be seen: two-sided, the inward-wound
        # mouth cavity would hide the teeth in a VRML browser
        ifs = Node("IndexedFaceSet", name=mnames[n], coord=coord, coordIndex=coord_index,
                   solid=m.is_closed(), creaseAngle=1.5, **fields)
        ifs_nodes[n] = ifs
        shape = Node("Shape", appearance=Node("Appearance", material=Node(
            "Material", diffuseColor=color)), geometry=ifs)
        (kids[m.parent] if m.parent is not None else roots).append((i, shape))
    first = _first_meshes(face)
    for n, t in face.transforms.items():
        (kids[t.parent] if t.parent is not None else roots).append((first[n], tnodes[n]))
    roots = [node for _, node in sorted(roots, key=lambda item: item[0])]
    for n, node in tnodes.items():
        if kids[n]:
            node["children"] = [k for _, k in sorted(kids[n], key=lambda item: item[0])]

    # The FAT.
    tables = []
    for table in face.fat:
        entries = []
        for m in table.meshes:
            if m.mesh not in ifs_nodes:
                raise ValueError(f"the table of FAP {table.fap} deforms mesh {m.mesh!r}, which "
                                 f"the face does not have ({sorted(face.meshes)})")
            entries.append(make("FaceDefMesh", faceSceneGraphNode=ifs_nodes[m.mesh],
                                intervalBorders=_integers(m.borders, f"FAP {table.fap} "
                                                          "interval borders"),
                                coordIndex=m.indices,
                                displacements=np.asarray(m.displacements).reshape(-1, 3)))
        transforms = []
        for t in table.transforms:
            if t.transform not in tnodes:
                raise ValueError(f"the table of FAP {table.fap} drives Transform "
                                 f"{t.transform!r}, which the face does not have")
            fields: dict = {"faceSceneGraphNode": tnodes[t.transform], "fieldId": t.field_id}
            decl = NODE_TYPES["FaceDefTransform"].fields
            for field, value in (("rotationDef", t.rotation), ("scaleDef", t.scale),
                                 ("translationDef", t.translation)):
                if _changed(value, decl[field].default):
                    fields[field] = value
            transforms.append(make("FaceDefTransform", **fields))
        fields = {"fapID": int(table.fap)}
        if table.select != 1:
            fields["highLevelSelect"] = int(table.select)
        if entries:
            fields["faceDefMesh"] = entries
        if transforms:
            fields["faceDefTransform"] = transforms
        tables.append(make("FaceDefTables", **fields))

    # FDP and Face.
    statements: list = list(decls.values())
    fdp_fields: dict = {}
    points = face.points
    if points.ids:
        if len(points) < len(points.ids):  # some points are only tied to vertices
            points = points.resolve({n: face.world_vertices(n) for n in face.meshes})
        fdp_fields["featurePointsCoord"] = fdp_coordinate(points)
    graph_name = names.claim(GRAPH_NAME, GRAPH_NAME)
    if protos:
        graph = Node("Group", name=graph_name, children=roots)
        statements.append(graph)
        fdp_fields["faceSceneGraph"] = [graph]
    else:
        fdp_fields["faceSceneGraph"] = roots
    if tables:
        fdp_fields["faceDefTables"] = tables
    face_fields: dict = {}
    if "FAP" in used:
        fap_fields = {FAP[k].bifs_name: int(v) for k, v in sorted(initial.items())}
        if viseme:
            fap_fields["viseme"] = make("Viseme", **viseme)
        if expression:
            fap_fields["expression"] = make("Expression", **expression)
        face_fields["fap"] = make("FAP", **fap_fields)
    face_fields["fdp"] = make("FDP", **fdp_fields)
    statements.append(make("Face", name=names.claim(face.name, "face"), **face_fields))
    return Scene(statements)


def save_face(face: FaceModel, path: PathLike, *, protos: bool = True) -> None:
    """Write ``face`` as VRML (gzipped for ``.gz`` / ``.wrz``), or as glTF for ``.glb`` /
    ``.gltf`` (:func:`mpeg4fba.formats.gltf.write_glb`: a morph target per FAT interval),
    atomically.

    >>> import os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "tri.wrl")
    >>> from mpeg4fba.formats.wrl_face import load_face
    >>> save_face(FaceModel([FaceMesh("Tri", np.eye(3), [[0, 1, 2]])]), p)
    >>> load_face(p).meshes["Tri"].vertices.tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    p = os.fspath(path)
    if p.lower().endswith((".glb", ".gltf")):
        from .gltf import write_glb
        write_glb(face, p)
        return
    dump(scene_from_face(face, protos=protos), p)

