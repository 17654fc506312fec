"""Heads as scanners and printing tools write them: PLY, STL and OFF, read through meshio.

A scan comes as one surface: :func:`read_scan` gives its vertices and triangles
(quads and polygons fan-triangulated; points, lines and other cells ignored; meshio
reads OFF files of triangles only), the mesh named after the file's stem by the
callers.  STL stores every triangle with its own
three corners; the detector and the cloner join such a soup into one surface
(:mod:`mpeg4fba.cloning.seams`).  Vertex colours and normals are not read.

meshio is an optional dependency (``pip install 'mpeg4fba[scans]'``); without it these
files get a :class:`~mpeg4fba.formats.errors.FormatError` saying so.  Only the file given
is opened.

>>> import os, tempfile
>>> p = os.path.join(tempfile.mkdtemp(), "square.off")
>>> _ = open(p, "w").write("OFF\\n4 2 0\\n0 0 0\\n1 0 0\\n1 1 0\\n0 1 0\\n3 0 1 2\\n3 0 2 3\\n")
>>> V, T = read_scan(p)
>>> V.shape, T.tolist()
((4, 3), [[0, 1, 2], [0, 2, 3]])
"""
from __future__ import annotations

import errno
import os
from typing import Union

import numpy as np

from .errors import FormatError

__all__ = ["SCAN_FORMATS", "read_scan"]

#: File ending -> meshio's name for the format.
SCAN_FORMATS = {".ply": "ply", ".stl": "stl", ".off": "off"}


def _fan(cells: np.ndarray) -> np.ndarray:
    """(m, k) polygons -> (m (k - 2), 3) triangles fanned from each first corner."""
    k = cells.shape[1]
    return np.concatenate([cells[:, [0, j, j + 1]] for j in range(1, k - 1)]) if k >= 3 else \
        np.zeros((0, 3), dtype=np.int64)


def read_scan(path: Union[str, "os.PathLike[str]"]) -> tuple:
    """(vertices (n, 3) float64, triangles (m, 3) int64) of a PLY, STL or OFF file;
    FormatError naming the file when it is unreadable or holds no triangle."""
    p = os.fspath(path)
    suffix = os.path.splitext(p)[1].lower()
    if suffix not in SCAN_FORMATS:
        raise FormatError(f"not a scan file ({', '.join(SCAN_FORMATS)})", p)
    try:
        import meshio
    except ImportError:
        raise FormatError(f"reading {suffix} files needs meshio: pip install 'mpeg4fba[scans]'",
                          p) from None
    if not os.path.isfile(p):
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), p)
    try:
        mesh = meshio.read(p, file_format=SCAN_FORMATS[suffix])
    except Exception as e:                          # noqa: BLE001 (meshio's errors vary)
        raise FormatError(f"not a readable {suffix[1:].upper()} mesh: {type(e).__name__}: "
                          f"{e}"[:400], p) from None
    V = np.asarray(mesh.points, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] not in (2, 3):
        raise FormatError(f"vertex positions of shape {V.shape}, expected (n, 3)", p)
    if V.shape[1] == 2:
        V = np.c_[V, np.zeros(len(V))]
    if not np.isfinite(V).all():
        raise FormatError("vertex coordinates must be finite numbers (not nan or inf)", p)
    tris = []
    for block in mesh.cells:
        data = np.asarray(block.data)
        if block.type in ("triangle", "quad") or (block.type.startswith("polygon") and data.ndim == 2):
            tris.append(_fan(data.astype(np.int64)))
    T = np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)
    if not len(T):
        raise FormatError("no triangles, quads or polygons in the file (a point cloud?): a "
                          "surface is needed", p)
    if T.min() < 0 or T.max() >= len(V):
        raise FormatError(f"a face refers to vertex {int(T.max() if T.max() >= len(V) else T.min())}, "
                          f"outside the file's {len(V)} vertices", p)
    return V, T
