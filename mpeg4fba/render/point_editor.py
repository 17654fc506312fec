"""The feature point editor: one self-contained HTML page to check and move a face's points.

:func:`point_editor_html` draws a face's meshes with three.js (vendored, inlined as the
HTML player inlines it: ``data:`` URLs in an import map; the page works from ``file://``
with no network) and on them every feature point, labelled with its id and coloured by
its confidence (red 0 -> yellow -> green 1; blue: no confidence given).  A side panel
has the legend, the required points that are missing (with the reasons given), and a
table of the points.  Click a point (its marker, label or row), then click the surface:
the point moves to the vertex of the clicked triangle nearest the click, and takes that
vertex's mesh and index and confidence 1.0 (a person placed it).  A missing point is
placed the same way.  "Undo" takes back the last move, "Save points" downloads the
sidecar JSON (:mod:`mpeg4fba.formats.fpjson`): built in the page to match
:func:`~mpeg4fba.formats.fpjson.dumps_feature_points_json` byte for byte, so a page
saved without edits gives back the file it was made from.

For tests the page exposes ``window.__editor`` (``ready``, ``error``, ``select(id)``,
``selected()``, ``moveTo(mesh, vertex or [x, y, z])``, ``undo()``, ``json()``,
``screenOf(mesh, vertex)``) and sets ``document.body.dataset.ready = "1"`` once drawn.

Example
-------
>>> from mpeg4fba.models import reference_head
>>> from mpeg4fba.fba import FeaturePointSet
>>> face = reference_head(resolution=0.5)
>>> found = {k: v for k, v in face.points.vertices.items() if k != "10.9"}
>>> page = point_editor_html(face, FeaturePointSet({}, found), missing=["10.9"],
...                          reasons={"10.9": "no ear found"}, title="Check <me>")
>>> page.startswith("<!DOCTYPE html>"), "Check &lt;me&gt;" in page, "<script src=" in page
(True, True, False)
>>> data = editor_data(page)
>>> len(data["points"]), data["missing"][0]["reason"]
(83, 'no ear found')
"""
from __future__ import annotations

import base64
import html
import json
import os
import re
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Iterable, Mapping, Optional, Union

import numpy as np

from .._atomic import atomic_write
from ..fba.featurepoints import FeaturePointSet, normalise_id, point_order
from ..fba.tables import FEATURE_POINTS
from ..formats.fpjson import FORMAT_NAME, FORMAT_VERSION, dumps_feature_points_json
from .player import THREE_VERSION, failure_script, vendored_modules

__all__ = ["point_editor_html", "write_point_editor", "editor_data"]

#: The vendored modules the editor uses (no glTF loader: the meshes travel as arrays).
_MODULES = ("three", "three/addons/controls/OrbitControls.js")
_DATA = re.compile(r'<script id="editor-data" type="application/json">(.*?)</script>', re.S)


@lru_cache(maxsize=1)
def _import_map_json() -> str:
    sources = vendored_modules()
    imports = {spec: "data:text/javascript;base64,"
               + base64.b64encode(sources[spec].encode("utf-8")).decode("ascii")
               for spec in _MODULES}
    return json.dumps({"imports": imports}, indent=0)


def _page(name: str) -> str:
    """The page's own HTML template or script (``pages/``; ``@NAME@`` marks what
    :func:`point_editor_html` fills in)."""
    return resources.files(__package__).joinpath("pages", name).read_text("utf-8")


def _licence() -> str:
    text = resources.files(__package__).joinpath("web", "LICENSE").read_text("utf-8")
    return text.replace("--", "- -").strip()


def _b64(array: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


def _script_json(value) -> str:
    """JSON safe inside a <script> element (no "</script", no "<!--")."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")


def editor_data(page: str) -> dict:
    """The data an editor page carries (meshes, points, missing points), as a dict.

    >>> editor_data('<script id="editor-data" type="application/json">{"points": []}</script>')
    {'points': []}
    """
    m = _DATA.search(page)
    if m is None:
        raise ValueError("the page carries no editor data")
    return json.loads(m.group(1))


def _ids(values: Iterable) -> list:
    if isinstance(values, str):
        values = [values]
    return point_order({normalise_id(v) for v in values})


def _payload(face, points: FeaturePointSet, confidences: Optional[Mapping], missing: Iterable,
             reasons: Optional[Mapping], fapu, units: Optional[str], filename: str) -> dict:
    if not isinstance(points, FeaturePointSet):
        raise TypeError(f"points is a FeaturePointSet, not {type(points).__name__}")
    missing = _ids(missing)
    # A finder may rate the points it did not find (0): those confidences are dropped.
    conf = {normalise_id(k): v for k, v in (confidences or {}).items()}
    conf = {k: v for k, v in conf.items() if k not in missing}
    # The checks of the writer the page imitates.
    dumps_feature_points_json(points, fapu, units, confidences=conf)
    conf = {k: float(v) for k, v in conf.items()}
    given = set(points.ids)
    both = [fp for fp in missing if fp in given]
    if both:
        raise ValueError(f"feature point{'s' if len(both) > 1 else ''} {', '.join(both)} "
                         "given and listed as missing")
    reasons = {normalise_id(k): str(v) for k, v in (reasons or {}).items()}
    world = {name: np.asarray(face.world_vertices(name), dtype=np.float64) for name in face.meshes}
    shown = points.resolve(world)         # where cloning will take each point to be
    meshes = []
    for name, mesh in face.meshes.items():
        if not len(mesh.vertices) or not len(mesh.triangles):
            continue
        colour, per_vertex = face.mesh_colors(name)
        meshes.append({
            "name": name,
            "positions": _b64(world[name].astype("<f8")),
            "triangles": _b64(np.asarray(mesh.triangles).astype("<u4")),
            "color": [float(c) for c in colour[:3]],
            "colors": None if per_vertex is None else _b64(
                np.clip(np.round(np.asarray(per_vertex)[:, :3] * 255), 0, 255).astype(np.uint8)),
            "closed": bool(mesh.is_closed()),
        })
    unknown = sorted({m for m, _ in points.vertices.values() if m is not None} - set(world))
    if unknown:           # resolve() has refused these already; kept as a guard
        raise ValueError(f"points on meshes the face does not have: {', '.join(unknown)}")
    names = {fp.id: fp.description for fp in FEATURE_POINTS}
    rows = []
    positions = set(points)
    for fp in points.ids:
        tie = points.vertex(fp)
        rows.append({"id": fp, "name": names.get(fp, ""),
                     "position": [float(x) for x in points[fp]] if fp in positions else None,
                     "mesh": tie[0] if tie else None, "vertex": tie[1] if tie else None,
                     "confidence": conf.get(fp), "shown": [float(x) for x in shown[fp]],
                     "reason": reasons.get(fp)})
    return {
        "format": FORMAT_NAME, "version": FORMAT_VERSION, "units": units,
        "fapu": None if fapu is None else {k: float(v) for k, v in fapu.as_dict().items()},
        "order": [fp.id for fp in FEATURE_POINTS], "filename": filename,
        "meshes": meshes, "points": rows,
        "missing": [{"id": fp, "name": names.get(fp, ""), "reason": reasons.get(fp, "")}
                    for fp in missing],
    }


def _view(up, forward) -> dict:
    """The head's up and forward as unit vectors, forward made square to up."""
    u = np.array([0.0, 1.0, 0.0] if up is None else up, float).reshape(-1)
    f = np.array([0.0, 0.0, 1.0] if forward is None else forward, float).reshape(-1)
    if u.shape != (3,) or f.shape != (3,) or not (np.isfinite(u).all() and np.isfinite(f).all()):
        raise ValueError("up and forward are 3 finite numbers each")
    u = u / (np.linalg.norm(u) or 1.0)
    f = f - np.dot(f, u) * u
    if np.linalg.norm(f) < 1e-9 or np.linalg.norm(u) < 1e-9:
        raise ValueError("up and forward must be two different directions")
    return {"up": u.tolist(), "forward": (f / np.linalg.norm(f)).tolist()}


def point_editor_html(face, points: FeaturePointSet, *, confidences: Optional[Mapping] = None,
                      missing: Iterable = (), reasons: Optional[Mapping] = None,
                      title: str = "Feature points", fapu=None, units: Optional[str] = None,
                      filename: str = "points.json", up: Optional[Iterable[float]] = None,
                      forward: Optional[Iterable[float]] = None, notes: Iterable[str] = ()) -> str:
    """One self-contained HTML page to review and move ``points`` on ``face``.

    ``up`` and ``forward`` (model coordinates; default +y and +z) say how the head
    stands, so that the page opens on its face (a +Z-up head, one facing +X).  ``notes``
    (what the finder says about the head as a whole: an open mouth, an eye with no
    opening) are shown above the panel's lists.

    ``confidences`` (``{id: 0..1}``) colour the points, ``missing`` lists required
    points not found (``reasons`` says why, ``{id: text}``; a reason for a given point
    shows in its row; a confidence for a missing point is dropped).  ``fapu`` and ``units`` are carried into the saved file as
    :func:`~mpeg4fba.formats.fpjson.dumps_feature_points_json` writes them;
    ``filename`` names the download.  ValueError for confidences out of 0..1 or of
    points not given, a point both given and missing, or a vertex the face lacks.

    >>> from mpeg4fba.fba.face import FaceMesh, FaceModel
    >>> quad = FaceMesh("Skin", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    >>> pts = FeaturePointSet({}, {"9.3": ("Skin", 2)})
    >>> data = editor_data(point_editor_html(FaceModel([quad]), pts, confidences={"9.3": 0.5}))
    >>> row = data["points"][0]
    >>> row["id"], row["position"], row["mesh"], row["vertex"], row["confidence"], row["shown"]
    ('9.3', None, 'Skin', 2, 0.5, [1.0, 1.0, 0.0])
    """
    data = _payload(face, points, confidences, missing, reasons, fapu, units, str(filename))
    data["view"] = _view(up, forward)
    data["notes"] = [str(n) for n in notes]
    fill = {"LICENSE": _licence(), "VERSION": THREE_VERSION, "IMPORTMAP": _import_map_json(),
            "DATA": _script_json(data), "JS": _page("point_editor.js").rstrip("\n"), "TITLE": html.escape(str(title)),
            "FAIL": failure_script("__editor", "editor")}
    return re.sub(r"@([A-Z]+)@", lambda m: fill[m.group(1)], _page("point_editor.html"))


def write_point_editor(path: Union[str, os.PathLike], face, points: FeaturePointSet,
                       **kw) -> Path:
    """Write :func:`point_editor_html` to ``path`` atomically (a temporary file beside it,
    then a rename) and return the path; ``title`` defaults to the file's name.

    >>> import tempfile
    >>> from mpeg4fba.models import reference_head
    >>> face = reference_head(resolution=0.5)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = write_point_editor(os.path.join(d, "review.html"), face, face.points)
    ...     p.name, "<title>review</title>" in p.read_text("utf-8"), os.listdir(d)
    ('review.html', True, ['review.html'])
    """
    path = Path(path)
    kw.setdefault("title", path.stem)
    text = point_editor_html(face, points, **kw)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, text)
    return path
