"""A FAP stream baked into VRML97: the face plus interpolators that play it in any browser.

:func:`animated_scene` takes the scene :func:`~mpeg4fba.formats.wrl_face.scene_from_face`
writes (the face scene graph, the MPEG-4 nodes declared as PROTOs so that VRML97
browsers open the file) and adds, after it:

* ``DEF FapClock TimeSensor { cycleInterval <frames / fps> loop TRUE }``;
* for each mesh the stream moves, a ``CoordinateInterpolator`` whose ``key`` are the
  frame times over the duration (``k / frames``) and whose ``keyValue`` holds every
  vertex position of every frame (mesh-local, as :meth:`Playback.vertices` gives
  them), DEF'd ``<mesh>_motion`` and routed to the mesh's Coordinate ``set_point`` (the
  Coordinate gets the DEF name ``<mesh>_coord``);
* for each Transform field a FaceDefTransform drives and the stream moves, an
  ``OrientationInterpolator`` (rotation) or ``PositionInterpolator`` (translation,
  and scale: VRML97 has no scale interpolator, and a PositionInterpolator's SFVec3f
  fits ``set_scale``), DEF'd ``<Transform>_<field>`` and routed to it.  The Transform
  keeps its ``center`` and ``scaleOrientation``: the browser composes them as playback
  does;
* ``ROUTE FapClock.fraction_changed TO <interpolator>.set_fraction`` for each.

Names already taken in the scene get ``_2``, ``_3``...  Frame k shows at time k / fps
of each cycle, as in playback; between frames the browser interpolates linearly (slerp
for rotations), and the last frame holds until the cycle starts again.  The Face node
and its FAT are kept, so :func:`~mpeg4fba.formats.wrl_face.load_face` still reads the
file.  Every vertex of every moving mesh is written for every frame, as text: about
0.5 MB per frame for ``reference_head(resolution=1)``; use glTF for long streams.

Example
-------
>>> from mpeg4fba import vrml
>>> from mpeg4fba.fba import FapStream
>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable
>>> skin = FaceMesh("Skin", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
>>> fat = FAT([FaceDefTable(3, [FaceDefMesh("Skin", [0, 1000], [2], [[0, -1e-4, 0]])])])
>>> scene = animated_scene(FaceModel([skin], fat=fat), FapStream.from_values({3: [0, 500]}, fps=10))
>>> for r in scene.routes:
...     print(r)
<ROUTE FapClock.fraction_changed TO Skin_motion.set_fraction>
<ROUTE Skin_motion.value_changed TO Skin_coord.set_point>
>>> scene.find("FapClock")["cycleInterval"], scene.find("Skin_motion")["keyValue"][-1].tolist()
(0.2, [0.0, 0.95, 0.0])
"""
from __future__ import annotations

import os
from typing import Union

import numpy as np

from ..fba.face import FaceModel
from ..fba.fat import rotation_matrices
from ..fba.stream import FapStream
from ..vrml.scene import Node, Route, Scene
from ..vrml.writer import dump
from .gltf import driven_transforms, quaternions
from .wrl_face import DefNamer, scene_from_face

__all__ = ["animated_scene", "write_animated_wrl", "CLOCK_NAME"]

PathLike = Union[str, os.PathLike]

#: DEF name (made unique) of the TimeSensor that drives the interpolators.
CLOCK_NAME = "FapClock"


def _axis_angles(R: np.ndarray) -> np.ndarray:
    """VRML rotations [f, 4] (axis, angle) of rotation matrices [f, 3, 3], through
    continuous quaternions so that consecutive keys interpolate the short way.

    >>> from mpeg4fba.fba.fat import rotation_matrices
    >>> _axis_angles(rotation_matrices((0, 1, 0), [0.0, 0.5])).round(6).tolist()
    [[0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 0.5]]
    """
    q = quaternions(R)
    s = np.linalg.norm(q[:, :3], axis=1)
    axis = np.where(s[:, None] > 0, q[:, :3] / np.where(s > 0, s, 1.0)[:, None], [0.0, 0.0, 1.0])
    return np.column_stack([axis, 2 * np.arctan2(s, q[:, 3])])


def _face_nodes(face: FaceModel, scene: Scene) -> tuple:
    """(mesh name -> IndexedFaceSet node, transform name -> Transform node) of a scene
    made by ``scene_from_face(face)``: its DEF names are claimed transforms first, then
    meshes, by one :class:`DefNamer`, so the same claims give them back."""
    names = DefNamer()
    tnames = {n: names.claim(n, "transform") for n in face.transforms}
    mnames = {n: names.claim(n, "mesh") for n in face.meshes}
    defs = scene.defs
    out = []
    for wanted, kind in ((mnames, "IndexedFaceSet"), (tnames, "Transform")):
        found = {}
        for n, def_name in wanted.items():
            node = defs.get(def_name)
            if node is None or node.type != kind:
                raise RuntimeError(f"scene_from_face no longer DEFs {kind} {n!r} as "
                                   f"{def_name!r}; update wrl_anim._face_nodes")
            found[n] = node
        out.append(found)
    return out[0], out[1]


MAX_NUMBERS = 1 << 27     # vertex coordinates over all frames: ~1 GB held as float64


def animated_scene(face: FaceModel, stream: FapStream, *, protos: bool = True) -> Scene:
    """The VRML97 scene of ``face`` playing ``stream`` in a loop (see the module doc).

    ValueError for a stream without frames and for what ``scene_from_face`` or playback
    refuse (a FAT naming a mesh the face lacks...).
    """
    n = len(stream)
    if n == 0:
        raise ValueError("the FAP stream has no frames: nothing to animate")
    vertices = sum(len(m.vertices) for m in face.meshes.values())
    if n * vertices * 3 > MAX_NUMBERS:
        # refused before the work: every frame's vertices are held, then written out
        raise ValueError(f"{n:,} frames x {vertices:,} vertices is {n * vertices * 3:,} "
                         f"numbers, more than the {MAX_NUMBERS:,} a VRML animation is "
                         "written with here; play a part of the stream (stream[a:b]) or write "
                         ".glb, which keeps morph-target weights per frame, not vertices")
    scene = scene_from_face(face, protos=protos)
    ifs, transforms = _face_nodes(face, scene)
    taken = set(scene.defs)

    def unique(base: str) -> str:
        name, k = base, 2
        while name in taken:
            name, k = f"{base}_{k}", k + 1
        taken.add(name)
        return name

    frames = face.play(stream)
    key = np.arange(n) / n                    # frame k at k / fps of a cycle of n / fps
    clock = Node("TimeSensor", name=unique(CLOCK_NAME), cycleInterval=n / stream.fps, loop=True)
    interpolators: list = []
    routes: list = []

    def drive(interp: Node, target: Node, event: str) -> None:
        interpolators.append(interp)
        routes.append(Route(clock, "fraction_changed", interp, "set_fraction"))
        routes.append(Route(interp, "value_changed", target, event))

    for name, m in face.meshes.items():
        V = frames.vertices(name)
        if not (V != m.vertices).any():
            continue                           # the stream leaves this mesh alone
        node = ifs[name]
        coord = node["coord"]
        if coord.name is None:
            coord.name = unique(f"{node.name}_coord")
        drive(Node("CoordinateInterpolator", name=unique(f"{node.name}_motion"), key=key,
                   keyValue=V.reshape(-1, 3)), coord, "set_point")
    for name, fields in driven_transforms(face).items():
        node = transforms[name]
        t = frames.transform(name)
        neutral = face.transforms[name]
        for field in fields:
            if field == "rotation":
                values = _axis_angles(t["rotation"])
                R0 = rotation_matrices(neutral.rotation[:3], [neutral.rotation[3]])
                moved = (t["rotation"] != R0).any()
                kind = "OrientationInterpolator"
            else:
                values = t[field]
                moved = (values != np.asarray(getattr(neutral, field), float)).any()
                kind = "PositionInterpolator"
            if moved:
                drive(Node(kind, name=unique(f"{node.name}_{field}"), key=key, keyValue=values),
                      node, f"set_{field}")
    scene.statements.extend([clock] + interpolators + routes)
    return scene


def write_animated_wrl(face: FaceModel, stream: FapStream, path: PathLike, *,
                       protos: bool = True) -> None:
    """Write :func:`animated_scene` to ``path`` (gzipped for ``.gz`` / ``.wrz``),
    atomically: the text is made in full, then written to a temporary file and renamed.

    >>> import tempfile
    >>> from mpeg4fba.fba.face import FaceMesh
    >>> p = os.path.join(tempfile.mkdtemp(), "still.wrl")
    >>> write_animated_wrl(FaceModel([FaceMesh("Tri", np.eye(3), [[0, 1, 2]])]),
    ...                    FapStream.from_values({3: [0, 0]}), p)
    >>> "DEF FapClock TimeSensor" in open(p).read()
    True
    """
    p = os.fspath(path)
    if p.lower().endswith((".glb", ".gltf")):
        raise ValueError(f"{p}: this writes VRML; write glTF with mpeg4fba.formats.gltf")
    dump(animated_scene(face, stream, protos=protos), p)
