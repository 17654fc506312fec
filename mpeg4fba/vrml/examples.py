"""A small example scene built in code, for demonstrations, tests and ``info --example``.

It holds what a typical face file holds: a Transform tree with meshes (an
icosphere head, two eyes sharing one Shape by DEF/USE, a nose of quads and
triangles), a Material shared by DEF/USE, a PROTO, and an animation (TimeSensor ->
OrientationInterpolator -> Transform) wired with ROUTEs.

Example
-------
>>> from mpeg4fba import vrml
>>> scene = example_scene()
>>> scene.find("HeadMesh")["coord"]["point"].shape
(642, 3)
>>> vrml.loads(vrml.dumps(scene)) == scene
True
"""
from __future__ import annotations

import numpy as np

from .catalogue import FieldDecl
from .fields import FIELD_TYPES
from .scene import Node, Proto, Route, Scene

__all__ = ["icosphere", "example_scene"]


def icosphere(subdivisions: int = 2) -> tuple:
    """Unit sphere mesh: ``(points (n, 3) float64, triangles (m, 3) int64)``.

    Starts from an icosahedron and splits every triangle into four ``subdivisions``
    times, all edges of a level at once (``10 * 4**k + 2`` points).

    >>> points, tris = icosphere(1)
    >>> points.shape, tris.shape, bool(np.allclose(np.linalg.norm(points, axis=1), 1))
    ((42, 3), (80, 3), True)
    """
    g = (1.0 + 5.0 ** 0.5) / 2.0
    points = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0],
                       [0, -1, g], [0, 1, g], [0, -1, -g], [0, 1, -g],
                       [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]], dtype=np.float64)
    tris = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                     [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                     [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                     [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(tris[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = points[unique[:, 0]] + points[unique[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(-1, 3) + len(points)          # midpoints of ab, bc, ca
        a, b, c = tris.T
        ab, bc, ca = m.T
        tris = np.stack([np.stack([a, ab, ca], 1), np.stack([ab, b, bc], 1),
                         np.stack([ca, bc, c], 1), np.stack([ab, bc, ca], 1)], 1).reshape(-1, 3)
        points = np.vstack([points, mid])
    return points, tris


def _index_list(polygons: np.ndarray) -> np.ndarray:
    """coordIndex of equal-sized polygons: each row followed by -1."""
    polygons = np.asarray(polygons, dtype=np.int64)
    return np.hstack([polygons, np.full((len(polygons), 1), -1)]).reshape(-1)


def _ifs(points: np.ndarray, coord_index: np.ndarray, name: str | None = None) -> Node:
    return Node("IndexedFaceSet", name=name, coord=Node("Coordinate", point=points),
                coordIndex=coord_index, creaseAngle=1.0)


def example_scene(subdivisions: int = 3) -> Scene:
    """The example scene (a head of ``10 * 4**subdivisions + 2`` vertices and friends).

    >>> from mpeg4fba.vrml.walk import iter_meshes
    >>> [(m.geometry.name, len(m.vertices), len(m.triangles)) for m in iter_meshes(example_scene(2))]
    [('HeadMesh', 162, 320), ('EyeMesh', 42, 80), ('EyeMesh', 42, 80), ('NoseMesh', 5, 6)]
    """
    head_points, head_tris = icosphere(subdivisions)
    head_points = head_points * np.array([0.8, 1.0, 0.9])   # a head is not a ball
    skin = Node("Material", name="Skin", diffuseColor=(0.87, 0.68, 0.58), shininess=0.1)
    head = Node("Shape", appearance=Node("Appearance", material=skin),
                geometry=_ifs(head_points, _index_list(head_tris), "HeadMesh"))

    eye_points, eye_tris = icosphere(1)
    eye = Node("Shape", name="Eye",
               appearance=Node("Appearance", material=Node("Material", diffuseColor=(0.1, 0.1, 0.15),
                                                           specularColor=(1, 1, 1), shininess=0.8)),
               geometry=_ifs(eye_points, _index_list(eye_tris), "EyeMesh"))
    left_eye = Node("Transform", name="LeftEye", translation=(-0.3, 0.2, 0.78),
                    scale=(0.12, 0.12, 0.12), children=[eye])
    right_eye = Node("Transform", name="RightEye", translation=(0.3, 0.2, 0.78),
                     scale=(0.12, 0.12, 0.12), children=[eye])

    # A square pyramid: one quad and four triangles, in one coordIndex.
    nose_points = np.array([[-0.1, -0.15, 0], [0.1, -0.15, 0], [0.1, 0.1, 0], [-0.1, 0.1, 0],
                            [0, -0.1, 0.2]])
    nose_index = np.array([3, 2, 1, 0, -1, 0, 1, 4, -1, 1, 2, 4, -1, 2, 3, 4, -1, 3, 0, 4, -1])
    nose = Node("Transform", name="Nose", translation=(0, -0.05, 0.85),
                children=[Node("Shape", appearance=Node("Appearance", material=skin),
                               geometry=_ifs(nose_points, nose_index, "NoseMesh"))])

    head_tf = Node("Transform", name="Head", translation=(0, 1.6, 0),
                   children=[head, left_eye, right_eye, nose])

    # A PROTO: a looping clock whose period is a field of the PROTO.
    body_clock = Node("TimeSensor", loop=True)
    body_clock.is_map["cycleInterval"] = "period"
    body_clock.is_map["fraction_changed"] = "fraction_changed"
    clock_proto = Proto("LoopingClock", [
        FieldDecl("field", FIELD_TYPES["SFTime"], "period", 4.0),
        FieldDecl("eventOut", FIELD_TYPES["SFFloat"], "fraction_changed")], [body_clock])
    clock = Node("LoopingClock", decl=clock_proto, name="Clock", period=6.0)

    angles = np.array([0.0, 0.35, 0.0, -0.35, 0.0])
    key_values = np.column_stack([np.zeros(5), np.ones(5), np.zeros(5), angles])
    turn = Node("OrientationInterpolator", name="Turn", key=np.linspace(0.0, 1.0, 5),
                keyValue=key_values)

    return Scene([
        Node("WorldInfo", title="mpeg4fba example", info=["built by mpeg4fba.vrml.examples"]),
        Node("Viewpoint", position=(0, 1.6, 4), description="Front"),
        clock_proto,
        head_tf,
        clock,
        turn,
        Route(clock, "fraction_changed", turn, "set_fraction"),
        Route(turn, "value_changed", head_tf, "set_rotation"),
    ])
