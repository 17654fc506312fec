"""FBA compliance of files and objects: ``validate(path_or_object) -> Report``.

A VRML file is read, then checked in two layers: rules on the nodes themselves, with
the file and line of each (no Face node, a Face without FDP, FaceDefMesh /
FaceDefTransform targets that are not an IndexedFaceSet / Transform of the face scene
graph, fieldId not 1-3), and, when those pass, the rules on the face model the FAT
codec reads from it (:func:`mpeg4fba.fba.compliance.check_fat`: fapIDs, selects,
borders, counts, indices, duplicate tables, feature points, FAPU) and the numeric FAP
check.  A ``.fap`` file is read and its counts and ranges checked.  A face in a mesh
file (``.glb``, ``.gltf``, ``.obj``: what ``play`` and ``demo`` write) is read as
:func:`~mpeg4fba.formats.face_files.read_face` reads it and its FAT checked; such a file
holds no feature points, so the rules that need them (FBA002, FBA003, the numeric check)
give way to one warning, FBA017.  A FaceModel or a FapStream is checked as an object.

Example
-------
>>> from mpeg4fba.fba.face import FaceModel
>>> validate(FaceModel()).ok
True
>>> r = validate("no-such-file.wrl")
>>> r.findings[0].code, r.ok
('FBA100', False)
"""
from __future__ import annotations

import os
import warnings
from typing import Optional, Union

from ..fba.compliance import Finding, Report, check_fap_ratios, check_fat
from ..fba.face import FaceModel
from ..fba.stream import FapRangeWarning, FapStream
from ..fba.tables import FAP
from ..vrml import Scene, VRMLError, load
from ..vrml.scene import Node, iter_nodes
from .errors import FormatError
from .face_files import MESH_SUFFIXES, read_face

__all__ = ["validate", "MAX_RANGE_FINDINGS"]

#: Out-of-range FAP values reported one by one before a summary line takes over.
MAX_RANGE_FINDINGS = 20


def validate(target: Union[str, os.PathLike, Scene, FaceModel, FapStream], *,
             tolerance: float = 0.05, strict: bool = True) -> Report:
    """Check a file (``.wrl``/``.wrl.gz`` face, ``.fap`` stream, ``.glb``/``.gltf``/``.obj``
    face) or an object.

    ``tolerance`` is the relative error the numeric FAP check allows (5%); ``strict``
    is the VRML reader's mode.  Never raises for a bad file: what is wrong is a finding.
    """
    if isinstance(target, FaceModel):
        return _check_face(target, getattr(target, "name", "<face>"), tolerance)
    if isinstance(target, FapStream):
        return _check_stream(target, target.name or "<stream>")
    if isinstance(target, Scene):
        return _check_scene(target, target.path, tolerance)
    path = os.fspath(target)
    if path.lower().endswith(".fap"):
        return _check_fap_file(path)
    if path.lower().endswith(MESH_SUFFIXES):
        return _check_mesh_file(path, tolerance, strict)
    report = Report(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = load(path, strict=strict)
    except VRMLError as e:
        report.findings.append(Finding("FBA100", e.message + (
            f" (expected {', '.join(e.expected)})" if e.expected else ""),
            e.path or path, e.line, e.column))
        return report
    return _check_scene(scene, path, tolerance)


def _loc(node: Node, path: Optional[str]) -> dict:
    loc = node.location
    if loc is None:
        return {"path": path}
    return {"path": loc[0] or path, "line": loc[1], "column": loc[2]}


def _nodes_of(value) -> list:
    if value is None:
        return []
    if isinstance(value, Node):
        return [value]
    return [v for v in value if isinstance(v, Node)]


def _check_scene(scene: Scene, path: Optional[str], tolerance: float) -> Report:
    report = Report(path or "<scene>")
    faces = [n for n in scene if n.type == "Face"]
    if not faces:
        report.findings.append(Finding("FBA015", "no Face node: this is not an MPEG-4 face",
                                       path))
        return report
    for face_node in faces:
        findings = _check_face_nodes(face_node, path)
        report.findings.extend(findings)
        if any(f.severity == "error" for f in findings):
            continue
        from .wrl_face import face_from_scene  # the FAT codec reads the model
        try:
            model = face_from_scene(scene, path, face=face_node.name if len(faces) > 1 else None)
        except FormatError as e:
            report.findings.append(Finding("FBA100", e.message, e.path or path, e.line, e.column))
            continue
        sub = _check_face(model, report.source, tolerance)
        report.findings.extend(sub.findings)
        report.ratios.update(sub.ratios)
    return report


def _check_face_nodes(face_node: Node, path: Optional[str]) -> list:
    """Rules on the MPEG-4 nodes themselves (what the face model can't represent)."""
    out = []
    fdp = face_node.get("fdp")
    if not isinstance(fdp, Node):
        out.append(Finding("FBA001", f"Face{' ' + face_node.name if face_node.name else ''} has "
                           "no FDP: no face scene graph, feature points or FAT",
                           **_loc(face_node, path)))
        return out
    graph = set(map(id, iter_nodes(_nodes_of(fdp.get("faceSceneGraph")))))
    for tables in _nodes_of(fdp.get("faceDefTables")):
        fap = tables.get("fapID")
        for m in _nodes_of(tables.get("faceDefMesh")):
            target = m.get("faceSceneGraphNode")
            if not (isinstance(target, Node) and target.type == "IndexedFaceSet"
                    and id(target) in graph):
                what = "nothing" if target is None else (
                    f"a {target.type}" + (" outside the face scene graph"
                                          if target.type == "IndexedFaceSet" else ""))
                out.append(Finding("FBA006", f"FAP {fap}: FaceDefMesh.faceSceneGraphNode is "
                                   f"{what}, not an IndexedFaceSet of the face scene graph",
                                   **_loc(m, path)))
        for t in _nodes_of(tables.get("faceDefTransform")):
            target = t.get("faceSceneGraphNode")
            if not (isinstance(target, Node) and target.type == "Transform" and id(target) in graph):
                what = "nothing" if target is None else f"a {target.type}"
                out.append(Finding("FBA010", f"FAP {fap}: FaceDefTransform.faceSceneGraphNode "
                                   f"is {what}, not a Transform of the face scene graph",
                                   **_loc(t, path)))
            field_id = t.get("fieldId")
            if field_id not in (1, 2, 3):
                out.append(Finding("FBA011", f"FAP {fap}: FaceDefTransform.fieldId is "
                                   f"{field_id}; 1 is rotation, 2 scale, 3 translation",
                                   **_loc(t, path)))
    return out


def _check_face(face: FaceModel, source: str, tolerance: float) -> Report:
    report = Report(source)
    report.findings.extend(check_fat(face))
    if not report.errors and len(face.fat):
        findings, ratios = check_fap_ratios(face, tolerance)
        report.findings.extend(findings)
        report.ratios = ratios
    return report


def _check_mesh_file(path: str, tolerance: float, strict: bool) -> Report:
    report = Report(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            face = read_face(path, lenient=not strict)
    except FormatError as e:
        report.findings.append(Finding("FBA100", e.message, e.path or path, e.line, e.column))
        return report
    except OSError as e:
        report.findings.append(Finding("FBA100", f"can't read the file: {e.strerror or e}", path))
        return report
    except ValueError as e:
        report.findings.append(Finding("FBA100", str(e), path))
        return report
    if len(face.points) or not len(face.fat):
        sub = _check_face(face, path, tolerance)
    else:  # the format has no place for them: not the face's fault, but say what went unchecked
        sub = Report(path, [f for f in check_fat(face) if f.code not in ("FBA002", "FBA003")])
        low = path.lower()
        kind = ("an OBJ" if low.endswith(".obj") else "a glTF" if low.endswith((".glb", ".gltf"))
                else f"a {os.path.splitext(low)[1][1:].upper()}")
        sub.findings.append(Finding("FBA017", f"{kind} file holds no feature points (no FDP): "
                                    "the checks that need them (feature points, FAPU, the "
                                    "numeric FAP check) were skipped", path))
    for f in sub.findings:
        f.path = f.path or path
    report.findings = sub.findings
    report.ratios = sub.ratios
    return report


def _check_stream(stream: FapStream, source: str, path: Optional[str] = None) -> Report:
    report = Report(source)
    bad = stream.out_of_range()
    for frame, fap, value in bad[:MAX_RANGE_FINDINGS]:
        r = FAP[fap]
        bounds = f"{r.range[0]:g} to {r.range[1]:g}" if r.range else "its field bounds"
        report.findings.append(Finding("FBA102", f"frame {frame}: FAP {fap} {r.name} = {value} "
                                       f"is outside {bounds}", path, data={"frame": frame, "fap": fap}))
    if len(bad) > MAX_RANGE_FINDINGS:
        report.findings.append(Finding("FBA102", f"{len(bad) - MAX_RANGE_FINDINGS} more values "
                                       "outside their range", path))
    return report


def _check_fap_file(path: str) -> Report:
    from .fap import FapError, FapWarning, read_fap
    report = Report(path)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            stream = read_fap(path)
    except (FapError, FormatError) as e:
        report.findings.append(Finding("FBA101", e.message, e.path or path, e.line))
        return report
    except OSError as e:
        report.findings.append(Finding("FBA101", f"can't read the file: {e.strerror}", path))
        return report
    for w in caught:
        if issubclass(w.category, FapWarning):
            text = str(w.message)
            prefix = f"{path}:"
            line = None
            if text.startswith(prefix):  # "path:line: message" -> its parts
                rest = text[len(prefix):]
                head, _, message = rest.partition(": ")
                if head.isdigit():
                    line, text = int(head), message
                else:
                    text = rest.lstrip()
            report.findings.append(Finding("FBA103", text, path, line))
        elif not issubclass(w.category, FapRangeWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    report.findings.extend(_check_stream(stream, path, path).findings)
    return report
