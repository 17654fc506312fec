"""Feature points in a VRML/BIFS scene: the FDP node's ``featurePointsCoord``.

**Convention.** ``FDP.featurePointsCoord`` is a Coordinate node whose ``point`` field
holds exactly 84 points, one per feature point of the standard, in the standard's
order (:data:`~mpeg4fba.fba.tables.FEATURE_POINTS`: by group, then by index: 2.1,
2.2, ... 2.14, 3.1, ... 11.6).  A point whose x is below -9999 is undefined (the
convention of visage|SDK); the writer puts ``-10000 0 0`` there.  Coordinates are
in the face's frame (x = the face's left, y = up, z = forward).

Example
-------
>>> from mpeg4fba.fba import FeaturePointSet
>>> from mpeg4fba.vrml import Node, Scene
>>> coord = fdp_coordinate(FeaturePointSet({"3.5": (31, 30, 72), "3.6": (-31, 30, 72)}))
>>> coord.type, coord["point"].shape, coord["point"][0].tolist()
('Coordinate', (84, 3), [-10000.0, 0.0, 0.0])
>>> face = Node("Face", fdp=Node("FDP", featurePointsCoord=coord))
>>> pts = feature_points_from_scene(Scene([Node("Transform", children=[face])]))
>>> list(pts), pts["3.6"].tolist()
(['3.5', '3.6'], [-31.0, 30.0, 72.0])
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..fba.featurepoints import FeaturePointError, FeaturePointSet
from ..fba.tables import FEATURE_POINTS
from ..vrml.scene import Node, Scene
from .errors import FormatError

__all__ = ["UNDEFINED_BELOW", "UNDEFINED_POINT", "feature_points_from_fdp", "fdp_coordinate",
           "feature_points_from_scene"]

#: A featurePointsCoord point with x below this is undefined.
UNDEFINED_BELOW = -9999.0
#: What the writer puts for an undefined point.
UNDEFINED_POINT = (-10000.0, 0.0, 0.0)

_IDS = [fp.id for fp in FEATURE_POINTS]


def _where(node: Node, default_path: Optional[str] = None) -> dict:
    """FormatError location keywords for a node (path, line, column) when known."""
    loc = node.location
    if loc is None:
        return {"path": default_path}
    path, line, column = loc
    return {"path": path if path is not None else default_path, "line": line, "column": column}


def _describe(node: Node) -> str:
    return f"{node.type} {node.name!r}" if node.name else node.type


def feature_points_from_fdp(fdp_node: Node, path: Optional[str] = None) -> FeaturePointSet:
    """The feature points in an FDP node's ``featurePointsCoord`` (see the module doc).

    ``path`` names the file in errors when the node does not know where it was read.
    FormatError (at the node's location when it has one) when there is no
    featurePointsCoord, it is not a Coordinate, it does not hold 84 points, or a
    point is not finite.

    >>> from mpeg4fba.vrml import Node
    >>> feature_points_from_fdp(Node("FDP", featurePointsCoord=Node("Coordinate", point=[(0, 0, 0)])))
    Traceback (most recent call last):
    ...
    mpeg4fba.formats.errors.FormatError: FDP.featurePointsCoord: the Coordinate has 1 point; it must hold the 84 feature points in the standard's order (x below -9999 for an undefined one)
    """
    if fdp_node.type != "FDP":
        raise FormatError(f"{_describe(fdp_node)} is not an FDP node", **_where(fdp_node, path))
    coord = _child(fdp_node, "featurePointsCoord", "Coordinate", path)
    where = _where(coord if coord.location is not None else fdp_node, path)
    raw = coord["point"]
    try:
        pts = np.asarray(raw, dtype=np.float64).reshape(-1, 3)
    except (TypeError, ValueError):
        raise FormatError(f"FDP.featurePointsCoord: the Coordinate's point is not a list of "
                          f"3-D points ({type(raw).__name__})", **where) from None
    if len(pts) != len(_IDS):
        raise FormatError(f"FDP.featurePointsCoord: the Coordinate has {len(pts)} point"
                          f"{'' if len(pts) == 1 else 's'}; it must hold the {len(_IDS)} "
                          "feature points in the standard's order (x below -9999 for an "
                          "undefined one)", **where)
    bad = np.flatnonzero(~np.isfinite(pts).all(axis=1))
    if bad.size:
        i = int(bad[0])
        raise FormatError(f"FDP.featurePointsCoord: point {i} (feature point {_IDS[i]}) is "
                          f"not finite: {pts[i].tolist()}", **where)
    defined = pts[:, 0] >= UNDEFINED_BELOW
    return FeaturePointSet({_IDS[i]: pts[i] for i in np.flatnonzero(defined)})


def fdp_coordinate(points: FeaturePointSet) -> Node:
    """A Coordinate node with the 84 feature points for ``FDP.featurePointsCoord``.

    Points without a position are written as ``-10000 0 0`` (undefined).  Raises
    FeaturePointError for points tied to a vertex but without a position (call
    ``points.resolve(meshes)`` first) and ValueError for a position whose x is below
    -9999, which would read back as undefined.
    """
    positions = set(points)
    unresolved = [fp for fp in points.ids if fp not in positions]
    if unresolved:
        raise FeaturePointError(f"feature point{'s' if len(unresolved) > 1 else ''} "
                                f"{', '.join(unresolved)} only name a mesh vertex; give them "
                                "positions with points.resolve(meshes) first", unresolved)
    out = np.tile(np.array(UNDEFINED_POINT), (len(_IDS), 1))
    for i, fp in enumerate(_IDS):
        if fp in positions:
            p = points[fp]
            if p[0] < UNDEFINED_BELOW:
                raise ValueError(f"feature point {fp} has x = {p[0]:g}, which an FDP reads as "
                                 f"'undefined' (x below {UNDEFINED_BELOW:g}); move or scale "
                                 "the face")
            out[i] = p
    return Node("Coordinate", point=out)


def find_face(scene: Scene, face: Optional[str] = None, path: Optional[str] = None) -> Node:
    """The scene's Face node (the one DEF'd ``face`` when given; needed only when the
    scene has several).  FormatError when there is none, or several and no name."""
    faces = [n for n in scene if n.type == "Face"]
    if face is not None:
        named = [n for n in faces if n.name == face]
        if not named:
            names = [n.name for n in faces if n.name]
            raise FormatError(f"no Face node DEF'd as {face!r}"
                              + (f" (the scene's Faces: {', '.join(names)})" if names
                                 else f" (the scene has {len(faces)} Face node"
                                      f"{'' if len(faces) == 1 else 's'}, none named)"), path)
        faces = named
    if not faces:
        roots = ", ".join(sorted({n.type for n in scene.nodes})) or "nothing"
        raise FormatError(f"no MPEG-4 Face node in the scene (root nodes: {roots}); a face "
                          "file holds Face { fdp FDP { ... } }", path)
    if len(faces) > 1:
        names = [n.name or "(no DEF name)" for n in faces]
        raise FormatError(f"the scene has {len(faces)} Face nodes ({', '.join(names)}); say "
                          "which with face=<DEF name>", **_where(faces[1], path))
    return faces[0]


def feature_points_from_scene(scene: Scene, face: Optional[str] = None) -> FeaturePointSet:
    """The feature points of the scene's Face node (its ``fdp.featurePointsCoord``).

    ``face`` is the DEF name of the Face to use; it is needed only when the scene has
    more than one.  FormatError saying what is missing: no Face, no fdp, no
    featurePointsCoord.
    """
    path = getattr(scene, "path", None)
    node = find_face(scene, face, path)
    fdp = _child(node, "fdp", "FDP", path, " (FDP node), so no feature points")
    return feature_points_from_fdp(fdp, path)


def _child(node: Node, field: str, type_name: str, path: Optional[str], why: str = "") -> Node:
    """``node[field]``, which must be a ``type_name`` node; FormatError saying what it is."""
    value = node[field]
    if value is None:
        raise FormatError(f"{_describe(node)} has no {field}{why}", **_where(node, path))
    if not isinstance(value, Node) or value.type != type_name:
        what = _describe(value) if isinstance(value, Node) else repr(value)
        raise FormatError(f"{_describe(node)}.{field} is {what}, not a {type_name}",
                          **_where(value if isinstance(value, Node) else node, path))
    return value
