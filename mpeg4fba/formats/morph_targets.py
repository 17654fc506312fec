"""Morph-target sets (a neutral face plus sculpted shapes) read from files.

Formats, chosen by the file name's ending (case-insensitive):

* **VRML97** (``.wrl``, ``.wrz``, ``.wrl.gz``, ``.vrml``): each IndexedFaceSet is a mesh,
  named by its DEF name (else its Shape's, else ``mesh_<k>`` in walk order; a node
  used in several places counts once); its vertices are the Coordinate points as
  written (local coordinates, no Transform applied).  Targets must have the same
  structure as the neutral.  Transforms (DEF name, else ``transform_<k>``) are kept
  for :func:`read_morph_face`.
* **OBJ** (``.obj``, :mod:`~mpeg4fba.formats.obj`): ``v`` and ``f`` lines (``f a``,
  ``a/b``, ``a/b/c``, ``a//c``, negative indices; polygons are fan-triangulated);
  every other line is ignored.
  With ``o`` / ``g`` lines each group (the faces after the last ``o`` or ``g`` line;
  groups of one name merge) is a mesh made of the vertices its faces use, in file
  order.  Without them the file is one mesh of all its vertices, named after the
  neutral's file stem (a target's ungrouped mesh is matched to a one-mesh neutral).
* **PLY, STL, OFF** (``.ply``, ``.stl``, ``.off``; :mod:`~mpeg4fba.formats.scans`,
  through meshio): one mesh, named after the file stem like an ungrouped OBJ.
* **glTF 2.0** (``.gltf``, ``.glb``, :mod:`~mpeg4fba.formats.gltf_file`): each
  primitive is a mesh (named after its glTF mesh, ``<mesh>_<k>`` when a mesh has
  several primitives,
  ``mesh_<i>`` when unnamed), read from its POSITION accessor in the mesh's own
  coordinates; the nodes holding meshes become Transforms for :func:`read_morph_face`
  (named after the node, ``node_<j>`` when unnamed; mesh and transform names are kept
  unique together, meshes first).  A neutral's own morph targets (deltas, named by
  ``mesh.extras.targetNames``, else ``target<k>``) become targets too; targets of one
  name in several meshes form one target, and meshes without it do not move.  A glTF
  file given as a target contributes its base shape only.

What a target file shows comes from ``mapping`` (a dict or a JSON / TSV file of
file name or glTF target name -> target name; a file is looked up by the path as
given, its base name, then its stem) or else from its stem, read by
:func:`mpeg4fba.fba.morph.parse_target_name`: ``open_jaw@1024.obj``,
``raise_b_midlip@-512.wrl``, ``viseme_PP.obj``, ``expression_joy.glb`` (``_`` or ``:``
after ``viseme`` / ``expression``).

Example
-------
>>> import os, tempfile
>>> d = tempfile.mkdtemp()
>>> quad = "v 0 0 0\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\n"
>>> _ = open(os.path.join(d, "neutral.obj"), "w").write(quad + "f 1 2 3 4\\n")
>>> _ = open(os.path.join(d, "open_jaw@1024.obj"), "w").write(
...     quad.replace("v 0 1 0", "v 0 0.5 0") + "f 1 2 3 4\\n")
>>> face = read_morph_face(os.path.join(d, "neutral.obj"), [os.path.join(d, "open_jaw@1024.obj")])
>>> face.fat.faps, face.pose({"open_jaw": 512}).vertices("neutral")[0, 3].tolist()
([3], [0.0, 0.75, 0.0])
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from ..fba.face import FaceMesh, FaceModel, FaceTransform
from ..fba.morph import FULL_SHAPE, MorphTarget, fat_from_morph_targets
from .errors import FormatError
from .gltf_file import Gltf, gltf_triangles, node_transform, target_names
from .jsontext import loads_json, shown as json_shown
from .obj import parse_obj, read_obj

__all__ = ["read_morph_targets", "read_morph_face", "read_obj", "parse_obj", "read_mapping",
           "target_stem", "FORMATS"]

PathLike = Union[str, os.PathLike]

#: File name endings -> format, longest first.
FORMATS = {".wrl.gz": "vrml", ".wrz": "vrml", ".wrl": "vrml", ".vrml": "vrml",
           ".obj": "obj", ".gltf": "gltf", ".glb": "gltf",
           ".ply": "scan", ".stl": "scan", ".off": "scan"}

_NAMING = ("name the file like 'open_jaw@1024.obj', 'viseme_PP.obj' or 'expression_joy.obj', "
           "or give a mapping file (file name -> target name)")


def _format(path: PathLike) -> str:
    low = os.path.basename(str(path)).lower()
    for suffix, kind in FORMATS.items():
        if low.endswith(suffix):
            return kind
    raise FormatError(f"unknown morph-target file type (use {', '.join(FORMATS)})", str(path))


def target_stem(path: PathLike) -> str:
    """The file name without its directory and format ending.

    >>> target_stem("shapes/open_jaw@0.5.obj"), target_stem("viseme_PP.wrl.gz")
    ('open_jaw@0.5', 'viseme_PP')
    """
    base = os.path.basename(str(path))
    low = base.lower()
    for suffix in FORMATS:
        if low.endswith(suffix) and len(base) > len(suffix):
            return base[:-len(suffix)]
    return os.path.splitext(base)[0]


# -- what a file holds ---------------------------------------------------------------------

@dataclass
class _Shapes:
    """The meshes of one file: name -> (vertices, triangles), their parents and
    transforms (for a FaceModel), and a glTF file's own morph targets."""

    meshes: dict = field(default_factory=dict)
    parents: dict = field(default_factory=dict)
    transforms: list = field(default_factory=list)
    targets: dict = field(default_factory=dict)     # name -> {mesh: vertices}
    unnamed: bool = False                           # one OBJ mesh without o/g


def _unique(name: str, taken: set) -> str:
    out, k = name, 2
    while out in taken:
        out, k = f"{name}_{k}", k + 1
    taken.add(out)
    return out


# -- OBJ -----------------------------------------------------------------------------------

def _obj_shapes(path: PathLike) -> _Shapes:
    shapes = _Shapes()
    meshes = read_obj(path)
    if len(meshes) == 1 and meshes[0][0] is None:
        shapes.unnamed = True
    taken: set = set()
    for name, v, t in meshes:
        shapes.meshes[_unique(name or target_stem(path), taken)] = (v, t)
    return shapes


# -- VRML ----------------------------------------------------------------------------------

def _vrml_shapes(path: PathLike, lenient: bool) -> _Shapes:
    from ..vrml import load
    from ..vrml.walk import iter_meshes
    scene = load(path, strict=not lenient)
    shapes = _Shapes()
    seen: set = set()
    taken: set = set()         # mesh and transform names, unique together
    tnames: dict = {}          # id(Transform node) -> its FaceTransform name
    for k, mesh in enumerate(iter_meshes(scene)):
        if id(mesh.geometry) in seen:
            continue
        seen.add(id(mesh.geometry))
        base = mesh.geometry.name or (mesh.shape.name if mesh.shape is not None else None)
        name = _unique(base or f"mesh_{len(shapes.meshes) + 1}", taken)
        shapes.meshes[name] = (mesh.local_vertices, mesh.triangles)
        parent = None
        for node in mesh.path:
            if node.type != "Transform":
                continue
            if id(node) not in tnames:
                tname = _unique(node.name or f"transform_{len(tnames) + 1}", taken)
                tnames[id(node)] = tname
                shapes.transforms.append(FaceTransform(
                    tname, parent, tuple(node["translation"]), tuple(node["rotation"]),
                    tuple(node["scale"]), tuple(node["center"]), tuple(node["scaleOrientation"])))
            parent = tnames[id(node)]
        shapes.parents[name] = parent
    if not shapes.meshes:
        raise FormatError("no IndexedFaceSet in the VRML file", str(path))
    return shapes


# -- glTF ----------------------------------------------------------------------------------

def _gltf_shapes(path: PathLike, with_targets: bool) -> _Shapes:
    g = Gltf(path)
    try:
        return _gltf_shapes_of(g, with_targets)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError, OverflowError,
            ZeroDivisionError) as e:
        if isinstance(e, FormatError):
            raise
        # pygltflib keeps whatever type the JSON had; a member of a type the checks
        # above did not foresee ends here, still as this file's error
        raise g.error(f"a member of the glTF document has a value of the wrong type or "
                      f"range ({type(e).__name__}: {json_shown(str(e), 120)})") from None


def _gltf_shapes_of(g: Gltf, with_targets: bool) -> _Shapes:
    doc = g.doc
    shapes = _Shapes()
    taken: set = set()
    owner: dict = {}            # mesh index -> node index (the first that holds it)
    parent_of: dict = {}
    for i, node in enumerate(doc.nodes or []):
        if node.mesh is not None:
            owner.setdefault(node.mesh, i)
        for c in node.children or []:
            parent_of.setdefault(c, i)
    tnames: dict = {}
    holder: dict = {}           # mesh name -> index of the node holding it

    def transform(i: int) -> str:
        chain = []
        j: Optional[int] = i
        while j is not None and j not in tnames and j not in chain:
            chain.append(j)
            j = parent_of.get(j)
        for j in reversed(chain):
            node = doc.nodes[j]
            tnames[j] = _unique(node.name or f"node_{j + 1}", taken)
            p = parent_of.get(j)
            shapes.transforms.append(node_transform(g, node, tnames[j], tnames.get(p)))
        return tnames[i]

    for mi, mesh in enumerate(doc.meshes or []):
        base = mesh.name or f"mesh_{mi + 1}"
        prims = mesh.primitives or []
        n_targets = max((len(p.targets or []) for p in prims), default=0)
        names = target_names(mesh, n_targets)
        if len(set(names)) != len(names):
            dup = next(x for x in names if names.count(x) > 1)
            raise g.error(f"mesh {base}: two morph targets named {dup!r}")
        for pk, prim in enumerate(prims):
            what = f"meshes[{mi}].primitives[{pk}]"
            v = g.positions(prim.attributes, f"{what}.attributes")
            if v is None:
                continue
            name = _unique(base if len(prims) == 1 else f"{base}_{pk}", taken)
            shapes.meshes[name] = (v, gltf_triangles(g, prim, len(v), what))
            holder[name] = owner.get(mi)
            if not with_targets:
                continue
            for k, t in enumerate(prim.targets or []):
                d = g.positions(t, f"{what}.targets[{k}]")
                if d is None:
                    continue
                if d.shape != v.shape:
                    raise g.error(f"{what}.targets[{k}] (morph target {names[k]!r}): "
                                  f"{len(d)} positions, the mesh {len(v)}")
                shapes.targets.setdefault(names[k], {})[name] = v + d
    if not shapes.meshes:
        raise g.error("no mesh primitive with POSITION in the glTF file")
    for name, node in holder.items():     # named after the meshes, so meshes keep theirs
        shapes.parents[name] = None if node is None else transform(node)
    return shapes


def _shapes(path: PathLike, lenient: bool = False, with_targets: bool = False) -> _Shapes:
    kind = _format(path)
    if kind == "obj":
        return _obj_shapes(path)
    if kind == "scan":
        from .scans import read_scan
        shapes = _Shapes(unnamed=True)
        shapes.meshes[target_stem(path)] = read_scan(path)
        return shapes
    if kind == "gltf":
        return _gltf_shapes(path, with_targets)
    return _vrml_shapes(path, lenient)


# -- mapping -------------------------------------------------------------------------------

def read_mapping(mapping: Union[None, Mapping, PathLike]) -> dict:
    """A mapping (file name or glTF target name -> target name) from a dict or a file:
    JSON (an object of strings) or TSV (``name<TAB>target`` lines, or two words; ``#``
    comments and blank lines are skipped).

    >>> read_mapping({"jaw.obj": "open_jaw@1024"})
    {'jaw.obj': 'open_jaw@1024'}
    """
    if mapping is None:
        return {}
    if isinstance(mapping, Mapping):
        return {str(k): str(v) for k, v in mapping.items()}
    path = str(mapping)
    with open(path, encoding="utf-8") as f:
        text = f.read()
    if text.lstrip().startswith("{"):
        data = loads_json(text, path)
        if not isinstance(data, dict):
            raise FormatError("a JSON mapping is one object of file or target name -> what "
                              "it shows", path)
        bad = [k for k, v in data.items() if not isinstance(v, str)]
        if bad:
            raise FormatError(f"mapping of {bad[0]!r} is not a string (give e.g. "
                              f"\"open_jaw@1024\" or \"viseme:PP\")", path)
        return dict(data)
    out = {}
    for line_no, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = [p.strip() for p in line.split("\t")] if "\t" in line else line.split()
        if len(parts) != 2 or not all(parts):
            raise FormatError("a mapping line holds a file (or glTF target) name and a target "
                              "name, separated by a tab", path, line_no)
        if parts[0] in out:
            raise FormatError(f"{parts[0]!r} is mapped twice", path, line_no)
        out[parts[0]] = parts[1]
    return out


def _lookup(mapping: dict, path: str) -> Optional[str]:
    for k in (path, os.path.basename(path), target_stem(path)):
        if k in mapping:
            return mapping[k]
    return None


def _target(text: str, meshes: dict, name: str, path: str, mapped: bool) -> MorphTarget:
    try:
        return MorphTarget(text, None, meshes, name=name)
    except ValueError as e:
        hint = "; fix the mapping" if mapped else f"; {_NAMING}"
        raise FormatError(f"{e}{hint}", path) from None


# -- the set -------------------------------------------------------------------------------

#: A target named after one FAT interval, as our glTF writer names them:
#: ``open_jaw[0,1024]``, ``viseme:PP[0,63]``, ``raise_b_midlip[-512,0]#2``.
_INTERVAL = re.compile(r"^(?P<key>[^\[\]]+)\[(?P<lo>-?\d+(?:\.\d+)?),(?P<hi>-?\d+(?:\.\d+)?)\](?:#\d+)?$")


def _interval_targets(neutral: "_Shapes", path: str) -> tuple:
    """(targets, other names): the FAT-interval targets of a glTF file (see
    :mod:`mpeg4fba.formats.gltf`) turned back into morph targets at each interval border,
    so :func:`fat_from_morph_targets` rebuilds the same tables; names that are not
    intervals are returned for the ordinary path."""
    groups: dict = {}
    others = []
    for tname, meshes in neutral.targets.items():
        m = _INTERVAL.match(tname)
        if m is None:
            others.append(tname)
            continue
        lo, hi = float(m["lo"]), float(m["hi"])
        if not lo < hi or (lo < 0 < hi):
            raise FormatError(f"glTF morph target {tname!r}: [{m['lo']},{m['hi']}] is not an "
                              f"interval on one side of 0", path)
        key = m["key"].strip()
        for mesh, shape in meshes.items():
            groups.setdefault(key, {}).setdefault(mesh, []).append(
                (lo, hi, shape - neutral.meshes[mesh][0]))
    targets = []
    for key, per_mesh in groups.items():
        borders = sorted({b for items in per_mesh.values() for lo, hi, _ in items for b in (lo, hi)})
        values = [b for b in borders if b != 0]
        full = {m: np.repeat(v[None], len(values), axis=0) for m, (v, _) in neutral.meshes.items()}
        for mesh, items in per_mesh.items():
            # each target is its interval's whole displacement, walked outward from 0
            for lo, hi, d in items:
                for k, b in enumerate(values):
                    if (hi > 0 and b >= hi) or (lo < 0 and b <= lo):
                        full[mesh][k] += d
        for k, b in enumerate(values):
            shapes = {mesh: arr[k] for mesh, arr in full.items()}
            high = key.lower().startswith(("viseme:", "expression:"))
            try:
                if high:
                    if b != FULL_SHAPE:
                        continue
                    targets.append(MorphTarget(key, None, shapes, name=f"{key} (in {path})"))
                else:
                    targets.append(MorphTarget(key, b, shapes, name=f"{key}@{b:g} (in {path})"))
            except ValueError as e:
                raise FormatError(f"glTF morph target {key!r}: {e}", path) from None
    return targets, others


def _read(neutral_path: PathLike, target_paths: Sequence[PathLike], mapping, lenient: bool):
    names = read_mapping(mapping)
    neutral = _shapes(neutral_path, lenient, with_targets=True)
    np_str = str(neutral_path)
    targets, plain = _interval_targets(neutral, np_str)
    ours = bool(targets)
    for tname in plain:
        meshes = neutral.targets[tname]
        full = {m: meshes.get(m, v) for m, (v, _) in neutral.meshes.items()}
        text = names.get(tname)
        label = f"{tname} (in {os.path.basename(np_str)})"
        if text is None:
            try:
                targets.append(MorphTarget(tname, None, full, name=label))
            except ValueError as e:
                raise FormatError(f"glTF morph target {tname!r}: {e}; rename the target or map "
                                  f"it in a mapping file (target name -> e.g. open_jaw@1024)",
                                  np_str) from None
        else:
            targets.append(_target(text, full, label, np_str, True))
    only = next(iter(neutral.meshes)) if len(neutral.meshes) == 1 else None
    for p in target_paths:
        p = str(p)
        shapes = _shapes(p, lenient)
        meshes = {m: v for m, (v, _) in shapes.meshes.items()}
        if shapes.unnamed and only is not None:
            meshes = {only: next(iter(meshes.values()))}
        text = _lookup(names, p)
        mapped = text is not None
        targets.append(_target(text if mapped else target_stem(p), meshes,
                               os.path.basename(p), p, mapped))
    return neutral, targets, ours


def read_morph_targets(neutral_path: PathLike, target_paths: Sequence[PathLike] = (),
                       mapping: Union[None, Mapping, PathLike] = None,
                       lenient: bool = False) -> tuple:
    """``(neutral, targets)``: mesh name -> neutral vertices [n, 3], and a list of
    :class:`~mpeg4fba.fba.morph.MorphTarget`, for
    :func:`~mpeg4fba.fba.morph.fat_from_morph_targets`.

    ``mapping`` (dict or JSON / TSV file) names what each file or glTF target shows
    where its name does not say it.  ``lenient`` reads VRML with unknown nodes (warns).
    FormatError naming the file for unreadable files and names that say nothing.
    """
    neutral, targets, _ = _read(neutral_path, target_paths, mapping, lenient)
    return {m: v for m, (v, _) in neutral.meshes.items()}, targets


def read_morph_face(neutral_path: PathLike, target_paths: Sequence[PathLike] = (),
                    mapping: Union[None, Mapping, PathLike] = None, tol: float = 0.0,
                    lenient: bool = False, name: Optional[str] = None) -> FaceModel:
    """A FaceModel: the neutral's meshes (with their VRML Transforms or glTF nodes) and a
    FAT built from the targets (see :func:`read_morph_targets`)."""
    neutral, targets, ours = _read(neutral_path, target_paths, mapping, lenient)
    base = {m: v for m, (v, _) in neutral.meshes.items()}
    # targets rebuilt from a FAT's intervals are in the neutral's order by construction
    # (and may move a small part far: no vertex-order guess)
    try:
        fat = fat_from_morph_targets(base, targets, tol=tol,
                                     **({"order_check": None} if ours else {}))
        meshes = [FaceMesh(m, v, t, neutral.parents.get(m))
                  for m, (v, t) in neutral.meshes.items()]
        return FaceModel(meshes, neutral.transforms, fat=fat,
                         name=name or target_stem(neutral_path))
    except ValueError as e:
        if isinstance(e, FormatError):
            raise
        # the targets' names say which file each came from
        raise FormatError(str(e), str(neutral_path)) from None
