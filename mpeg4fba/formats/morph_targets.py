"""Morph-target sets (a neutral face plus sculpted shapes) read from files.

Formats, chosen by the file name's ending (case-insensitive):

* **VRML97** (``.wrl``, ``.wrz``, ``.wrl.gz``, ``.vrml``): each IndexedFaceSet is a mesh,
  named by its DEF name (else its Shape's, else ``mesh_<k>`` in walk order; a node
  used in several places counts once); its vertices are the Coordinate points as
  written (local coordinates, no Transform applied).  Targets must have the same
  structure as the neutral.  Transforms (DEF name, else ``transform_<k>``) are kept
  for :func:`read_morph_face`.
* **OBJ** (``.obj``): ``v`` and ``f`` lines (``f a``, ``a/b``, ``a/b/c``, ``a//c``,
  negative indices; polygons are fan-triangulated); every other line is ignored.
  With ``o`` / ``g`` lines each group (the faces after the last ``o`` or ``g`` line;
  groups of one name merge) is a mesh made of the vertices its faces use, in file
  order.  Without them the file is one mesh of all its vertices, named after the
  neutral's file stem (a target's ungrouped mesh is matched to a one-mesh neutral).
* **PLY, STL, OFF** (``.ply``, ``.stl``, ``.off``; :mod:`~mpeg4fba.formats.scans`,
  through meshio): one mesh, named after the file stem like an ungrouped OBJ.
* **glTF 2.0** (``.gltf``, ``.glb``): each primitive is a mesh (named after its glTF
  mesh, ``<mesh>_<k>`` when a mesh has several primitives,
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

import base64
import os
import re
import stat
import urllib.parse
from dataclasses import dataclass, field
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from ..fba.face import FaceMesh, FaceModel, FaceTransform
from ..fba.morph import FULL_SHAPE, MorphTarget, fat_from_morph_targets
from ..vrml.walk import fan_triangulate
from .errors import FormatError
from .jsontext import loads_json, shown as json_shown

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

_OBJ_RECORD = re.compile(r"^[ \t]*(v|f|o|g)(?![^ \t\r\n])[ \t]*([^\r\n#]*)", re.M)
_XYZ = re.compile(r"^[ \t]*(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.M)
_SLASHES = re.compile(r"/\S*")


def _obj_error(text: str, path: Optional[str], record: int, message: str) -> FormatError:
    for k, m in enumerate(_OBJ_RECORD.finditer(text)):
        if k == record:
            return FormatError(message, path, text.count("\n", 0, m.start()) + 1)
    return FormatError(message, path)


def parse_obj(text: str, path: Optional[str] = None) -> list:
    """The meshes of OBJ text as ``(name or None, vertices [n, 3], triangles [m, 3])``.

    Vertex order is kept.  ``name`` is None for a file without ``o`` / ``g`` lines,
    which is one mesh of all its vertices.  FormatError (with the line) for bad input.

    >>> meshes = parse_obj("v 0 0 0\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\ng quad\\nf -4/1 -3/2 -2/3 -1/4\\n")
    >>> [(name, v.shape, t.tolist()) for name, v, t in meshes]
    [('quad', (4, 3), [[0, 1, 2], [0, 2, 3]])]
    """
    records = _OBJ_RECORD.findall(text)
    kinds = np.array([k for k, _ in records], dtype="<U1")
    where = {k: np.flatnonzero(kinds == k) for k in "vfog"}
    vbodies = [records[i][1] for i in where["v"]]
    if not vbodies:
        raise FormatError("no vertices ('v' lines) in the OBJ file", path)
    triples = _XYZ.findall("\n".join(vbodies))
    if len(triples) != len(vbodies):
        bad = next((i for i, b in zip(where["v"], vbodies) if not _XYZ.match(b)), where["v"][0])
        raise _obj_error(text, path, int(bad), f"'v' line {records[bad][1].strip()!r}: needs "
                         "x, y and z separated by spaces or tabs")
    try:
        vertices = np.array(triples, dtype=np.float64)
    except ValueError:
        bad = next((i for i, t in zip(where["v"], triples) if not _floats(t)), where["v"][0])
        raise _obj_error(text, path, int(bad), f"'v {records[bad][1].strip()}': not numbers") from None
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        bad = where["v"][int(np.argmin(finite))]
        raise _obj_error(text, path, int(bad), f"'v {records[bad][1].strip()}': coordinates "
                         "must be finite numbers (not nan, inf or beyond 1.8e308)")
    n = len(vertices)
    faces = where["f"]
    groups = np.sort(np.concatenate([where["o"], where["g"]]))
    if not len(faces):
        return [(None, vertices, np.empty((0, 3), np.int64))] if not len(groups) else []
    fbodies = [records[i][1] for i in faces]
    tokens = _SLASHES.sub("", " 0 ".join(fbodies)).split()
    try:
        idx = np.array(tokens, dtype=np.int64)
    except (ValueError, OverflowError):
        bad = next((i for i, b in zip(faces, fbodies) if not _ints(_SLASHES.sub("", b).split())),
                   faces[0])
        raise _obj_error(text, path, int(bad), f"'f {records[bad][1].strip()}': vertex "
                                               f"indices must be whole numbers within "
                                               f"+-{_INDEX_MAX:,}") from None
    sep = idx == 0
    if sep.sum() != len(faces) - 1:
        # "0", "00", "+0", "-0": all zero, and OBJ counts from 1
        bad = next((i for i, b in zip(faces, fbodies)
                    if 0 in map(int, _SLASHES.sub("", b).split())), faces[0])
        raise _obj_error(text, path, int(bad), f"'f {records[bad][1].strip()}': vertex index 0 "
                         "(OBJ counts from 1; negative indices count back from the last 'v')")
    poly = np.cumsum(sep)                                   # the f line of each token
    before = np.cumsum(kinds == "v")[faces]                 # vertices defined before each f
    resolved = np.where(idx > 0, idx - 1, before[poly] + idx)
    bad_tok = ~sep & ((resolved < 0) | (resolved >= n))
    if bad_tok.any():
        k = int(np.argmax(bad_tok))
        raise _obj_error(text, path, int(faces[poly[k]]),
                         f"vertex index {int(idx[k])} is out of range ({n} vertices"
                         + (f", {int(before[poly[k]])} before this line)" if idx[k] < 0 else ")"))
    if not len(groups):
        tris, _ = fan_triangulate(np.where(sep, -1, resolved))
        return [(None, vertices, tris)]
    # the group (latest o/g record) of each f line; faces before any group get -1
    last = np.searchsorted(groups, faces) - 1
    names = np.array([records[i][1].strip() or "default" for i in groups] + [""], dtype=object)
    face_names = names[last]                               # -1 picks the trailing ""
    out = []
    for name in dict.fromkeys(face_names.tolist()):
        mine = (face_names == name)[poly] & ~sep
        used = np.unique(resolved[mine])
        local = np.searchsorted(used, resolved[mine])
        polys = poly[mine]
        cut = np.flatnonzero(np.diff(polys)) + 1
        tris, _ = fan_triangulate(np.insert(local, cut, -1))
        out.append((name or None, vertices[used], tris))
    return out


def _floats(items) -> bool:
    try:
        [float(x) for x in items]
        return True
    except ValueError:
        return False


_INDEX_MAX = 2 ** 62      # no mesh comes near; beyond it an index is garbage, not a vertex


def _ints(items) -> bool:
    """Whether every item is a whole number within +-_INDEX_MAX."""
    try:
        return all(-_INDEX_MAX <= int(x) <= _INDEX_MAX for x in items)
    except ValueError:
        return False


def read_obj(path: PathLike) -> list:
    """:func:`parse_obj` of a file."""
    with open(path, encoding="utf-8", errors="replace") as f:
        return parse_obj(f.read(), str(path))


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

# A URI scheme ("http:", "file:"; also a Windows drive "C:"), RFC 3986 section 3.1.
_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:")


def _shown(text: str, limit: int = 200) -> str:
    """``text`` quoted, cut at ``limit`` characters (a URI may be megabytes long)."""
    return repr(text) if len(text) <= limit else repr(text[:limit]) + "..."


def _confined_read(path: str, uri: str, length: int, where: str) -> bytes:
    """The first ``length`` bytes of the file a glTF ``uri`` names, read only when it is
    a relative path to a regular file inside the folder of ``path`` (the glTF file);
    anything else is a FormatError naming ``path``, ``where`` (``buffers[0]``) and the URI.

    A face file must not make us read outside its folder: absolute paths, ``..``,
    percent-encoded forms of either, symbolic links that lead out, other schemes,
    devices and FIFOs (``/dev/zero`` would be read forever) are all refused.

    >>> import os, tempfile
    >>> d = tempfile.mkdtemp()
    >>> _ = open(os.path.join(d, "a b.bin"), "wb").write(b"0123456789")
    >>> _confined_read(os.path.join(d, "f.gltf"), "a%20b.bin", 4, "buffers[0]")
    b'0123'
    >>> _confined_read(os.path.join(d, "f.gltf"), "..%2Fetc%2Fpasswd", 4, "buffers[0]")
    Traceback (most recent call last):
    ...
    mpeg4fba.formats.errors.FormatError: ...: buffers[0].uri '..%2Fetc%2Fpasswd': ...
    """
    def refuse(why: str) -> FormatError:
        return FormatError(f"{where}.uri {_shown(uri)}: {why}; a buffer is read only from a "
                           f"base64 data: URI or a relative path to a regular file inside "
                           f"the glTF file's own folder", path)

    scheme = _SCHEME.match(uri)
    if scheme:
        raise refuse(f"'{scheme.group(0)}' URIs are not read")
    try:
        name = urllib.parse.unquote(uri, errors="strict")
    except UnicodeDecodeError:
        raise refuse("its percent-encoding is not UTF-8") from None
    if "\x00" in name:
        raise refuse("it holds a NUL character")
    if name.startswith(("/", "\\")) or os.path.isabs(name):
        raise refuse("an absolute path")
    if ".." in re.split(r"[/\\]", name):
        raise refuse("'..' leads out of the folder")
    folder = os.path.realpath(os.path.dirname(os.path.abspath(path)))
    target = os.path.realpath(os.path.join(folder, name))
    if os.path.commonpath([folder, target]) != folder:
        raise refuse(f"it leads (through a symbolic link) to {target}, outside the folder")
    # O_NONBLOCK: opening a FIFO must not wait for a writer; O_NOFOLLOW: a link swapped in
    # since realpath() is not followed
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0) | \
        getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(target, flags)
    except OSError as e:
        raise FormatError(f"{where}.uri {_shown(uri)}: can't read it: {e.strerror}",
                          path) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise refuse("not a regular file")
        if st.st_size < length:
            raise FormatError(f"{where}.uri {_shown(uri)}: the file has {st.st_size} bytes, "
                              f"fewer than the buffer's byteLength {length}", path)
        chunks, left = [], length
        while left:                     # read() may return less than asked
            chunk = os.read(fd, min(left, 1 << 24))
            if not chunk:               # the file shrank since fstat()
                raise FormatError(f"{where}.uri {_shown(uri)}: the file ended before the "
                                  f"buffer's byteLength {length}", path)
            chunks.append(chunk)
            left -= len(chunk)
    finally:
        os.close(fd)
    return b"".join(chunks)


_COMPONENTS = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


class _Gltf:
    """A loaded glTF with numpy access to its accessors.

    Buffers are read by us, never by pygltflib (whose helpers open any path a URI
    names): only the GLB chunk, base64 ``data:`` URIs, and relative paths to regular
    files inside the glTF file's own folder (see :func:`_confined_read`).  Images are
    never opened.
    """

    def __init__(self, path: PathLike):
        try:
            from pygltflib import GLTF2
        except ImportError as e:  # pragma: no cover - a declared dependency
            raise ImportError("reading glTF needs pygltflib (pip install pygltflib)") from e
        self.path = str(path)
        with open(self.path, "rb") as f:      # a missing or unreadable file is an OSError
            raw = f.read()
        self.size = len(raw)
        try:
            # parsed from bytes, GLB or JSON by the magic, so pygltflib touches no file
            if raw[:4] == b"glTF":
                self.doc = GLTF2.load_from_bytes(raw)
            else:
                self.doc = GLTF2.gltf_from_json(raw.decode("utf-8-sig"))
        except Exception as e:            # pygltflib raises many kinds on a bad file
            raise FormatError(f"not a readable glTF 2.0 file ({e})", self.path) from None
        if self.doc is None:
            raise FormatError("not a readable glTF 2.0 file", self.path)
        packed = {"KHR_draco_mesh_compression", "EXT_meshopt_compression"} & \
            set(self.doc.extensionsUsed or [])
        if packed:
            raise FormatError(f"compressed geometry ({', '.join(sorted(packed))}) is not "
                              f"supported; export the glTF without mesh compression", self.path)
        self._buffers: dict = {}

    def error(self, message: str) -> FormatError:
        return FormatError(message, self.path)

    def whole(self, value, where: str, low: int = 0) -> int:
        """``value`` checked to be a whole number >= ``low``; ``where`` is its JSON path
        (``accessors[3].count``) for the error."""
        if not isinstance(value, int) or isinstance(value, bool) or value < low:
            raise self.error(f"{where} is {json_shown(value, 40)}, not a whole number "
                             f">= {low}")
        return value

    def item(self, array, index, where: str, what: str):
        """``array[index]`` of a top-level glTF array, ``index`` checked."""
        index = self.whole(index, where)
        if not isinstance(array, list) or index >= len(array):
            raise self.error(f"{where}: {what}[{index}] does not exist")
        return array[index]

    def buffer(self, i: int, where: str) -> bytes:
        if i not in self._buffers:
            b = self.item(self.doc.buffers, i, where, "buffers")
            length = b.byteLength
            if not isinstance(length, int) or isinstance(length, bool) or length < 0:
                raise self.error(f"buffers[{i}].byteLength is {length!r}, not a whole number "
                                 f">= 0")
            if b.uri is None:
                data = self.doc.binary_blob()
                if data is None:
                    raise self.error(f"buffers[{i}] has no uri and the file no binary chunk")
            elif not isinstance(b.uri, str):
                raise self.error(f"buffers[{i}].uri is {b.uri!r}, not a string")
            elif b.uri[:5].lower() == "data:":
                data = self._data_uri(i, b.uri)
            else:
                data = _confined_read(self.path, b.uri, length, f"buffers[{i}]")
            if len(data) < length:
                raise self.error(f"buffers[{i}] holds {len(data)} bytes, fewer than its "
                                 f"byteLength {length}")
            self._buffers[i] = bytes(data)
        return self._buffers[i]

    def _data_uri(self, i: int, uri: str) -> bytes:
        head, comma, payload = uri.partition(",")
        if not comma or not head.lower().endswith(";base64"):
            raise self.error(f"buffers[{i}].uri: a data: URI is read only base64-encoded "
                             f"('data:<type>;base64,<data>'), not {_shown(uri, 60)}")
        try:
            return base64.b64decode(payload)
        except ValueError:
            raise self.error(f"buffers[{i}].uri: bad base64 data in the data: URI") from None

    def _view(self, view, offset, dtype: np.dtype, count: int, width: int,
              where: str) -> np.ndarray:
        """``count`` elements of ``width`` x ``dtype`` from a bufferView; ``where`` is the
        JSON path of what asks (``accessors[2]``), for errors."""
        view = self.whole(view, f"{where}.bufferView")
        bv = self.item(self.doc.bufferViews, view, f"{where}.bufferView", "bufferViews")
        vp = f"bufferViews[{view}]"
        buffer = self.whole(bv.buffer, f"{vp}.buffer")
        data = self.buffer(buffer, f"{vp}.buffer")
        item = dtype.itemsize * width
        stride = item if bv.byteStride is None else self.whole(bv.byteStride, f"{vp}.byteStride",
                                                               low=item)
        start = self.whole(bv.byteOffset or 0, f"{vp}.byteOffset") + \
            self.whole(offset or 0, f"{where}.byteOffset")
        end = self.whole(bv.byteOffset or 0, f"{vp}.byteOffset") + \
            self.whole(bv.byteLength, f"{vp}.byteLength")
        if end > len(data):
            raise self.error(f"{vp} ends at byte {end}, past the {len(data)} bytes of "
                             f"buffers[{buffer}]")
        if count and start + stride * (count - 1) + item > end:
            raise self.error(f"{where}: {count} elements of {item} bytes do not fit in {vp} "
                             f"({end - min(start, end)} bytes from the element start)")
        arr = np.ndarray((count, width), dtype=dtype, buffer=data, offset=start,
                         strides=(stride, dtype.itemsize))
        return arr.copy()

    def accessor(self, index, what: str) -> np.ndarray:
        """Accessor ``index`` as a float array [count, width], sparse and normalised
        values resolved.  ``what`` (the JSON path of what refers to it) names it in
        errors, beside its own path."""
        acc = self.item(self.doc.accessors, index, what, "accessors")
        ap = f"accessors[{index}]"
        if acc.componentType not in _COMPONENTS or acc.type not in _WIDTH:
            raise self.error(f"{ap} (for {what}): unsupported accessor "
                             f"{json_shown(acc.componentType, 20)} {json_shown(acc.type, 20)}")
        dtype, width = np.dtype(_COMPONENTS[acc.componentType]), _WIDTH[acc.type]
        count = self.whole(acc.count, f"{ap}.count")
        if acc.bufferView is None:
            # all zeros until sparse values: bounded by the file, not by the count it states
            if count * width > 64 * self.size + 4096:
                raise self.error(f"{ap}.count is {count}: an accessor without a bufferView "
                                 f"that large does not fit a {self.size}-byte file")
            out = np.zeros((count, width))
        else:
            out = self._view(acc.bufferView, acc.byteOffset, dtype, count, width, ap)
            out = out.astype(np.float64)
        if acc.normalized and dtype.kind in "iu":
            out = out / np.iinfo(dtype).max
            if dtype.kind == "i":
                out = np.maximum(out, -1.0)
        if acc.sparse is not None and acc.sparse.count:
            s = acc.sparse
            sp = f"{ap}.sparse"
            n = self.whole(s.count, f"{sp}.count")
            if s.indices is None or s.values is None:
                raise self.error(f"{sp}: needs both indices and values")
            if s.indices.componentType not in (5121, 5123, 5125):
                raise self.error(f"{sp}.indices.componentType is "
                                 f"{json_shown(s.indices.componentType, 20)}, not 5121, 5123 or 5125")
            idx = self._view(s.indices.bufferView, s.indices.byteOffset,
                             np.dtype(_COMPONENTS[s.indices.componentType]), n, 1,
                             f"{sp}.indices")[:, 0].astype(np.int64)
            vals = self._view(s.values.bufferView, s.values.byteOffset, dtype, n, width,
                              f"{sp}.values").astype(np.float64)
            if acc.normalized and dtype.kind in "iu":
                vals = vals / np.iinfo(dtype).max
            if len(idx) and (idx.min() < 0 or idx.max() >= count):
                raise self.error(f"{sp}.indices: index {int(idx.max())} out of range "
                                 f"({count} elements)")
            out[idx] = vals
        if not np.isfinite(out).all():
            raise self.error(f"{ap} (for {what}): values must be finite (not nan or inf)")
        return out

    def positions(self, attributes, what: str) -> Optional[np.ndarray]:
        index = attributes.get("POSITION") if isinstance(attributes, dict) else \
            getattr(attributes, "POSITION", None)
        if index is None:
            return None
        v = self.accessor(index, f"{what}.POSITION")
        if v.shape[1] != 3:
            raise self.error(f"{what}.POSITION: accessors[{index}] is not VEC3")
        return v


def _gltf_triangles(g: _Gltf, prim, n: int, what: str) -> np.ndarray:
    if prim.indices is None:
        idx = np.arange(n, dtype=np.int64)
    else:
        idx = g.accessor(prim.indices, f"{what}.indices")[:, 0].astype(np.int64)
    if len(idx) and (idx.min() < 0 or idx.max() >= n):
        raise g.error(f"{what}.indices: vertex index {int(idx.max())} out of range ({n} "
                      "vertices)")
    mode = 4 if prim.mode is None else prim.mode
    if mode == 4:
        return idx[: len(idx) // 3 * 3].reshape(-1, 3)
    if mode == 5:      # strip: flip every other triangle to keep the winding
        k = np.arange(max(len(idx) - 2, 0))
        t = np.stack([idx[k], idx[k + 1], idx[k + 2]], axis=1)
        t[1::2, [0, 1]] = t[1::2, [1, 0]]
        return t
    if mode == 6:      # fan
        k = np.arange(1, max(len(idx) - 1, 1))
        return np.stack([np.full(len(k), idx[0]), idx[k], idx[k + 1]], axis=1) if len(k) and \
            len(idx) >= 3 else np.empty((0, 3), np.int64)
    return np.empty((0, 3), np.int64)   # points and lines: vertices only


def _axis_angle(q) -> tuple:
    x, y, z, w = (float(c) for c in q)
    s = np.sqrt(x * x + y * y + z * z)
    if s == 0:
        return (0.0, 0.0, 1.0, 0.0)
    return (x / s, y / s, z / s, float(2 * np.arctan2(s, w)))


def _node_transform(g: _Gltf, node, name: str, parent: Optional[str]) -> FaceTransform:
    if node.matrix and not np.allclose(node.matrix, np.eye(4).ravel()):
        m = np.asarray(node.matrix, dtype=np.float64).reshape(4, 4).T   # column-major
        lin = m[:3, :3]
        scale = np.linalg.norm(lin, axis=0)
        if (scale == 0).any():
            raise g.error(f"node {name}: its matrix flattens the mesh")
        rot = lin / scale
        if np.linalg.det(rot) < 0:
            scale[0], rot[:, 0] = -scale[0], -rot[:, 0]
        if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-6):
            raise g.error(f"node {name}: its matrix shears, which a VRML Transform can't hold")
        w = np.sqrt(max(1.0 + np.trace(rot), 0.0)) / 2
        if w > 1e-6:
            q = ((rot[2, 1] - rot[1, 2]) / (4 * w), (rot[0, 2] - rot[2, 0]) / (4 * w),
                 (rot[1, 0] - rot[0, 1]) / (4 * w), w)
        else:   # a half turn: the axis is the eigenvector of eigenvalue 1
            vals, vecs = np.linalg.eigh(rot)
            axis = vecs[:, int(np.argmax(vals))]
            q = (axis[0], axis[1], axis[2], 0.0)
        return FaceTransform(name, parent, tuple(m[:3, 3]), _axis_angle(q), tuple(scale))
    return FaceTransform(name, parent, tuple(node.translation or (0, 0, 0)),
                         _axis_angle(node.rotation or (0, 0, 0, 1)),
                         tuple(node.scale or (1, 1, 1)))


def _target_names(mesh, n: int) -> list:
    names = None
    for extras in [mesh.extras] + [p.extras for p in mesh.primitives]:
        if isinstance(extras, dict) and isinstance(extras.get("targetNames"), list):
            names = extras["targetNames"]
            break
    names = [str(x) for x in (names or [])][:n]
    return names + [f"target{k}" for k in range(len(names), n)]


def _gltf_shapes(path: PathLike, with_targets: bool) -> _Shapes:
    g = _Gltf(path)
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


def _gltf_shapes_of(g: _Gltf, with_targets: bool) -> _Shapes:
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
            shapes.transforms.append(_node_transform(g, node, tnames[j], tnames.get(p)))
        return tnames[i]

    for mi, mesh in enumerate(doc.meshes or []):
        base = mesh.name or f"mesh_{mi + 1}"
        prims = mesh.primitives or []
        n_targets = max((len(p.targets or []) for p in prims), default=0)
        names = _target_names(mesh, n_targets)
        if len(set(names)) != len(names):
            dup = next(x for x in names if names.count(x) > 1)
            raise g.error(f"mesh {base}: two morph targets named {dup!r}")
        for pk, prim in enumerate(prims):
            what = f"meshes[{mi}].primitives[{pk}]"
            v = g.positions(prim.attributes, f"{what}.attributes")
            if v is None:
                continue
            name = _unique(base if len(prims) == 1 else f"{base}_{pk}", taken)
            shapes.meshes[name] = (v, _gltf_triangles(g, prim, len(v), what))
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
