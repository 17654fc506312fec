"""Feature point sidecar files: our own small JSON format.

A sidecar file says where the standard's feature points are on one face model, by
position, by mesh vertex, or both, and optionally gives the model's FAPU.  Example
(``spec_fixtures/feature_points/example.json`` is a complete one)::

    {
      "format": "mpeg4fba-feature-points",
      "version": 1,
      "units": "millimetres; x = the face's left, y = up, z = forward",
      "points": {
        "2.1": {"position": [0.0, -62.0, 28.0]},
        "3.5": {"position": [31.0, 38.0, 32.0], "mesh": "Skin", "vertex": 1204},
        "9.15": {"mesh": "Skin", "vertex": 331, "confidence": 0.8}
      },
      "fapu": {"IRISD0": 10.0, "ES0": 62.0, "ENS0": 42.0, "MNS0": 16.0, "MW0": 50.0}
    }

Rules:

- ``format`` (exactly ``"mpeg4fba-feature-points"``), ``version`` (1) and ``points``
  are required; ``units`` (free text for people; the reader checks it is a string and
  otherwise ignores it) and ``fapu`` are optional.  No other keys are allowed, at
  any level.
- ``points`` maps feature point ids ("group.index", groups 2-11) to objects with a
  ``position`` (3 finite numbers) and/or a ``vertex`` (an integer >= 0) with an
  optional ``mesh`` name (a string; a vertex without a mesh is on the model's only
  mesh).  A ``mesh`` needs a ``vertex``.  A point may also carry a ``confidence``,
  a number from 0 (a guess) to 1 (certain, e.g. placed by a person): how sure whoever
  found the point is of it.  :func:`loads_feature_points_json` checks and drops it,
  :func:`loads_confidences` returns it.
- ``fapu`` holds the five FAPU0 distances IRISD0, ES0, ENS0, MNS0 and MW0, in model
  units (the FAP units are these / 1024).

Errors are :class:`~mpeg4fba.formats.errors.FormatError` naming the item by its path
in the document, e.g. ``points["3.5"].position: expected 3 numbers``, and the line for
JSON syntax errors.

>>> from mpeg4fba.fba import FeaturePointSet
>>> pts = FeaturePointSet({"3.5": (31, 38, 32)}, {"3.5": ("Skin", 1204), "9.15": ("Skin", 331)})
>>> text = dumps_feature_points_json(pts)
>>> print(text, end="")
{
  "format": "mpeg4fba-feature-points",
  "version": 1,
  "points": {
    "3.5": {"position": [31.0, 38.0, 32.0], "mesh": "Skin", "vertex": 1204},
    "9.15": {"mesh": "Skin", "vertex": 331}
  }
}
>>> loads_feature_points_json(text) == (pts, None)
True
>>> text = dumps_feature_points_json(pts, confidences={"9.15": 0.25})
>>> text.splitlines()[5]
'    "9.15": {"mesh": "Skin", "vertex": 331, "confidence": 0.25}'
>>> loads_confidences(text)
{'9.15': 0.25}
"""
from __future__ import annotations

import json
import math
import numbers
import os
from typing import Mapping, Optional, Union

from ..fba.fapu import FAPU
from ..fba.featurepoints import FeaturePointError, FeaturePointSet, normalise_id, point_order
from .._atomic import atomic_write
from .errors import FormatError
from .jsontext import loads_json, shown

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "read_feature_points_json",
           "loads_feature_points_json", "write_feature_points_json",
           "dumps_feature_points_json", "read_confidences", "loads_confidences"]

FORMAT_NAME = "mpeg4fba-feature-points"
FORMAT_VERSION = 1

_TOP_KEYS = ("format", "version", "units", "points", "fapu")
_POINT_KEYS = ("position", "mesh", "vertex", "confidence")
_FAPU_KEYS = ("IRISD0", "ES0", "ENS0", "MNS0", "MW0")

PathLike = Union[str, "os.PathLike[str]"]


class _Object(dict):
    """A JSON object that remembers keys it had more than once (JSON keeps the last)."""

    def __init__(self, pairs):
        super().__init__()
        self.duplicates = []
        for k, v in pairs:
            if k in self and k not in self.duplicates:
                self.duplicates.append(k)
            self[k] = v


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


class _Checker:
    def __init__(self, path: Optional[str]):
        self.path = path

    def error(self, where: str, message: str) -> FormatError:
        return FormatError(f"{where}: {message}" if where else message, self.path)

    def object(self, value, where: str, allowed: tuple, what: str) -> dict:
        if not isinstance(value, dict):
            raise self.error(where, f"expected an object ({what}), not {_kind(value)}")
        if getattr(value, "duplicates", None):
            raise self.error(where, "key " + ", ".join(map(json.dumps, value.duplicates))
                             + " given more than once")
        extra = [k for k in value if k not in allowed]
        if extra and allowed:
            raise self.error(where, f"unknown key{'s' if len(extra) > 1 else ''} "
                             f"{', '.join(map(json.dumps, extra))}; allowed: "
                             f"{', '.join(allowed)}")
        return value


def _kind(value) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return json.dumps(value)
    return {dict: "an object", list: "an array", str: "a string"}.get(
        type(value), f"{value!r}")


def _join(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def loads_feature_points_json(text: Union[str, bytes], path: Optional[str] = None
                              ) -> tuple[FeaturePointSet, Optional[FAPU]]:
    """(feature points, FAPU or None) from sidecar JSON text; ``path`` names it in errors.

    Confidences are checked and left out (:func:`loads_confidences` returns them).

    >>> loads_feature_points_json('{"format": "mpeg4fba-feature-points", "version": 1,'
    ...     ' "points": {"3.5": {"position": [1, 2]}}}')
    Traceback (most recent call last):
    ...
    mpeg4fba.formats.errors.FormatError: points["3.5"].position: expected 3 numbers, not [1, 2]
    """
    points, fapu, _ = _parse(text, path)
    return points, fapu


def loads_confidences(text: Union[str, bytes], path: Optional[str] = None) -> dict:
    """{feature point id: confidence} of the points of sidecar JSON text that carry one,
    in the standard's order; the whole document is checked as
    :func:`loads_feature_points_json` checks it.

    >>> loads_confidences('{"format": "mpeg4fba-feature-points", "version": 1,'
    ...     ' "points": {"3.5": {"vertex": 7, "confidence": 1.5}}}')
    Traceback (most recent call last):
    ...
    mpeg4fba.formats.errors.FormatError: points["3.5"].confidence: expected a number from 0 to 1, not 1.5
    """
    return _parse(text, path)[2]


def read_confidences(path: PathLike) -> dict:
    """{feature point id: confidence} from the sidecar file at ``path`` (see
    :func:`loads_confidences`)."""
    with open(path, "rb") as f:
        data = f.read()
    return loads_confidences(data, os.fspath(path))


def _parse(text: Union[str, bytes], path: Optional[str]) -> tuple:
    """(points, FAPU or None, {id: confidence}) of a checked document."""
    doc = loads_json(text, path, object_pairs_hook=_Object)
    check = _Checker(path)
    check.object(doc, "", _TOP_KEYS, "the document")
    for key in ("format", "version", "points"):
        if key not in doc:
            raise check.error("", f"no {json.dumps(key)} key; a feature point file has "
                              f"\"format\": \"{FORMAT_NAME}\", \"version\": {FORMAT_VERSION} "
                              "and \"points\"")
    if doc["format"] != FORMAT_NAME:
        raise check.error("format", f"{json.dumps(doc['format'])} is not "
                          f"{json.dumps(FORMAT_NAME)}")
    version = doc["version"]
    if not (_is_number(version) and version == FORMAT_VERSION):
        raise check.error("version", f"{json.dumps(version)} is not supported (this reader "
                          f"reads version {FORMAT_VERSION})")
    if "units" in doc and not isinstance(doc["units"], str):
        raise check.error("units", f"expected a string, not {_kind(doc['units'])}")

    positions, vertices, confidences, seen = {}, {}, {}, {}
    points = check.object(doc["points"], "points", (), "feature point id -> point")
    for key, value in points.items():
        where = f"points[{json.dumps(key)}]"
        try:
            fp = normalise_id(key)
        except FeaturePointError as e:
            raise check.error(where, str(e)) from None
        if fp in seen:
            raise check.error(where, f"feature point {fp} is also given as "
                              f"{json.dumps(seen[fp])}")
        seen[fp] = key
        point = check.object(value, where, _POINT_KEYS, "position and/or mesh and vertex")
        if "mesh" in point and "vertex" not in point:
            raise check.error(where, "a \"mesh\" without a \"vertex\"")
        if "position" not in point and "vertex" not in point:
            raise check.error(where, "a point needs a \"position\", a \"vertex\" or both")
        if "position" in point:
            p = point["position"]
            if not (isinstance(p, list) and len(p) == 3 and all(map(_is_number, p))):
                raise check.error(_join(where, "position"),
                                  f"expected 3 numbers, not {json.dumps(p)}")
            positions[fp] = [float(x) for x in p]
        if "vertex" in point:
            v = point["vertex"]
            if not (isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 2 ** 31):
                raise check.error(_join(where, "vertex"),
                                  f"expected an integer >= 0 (a vertex index, below 2**31), "
                                  f"not {shown(v)}")
            mesh = point.get("mesh")
            if mesh is not None and not isinstance(mesh, str):
                raise check.error(_join(where, "mesh"),
                                  f"expected a string, not {_kind(mesh)}")
            vertices[fp] = (mesh, v)
        if "confidence" in point:
            c = point["confidence"]
            if not (_is_number(c) and 0 <= c <= 1):
                raise check.error(_join(where, "confidence"),
                                  f"expected a number from 0 to 1, not {json.dumps(c)}")
            confidences[fp] = float(c)

    fapu = None
    if "fapu" in doc and doc["fapu"] is not None:
        values = check.object(doc["fapu"], "fapu", _FAPU_KEYS, "the five FAPU0 distances")
        missing = [k for k in _FAPU_KEYS if k not in values]
        if missing:
            raise check.error("fapu", f"missing {', '.join(missing)} (give all of "
                              f"{', '.join(_FAPU_KEYS)})")
        for k in _FAPU_KEYS:
            if not _is_number(values[k]):
                raise check.error(_join("fapu", k), f"expected a number, not "
                                  f"{json.dumps(values[k])}")
        fapu = FAPU(**{k: float(values[k]) for k in _FAPU_KEYS})
    ordered = {fp: confidences[fp] for fp in point_order(confidences)}
    return FeaturePointSet(positions, vertices), fapu, ordered


def read_feature_points_json(path: PathLike) -> tuple[FeaturePointSet, Optional[FAPU]]:
    """(feature points, FAPU or None) from the sidecar file at ``path``."""
    with open(path, "rb") as f:
        data = f.read()
    return loads_feature_points_json(data, os.fspath(path))


def _checked_confidences(points: FeaturePointSet, confidences: Optional[Mapping]) -> dict:
    """``confidences`` by normalised id; ValueError for one of no point of ``points`` or
    one that is not a number from 0 to 1."""
    out = {}
    for key, value in (confidences or {}).items():
        fp = normalise_id(key)
        if fp not in points.ids:
            raise ValueError(f"a confidence for feature point {fp}, which the points do not have")
        if not isinstance(value, numbers.Real) or isinstance(value, bool) \
                or not 0 <= float(value) <= 1:     # NaN fails the range too
            raise ValueError(f"feature point {fp}: a confidence is a number from 0 to 1, "
                             f"not {value!r}")
        out[fp] = float(value)
    return out


def dumps_feature_points_json(points: FeaturePointSet, fapu: Optional[FAPU] = None,
                              units: Optional[str] = None, *,
                              confidences: Optional[Mapping] = None) -> str:
    """Sidecar JSON text: one line per point, in the standard's order.  ``confidences``
    (``{id: number from 0 to 1}``, optional) gives points their ``"confidence"``."""
    conf = _checked_confidences(points, confidences)
    lines = []
    positions = set(points)
    vertices = points.vertices
    for fp in points.ids:
        entry = {}
        if fp in positions:
            entry["position"] = [float(x) for x in points[fp]]
        if fp in vertices:
            mesh, index = vertices[fp]
            if mesh is not None:
                entry["mesh"] = mesh
            entry["vertex"] = int(index)
        if fp in conf:
            entry["confidence"] = conf[fp]
        lines.append(f"    {json.dumps(fp)}: {json.dumps(entry)}")
    out = ["{", f'  "format": {json.dumps(FORMAT_NAME)},', f'  "version": {FORMAT_VERSION},']
    if units is not None:
        out.append(f'  "units": {json.dumps(units)},')
    body = ",\n".join(lines)
    out.append('  "points": {' + (f"\n{body}\n  " if lines else "") + "}"
               + ("," if fapu is not None else ""))
    if fapu is not None:
        out.append(f'  "fapu": {json.dumps(fapu.as_dict())}')
    out.append("}")
    return "\n".join(out) + "\n"


def write_feature_points_json(points: FeaturePointSet, path: PathLike,
                              fapu: Optional[FAPU] = None, units: Optional[str] = None, *,
                              confidences: Optional[Mapping] = None) -> None:
    """Write a sidecar file (atomically: all or nothing); ``confidences`` as in
    :func:`dumps_feature_points_json`."""
    text = dumps_feature_points_json(points, fapu, units, confidences=confidences)
    atomic_write(os.fspath(path), text.encode("utf-8"))
