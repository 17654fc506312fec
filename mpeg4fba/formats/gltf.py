"""glTF 2.0 export: a :class:`FaceModel` (and optionally a FAP stream) -> ``.glb`` / ``.gltf``.

What is written
---------------
* **Nodes** follow the face's Transform tree.  glTF nodes are ``T . R . S``; a VRML97
  Transform is ``T . C . R . SR . S . SR^-1 . C^-1`` (C = ``center``, SR =
  ``scaleOrientation``).  Each Transform becomes a node named after it holding
  translation ``T + C``, rotation ``R . SR`` and scale ``S``; when C or SR is not
  neutral a child node ``<name>_pivot`` holds rotation ``SR^-1`` and translation
  ``-SR^-1 . C`` (that is ``SR^-1 . C^-1``), and the Transform's children hang under
  the pivot.  The product of the two is exactly the VRML matrix, and the FAP-driven
  fields stay on the named node, where the animation drives them: translation
  ``T(t) + C``, rotation ``R(t) . SR`` (slerp is invariant under the constant right
  factor SR, so interpolated frames agree too) and scale ``S(t)``.  The face frame of
  MPEG-4 (y up, z = the gaze, metres) is glTF's (y up, the front facing +z, metres):
  no axis change.
* **Meshes**, one node each under their Transform: POSITION (float32), smooth NORMAL
  (area-weighted, computed), uint32 triangle indices, COLOR_0 when ``face.colors``
  has the mesh (sRGB colours turned linear), a material of its own named after it, and
  one **morph target per FAT interval** touching the mesh.  The material's base colour
  is the mesh's (:meth:`FaceModel.mesh_colors`: its own, else one from its name), or
  white under COLOR_0, which then gives the colours; it is single-sided
  (``doubleSided`` false: back faces culled) for a closed mesh
  (:meth:`FaceMesh.is_closed`: eyeballs, teeth, tongue, the mouth cavity) and
  double-sided for an open one (the skin, the hair).  A viewer draws both sides of a
  double-sided mesh, so the mouth cavity, which is wound inward so that culling shows
  its far wall, would cover the teeth and tongue with its near wall if it were
  double-sided.
* **Targets and weights.**  An interval ``[lo, hi]`` of a FaceDefMesh adds
  ``w(P) * d`` for FAP value P (``w`` from :func:`~mpeg4fba.fba.fat.interval_weights`).
  Its target holds the interval's *full* displacement ``s * d``, where ``s = hi - lo``
  for intervals above 0 and ``lo - hi`` below (the way P walks through it), and its
  weight is ``w(P) / s``.  Weights thus run 0 -> 1 as P crosses the interval (viewers
  and sliders expect that range), are 1 for the intervals P has passed, and go past 1
  only beyond the outermost border, where the FAT itself extrapolates; and
  ``neutral + sum(weight * target)`` is the FAT evaluation exactly (up to float32).
  Targets are named ``<what>[lo,hi]``: ``open_jaw[0,1024]``, ``viseme:PP[0,63]``,
  ``expression:joy[0,63]``, listed in ``mesh.extras.targetNames`` (the convention
  three.js and Blender read).  A target moving few vertices is a sparse accessor.
  Normals are not morphed (targets carry POSITION only).
* **With a stream**: one animation ``fap_stream``, keyframe times ``frame / fps``,
  LINEAR: a ``weights`` channel for each mesh with targets (values from
  :func:`~mpeg4fba.fba.face.table_values`, as playback computes them), and a
  translation / rotation / scale channel for each Transform field a FaceDefTransform
  drives (values from :meth:`Playback.transform`).  Every frame of the stream is a
  keyframe, so the frames are reproduced exactly; between them glTF interpolates.

ValueError names the mesh, Transform or table for what glTF can't hold (empty meshes,
numbers beyond float32, a stream without frames...).  Files are written atomically.

Example
-------
>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable
>>> skin = FaceMesh("Skin", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
>>> jaw = FaceDefMesh("Skin", [-100, 0, 100], [2], [[0, 1e-3, 0], [0, -1e-3, 0]])
>>> fat = FAT([FaceDefTable(3, [jaw])])
>>> doc = face_to_gltf(FaceModel([skin], fat=fat))
>>> doc.meshes[0].extras["targetNames"], doc.meshes[0].weights
(['open_jaw[-100,0]', 'open_jaw[0,100]'], [0.0, 0.0])
>>> dumps_glb(FaceModel([skin], fat=fat))[:4]
b'glTF'
"""
from __future__ import annotations

import base64
import os
from typing import TYPE_CHECKING, Optional, Union

import numpy as np

from ..fba.face import FaceModel, FaceTransform, table_values
from ..fba.fat import FaceDefTable, interval_weights, rotation_matrices
from ..fba.morph import TargetKey
from ..fba.stream import FapStream
from .._atomic import atomic_write

if TYPE_CHECKING:        # pygltflib is imported when a document is made
    import pygltflib

__all__ = ["face_to_gltf", "dumps_glb", "dumps_gltf", "write_glb", "target_label"]

PathLike = Union[str, os.PathLike]

# glTF enums
_FLOAT, _UINT, _USHORT, _UBYTE = 5126, 5125, 5123, 5121
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_COMPONENT = {np.dtype("<f4"): _FLOAT, np.dtype("<u4"): _UINT, np.dtype("<u2"): _USHORT,
              np.dtype("<u1"): _UBYTE}
_TYPE = {1: "SCALAR", 3: "VEC3", 4: "VEC4"}
_F32_MAX = float(np.finfo(np.float32).max)


# -- small numeric helpers ------------------------------------------------------------------

def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """glTF colours are linear; face colours are display (sRGB) colours."""
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions [f, 4] (x, y, z, w) of rotation matrices [f, 3, 3], vectorised
    (Shepperd: each from its largest diagonal term, so none divides by ~0), signs made
    continuous so that slerp between keyframes takes the short way.

    >>> quaternions(rotation_matrices((0, 0, 1), [np.pi / 2])).round(6).tolist()
    [[0.0, 0.0, 0.707107, 0.707107]]
    """
    R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
    m00, m11, m22 = R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]
    tr = m00 + m11 + m22
    cand = np.stack([
        np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1],
                  1 + tr], axis=1),
        np.stack([1 + m00 - m11 - m22, R[:, 0, 1] + R[:, 1, 0], R[:, 0, 2] + R[:, 2, 0],
                  R[:, 2, 1] - R[:, 1, 2]], axis=1),
        np.stack([R[:, 0, 1] + R[:, 1, 0], 1 - m00 + m11 - m22, R[:, 1, 2] + R[:, 2, 1],
                  R[:, 0, 2] - R[:, 2, 0]], axis=1),
        np.stack([R[:, 0, 2] + R[:, 2, 0], R[:, 1, 2] + R[:, 2, 1], 1 - m00 - m11 + m22,
                  R[:, 1, 0] - R[:, 0, 1]], axis=1)], axis=1)            # [f, 4 cases, 4]
    pick = np.argmax(np.stack([tr, m00, m11, m22], axis=1), axis=1)
    q = cand[np.arange(len(R)), pick]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    if len(q):
        # q and -q are one rotation: keep w >= 0 at the first key, then no sign jumps.
        flips = np.ones(len(q))
        flips[0] = -1.0 if q[0, 3] < 0 else 1.0
        flips[1:] = np.where(np.einsum("ij,ij->i", q[1:], q[:-1]) < 0, -1.0, 1.0)
        q *= np.cumprod(flips)[:, None]
    return q


def _smooth_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Unit vertex normals [n, 3]: area-weighted sums of the face normals (vertices in no
    proper triangle get +z, since glTF wants unit normals everywhere)."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    fn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])    # |fn| = 2 x area
    idx = t.ravel()
    N = np.stack([np.bincount(idx, weights=np.repeat(fn[:, c], 3), minlength=len(v))
                  for c in range(3)], axis=1)
    norm = np.linalg.norm(N, axis=1, keepdims=True)
    ok = norm[:, 0] > 0
    out = np.tile([0.0, 0.0, 1.0], (len(v), 1))
    out[ok] = N[ok] / norm[ok]
    return out


def _float32(values, what: str) -> np.ndarray:
    """``values`` as little-endian float32, or ValueError naming ``what`` when a number
    is not finite or beyond float32."""
    a = np.asarray(values, dtype=np.float64)
    bad = ~np.isfinite(a) | (np.abs(a) > _F32_MAX)
    if bad.any():
        first = a.reshape(-1)[np.flatnonzero(bad.reshape(-1))[0]]
        raise ValueError(f"{what}: {float(first)!r} can't be stored in glTF (float32, finite)")
    return a.astype("<f4")


def _num(x: float) -> str:
    """A border for a target name: integers without a decimal point."""
    x = float(x)
    return str(int(x)) if x == int(x) and abs(x) < 1e15 else repr(x)


def target_label(table: FaceDefTable) -> str:
    """What a table animates, as target names start: ``open_jaw``, ``viseme:PP``,
    ``expression:joy`` (``viseme:15`` for a select the standard does not name).

    >>> target_label(FaceDefTable(1, select=1)), target_label(FaceDefTable(48))
    ('viseme:PP', 'head_pitch')
    """
    try:
        return str(TargetKey(table.fap, table.select if table.fap <= 2 else 0))
    except KeyError:
        return f"{'viseme' if table.fap == 1 else 'expression'}:{table.select}"


# -- what the FAT becomes -------------------------------------------------------------------

class _Slot:
    """One morph target: interval ``j`` of ``entry`` (a FaceDefMesh of ``table``), its
    displacement scaled by ``scale`` (the signed interval width)."""

    __slots__ = ("name", "table", "entry", "j", "scale")

    def __init__(self, name: str, table: FaceDefTable, entry, j: int, scale: float):
        self.name, self.table, self.entry, self.j, self.scale = name, table, entry, j, scale


def _slots(face: FaceModel) -> dict:
    """Mesh name -> its morph targets, in playback's order (tables by key, then entries,
    then intervals).  ``face.compile()`` first, so a bad FAT raises playback's
    ValueError, which names the table and mesh."""
    face.compile()
    out: dict = {name: [] for name in face.meshes}
    for table in sorted(face.fat, key=lambda t: t.key):
        label = target_label(table)
        for entry in table.meshes:
            b = entry.borders
            lo, hi = b[:-1], b[1:]
            # interval_weights walks intervals at or above 0 upwards and the others
            # downwards: the full weight of an interval is its width with that sign.
            scale = np.where(lo >= 0, hi - lo, lo - hi)
            slots = out[entry.mesh]
            taken = {s.name for s in slots}
            for j in range(entry.n_intervals):
                name = base = f"{label}[{_num(lo[j])},{_num(hi[j])}]"
                k = 2
                while name in taken:          # two entries of one table on one mesh
                    name, k = f"{base}#{k}", k + 1
                taken.add(name)
                slots.append(_Slot(name, table, entry, j, float(scale[j])))
    return out


def _target_deltas(face: FaceModel, mesh: str, slots: list) -> list:
    """Each slot's full displacement [n, 3] as float32 (duplicated vertex indices add,
    as in playback)."""
    n = len(face.meshes[mesh].vertices)
    out = []
    for s in slots:
        d = np.zeros((n, 3))
        np.add.at(d, s.entry.indices, s.entry.displacements[:, s.j, :] * s.scale)
        out.append(_float32(d, f"mesh {mesh}: morph target {s.name} (table of FAP "
                               f"{s.table.fap}, {target_label(s.table)})"))
    return out


def _stream_weights(face: FaceModel, slots: dict, stream: FapStream) -> dict:
    """Mesh name -> morph weights [frames, targets] of every frame of ``stream``."""
    held, given, vis, exp = stream.held()
    values: dict = {}        # id(table) -> its value P per frame
    weights: dict = {}       # id(FaceDefMesh) -> its interval weights [frames, intervals]
    out = {}
    for mesh, ss in slots.items():
        W = np.zeros((len(stream), len(ss)))
        for k, s in enumerate(ss):
            if id(s.entry) not in weights:
                if id(s.table) not in values:
                    values[id(s.table)] = table_values(s.table, held, given, vis, exp)
                weights[id(s.entry)] = interval_weights(s.entry.borders, values[id(s.table)])
            W[:, k] = weights[id(s.entry)][:, s.j] / s.scale
        out[mesh] = W
    return out


def driven_transforms(face: FaceModel) -> dict:
    """Transform name -> the fields FaceDefTransforms drive, in field order."""
    out: dict = {}
    for table in face.fat:
        for t in table.transforms:
            out.setdefault(t.transform, set()).add(t.field)
    order = ("translation", "rotation", "scale")
    return {name: [f for f in order if f in fields] for name, fields in out.items()}


# -- the binary buffer ------------------------------------------------------------------------

class _Buffer:
    """The one binary buffer, with its bufferViews and accessors as they are added."""

    def __init__(self):
        import pygltflib as g
        self.g = g
        self.data = bytearray()
        self.views: list = []
        self.accessors: list = []

    def view(self, arr: np.ndarray, target: Optional[int] = None) -> int:
        while len(self.data) % 4:          # every accessor's data 4-byte aligned
            self.data.append(0)
        raw = np.ascontiguousarray(arr).tobytes()
        self.views.append(self.g.BufferView(buffer=0, byteOffset=len(self.data),
                                            byteLength=len(raw), target=target))
        self.data += raw
        return len(self.views) - 1

    def accessor(self, arr: np.ndarray, target: Optional[int] = None, bounds: bool = False) -> int:
        a = np.asarray(arr)
        a2 = a.reshape(len(a), -1)
        kw = {}
        if bounds:   # required for POSITION and animation inputs
            kw = {"min": a2.min(axis=0).tolist(), "max": a2.max(axis=0).tolist()}
        self.accessors.append(self.g.Accessor(
            bufferView=self.view(a, target), componentType=_COMPONENT[a.dtype],
            count=len(a), type=_TYPE[a2.shape[1]], **kw))
        return len(self.accessors) - 1

    def target(self, d: np.ndarray) -> int:
        """A morph target's POSITION deltas [n, 3] float32: sparse when that is smaller
        (none stored at all for a target that moves nothing)."""
        g = self.g
        n = len(d)
        moved = np.flatnonzero(d.any(axis=1))
        bounds = {"min": d.min(axis=0).tolist(), "max": d.max(axis=0).tolist()}
        if not len(moved):      # no bufferView, no sparse: an accessor of zeros
            self.accessors.append(g.Accessor(componentType=_FLOAT, count=n, type="VEC3",
                                             byteOffset=None, **bounds))
            return len(self.accessors) - 1
        itype = np.dtype("<u2") if n <= 65536 else np.dtype("<u4")
        if len(moved) * (itype.itemsize + 12) >= 12 * n:
            return self.accessor(d, _ARRAY_BUFFER, bounds=True)
        sparse = g.Sparse(count=len(moved),
                          indices=g.AccessorSparseIndices(
                              bufferView=self.view(moved.astype(itype)),
                              componentType=_COMPONENT[itype]),
                          values=g.AccessorSparseValues(bufferView=self.view(d[moved])))
        # byteOffset=None: pygltflib writes 0 by default, invalid without a bufferView
        self.accessors.append(g.Accessor(componentType=_FLOAT, count=n, type="VEC3",
                                         byteOffset=None, sparse=sparse, **bounds))
        return len(self.accessors) - 1


# -- the document ---------------------------------------------------------------------------

def _trs(t: FaceTransform, rotation: np.ndarray, translation: np.ndarray,
         scale: np.ndarray) -> tuple:
    """The named node's (translation, rotation quaternion, scale) per frame for a
    Transform's (R, T, S) per frame: T + C, R . SR, S (see the module doc)."""
    SR = rotation_matrices(t.scale_orientation[:3], [t.scale_orientation[3]])[0]
    c = np.asarray(t.center, dtype=np.float64)
    return (np.asarray(translation, float) + c, quaternions(np.asarray(rotation) @ SR),
            np.asarray(scale, float))


def _transform_values(t: FaceTransform) -> tuple:
    """A Transform's neutral (R [1, 3, 3], T [1, 3], S [1, 3])."""
    return (rotation_matrices(t.rotation[:3], [t.rotation[3]]),
            np.asarray([t.translation], float), np.asarray([t.scale], float))


def _pivot(t: FaceTransform) -> Optional[tuple]:
    """(translation, rotation) of the ``_pivot`` node, or None when C and SR are neutral."""
    c = np.asarray(t.center, dtype=np.float64)
    SR = rotation_matrices(t.scale_orientation[:3], [t.scale_orientation[3]])[0]
    if not c.any() and np.allclose(SR, np.eye(3), rtol=0, atol=1e-15):
        return None
    return -(SR.T @ c), quaternions(SR.T[None])[0]


def _optional(value: np.ndarray, default: tuple) -> Optional[list]:
    """A node TRS value, or None (left out) when it is glTF's default."""
    v = [float(x) + 0.0 for x in np.asarray(value, dtype=np.float32)]   # + 0.0: no -0.0
    return None if v == list(default) else v


def face_to_gltf(face: FaceModel, stream: Optional[FapStream] = None) -> "pygltflib.GLTF2":
    """The glTF 2.0 document (a ``pygltflib.GLTF2`` whose buffer is its binary blob) of
    ``face``, animated by ``stream`` when given (see the module doc).

    >>> from mpeg4fba.fba.face import FaceMesh, FaceTransform
    >>> jaw = FaceTransform("Jaw", center=(0, 1, 0))
    >>> face = FaceModel([FaceMesh("Tri", np.eye(3), [[0, 1, 2]], parent="Jaw")], [jaw])
    >>> [(n.name, n.translation, n.children) for n in face_to_gltf(face).nodes]
    [('Jaw', [0.0, 1.0, 0.0], [1]), ('Jaw_pivot', [0.0, -1.0, 0.0], [2]), ('Tri', None, [])]
    """
    import pygltflib as g
    from .. import __version__

    slots = _slots(face)
    for name, t in face.transforms.items():
        if t.parent is not None and t.parent not in face.transforms:
            raise ValueError(f"Transform {name} hangs under {t.parent!r}, which is not a "
                             "Transform of the face")
        face.chain(name)                     # ValueError when the tree loops
    buf = _Buffer()

    # Transforms: the named node, and its pivot when it has one.
    nodes: list = []
    outer: dict = {}
    inner: dict = {}
    for name, t in face.transforms.items():
        R, T, S = _transform_values(t)
        tr, q, sc = _trs(t, R, T, S)
        _float32(np.concatenate([tr[0], q[0], sc[0], np.asarray(t.center, float)]),
                 f"Transform {name}")
        nodes.append(g.Node(name=name, translation=_optional(tr[0], (0.0, 0.0, 0.0)),
                            rotation=_optional(q[0], (0.0, 0.0, 0.0, 1.0)),
                            scale=_optional(sc[0], (1.0, 1.0, 1.0))))
        outer[name] = inner[name] = len(nodes) - 1
        pivot = _pivot(t)
        if pivot is not None:
            nodes.append(g.Node(name=f"{name}_pivot",
                                translation=_optional(pivot[0], (0.0, 0.0, 0.0)),
                                rotation=_optional(pivot[1], (0.0, 0.0, 0.0, 1.0))))
            nodes[outer[name]].children.append(len(nodes) - 1)
            inner[name] = len(nodes) - 1
    roots = [outer[n] for n, t in face.transforms.items() if t.parent is None]
    for n, t in face.transforms.items():
        if t.parent is not None:
            nodes[inner[t.parent]].children.append(outer[n])

    # Meshes, each with its own material (see the module doc).
    materials: list = []

    def material(m, color: tuple, vertex_colors: bool) -> int:
        base = None if vertex_colors else [float(x) for x in _srgb_to_linear(color)] + [1.0]
        materials.append(g.Material(name=m.name, doubleSided=not m.is_closed(),
                                    pbrMetallicRoughness=g.PbrMetallicRoughness(
                                        baseColorFactor=base, metallicFactor=0.0,
                                        roughnessFactor=0.7)))
        return len(materials) - 1

    meshes: list = []
    mesh_node: dict = {}
    for name, m in face.meshes.items():
        if not len(m.vertices) or not len(m.triangles):
            raise ValueError(f"mesh {name}: {len(m.vertices)} vertices and {len(m.triangles)} "
                             "triangles; glTF can't hold an empty mesh")
        if m.triangles.min() < 0 or m.triangles.max() >= len(m.vertices):
            raise ValueError(f"mesh {name}: a triangle names a vertex outside "
                             f"0..{len(m.vertices) - 1}")
        v = _float32(m.vertices, f"mesh {name}: vertex positions")
        attributes = g.Attributes(
            POSITION=buf.accessor(v, _ARRAY_BUFFER, bounds=True),
            NORMAL=buf.accessor(_smooth_normals(m.vertices, m.triangles).astype("<f4"),
                                _ARRAY_BUFFER))
        color, per_vertex = face.mesh_colors(name)
        if per_vertex is not None:
            attributes.COLOR_0 = buf.accessor(_srgb_to_linear(per_vertex).astype("<f4"),
                                              _ARRAY_BUFFER)
        prim = g.Primitive(attributes=attributes, mode=4,
                           material=material(m, color, per_vertex is not None),
                           indices=buf.accessor(m.triangles.astype("<u4").reshape(-1),
                                                _ELEMENT_ARRAY_BUFFER))
        ss = slots[name]
        extras = {}
        weights = None
        if ss:
            prim.targets = [{"POSITION": buf.target(d)} for d in _target_deltas(face, name, ss)]
            extras = {"targetNames": [s.name for s in ss]}
            weights = [0.0] * len(ss)
        meshes.append(g.Mesh(name=name, primitives=[prim], weights=weights, extras=extras))
        nodes.append(g.Node(name=name, mesh=len(meshes) - 1))
        mesh_node[name] = len(nodes) - 1
        if m.parent is None:
            roots.append(len(nodes) - 1)
        else:
            nodes[inner[m.parent]].children.append(len(nodes) - 1)

    animations = [] if stream is None else [_animation(face, stream, slots, outer, mesh_node, buf)]
    doc = g.GLTF2(asset=g.Asset(version="2.0", generator=f"mpeg4fba {__version__}"),
                  scene=0, scenes=[g.Scene(name=face.name, nodes=roots)], nodes=nodes,
                  meshes=meshes, materials=materials, accessors=buf.accessors,
                  bufferViews=buf.views, animations=animations)
    if len(buf.data) > 0xFFFFFFFF - 1024:
        raise ValueError(f"face {face.name}: {len(buf.data)} bytes of data, more than a glTF "
                         "binary buffer holds (4 GiB)")
    doc.buffers = [g.Buffer(byteLength=len(buf.data))]
    doc.set_binary_blob(bytes(buf.data))
    return doc


def _animation(face: FaceModel, stream: FapStream, slots: dict, outer: dict, mesh_node: dict,
               buf: _Buffer) -> "pygltflib.Animation":
    """The animation ``fap_stream``: every frame a LINEAR keyframe (see the module doc)."""
    import pygltflib as g
    n = len(stream)
    if n == 0:
        raise ValueError("the FAP stream has no frames: a glTF animation needs at least one "
                         "keyframe")
    times = _float32(stream.times, "the stream's frame times")
    if n > 1 and not (np.diff(times) > 0).all():
        raise ValueError(f"the stream's frame times ({n} frames at {stream.fps:g} fps) are not "
                         "strictly increasing in float32, as glTF keyframes must be")
    samplers: list = []
    channels: list = []
    time_acc = buf.accessor(times, bounds=True)

    def channel(node: int, path: str, output: np.ndarray) -> None:
        samplers.append(g.AnimationSampler(input=time_acc, output=buf.accessor(output),
                                           interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1,
                                           target=g.AnimationChannelTarget(node=node, path=path)))

    for mesh, W in _stream_weights(face, slots, stream).items():
        if W.shape[1]:
            channel(mesh_node[mesh], "weights",
                    _float32(W.reshape(-1), f"mesh {mesh}: morph weights"))
    driven = driven_transforms(face)
    if driven:
        frames = face.play(stream)
        for name, fields in driven.items():
            t = frames.transform(name)
            tr, q, sc = _trs(face.transforms[name], t["rotation"], t["translation"], t["scale"])
            out = {"translation": tr, "rotation": q, "scale": sc}
            for field in fields:
                channel(outer[name], field, _float32(out[field], f"Transform {name}: animated "
                                                                 f"{field}"))
    if not channels:
        raise ValueError(f"face {face.name}: its FAT moves no mesh and no Transform, so the "
                         "stream animates nothing")
    return g.Animation(name="fap_stream", samplers=samplers, channels=channels,
                       extras={"fps": stream.fps, "frames": n})


# -- bytes and files ------------------------------------------------------------------------

def dumps_glb(face: FaceModel, stream: Optional[FapStream] = None) -> bytes:
    """The binary glTF (``.glb``) of ``face`` (animated by ``stream`` when given).

    >>> from mpeg4fba.fba.face import FaceMesh
    >>> data = dumps_glb(FaceModel([FaceMesh("Tri", np.eye(3), [[0, 1, 2]])]))
    >>> data[:4], int.from_bytes(data[8:12], "little") == len(data)
    (b'glTF', True)
    """
    return b"".join(face_to_gltf(face, stream).save_to_bytes())


def dumps_gltf(face: FaceModel, stream: Optional[FapStream] = None) -> str:
    """The JSON glTF (``.gltf``) of ``face``, its buffer embedded as a base64 data URI."""
    doc = face_to_gltf(face, stream)
    data = doc.binary_blob()
    doc.buffers[0].uri = "data:application/octet-stream;base64," + \
        base64.b64encode(data).decode("ascii")
    doc.destroy_binary_blob()
    return doc.gltf_to_json(separators=(",", ":"), indent=None)


def write_glb(face: FaceModel, path: PathLike, stream: Optional[FapStream] = None) -> None:
    """Write ``face`` (animated by ``stream`` when given) as ``.glb`` (binary) or
    ``.gltf`` (JSON, buffer embedded), by the path's ending; atomically: everything is
    built in memory first, then written to a temporary file that is renamed.

    >>> import tempfile
    >>> from mpeg4fba.fba.face import FaceMesh
    >>> p = os.path.join(tempfile.mkdtemp(), "tri.glb")
    >>> write_glb(FaceModel([FaceMesh("Tri", np.eye(3), [[0, 1, 2]])]), p)
    >>> open(p, "rb").read(4)
    b'glTF'
    """
    p = os.fspath(path)
    low = p.lower()
    if low.endswith(".glb"):
        data = dumps_glb(face, stream)
    elif low.endswith(".gltf"):
        data = dumps_gltf(face, stream).encode("utf-8")
    else:
        raise ValueError(f"{p}: a glTF file ends in .glb (binary) or .gltf (JSON)")
    atomic_write(p, data)
