"""A glTF 2.0 file (``.gltf`` with its buffers, or ``.glb``) as read for a face: the
document by pygltflib, the buffers by us and confined to the file's own folder
(:func:`_confined_read`), accessors as numpy arrays (:class:`Gltf`), node transforms
and morph-target names (:mod:`mpeg4fba.formats.morph_targets` turns them into meshes).
"""
from __future__ import annotations

import base64
import os
import re
import stat
import urllib.parse
from typing import Optional, Union

import numpy as np

from ..fba.face import FaceTransform
from .errors import FormatError
from .jsontext import shown as json_shown

__all__ = ["Gltf", "gltf_triangles", "node_transform", "target_names"]

PathLike = Union[str, os.PathLike]

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


class Gltf:
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


def gltf_triangles(g: Gltf, prim, n: int, what: str) -> np.ndarray:
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


def node_transform(g: Gltf, node, name: str, parent: Optional[str]) -> FaceTransform:
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


def target_names(mesh, n: int) -> list:
    names = None
    for extras in [mesh.extras] + [p.extras for p in mesh.primitives]:
        if isinstance(extras, dict) and isinstance(extras.get("targetNames"), list):
            names = extras["targetNames"]
            break
    names = [str(x) for x in (names or [])][:n]
    return names + [f"target{k}" for k in range(len(names), n)]
