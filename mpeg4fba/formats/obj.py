"""Wavefront OBJ meshes: ``v`` and ``f`` records, grouped by ``o`` / ``g``
(:func:`parse_obj`, :func:`read_obj`); every other record is ignored.

>>> [(name, v.shape, t.tolist()) for name, v, t in parse_obj("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 3\\n")]
[(None, (3, 3), [[0, 1, 2]])]
"""
from __future__ import annotations

import os
import re
from typing import Optional, Union

import numpy as np

from ..vrml.walk import fan_triangulate
from .errors import FormatError

__all__ = ["parse_obj", "read_obj"]

PathLike = Union[str, os.PathLike]

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
